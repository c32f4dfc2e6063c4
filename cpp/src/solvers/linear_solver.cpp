#include "yore/solvers/linear_solver.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/solvers/sparse_cholesky.hpp"

namespace yore {

namespace {

template <typename Enum>
Enum parse_named(const std::string& name, const char* what,
                 const std::vector<std::pair<std::string, Enum>>& choices) {
  std::string valid;
  for (const auto& [text, code] : choices) {
    if (text == name) return code;
    valid += (valid.empty() ? "" : ", ") + text;
  }
  throw std::invalid_argument("unknown " + std::string(what) + " '" + name + "'; valid: " + valid);
}

}  // namespace

const std::vector<std::pair<std::string, Ordering>>& ordering_choices() {
  static const std::vector<std::pair<std::string, Ordering>> choices = {
      {"amd", Ordering::amd},
      {"metis", Ordering::metis},
      {"nesdis", Ordering::nesdis},
      {"auto", Ordering::automatic},
      {"natural", Ordering::natural}};
  return choices;
}

Ordering resolve_ordering(Ordering ordering, std::int32_t vertices) {
  if (ordering != Ordering::automatic) return ordering;
  return vertices >= kNestedDissectionFromVertices ? Ordering::nesdis : Ordering::amd;
}

const std::vector<std::pair<std::string, FactorKind>>& factor_kind_choices() {
  static const std::vector<std::pair<std::string, FactorKind>> choices = {
      {"supernodal", FactorKind::supernodal}, {"simplicial", FactorKind::simplicial}};
  return choices;
}

Ordering parse_ordering(const std::string& name) {
  return parse_named(name, "ordering", ordering_choices());
}

FactorKind parse_factor_kind(const std::string& name) {
  return parse_named(name, "factorization", factor_kind_choices());
}
namespace {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, std::int32_t>;

/// An Eigen matrix with the pattern's structure; factorize() only overwrites its values.
SparseMatrix matrix_with_pattern(const SymmetricPattern& pattern) {
  SparseMatrix matrix(pattern.size, pattern.size);
  matrix.resizeNonZeros(pattern.nonzeros());
  std::memcpy(matrix.outerIndexPtr(), pattern.column_starts.data(),
              pattern.column_starts.size() * sizeof(std::int32_t));
  std::memcpy(matrix.innerIndexPtr(), pattern.row_indices.data(),
              pattern.row_indices.size() * sizeof(std::int32_t));
  std::memset(matrix.valuePtr(), 0, pattern.row_indices.size() * sizeof(double));
  return matrix;
}

/// Eigen's SimplicialLDLT (AMD ordering), for comparison with CHOLMOD.
class EigenLdlt final : public LinearSolver {
 public:
  explicit EigenLdlt(Ordering ordering) {
    if (ordering != Ordering::amd && ordering != Ordering::automatic) {
      throw std::invalid_argument(
          "backend 'eigen-ldlt' orders with AMD only; valid ordering: amd, auto");
    }
  }
  void analyze(const SymmetricPattern& pattern) override {
    m_matrix = matrix_with_pattern(pattern);
    m_solver.analyzePattern(m_matrix);
    if (m_solver.info() != Eigen::Success) throw std::runtime_error("Eigen LDLT analysis failed");
    ++m_statistics.analyses;
    m_statistics.ordering = "amd";
    m_factored = false;
  }
  void factorize(const double* values) override {
    std::memcpy(m_matrix.valuePtr(), values, m_matrix.nonZeros() * sizeof(double));
    m_solver.factorize(m_matrix);
    ++m_statistics.factorizations;
    // LDLᵀ also factors indefinite matrices: positive definiteness is D > 0.
    if (m_solver.info() != Eigen::Success || !(m_solver.vectorD().minCoeff() > 0.0)) {
      m_factored = false;
      throw NotPositiveDefinite(
          "the system matrix is not positive definite (Eigen LDLT found a pivot <= 0)");
    }
    const SparseMatrix& lower = m_solver.matrixL();
    m_statistics.factor_nonzeros = static_cast<double>(lower.nonZeros() + m_matrix.rows());
    m_factored = true;
  }
  void solve(const double* rhs, double* solution) override {
    if (!m_factored) throw std::logic_error("EigenLdlt::solve without a valid factor");
    Eigen::Map<const Eigen::VectorXd> b(rhs, m_matrix.rows());
    Eigen::Map<Eigen::VectorXd> x(solution, m_matrix.rows());
    x = m_solver.solve(b);
    ++m_statistics.solves;
  }
  const SolverStatistics& statistics() const override { return m_statistics; }

