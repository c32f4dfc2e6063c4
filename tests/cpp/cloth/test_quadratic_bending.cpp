// Tests of cpp/src/cloth/quadratic_bending.cpp (cpp/include/yore/cloth/quadratic_bending.hpp):
// Bergou et al.'s constant matrix Q — symmetry, definiteness, null space, the closed-form energy of
// a folded hinge, the gradient κQx, the free-entry walk, and the Cloth's use of it.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/cloth/quadratic_bending.hpp"

using yore::Positions;

namespace {

Eigen::MatrixXd dense_q(const yore::QuadraticBendingMatrix& q) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(q.size, q.size);
  for (std::int64_t i = 0; i < q.size; ++i)
    for (std::int32_t k = q.row_starts[static_cast<std::size_t>(i)];
         k < q.row_starts[static_cast<std::size_t>(i) + 1]; ++k)
      out(i, q.columns[static_cast<std::size_t>(k)]) = q.values[static_cast<std::size_t>(k)];
  return out;
}

// Two triangles hinged on the edge (0, 1) of length 1, each of height h; vertex 3 folded by
// the dihedral angle theta (0: flat).
Positions hinge(double h, double theta) {
  Positions x(4, 3);
  x << 0, 0, 0, 1, 0, 0, 0.5, h, 0, 0.5, -h * std::cos(theta), h * std::sin(theta);
  return x;
}

yore::Faces hinge_faces() {
  yore::Faces f(2, 3);
  f << 0, 1, 2, 1, 0, 3;
  return f;
}

}  // namespace

TEST_CASE("Q is symmetric PSD, kills translations and planar affine maps; CSR as documented") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 4, 0.6, 0.6);
  const yore::QuadraticBendingMatrix q = yore::quadratic_bending_matrix(mesh.positions, mesh.faces);
  REQUIRE(q.size == 16);
  CHECK(q.hinge_count == static_cast<std::int64_t>(
                             yore::mesh_connectivity(mesh.faces).edges.size() - 12));  // interior
  // diagonal first in every row, then increasing columns
  for (std::int64_t i = 0; i < q.size; ++i) {
    const auto begin = q.row_starts[static_cast<std::size_t>(i)];
    CHECK(q.columns[static_cast<std::size_t>(begin)] == i);
    for (auto k = begin + 2; k < q.row_starts[static_cast<std::size_t>(i) + 1]; ++k)
      CHECK(q.columns[static_cast<std::size_t>(k - 1)] < q.columns[static_cast<std::size_t>(k)]);
  }
  const Eigen::MatrixXd Q = dense_q(q);
  const double scale = Q.norm();
  CHECK((Q - Q.transpose()).norm() == 0.0);
  const Eigen::VectorXd eigenvalues =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Q).eigenvalues();
  CHECK(eigenvalues[0] > -1e-12 * scale);  // PSD up to round-off
  // Q x = 0 for every x affine in the rest plane (constants, x, y): the flat states
  CHECK((Q * Eigen::VectorXd::Ones(16)).norm() < 1e-12 * scale);
  CHECK((Q * mesh.positions.col(0)).norm() < 1e-12 * scale);
  CHECK((Q * mesh.positions.col(1)).norm() < 1e-12 * scale);
  // so a flat sheet in any rigid or in-plane affine pose has no bending energy
  Eigen::Matrix3d a;
  a << 1.3, 0.2, 0.0, -0.4, 0.9, 0.0, 0.0, 0.0, 1.0;
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
  const Positions posed =
      (mesh.positions * (r * a).transpose()).rowwise() + Eigen::RowVector3d(0.3, 0.1, -2.0);
  CHECK(yore::quadratic_bending_energy(q, 2.0, posed) < 1e-12);
  // fold_energy is Σ 2|e|²/(A₀ + A₁)
  CHECK(q.fold_energy > 0.0);
}

