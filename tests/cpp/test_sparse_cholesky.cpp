// Tests of cpp/src/sparse_cholesky.cpp (cpp/include/yore/sparse_cholesky.hpp): CHOLMOD behind
// analyze / factorize / solve — solutions against Eigen's dense Cholesky, the reuse of one
// analysis, given permutations, many right-hand sides, and the errors.
#include "yore/sparse_cholesky.hpp"

#include "yore/errors.hpp"
#include "helpers.hpp"

#include <doctest/doctest.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <numeric>
#include <stdexcept>

using yore::FactorKind;
using yore::Ordering;
using yore::SparseCholesky;

namespace {

// The 2-D grid Laplacian of an nx × ny grid plus shift × I: sparse, SPD for shift > 0.
Eigen::MatrixXd grid_laplacian(int nx, int ny, double shift) {
  const int n = nx * ny;
  Eigen::MatrixXd a = shift * Eigen::MatrixXd::Identity(n, n);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int v = j * nx + i;
      for (const int w : {i + 1 < nx ? v + 1 : -1, j + 1 < ny ? v + nx : -1}) {
        if (w < 0) continue;
        a(v, v) += 1.0;
        a(w, w) += 1.0;
        a(v, w) -= 1.0;
        a(w, v) -= 1.0;
      }
    }
  return a;
}

Eigen::VectorXd rhs(int n) {
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) b[i] = std::cos(0.7 * i);
  return b;
}

}  // namespace

TEST_CASE("supernodal and simplicial factors of every ordering solve like dense Cholesky") {
  const Eigen::MatrixXd a = grid_laplacian(6, 5, 0.1);
  std::vector<double> values;
  const yore::SymmetricPattern pattern = yore_test::lower_pattern(a, values);
  const Eigen::VectorXd b = rhs(30);
  const Eigen::VectorXd expected = a.llt().solve(b);
  for (const FactorKind kind : {FactorKind::supernodal, FactorKind::simplicial}) {
    for (const Ordering ordering : {Ordering::amd, Ordering::natural}) {
      SparseCholesky solver(kind, ordering);
      solver.analyze(pattern);
      solver.factorize(values.data());
      Eigen::VectorXd x(30);
      solver.solve(b.data(), x.data());
      // condition number ~ 8/0.1: a relative error of ~1e-14 at most
      CHECK((x - expected).norm() < 1e-12 * expected.norm());
      const auto& statistics = solver.statistics();
      CHECK(statistics.analyses == 1);
      CHECK(statistics.factorizations == 1);
      CHECK(statistics.solves >= 1);
      // L holds at least A's lower triangle (fill only adds)
      CHECK(statistics.factor_nonzeros >= static_cast<double>(pattern.nonzeros()));
      CHECK(statistics.factor_flops > 0.0);
      CHECK(statistics.ordering == (ordering == Ordering::amd ? "amd" : "natural"));
      const std::vector<std::int32_t> permutation = solver.permutation();
      std::vector<std::int32_t> sorted = permutation;
      std::sort(sorted.begin(), sorted.end());
      std::vector<std::int32_t> identity(30);
      std::iota(identity.begin(), identity.end(), 0);
      CHECK(sorted == identity);
      if (ordering == Ordering::natural) CHECK(permutation == identity);
    }
  }
}

TEST_CASE("one analysis serves many factorizations of the same pattern") {
  const Eigen::MatrixXd a = grid_laplacian(5, 5, 0.5);
  std::vector<double> values;
  const yore::SymmetricPattern pattern = yore_test::lower_pattern(a, values);
  SparseCholesky solver(FactorKind::supernodal, Ordering::amd);
  solver.analyze(pattern);
  const Eigen::VectorXd b = rhs(25);
  for (const double scale : {1.0, 3.0, 0.25}) {
    std::vector<double> scaled = values;
    for (double& v : scaled) v *= scale;
    solver.factorize(scaled.data());
    Eigen::VectorXd x(25);
    solver.solve(b.data(), x.data());
    CHECK((scale * a * x - b).norm() < 1e-12 * b.norm());
  }
  CHECK(solver.statistics().analyses == 1);
  CHECK(solver.statistics().factorizations == 3);
}

TEST_CASE("a given permutation, many right-hand sides at once, simplicial solves") {
  const Eigen::MatrixXd a = grid_laplacian(4, 6, 0.2);
  std::vector<double> values;
  const yore::SymmetricPattern pattern = yore_test::lower_pattern(a, values);
  std::vector<std::int32_t> reversed(24);
  for (int k = 0; k < 24; ++k) reversed[static_cast<std::size_t>(k)] = 23 - k;
  SparseCholesky solver(FactorKind::supernodal, Ordering::amd);
  solver.analyze_with_permutation(pattern, reversed);
  CHECK(solver.permutation() == reversed);
  solver.set_simplicial_solves(true);
  solver.factorize(values.data());
  Eigen::MatrixXd b(24, 3);
  b << rhs(24), rhs(24).reverse(), Eigen::VectorXd::Ones(24);
  Eigen::MatrixXd x(24, 3);
  solver.solve_columns(b.data(), x.data(), 3);
  const Eigen::MatrixXd expected = a.llt().solve(b);
  CHECK((x - expected).norm() < 1e-12 * expected.norm());
  Eigen::VectorXd single(24);
  solver.solve(b.col(1).data(), single.data());
  CHECK((single - expected.col(1)).norm() < 1e-12 * expected.norm());
  std::vector<std::int32_t> bad = reversed;
  bad[0] = bad[1];
  CHECK_THROWS_WITH_AS(solver.analyze_with_permutation(pattern, bad),
                       doctest::Contains("not a permutation"), std::invalid_argument);
}

TEST_CASE("an indefinite matrix is NotPositiveDefinite naming the column; misuse is a logic error") {
  Eigen::MatrixXd a = grid_laplacian(3, 3, 0.1);
  a(4, 4) = -1.0;  // column 4 of the natural order
  std::vector<double> values;
  const yore::SymmetricPattern pattern = yore_test::lower_pattern(a, values);
  SparseCholesky solver(FactorKind::simplicial, Ordering::natural);
  solver.analyze(pattern);
  CHECK_THROWS_WITH_AS(solver.factorize(values.data()),
                       doctest::Contains("non-positive pivot at column 4 of 9"),
                       yore::NotPositiveDefinite);
  const Eigen::VectorXd b = rhs(9);
  Eigen::VectorXd x(9);
  CHECK_THROWS_AS(solver.solve(b.data(), x.data()), std::logic_error);  // no valid factor
  SparseCholesky fresh(FactorKind::supernodal, Ordering::amd);
  CHECK_THROWS_AS(fresh.factorize(values.data()), std::logic_error);
}
