// Tests of cpp/src/solvers/sparse_cholesky.cpp (cpp/include/yore/solvers/sparse_cholesky.hpp):
// CHOLMOD behind analyze / factorize / solve — solutions against Eigen's dense Cholesky, the reuse
// of one analysis, given permutations, many right-hand sides, and the errors.
#include <doctest/doctest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/platform/errors.hpp"
#include "yore/solvers/sparse_cholesky.hpp"

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

TEST_CASE(
    "an indefinite matrix is NotPositiveDefinite naming the column; misuse is a logic error") {
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

namespace {

// The grid Laplacian with every vertex made a 3×3 block (the Kronecker product with a fixed SPD
// 3×3 matrix): the shape of the implicit step's systems, one block per vertex.
Eigen::MatrixXd block_laplacian(int nx, int ny, double shift) {
  const Eigen::MatrixXd scalar = grid_laplacian(nx, ny, shift);
  Eigen::Matrix3d block;
  block << 2.0, 0.5, 0.1, 0.5, 1.5, 0.2, 0.1, 0.2, 1.0;
  const Eigen::Index n = scalar.rows();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j) a.block<3, 3>(3 * i, 3 * j) = scalar(i, j) * block;
  return a;
}

}  // namespace

TEST_CASE("orderings of 3×3 blocks: computed on the vertex graph, they keep each block whole") {
  const Eigen::MatrixXd a = block_laplacian(9, 8, 0.1);
  std::vector<double> values;
  yore::SymmetricPattern pattern = yore_test::lower_pattern(a, values);
  const Eigen::VectorXd b = rhs(216);
  const Eigen::VectorXd expected = a.llt().solve(b);
  for (const Ordering ordering : {Ordering::amd, Ordering::metis, Ordering::nesdis}) {
    CAPTURE(static_cast<int>(ordering));
    double scalar_fill = 0.0;
    for (const int block_size : {1, 3}) {
      pattern.block_size = block_size;
      SparseCholesky solver(FactorKind::supernodal, ordering);
      solver.analyze(pattern);
      solver.factorize(values.data());
      Eigen::VectorXd x(216);
      solver.solve(b.data(), x.data());
      CHECK((x - expected).norm() < 1e-12 * expected.norm());
      CHECK(solver.statistics().ordering == (ordering == Ordering::amd     ? "amd"
                                             : ordering == Ordering::metis ? "metis"
                                                                           : "nesdis"));
      const std::vector<std::int32_t> permutation = solver.permutation();
      if (block_size == 3) {
        // the three unknowns of a vertex stay together, in their order
        for (std::size_t k = 0; k < permutation.size(); k += 3) {
          CHECK(permutation[k] % 3 == 0);
          CHECK(permutation[k + 1] == permutation[k] + 1);
          CHECK(permutation[k + 2] == permutation[k] + 2);
        }
        // the same ordering problem, 9 times smaller: AMD's fill agrees with the scalar
        // graph's to within its tie-breaking (here: exactly, or within 5 %)
        CHECK(solver.statistics().factor_nonzeros <= 1.05 * scalar_fill);
      } else {
        scalar_fill = solver.statistics().factor_nonzeros;
      }
    }
  }
}

TEST_CASE("the automatic ordering: AMD on small systems, nested dissection on large ones") {
  CHECK(yore::resolve_ordering(Ordering::automatic, 100) == Ordering::amd);
  CHECK(yore::resolve_ordering(Ordering::automatic, yore::kNestedDissectionFromVertices - 1) ==
        Ordering::amd);
  CHECK(yore::resolve_ordering(Ordering::automatic, yore::kNestedDissectionFromVertices) ==
        Ordering::nesdis);
  for (const Ordering ordering :
       {Ordering::amd, Ordering::metis, Ordering::nesdis, Ordering::natural}) {
    CHECK(yore::resolve_ordering(ordering, 1 << 20) == ordering);
  }
  CHECK(yore::parse_ordering("auto") == Ordering::automatic);
  CHECK(yore::parse_ordering("nesdis") == Ordering::nesdis);
  // a 16-vertex system of 3×3 blocks is AMD's
  const Eigen::MatrixXd small = block_laplacian(4, 4, 0.3);
  std::vector<double> values;
  yore::SymmetricPattern pattern = yore_test::lower_pattern(small, values);
  pattern.block_size = 3;
  SparseCholesky solver(FactorKind::supernodal, Ordering::automatic);
  solver.analyze(pattern);
  CHECK(solver.statistics().ordering == "amd");
}