TEST_CASE("a folded hinge has E = ½ κ (2|e| sin(θ/2))² / (A₀ + A₁)") {
  const double h = 0.4, kappa = 0.3;
  const yore::QuadraticBendingMatrix q =
      yore::quadratic_bending_matrix(hinge(h, 0.0), hinge_faces());
  REQUIRE(q.hinge_count == 1);
  const double areas = 2 * (0.5 * h);
  for (const double theta : {0.3, 1.0, M_PI / 2}) {
    const double expected = 0.5 * kappa * std::pow(2 * std::sin(theta / 2), 2) / areas;
    // exact for isometric bending: round-off only
    CHECK(yore::quadratic_bending_energy(q, kappa, hinge(h, theta)) ==
          doctest::Approx(expected).epsilon(1e-12));
  }
  // fold_energy is the energy per unit modulus folded flat (θ = π): 2|e|²/(A₀ + A₁)
  CHECK(q.fold_energy == doctest::Approx(2.0 / areas).epsilon(1e-12));
  CHECK(yore::quadratic_bending_energy(q, 1.0, hinge(h, M_PI)) ==
        doctest::Approx(q.fold_energy).epsilon(1e-12));
}

TEST_CASE("the gradient κQx is the finite difference of the energy, returned with it") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3, 0.5, 0.5);
  const yore::QuadraticBendingMatrix q = yore::quadratic_bending_matrix(mesh.positions, mesh.faces);
  Positions x = mesh.positions;
  x(4, 2) = 0.07;
  x(2, 2) = -0.03;
  const double kappa = 0.2;
  Positions gradient;
  const double energy = yore::quadratic_bending_gradient(q, kappa, x, gradient);
  REQUIRE(gradient.rows() == 9);
  CHECK(energy == doctest::Approx(yore::quadratic_bending_energy(q, kappa, x)).epsilon(1e-14));
  // a quadratic: central differences are exact up to round-off, ε E / h ≈ 1e-11 with
  // h = 1e-5 m; 1e-7 of the largest gradient entry is far above that
  const double step = 1e-5, tolerance = 1e-7 * gradient.cwiseAbs().maxCoeff();
  for (int i = 0; i < 9; ++i)
    for (int c = 0; c < 3; ++c) {
      Positions plus = x, minus = x;
      plus(i, c) += step;
      minus(i, c) -= step;
      const double numeric = (yore::quadratic_bending_energy(q, kappa, plus) -
                              yore::quadratic_bending_energy(q, kappa, minus)) /
                             (2 * step);
      CHECK(std::abs(numeric - gradient(i, c)) < tolerance);
    }
}

TEST_CASE("for_each_free_entry visits the upper pairs of free vertices once") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3);
  const yore::QuadraticBendingMatrix q = yore::quadratic_bending_matrix(mesh.positions, mesh.faces);
  std::vector<std::int32_t> index(9);
  for (int i = 0; i < 9; ++i) index[static_cast<std::size_t>(i)] = i;
  index[0] = -1;  // constrained
  index[4] = -1;
  const Eigen::MatrixXd Q = dense_q(q);
  int expected = 0;
  for (int i = 0; i < 9; ++i)
    for (int j = i; j < 9; ++j)
      if (index[static_cast<std::size_t>(i)] >= 0 && index[static_cast<std::size_t>(j)] >= 0 &&
          (i == j || Q(i, j) != 0.0))
        ++expected;
  int visited = 0;
  yore::for_each_free_entry(
      q, index,
      [&](std::int32_t k, std::int32_t i, std::int32_t j, std::int32_t a, std::int32_t b) {
        ++visited;
        CHECK(j >= i);
        CHECK(a == index[static_cast<std::size_t>(i)]);
        CHECK(b == index[static_cast<std::size_t>(j)]);
        CHECK(q.values[static_cast<std::size_t>(k)] == Q(i, j));
      });
  CHECK(visited == expected);
}

