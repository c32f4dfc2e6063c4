// Tests of cpp/src/solvers/linear_solver.cpp (cpp/include/yore/solvers/linear_solver.hpp): the
// three backends behind one interface on SPD and indefinite matrices, the name tables, the
// symmetric product and preconditioned CG.
#include <doctest/doctest.h>

#include <stdexcept>

#include "helpers.hpp"
#include "yore/platform/errors.hpp"
#include "yore/solvers/linear_solver.hpp"

using yore::LinearSolverOptions;

namespace {

constexpr int kSize = 12;

Eigen::VectorXd solve_with(const std::string& backend, const Eigen::MatrixXd& matrix,
                           const Eigen::VectorXd& rhs,
                           yore::SolverStatistics* statistics = nullptr) {
  LinearSolverOptions options;
  options.solver = backend;
  auto solver = yore::make_linear_solver(options);
  std::vector<double> values;
  const yore::SymmetricPattern pattern = yore_test::lower_pattern(matrix, values);
  solver->analyze(pattern);
  solver->factorize(values.data());
  Eigen::VectorXd x(rhs.size());
  solver->solve(rhs.data(), x.data());
  if (statistics != nullptr) *statistics = solver->statistics();
  return x;
}

}  // namespace

TEST_CASE("every backend solves an SPD system and rejects an indefinite one") {
  const Eigen::MatrixXd spd = yore_test::random_spd(kSize, 2);
  Eigen::VectorXd b(kSize);
  for (int i = 0; i < kSize; ++i) b[i] = std::sin(1.0 + i);
  for (const std::string& backend : yore::linear_solver_backends()) {
    CAPTURE(backend);
    yore::SolverStatistics statistics;
    const Eigen::VectorXd x = solve_with(backend, spd, b, &statistics);
    // direct solvers: backward stable, ~1e-15; CG stops at its default 1e-12 relative residual
    CHECK((spd * x - b).norm() / b.norm() < 1e-10);
    CHECK(statistics.analyses == 1);
    CHECK(statistics.factorizations == 1);
    // an indefinite matrix (for PCG: one with a negative diagonal, all it can tell)
    const Eigen::MatrixXd indefinite =
        spd - (backend == "pcg" ? 100.0 : 40.0) * Eigen::MatrixXd::Identity(kSize, kSize);
    CHECK_THROWS_WITH_AS(solve_with(backend, indefinite, b),
                         doctest::Contains("not positive definite"), yore::NotPositiveDefinite);
  }
  CHECK(yore::linear_solver_backends() == std::vector<std::string>{"cholmod", "eigen-ldlt", "pcg"});
}

TEST_CASE("a one-by-one system") {
  yore::SymmetricPattern pattern;
  pattern.size = 1;
  pattern.column_starts = {0, 1};
  pattern.row_indices = {0};
  for (const std::string& backend : yore::linear_solver_backends()) {
    LinearSolverOptions options;
    options.solver = backend;
    auto solver = yore::make_linear_solver(options);
    solver->analyze(pattern);
    const double value = 2.0, rhs = 1.0;
    solver->factorize(&value);
    double x = 0.0;
    solver->solve(&rhs, &x);
    CHECK(x == doctest::Approx(0.5).epsilon(1e-15));
  }
}

TEST_CASE("the name tables: orderings and factorizations parse, unknown names list the valid") {
  for (const auto& [name, ordering] : yore::ordering_choices())
    CHECK(yore::parse_ordering(name) == ordering);
  for (const auto& [name, kind] : yore::factor_kind_choices())
    CHECK(yore::parse_factor_kind(name) == kind);
  CHECK(yore::parse_ordering("amd") == yore::Ordering::amd);
  CHECK(yore::parse_factor_kind("simplicial") == yore::FactorKind::simplicial);
  CHECK_THROWS_WITH_AS(
      yore::parse_ordering("colamd"),
      doctest::Contains("unknown ordering 'colamd'; valid: amd, metis, nesdis, auto, natural"),
      std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::parse_factor_kind("dense"), doctest::Contains("'dense'; valid:"),
                       std::invalid_argument);
}

TEST_CASE("make_linear_solver refuses unknown backends and orderings a backend cannot do") {
  LinearSolverOptions options;
  options.solver = "umfpack";
  CHECK_THROWS_WITH_AS(
      yore::make_linear_solver(options),
      doctest::Contains("unknown solver 'umfpack'; valid: cholmod, eigen-ldlt, pcg"),
      std::invalid_argument);
  options.solver = "eigen-ldlt";
  options.ordering = yore::Ordering::natural;
  CHECK_THROWS_WITH_AS(yore::make_linear_solver(options), doctest::Contains("AMD only"),
                       std::invalid_argument);
  options.solver = "pcg";
  options.ordering = yore::Ordering::metis;
  CHECK_THROWS_WITH_AS(yore::make_linear_solver(options), doctest::Contains("does not reorder"),
                       std::invalid_argument);
  options.ordering = yore::Ordering::amd;
  options.pcg_tol = 0.0;
  CHECK_THROWS_WITH_AS(yore::make_linear_solver(options), doctest::Contains("pcg_tol must be > 0"),
                       std::invalid_argument);
  options.solver = "cholmod";
  options.ordering = yore::Ordering::metis;
  if (yore::cholmod_has_metis()) {
    CHECK_NOTHROW(yore::make_linear_solver(options));
  } else {
    CHECK_THROWS_WITH_AS(yore::make_linear_solver(options), doctest::Contains("metis"),
                         std::invalid_argument);
  }
}

TEST_CASE("symmetric_multiply is the product with the full symmetric matrix") {
  const Eigen::MatrixXd matrix = yore_test::random_spd(7, 5);
  std::vector<double> values;
  const yore::SymmetricPattern pattern = yore_test::lower_pattern(matrix, values);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(7, -1.0, 2.0);
  Eigen::VectorXd y(7);
  yore::symmetric_multiply(pattern, values.data(), x, y);
  CHECK((y - matrix * x).norm() < 1e-13 * (matrix * x).norm());
  CHECK(yore_test::dense(pattern, values.data()) == matrix);
}

TEST_CASE("preconditioned CG: converges to the tolerance, stops at the iteration cap") {
  const Eigen::MatrixXd matrix = yore_test::random_spd(kSize, 3);
  std::vector<double> values;
  const yore::SymmetricPattern pattern = yore_test::lower_pattern(matrix, values);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(kSize);
  const Eigen::VectorXd diagonal = matrix.diagonal();
  const auto jacobi = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
    z = r.cwiseQuotient(diagonal);
  };
  yore::CgWorkspace work;
  work.resize(kSize);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(kSize);
  bool converged = false;
  const int iterations =
      yore::preconditioned_cg(pattern, values.data(), b, x, jacobi, 1e-12, 1000, work, converged);
  CHECK(converged);
  CHECK(iterations > 0);
  CHECK((matrix * x - b).norm() <= 1e-12 * b.norm() * (1 + 1e-6));
  // a cap of one iteration cannot reach 1e-12 from zero
  Eigen::VectorXd y = Eigen::VectorXd::Zero(kSize);
  CHECK(yore::preconditioned_cg(pattern, values.data(), b, y, jacobi, 1e-12, 1, work, converged) ==
        1);
  CHECK_FALSE(converged);
  // starting at the solution: no iteration at all
  Eigen::VectorXd exact = matrix.ldlt().solve(b);
  CHECK(yore::preconditioned_cg(pattern, values.data(), b, exact, jacobi, 1e-8, 100, work,
                                converged) == 0);
  CHECK(converged);
}