TEST_CASE("supernode relaxation: a wider amalgamation stores more zeros and solves the same") {
  const Eigen::MatrixXd a = block_laplacian(12, 12, 0.1);
  std::vector<double> values;
  yore::SymmetricPattern pattern = yore_test::lower_pattern(a, values);
  pattern.block_size = 3;
  const Eigen::VectorXd b = rhs(432);
  const Eigen::VectorXd expected = a.llt().solve(b);
  double previous_fill = 0.0;
  for (const double relaxation : {0.0, 1.0, 8.0}) {
    SparseCholesky solver(FactorKind::supernodal, Ordering::amd, relaxation);
    solver.analyze(pattern);
    solver.factorize(values.data());
    Eigen::VectorXd x(432);
    solver.solve(b.data(), x.data());
    CHECK((x - expected).norm() < 1e-12 * expected.norm());
    // nnz(L) and the flops count the true nonzeros: the same whatever the amalgamation
    if (previous_fill > 0.0) CHECK(solver.statistics().factor_nonzeros == previous_fill);
    previous_fill = solver.statistics().factor_nonzeros;
  }
  CHECK_THROWS_WITH_AS(SparseCholesky(FactorKind::supernodal, Ordering::amd, -1.0),
                       doctest::Contains("supernode_relaxation"), std::invalid_argument);
  CHECK_THROWS_AS(SparseCholesky(FactorKind::supernodal, Ordering::amd, 17.0),
                  std::invalid_argument);
}

namespace {

// A symmetric, strictly diagonally dominant (so SPD) matrix on the block Laplacian's pattern
// whose entries all differ: an entry that lands in another's place changes the solution.
Eigen::MatrixXd distinct_entries(const Eigen::MatrixXd& pattern, double phase) {
  const Eigen::Index n = pattern.rows();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j) {
      if (i == j || pattern(i, j) == 0.0) continue;
      a(i, j) = 0.5 + 0.4 * std::sin(phase + static_cast<double>(i * j + i + j));
    }
  for (Eigen::Index i = 0; i < n; ++i)
    a(i, i) = a.row(i).cwiseAbs().sum() + 0.1 + 0.01 * static_cast<double>(i);
  return a;
}

}  // namespace

TEST_CASE("a permuted supernodal factor is refactored from the matrix stored permuted") {
  // sparse_cholesky.cpp keeps P A Pᵀ's lower triangle and gathers each factorization's values
  // into it (no transposes per factorization): entries that all differ, two matrices on one
  // analysis, against dense Cholesky.
  const Eigen::MatrixXd shape = block_laplacian(10, 9, 0.1);
  const Eigen::MatrixXd first = distinct_entries(shape, 0.0), second = distinct_entries(shape, 1.3);
  std::vector<double> values_first, values_second;
  yore::SymmetricPattern pattern = yore_test::lower_pattern(first, values_first);
  const yore::SymmetricPattern same = yore_test::lower_pattern(second, values_second);
  REQUIRE(same.row_indices == pattern.row_indices);
  const Eigen::VectorXd b = rhs(270);
  for (const Ordering ordering : {Ordering::amd, Ordering::nesdis, Ordering::natural}) {
    for (const int block_size : {1, 3}) {
      CAPTURE(static_cast<int>(ordering));
      CAPTURE(block_size);
      pattern.block_size = block_size;
      SparseCholesky solver(FactorKind::supernodal, ordering);
      solver.analyze(pattern);
      for (int round = 0; round < 2; ++round) {
        const Eigen::MatrixXd& a = round == 0 ? first : second;
        solver.factorize((round == 0 ? values_first : values_second).data());
        Eigen::VectorXd x(270);
        solver.solve(b.data(), x.data());
        const Eigen::VectorXd expected = a.llt().solve(b);
        CHECK((x - expected).norm() < 1e-12 * expected.norm());
        Eigen::MatrixXd columns(270, 2), solved(270, 2);
        columns << b, b.reverse();
        solver.solve_columns(columns.data(), solved.data(), 2);
        CHECK((solved - a.llt().solve(columns)).norm() < 1e-12 * solved.norm());
      }
      // the permutation reported is the analysis's, not the stored matrix's identity
      const std::vector<std::int32_t> permutation = solver.permutation();
      std::vector<std::int32_t> identity(270);
      std::iota(identity.begin(), identity.end(), 0);
      std::vector<std::int32_t> sorted = permutation;
      std::sort(sorted.begin(), sorted.end());
      CHECK(sorted == identity);
      CHECK((permutation == identity) == (ordering == Ordering::natural));
      // CHOLMOD's OpenMP regions ran on this thread, without a libgomp team
      CHECK(solver.statistics().openmp_regions_inlined > 0);
    }
  }
}