TEST_CASE("a quadratic-bending cloth: no bending springs, its energy term is Q's") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3);
  yore::Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(9, 0.01),
                    yore_test::material(100.0, 0.0, 0.0, 0.0, yore::BendingModel::quadratic, 0.05));
  CHECK(cloth.has_quadratic_bending());
  for (std::size_t k = 0; k < cloth.springs().size(); ++k)
    CHECK(cloth.springs().kind[k] == yore::SpringKind::structural);
  CHECK(cloth.bending_rest_positions() == mesh.positions);
  Positions x = mesh.positions;
  x(4, 2) = 0.1;
  cloth.set_positions(x);
  CHECK(cloth.energy(yore::Vec3::Zero()).bending ==
        doctest::Approx(yore::quadratic_bending_energy(cloth.quadratic_bending(), 0.05, x))
            .epsilon(1e-15));
  CHECK(cloth.energy(yore::Vec3::Zero()).bending > 0.0);
  // Q follows the topology: a split rebuilds it for the new vertex count
  cloth.split_faces({{0, Eigen::Vector3d::Constant(1.0 / 3)}}, {});
  CHECK(cloth.quadratic_bending().size == 10);
  CHECK(cloth.bending_rest_positions().rows() == 10);
}

TEST_CASE("Q refuses a hinge face without rest area, and faces out of range") {
  // a hinge on edge (0, 1) whose first face is flat (vertex 2 on the edge's line)
  Positions p(4, 3);
  p << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0.5, -0.5, 0;
  CHECK_THROWS_WITH_AS(yore::quadratic_bending_matrix(p, hinge_faces()),
                       doctest::Contains("face 0 has rest area 0"), std::invalid_argument);
  yore::Faces f(1, 3);
  f << 0, 1, 4;
  CHECK_THROWS_WITH_AS(yore::quadratic_bending_matrix(p, f),
                       doctest::Contains("face 0 has a vertex index out of range"),
                       std::invalid_argument);
}

TEST_CASE("fitted Q: symmetric PSD, exact for quadratic fields, affine-free, refused when tiny") {
  // A grid stretched 5:1 (whitened fits keep its 1-rings), lifted to a paraboloid z = ½ (a u²
  // + 2b uv + c v²): each vertex's fit reproduces the constant Hessian, the residual term is
  // zero, so E = ½ κ A (a² + 2b² + c²) to round-off. Affine fields cost nothing.
  const yore_test::Mesh mesh = yore_test::grid_mesh(7, 6, 1.0, 0.2);
  const yore::QuadraticBendingMatrix q = yore::fitted_bending_matrix(mesh.positions, mesh.faces);
  REQUIRE(q.size == 42);
  const Eigen::MatrixXd Q = dense_q(q);
  const double scale = Q.norm();
  CHECK((Q - Q.transpose()).norm() == 0.0);
  const Eigen::VectorXd eigenvalues =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Q).eigenvalues();
  CHECK(eigenvalues[0] > -1e-12 * scale);
  CHECK(eigenvalues[3] > 1e-9 * scale);  // only the three affine fields are free
  CHECK((Q * Eigen::VectorXd::Ones(42)).norm() < 1e-10 * scale);
  CHECK((Q * mesh.positions.col(0)).norm() < 1e-10 * scale);
  CHECK((Q * mesh.positions.col(1)).norm() < 1e-10 * scale);
  const double a = 1.7, b = -0.6, c = 0.4, modulus = 3e-3;
  Positions lifted = mesh.positions;
  for (Eigen::Index i = 0; i < lifted.rows(); ++i) {
    const double u = lifted(i, 0), v = lifted(i, 1);
    lifted(i, 2) = 0.5 * (a * u * u + 2.0 * b * u * v + c * v * v);
  }
  const double expected = 0.5 * modulus * 0.2 * (a * a + 2.0 * b * b + c * c);
  CHECK(yore::quadratic_bending_energy(q, modulus, lifted) ==
        doctest::Approx(expected).epsilon(1e-9));
  // a mesh of four vertices holds no quadratic fit: refused, naming the other models
  Positions p(4, 3);
  p << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  yore::Faces f(2, 3);
  f << 0, 1, 2, 1, 3, 2;
  CHECK_THROWS_AS(yore::fitted_bending_matrix(p, f), std::invalid_argument);
}
