#pragma once
/// @file linear_solver.hpp
/// Solvers for the symmetric positive-definite systems of implicit stepping, behind one interface
/// with separate analyze (symbolic, once per sparsity pattern), factorize (numeric) and solve.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace yore {

/// Lower triangle (row >= column) of a symmetric N×N matrix in compressed sparse columns; row
/// indices increase within each column.
struct SymmetricPattern {
  std::int32_t size = 0;  ///< N
  /// 3 when the matrix is made of 3×3 blocks, one per vertex (unknowns 3b, 3b + 1, 3b + 2 share
  /// their pattern): orderings are then computed on the vertex graph, 9 times smaller, and
  /// expanded. 1 for a scalar pattern.
  std::int32_t block_size = 1;
  std::vector<std::int32_t> column_starts;  ///< N + 1
  std::vector<std::int32_t> row_indices;    ///< nnz
  std::int64_t nonzeros() const { return static_cast<std::int64_t>(row_indices.size()); }
};

/// Fill-reducing orderings of the sparse Cholesky factorization: approximate minimum degree,
/// METIS's nested dissection, CHOLMOD's nested dissection (METIS's separators, constrained
/// minimum degree within), automatic (AMD below kNestedDissectionFromVertices vertices, CHOLMOD's
/// nested dissection from there: measured by benchmarks/factorization.py), or none.
enum class Ordering { amd, metis, nesdis, automatic, natural };

/// The automatic ordering's switch from AMD to nested dissection, in vertices (3×3 blocks) of
/// the system. Measured on grid cloths by benchmarks/factorization.py (one thread, AVX-512
/// kernels): at 32² both factor alike and AMD's analysis is twice as cheap; at 64² nested
/// dissection factors about 10 % faster (17 % fewer flops) and its extra analysis (≈ 10 ms) is
/// repaid within four factorizations, half a TR-BDF2 step; at 128² 9 % faster (28 % fewer
/// flops), at 256² 26 % (34 %).
constexpr std::int32_t kNestedDissectionFromVertices = 2500;

/// The ordering `automatic` stands for on a system of that many vertices (blocks); any other
/// ordering is itself.
Ordering resolve_ordering(Ordering ordering, std::int32_t vertices);
/// Supernodal (BLAS-3 dense blocks) or simplicial (column by column) factorization.
enum class FactorKind { supernodal, simplicial };

/// The names of the orderings ("amd", "metis", "nesdis", "auto", "natural") and of the
/// factorizations
/// ("supernodal", "simplicial"): the one list the parsers and the bindings use.
const std::vector<std::pair<std::string, Ordering>>& ordering_choices();
const std::vector<std::pair<std::string, FactorKind>>& factor_kind_choices();
/// The ordering of that name; std::invalid_argument listing the valid names.
Ordering parse_ordering(const std::string& name);
/// The factorization of that name; std::invalid_argument listing the valid names.
FactorKind parse_factor_kind(const std::string& name);

/// What a solver reports about its work.
struct SolverStatistics {
  std::int64_t analyses = 0;        ///< symbolic analyses done
  std::int64_t factorizations = 0;  ///< numeric factorizations done
  std::int64_t solves = 0;
  double factor_nonzeros = 0.0;  ///< nnz(L) of the last analysis (0 for an iterative solver)
  double factor_flops = 0.0;     ///< flops of one factorization with the last analysis
  /// Supernodal factor: half of a factorization's flops are in supernodes (dense blocks of
  /// columns eliminated together) of at most this many columns, and in rows below them of at
  /// most supernode_median_rows (both flop-weighted medians); 0 otherwise. The size of the
  /// dense kernels that bound the factorization's rate.
  double supernode_median_columns = 0.0;
  double supernode_median_rows = 0.0;
  std::string ordering;          ///< ordering used by the last analysis ("" if none)
  std::int64_t iterations = 0;   ///< iterations of an iterative solver, cumulative
  std::int64_t unconverged = 0;  ///< solves of an iterative solver that hit its iteration limit
  /// CHOLMOD's OpenMP regions its factorizations ran on the calling thread without a libgomp
  /// team (sparse_cholesky.cpp: a team of one costs a system call per region), cumulative; 0
  /// where libgomp's own GOMP_parallel was bound ahead of yore's.
  std::int64_t openmp_regions_inlined = 0;
};

/// Solves H x = b for a symmetric positive-definite H given by its lower triangle.
class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  /// Symbolic work for a pattern (ordering, elimination tree); the pattern must outlive the
  /// solver's use of it until the next analyze.
  virtual void analyze(const SymmetricPattern& pattern) = 0;
  /// Numeric factorization (or preconditioner set-up) of the matrix with these values, one per
  /// pattern entry. Throws NotPositiveDefinite when the matrix is not positive definite.
  virtual void factorize(const double* values) = 0;
  /// Writes H⁻¹ rhs into solution (both of length N). No allocation after the first call.
  virtual void solve(const double* rhs, double* solution) = 0;
  /// Counters and the factor's size.
  virtual const SolverStatistics& statistics() const = 0;
};

/// Options of the solver backends.
struct LinearSolverOptions {
  std::string solver = "cholmod";  ///< "cholmod", "eigen-ldlt" or "pcg"
  Ordering ordering = Ordering::automatic;
  FactorKind factorization = FactorKind::supernodal;
  /// Scale of CHOLMOD's relaxed supernode amalgamation (its nrelax sizes 4, 16, 48 columns):
  /// 0 merges only where no zero is added, 1 is CHOLMOD's default (measured best).
  double supernode_relaxation = 1.0;
  double pcg_tol = 1e-12;  ///< relative residual of the Jacobi-preconditioned CG
  int pcg_max_iterations = 20000;
};

/// y = H x for a symmetric H stored as its lower triangle (values in pattern order).
void symmetric_multiply(const SymmetricPattern& pattern, const double* values,
                        const Eigen::VectorXd& x, Eigen::VectorXd& y);

/// Work vectors of preconditioned_cg, sized once and reused (no allocation per solve).
struct CgWorkspace {
  Eigen::VectorXd residual, preconditioned, direction, product;
  void resize(Eigen::Index n) {
    residual.resize(n);
    preconditioned.resize(n);
    direction.resize(n);
    product.resize(n);
  }
};

/// Preconditioned conjugate gradients on H x = b (H symmetric positive definite, lower
/// triangle), from the x given. precondition(r, z) writes z = P⁻¹ r for an SPD P. Stops when
/// ‖r‖ ≤ tolerance ‖b‖ or after max_iterations; returns the iterations and sets converged.
int preconditioned_cg(
    const SymmetricPattern& pattern, const double* values, const Eigen::VectorXd& b,
    Eigen::VectorXd& x,
    const std::function<void(const Eigen::VectorXd&, Eigen::VectorXd&)>& precondition,
    double tolerance, int max_iterations, CgWorkspace& work, bool& converged);

/// The backend names make_linear_solver accepts.
std::vector<std::string> linear_solver_backends();

/// Whether CHOLMOD was built with METIS on this machine.
bool cholmod_has_metis();

/// Builds a solver. Throws std::invalid_argument for an unknown backend or an ordering the
/// backend cannot do.
std::unique_ptr<LinearSolver> make_linear_solver(const LinearSolverOptions& options);

}  // namespace yore
