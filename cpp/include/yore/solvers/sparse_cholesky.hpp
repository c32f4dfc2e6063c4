#pragma once
/// @file sparse_cholesky.hpp
/// CHOLMOD's sparse Cholesky factorization behind RAII (cholmod.h stays in the .cpp).

#include <memory>

#include "yore/solvers/linear_solver.hpp"

namespace yore {

/// Sparse LLᵀ by CHOLMOD: analyze once per pattern, factorize per matrix, solve per right-hand
/// side. Owns its cholmod_common and every CHOLMOD object; every CHOLMOD status is checked.
class SparseCholesky final : public LinearSolver {
 public:
  /// `supernode_relaxation` scales CHOLMOD's relaxed amalgamation (LinearSolverOptions).
  /// Throws std::invalid_argument if METIS (metis, nesdis, auto) is asked for and CHOLMOD has
  /// none, or for a relaxation outside [0, 16].
  SparseCholesky(FactorKind factor, Ordering ordering, double supernode_relaxation = 1.0);
  ~SparseCholesky() override;
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  /// Symbolic analysis with the solver's ordering; on a pattern of 3×3 blocks the ordering is
  /// computed on the block (vertex) graph and expanded: the same factor for 9 times less
  /// ordering work.
  void analyze(const SymmetricPattern& pattern) override;
  /// Symbolic analysis with a given fill-reducing permutation (cholmod_analyze_p with
  /// CHOLMOD_GIVEN): permutation[k] is the k-th unknown eliminated. Throws std::invalid_argument
  /// if it is not a permutation of 0..N-1.
  void analyze_with_permutation(const SymmetricPattern& pattern,
                                const std::vector<std::int32_t>& permutation);
  /// With `on`, every factorization also keeps a simplicial (column-by-column) copy of the
  /// factor that the solves use: for a factor reused by many solves, such as local-global's
  /// constant matrix. A supernodal factorization is faster from about 10⁴ unknowns, but its
  /// solves are not: a 64² cloth's x, y, z solve took 1.17 ms on it and 0.56 ms on the copy
  /// (CHOLMOD 3.0, one thread); the copy costs about one solve and the factor's memory again.
  void set_simplicial_solves(bool on);
  /// The permutation of the current analysis (empty before the first).
  std::vector<std::int32_t> permutation() const;
  /// Throws NotPositiveDefinite naming the column where CHOLMOD met a non-positive pivot.
  void factorize(const double* values) override;
  void solve(const double* rhs, double* solution) override;
  /// Solves for `columns` right-hand sides at once (N×columns, column-major): one pass over
  /// the factor with dense blocks. No allocation after the first call with that many columns.
  void solve_columns(const double* rhs, double* solution, int columns);
  const SolverStatistics& statistics() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace yore