 private:
  SparseMatrix m_matrix;
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<std::int32_t>> m_solver;
  SolverStatistics m_statistics;
  bool m_factored = false;
};

/// Eigen's DiagonalPreconditioner, same arithmetic, plus an interrupt poll per application
/// (once per CG iteration): pcg_max_iterations is user-typed and Eigen's loop has no hook.
class PollingJacobi {
 public:
  using StorageIndex = std::int32_t;
  enum { ColsAtCompileTime = Eigen::Dynamic, MaxColsAtCompileTime = Eigen::Dynamic };
  PollingJacobi() = default;
  template <typename Matrix>
  explicit PollingJacobi(const Matrix& matrix) {
    compute(matrix);
  }
  Eigen::Index rows() const { return m_inverse_diagonal.size(); }
  Eigen::Index cols() const { return m_inverse_diagonal.size(); }
  template <typename Matrix>
  PollingJacobi& analyzePattern(const Matrix&) {
    return *this;
  }
  template <typename Matrix>
  PollingJacobi& factorize(const Matrix& matrix) {
    m_inverse_diagonal.resize(matrix.cols());
    for (Eigen::Index j = 0; j < matrix.outerSize(); ++j) {
      typename Matrix::InnerIterator it(matrix, j);
      while (it && it.index() != j) ++it;
      m_inverse_diagonal(j) = it && it.index() == j && it.value() != 0.0 ? 1.0 / it.value() : 1.0;
    }
    return *this;
  }
  template <typename Matrix>
  PollingJacobi& compute(const Matrix& matrix) {
    return factorize(matrix);
  }
  template <typename Rhs>
  Eigen::VectorXd solve(const Eigen::MatrixBase<Rhs>& b) const {
    poll_interrupt();
    return (m_inverse_diagonal.array() * b.derived().array()).matrix();
  }
  Eigen::ComputationInfo info() const { return Eigen::Success; }

 private:
  Eigen::VectorXd m_inverse_diagonal;
};

/// Conjugate gradients with a Jacobi (diagonal) preconditioner: no factorization at all.
class JacobiPcg final : public LinearSolver {
 public:
  JacobiPcg(Ordering ordering, double tolerance, int max_iterations) {
    if (ordering != Ordering::amd && ordering != Ordering::natural &&
        ordering != Ordering::automatic) {
      throw std::invalid_argument(
          "backend 'pcg' does not reorder; valid ordering: amd, auto, natural");
    }
    if (!(tolerance > 0.0) || max_iterations < 1) {
      std::ostringstream msg;
      msg << "pcg_tol must be > 0 and pcg_max_iterations >= 1, got " << tolerance << " and "
          << max_iterations;
      throw std::invalid_argument(msg.str());
    }
    m_solver.setTolerance(tolerance);
    m_solver.setMaxIterations(max_iterations);
  }
  void analyze(const SymmetricPattern& pattern) override {
    m_matrix = matrix_with_pattern(pattern);
    m_solver.analyzePattern(m_matrix);
    ++m_statistics.analyses;
  }
  void factorize(const double* values) override {
    std::memcpy(m_matrix.valuePtr(), values, m_matrix.nonZeros() * sizeof(double));
    // The diagonal of an SPD matrix is positive; a non-positive one cannot be preconditioned.
    for (std::int32_t column = 0; column < m_matrix.cols(); ++column) {
      const double diagonal = m_matrix.valuePtr()[m_matrix.outerIndexPtr()[column]];
      if (!(diagonal > 0.0)) {
        std::ostringstream msg;
        msg << "the system matrix is not positive definite: diagonal entry " << column << " is "
            << diagonal;
        throw NotPositiveDefinite(msg.str());
      }
    }
    m_solver.factorize(m_matrix);  // the Jacobi preconditioner: reads the diagonal
    ++m_statistics.factorizations;
  }
  void solve(const double* rhs, double* solution) override {
    Eigen::Map<const Eigen::VectorXd> b(rhs, m_matrix.rows());
    Eigen::Map<Eigen::VectorXd> x(solution, m_matrix.rows());
    x = m_solver.solve(b);
    m_statistics.iterations += m_solver.iterations();
    if (m_solver.info() != Eigen::Success) ++m_statistics.unconverged;
    ++m_statistics.solves;
  }
  const SolverStatistics& statistics() const override { return m_statistics; }

