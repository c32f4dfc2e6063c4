// Tests of cpp/src/solvers/spring_matrix.cpp (cpp/include/yore/solvers/spring_matrix.hpp): the
// constant scalar matrix Q of the prefactored methods, its pattern over the free vertices, and the
// checksum that decides when it must be refactored.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>

#include "helpers.hpp"
#include "yore/solvers/spring_matrix.hpp"

using yore::Cloth;

namespace {

// Q = M/h² + drag·M/h + Σ (k + c/h) AᵀA (+ κ Q_bending), built densely over all vertices,
// then restricted to the free ones.
Eigen::MatrixXd expected_q(const Cloth& cloth, double h, const std::vector<std::int32_t>& free) {
  const Eigen::Index n = cloth.vertex_count();
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    full(i, i) += cloth.masses()[i] / (h * h) + cloth.drag() * cloth.masses()[i] / h;
  const auto& s = cloth.springs();
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double w = s.stiffness[k] + s.damping[k] / h;
    full(s.first[k], s.first[k]) += w;
    full(s.second[k], s.second[k]) += w;
    full(s.first[k], s.second[k]) -= w;
    full(s.second[k], s.first[k]) -= w;
  }
  if (cloth.has_quadratic_bending()) {
    const auto& q = cloth.quadratic_bending();
    for (std::int64_t i = 0; i < q.size; ++i)
      for (auto k = q.row_starts[static_cast<std::size_t>(i)];
           k < q.row_starts[static_cast<std::size_t>(i) + 1]; ++k)
        full(i, q.columns[static_cast<std::size_t>(k)]) +=
            cloth.bending_modulus() * q.values[static_cast<std::size_t>(k)];
  }
  Eigen::MatrixXd out(free.size(), free.size());
  for (std::size_t a = 0; a < free.size(); ++a)
    for (std::size_t b = 0; b < free.size(); ++b) out(a, b) = full(free[a], free[b]);
  return out;
}

}  // namespace

TEST_CASE("Q over the free vertices is M/h² + drag M/h + Σ (k + c/h) AᵀA, SPD") {
  Cloth cloth = yore_test::grid_cloth(4, 300.0, 30.0, 0.05, 0.4);
  cloth.fix({0, 3});
  yore::ScalarSpringPattern structure;
  yore::build_scalar_spring_pattern(cloth, structure);
  REQUIRE(structure.free_vertices.size() == 14);
  CHECK(structure.free_of_vertex[0] == -1);
  CHECK(structure.free_of_vertex[1] == 0);
  CHECK(structure.free_of_vertex[4] == 2);
  CHECK(std::is_sorted(structure.free_vertices.begin(), structure.free_vertices.end()));
  const auto& pattern = structure.pattern;
  for (std::int32_t c = 0; c < pattern.size; ++c)  // each column starts with its diagonal
    CHECK(pattern.row_indices[static_cast<std::size_t>(pattern.column_starts[c])] == c);
  // a spring to a fixed vertex has no off-diagonal slot
  const auto& s = cloth.springs();
  for (std::size_t k = 0; k < s.size(); ++k)
    CHECK((structure.spring_slot[k] < 0) ==
          (s.first[k] == 0 || s.second[k] == 0 || s.first[k] == 3 || s.second[k] == 3));
  const double h = 0.01;
  std::vector<double> values;
  yore::fill_scalar_spring_matrix(cloth, h, structure, values);
  const Eigen::MatrixXd q = yore_test::dense(pattern, values.data());
  const Eigen::MatrixXd expected = expected_q(cloth, h, structure.free_vertices);
  CHECK((q - expected).norm() < 1e-13 * expected.norm());
  CHECK(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(q).eigenvalues()[0] > 0.0);
}

TEST_CASE("quadratic bending enters Q as κ Q_bending") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 4);
  Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(16, 0.01),
              yore_test::material(300.0, 0.0, 0.0, 0.0, yore::BendingModel::quadratic, 0.02));
  cloth.fix({0});
  yore::ScalarSpringPattern structure;
  yore::build_scalar_spring_pattern(cloth, structure);
  CHECK(structure.bending_slot.size() == cloth.quadratic_bending().columns.size());
  std::vector<double> values;
  yore::fill_scalar_spring_matrix(cloth, 0.02, structure, values);
  const Eigen::MatrixXd expected = expected_q(cloth, 0.02, structure.free_vertices);
  CHECK((yore_test::dense(structure.pattern, values.data()) - expected).norm() <
        1e-13 * expected.norm());
}

TEST_CASE("the material checksum follows stiffness, damping and drag, not positions") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3);
  const Eigen::VectorXd masses = Eigen::VectorXd::Constant(9, 0.01);
  const double base = yore::spring_material_checksum(
      Cloth(mesh.positions, mesh.faces, masses, yore_test::material(100, 10, 0.1, 0.2)));
  CHECK(yore::spring_material_checksum(Cloth(mesh.positions, mesh.faces, masses,
                                             yore_test::material(101, 10, 0.1, 0.2))) != base);
  CHECK(yore::spring_material_checksum(Cloth(mesh.positions, mesh.faces, masses,
                                             yore_test::material(100, 10, 0.2, 0.2))) != base);
  CHECK(yore::spring_material_checksum(Cloth(mesh.positions, mesh.faces, masses,
                                             yore_test::material(100, 10, 0.1, 0.3))) != base);
  Cloth moved(mesh.positions, mesh.faces, masses, yore_test::material(100, 10, 0.1, 0.2));
  moved.set_positions(mesh.positions * 2.0);
  CHECK(yore::spring_material_checksum(moved) == base);
}
