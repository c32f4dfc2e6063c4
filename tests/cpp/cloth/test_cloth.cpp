// Tests of cpp/src/cloth/cloth.cpp (cpp/include/yore/cloth/cloth.hpp): wiring, materials and their
// checks, spring networks, and energy. The stepping state is tested in test_cloth_state.cpp,
// subdivision in test_cloth_rewiring.cpp, the stable-step estimates in test_stable_step.cpp.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/cloth/cloth.hpp"

using yore::Cloth;
using yore::Edges;
using yore::Positions;
using yore::SpringKind;
using yore::Vec3;
using yore_test::chain;
using yore_test::check_wiring;
using yore_test::pairs_of_kind;

TEST_CASE("a cloth is wired as Fig. 1 with rest lengths and materials from its input") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 3, 0.9, 0.5);
  const Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(12, 0.01),
                    yore_test::material(300.0, 7.0, 0.05, 0.2));
  check_wiring(cloth);
  const auto& s = cloth.springs();
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double length = (mesh.positions.row(s.first[k]) - mesh.positions.row(s.second[k])).norm();
    CHECK(s.rest_length[k] == length);  // the same arithmetic: exactly
    CHECK(s.reference_length[k] == s.rest_length[k]);
    CHECK(s.stiffness[k] == (s.kind[k] == SpringKind::structural ? 300.0 : 7.0));
    CHECK(s.damping[k] == 0.05);
  }
  CHECK(cloth.drag() == 0.2);
  CHECK(cloth.velocities().isZero(0.0));
  CHECK(cloth.has_spring_damping());
  // zero bend stiffness: no bending springs at all (model only what a scene needs)
  const Cloth flat(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(12, 0.01),
                   yore_test::material(300.0, 0.0, 0.0, 0.0));
  CHECK(pairs_of_kind(flat, SpringKind::bending).empty());
  CHECK_FALSE(flat.has_spring_damping());
}

TEST_CASE("bad cloth input is std::invalid_argument naming the problem") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3);
  const Eigen::VectorXd masses = Eigen::VectorXd::Constant(9, 0.01);
  CHECK_THROWS_WITH_AS(
      Cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Ones(8), yore_test::material(1, 1, 0, 0)),
      doctest::Contains("masses has 8 entries for 9 vertices"), std::invalid_argument);
  Eigen::VectorXd bad = masses;
  bad[4] = -1.0;
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, bad, yore_test::material(1, 1, 0, 0)),
                       doctest::Contains("mass of vertex 4"), std::invalid_argument);
  bad[4] = 5e-324;  // subnormal
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, bad, yore_test::material(1, 1, 0, 0)),
                       doctest::Contains("mass of vertex 4"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, yore_test::material(0.0, 1, 0, 0)),
                       doctest::Contains("stretch_stiffness"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, yore_test::material(1, -1, 0, 0)),
                       doctest::Contains("bend_stiffness"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(
      Cloth(mesh.positions, mesh.faces, masses, yore_test::material(1, 1, std::nan(""), 0)),
      doctest::Contains("damping"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(
      Cloth(mesh.positions, mesh.faces, masses, yore_test::material(1, 1, 0, -0.1)),
      doctest::Contains("drag"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses,
                             yore_test::material(1, 1, 0, 0, yore::BendingModel::springs, 0.5)),
                       doctest::Contains("bending_modulus is for quadratic bending"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses,
                             yore_test::material(1, 1, 0, 0, yore::BendingModel::quadratic, 0.5)),
                       doctest::Contains("bend_stiffness must be 0"), std::invalid_argument);
  // the mesh is validated too (validate_mesh's message comes through)
  yore::Faces faces = mesh.faces;
  faces(0, 0) = 42;
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, faces, masses, yore_test::material(1, 1, 0, 0)),
                       doctest::Contains("out of range"), std::invalid_argument);
}

TEST_CASE("from_springs: default and given rest lengths, and its errors") {
  const Cloth net = chain();
  REQUIRE(net.springs().size() == 2);
  CHECK(net.face_count() == 0);
  CHECK(net.springs().rest_length[0] == doctest::Approx(0.4).epsilon(1e-15));
  CHECK(net.springs().rest_length[1] == doctest::Approx(std::hypot(0.4, 0.1)).epsilon(1e-15));
  Positions p(3, 3);
  p << 0, 0, 0, 1, 0, 0, 2, 0, 0;
  const Eigen::VectorXd m = Eigen::VectorXd::Ones(3);
  Edges edges(2, 2);
  edges << 0, 1, 1, 2;
  const Cloth given = Cloth::from_springs(p, edges, Eigen::Vector2d(0.5, 0.25), m, 1, 0, 0);
  CHECK(given.springs().rest_length == std::vector<double>{0.5, 0.25});
  Edges loop(1, 2);
  loop << 1, 1;
  CHECK_THROWS_WITH_AS(Cloth::from_springs(p, loop, {}, m, 1, 0, 0),
                       doctest::Contains("joins vertex 1 to itself"), std::invalid_argument);
  Edges twice(2, 2);
  twice << 0, 1, 1, 0;
  CHECK_THROWS_WITH_AS(Cloth::from_springs(p, twice, {}, m, 1, 0, 0),
                       doctest::Contains("(0, 1) is joined by more than one spring"),
                       std::invalid_argument);
  Edges far(1, 2);
  far << 0, 3;
  CHECK_THROWS_WITH_AS(Cloth::from_springs(p, far, {}, m, 1, 0, 0),
                       doctest::Contains("out of range"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth::from_springs(p, edges, Eigen::Vector2d(1.0, 0.0), m, 1, 0, 0),
                       doctest::Contains("spring 1 (1, 2) has rest length 0"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth::from_springs(p, Edges(0, 2), {}, m, 1, 0, 0),
                       doctest::Contains("at least one spring"), std::invalid_argument);
}

TEST_CASE("energy terms: kinetic, spring and gravity from their definitions") {
  Cloth cloth = yore_test::grid_cloth(3, 100.0, 10.0);
  Positions x = cloth.positions();
  x(4, 2) = 0.2;  // lift the centre: stretches its springs
  cloth.set_positions(x);
  Positions v = Positions::Zero(9, 3);
  v(1, 0) = 2.0;
  cloth.set_velocities(v);
  const Vec3 g(0, 0, -9.81);
  const yore::EnergyTerms e = cloth.energy(g);
  const double m = 0.1 / 9;
  CHECK(e.kinetic == doctest::Approx(0.5 * m * 4.0).epsilon(1e-14));
  CHECK(e.gravity == doctest::Approx(m * 9.81 * 0.2).epsilon(1e-14));
  double spring = 0.0;
  const auto& s = cloth.springs();
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double l = (x.row(s.first[k]) - x.row(s.second[k])).norm();
    spring += 0.5 * s.stiffness[k] * (l - s.rest_length[k]) * (l - s.rest_length[k]);
  }
  CHECK(e.spring == doctest::Approx(spring).epsilon(1e-12));
  CHECK(e.spring > 0.0);
  CHECK(e.bending == 0.0);
  CHECK(e.membrane == 0.0);
  CHECK(e.total() == doctest::Approx(e.kinetic + e.spring + e.gravity).epsilon(1e-15));
}