 private:
  SparseMatrix m_matrix;
  Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower, PollingJacobi> m_solver;
  SolverStatistics m_statistics;
};

}  // namespace

void symmetric_multiply(const SymmetricPattern& pattern, const double* values,
                        const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  y.setZero();
  for (std::int32_t column = 0; column < pattern.size; ++column) {
    for (std::int32_t p = pattern.column_starts[column]; p < pattern.column_starts[column + 1];
         ++p) {
      const std::int32_t row = pattern.row_indices[static_cast<std::size_t>(p)];
      y[row] += values[p] * x[column];
      if (row != column) y[column] += values[p] * x[row];
    }
  }
}

int preconditioned_cg(
    const SymmetricPattern& pattern, const double* values, const Eigen::VectorXd& b,
    Eigen::VectorXd& x,
    const std::function<void(const Eigen::VectorXd&, Eigen::VectorXd&)>& precondition,
    double tolerance, int max_iterations, CgWorkspace& work, bool& converged) {
  symmetric_multiply(pattern, values, x, work.product);
  work.residual = b - work.product;
  const double target = tolerance * b.norm();
  precondition(work.residual, work.preconditioned);
  work.direction = work.preconditioned;
  double rz = work.residual.dot(work.preconditioned);
  int iterations = 0;
  while (work.residual.norm() > target && iterations < max_iterations) {
    poll_interrupt();  // max_iterations is user-typed
    symmetric_multiply(pattern, values, work.direction, work.product);
    const double alpha = rz / work.direction.dot(work.product);
    x += alpha * work.direction;
    work.residual -= alpha * work.product;
    precondition(work.residual, work.preconditioned);
    const double next = work.residual.dot(work.preconditioned);
    work.direction = work.preconditioned + (next / rz) * work.direction;
    rz = next;
    ++iterations;
  }
  converged = work.residual.norm() <= target;
  return iterations;
}

std::vector<std::string> linear_solver_backends() { return {"cholmod", "eigen-ldlt", "pcg"}; }

std::unique_ptr<LinearSolver> make_linear_solver(const LinearSolverOptions& options) {
  if (options.solver == "cholmod") {
    return std::make_unique<SparseCholesky>(options.factorization, options.ordering,
                                            options.supernode_relaxation);
  }
  if (options.solver == "eigen-ldlt") return std::make_unique<EigenLdlt>(options.ordering);
  if (options.solver == "pcg") {
    return std::make_unique<JacobiPcg>(options.ordering, options.pcg_tol,
                                       options.pcg_max_iterations);
  }
  throw std::invalid_argument("unknown solver '" + options.solver +
                              "'; valid: cholmod, eigen-ldlt, pcg");
}

}  // namespace yore
