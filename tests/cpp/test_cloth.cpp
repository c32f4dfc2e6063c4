// Tests of cpp/src/cloth.cpp (cpp/include/yore/cloth.hpp): wiring, materials and their checks,
// constraints and drivers, energy, state round trip and clock, the paper's 1→3 split and 1→4
// refinement as the Cloth rewires them, and the stable-step estimates.
#include "yore/cloth.hpp"

#include "yore/explicit.hpp"
#include "helpers.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

using yore::Cloth;
using yore::Edges;
using yore::Positions;
using yore::SpringKind;
using yore::Vec3;

namespace {

std::set<yore::VertexPair> pairs_of_kind(const Cloth& cloth, SpringKind kind) {
  std::set<yore::VertexPair> out;
  const auto& s = cloth.springs();
  for (std::size_t k = 0; k < s.size(); ++k)
    if (s.kind[k] == kind)
      out.insert({std::min(s.first[k], s.second[k]), std::max(s.first[k], s.second[k])});
  return out;
}

// The springs are exactly the paper's Fig. 1 wiring of the cloth's current faces.
void check_wiring(const Cloth& cloth) {
  const yore::MeshConnectivity c = yore::mesh_connectivity(cloth.faces());
  CHECK(pairs_of_kind(cloth, SpringKind::structural) ==
        std::set<yore::VertexPair>(c.edges.begin(), c.edges.end()));
  CHECK(pairs_of_kind(cloth, SpringKind::bending) ==
        std::set<yore::VertexPair>(c.bending_pairs.begin(), c.bending_pairs.end()));
  CHECK(cloth.springs().size() == c.edges.size() + c.bending_pairs.size());
}

Cloth chain() {
  Positions positions(3, 3);
  positions << 0, 0, 0, 0.4, 0, 0, 0.8, 0.1, 0;
  Edges edges(2, 2);
  edges << 0, 1, 1, 2;
  return Cloth::from_springs(positions, edges, Eigen::VectorXd(),
                             Eigen::VectorXd::Constant(3, 0.1), 40.0, 0.01, 0.1);
}

double face_rest_area(const Cloth& cloth, const std::vector<std::int32_t>& faces) {
  const auto& s = cloth.springs();
  auto rest = [&](std::int32_t i, std::int32_t j) {
    for (std::size_t k = 0; k < s.size(); ++k)
      if (s.kind[k] == SpringKind::structural &&
          ((s.first[k] == i && s.second[k] == j) || (s.first[k] == j && s.second[k] == i)))
        return s.rest_length[k];
    return std::numeric_limits<double>::quiet_NaN();
  };
  double area = 0.0;
  for (const std::int32_t f : faces) {
    const auto& F = cloth.faces();
    area += yore::area_from_sides(rest(F(f, 0), F(f, 1)), rest(F(f, 1), F(f, 2)),
                                  rest(F(f, 2), F(f, 0)));
  }
  return area;
}

}  // namespace

TEST_CASE("a cloth is wired as Fig. 1 with rest lengths and materials from its input") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 3, 0.9, 0.5);
  const Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(12, 0.01), 300.0, 7.0,
                    0.05, 0.2);
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
  const Cloth flat(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(12, 0.01), 300.0, 0.0,
                   0.0, 0.0);
  CHECK(pairs_of_kind(flat, SpringKind::bending).empty());
  CHECK_FALSE(flat.has_spring_damping());
}

TEST_CASE("incidence lists every spring at both of its ends with the right sign") {
  const Cloth cloth = yore_test::grid_cloth(4);
  const auto& offsets = cloth.incidence_offsets();
  REQUIRE(offsets.size() == static_cast<std::size_t>(cloth.vertex_count()) + 1);
  std::vector<int> seen(cloth.springs().size(), 0);
  for (std::int64_t i = 0; i < cloth.vertex_count(); ++i) {
    for (std::int32_t k = offsets[i]; k < offsets[i + 1]; ++k) {
      const auto spring = static_cast<std::size_t>(cloth.incident_springs()[k]);
      const double sign = cloth.incident_signs()[k];
      CHECK((sign == 1.0 ? cloth.springs().first[spring] : cloth.springs().second[spring]) == i);
      ++seen[spring];
    }
  }
  CHECK(std::all_of(seen.begin(), seen.end(), [](int count) { return count == 2; }));
}

TEST_CASE("bad cloth input is std::invalid_argument naming the problem") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3);
  const Eigen::VectorXd masses = Eigen::VectorXd::Constant(9, 0.01);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Ones(8), 1, 1, 0, 0),
                       doctest::Contains("masses has 8 entries for 9 vertices"),
                       std::invalid_argument);
  Eigen::VectorXd bad = masses;
  bad[4] = -1.0;
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, bad, 1, 1, 0, 0),
                       doctest::Contains("mass of vertex 4"), std::invalid_argument);
  bad[4] = 5e-324;  // subnormal
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, bad, 1, 1, 0, 0),
                       doctest::Contains("mass of vertex 4"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, 0.0, 1, 0, 0),
                       doctest::Contains("stretch_stiffness"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, 1, -1, 0, 0),
                       doctest::Contains("bend_stiffness"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, 1, 1, std::nan(""), 0),
                       doctest::Contains("damping"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, 1, 1, 0, -0.1),
                       doctest::Contains("drag"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, 1, 1, 0, 0,
                             yore::BendingModel::springs, 0.5),
                       doctest::Contains("bending_modulus is for quadratic bending"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, mesh.faces, masses, 1, 1, 0, 0,
                             yore::BendingModel::quadratic, 0.5),
                       doctest::Contains("bend_stiffness must be 0"), std::invalid_argument);
  // the mesh is validated too (validate_mesh's message comes through)
  yore::Faces faces = mesh.faces;
  faces(0, 0) = 42;
  CHECK_THROWS_WITH_AS(Cloth(mesh.positions, faces, masses, 1, 1, 0, 0),
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

TEST_CASE("state setters check shapes and values and count as edits") {
  Cloth cloth = yore_test::grid_cloth(3);
  const auto edits = cloth.edit_count();
  const auto version = cloth.topology_version();
  CHECK_THROWS_WITH_AS(cloth.set_positions(Positions::Zero(4, 3)),
                       doctest::Contains("positions must have shape (9, 3), got (4, 3)"),
                       std::invalid_argument);
  Positions x = cloth.positions();
  x(2, 0) = std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH_AS(cloth.set_positions(x), doctest::Contains("position of vertex 2"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(cloth.set_rest_lengths(Eigen::VectorXd::Ones(3)),
                       doctest::Contains("rest lengths must have"), std::invalid_argument);
  Eigen::VectorXd rest = Eigen::Map<const Eigen::VectorXd>(
      cloth.springs().rest_length.data(), static_cast<Eigen::Index>(cloth.springs().size()));
  rest[3] = 0.0;
  CHECK_THROWS_WITH_AS(cloth.set_rest_lengths(rest),
                       doctest::Contains("rest length of spring 3 must be finite and > 0"),
                       std::invalid_argument);
  CHECK(cloth.edit_count() == edits);  // refused edits change nothing
  cloth.set_positions(cloth.positions() * 1.1);
  CHECK(cloth.edit_count() == edits + 1);
  // an edit of the state is not a change of topology
  CHECK(cloth.topology_version() == version);
  // constrained vertices keep their prescribed velocity
  cloth.fix({0});
  cloth.set_velocities(Positions::Ones(9, 3));
  CHECK(cloth.velocities().row(0).isZero(0.0));
  CHECK(cloth.velocities().row(1) == Eigen::RowVector3d::Ones());
}

TEST_CASE("fix and drive: new topology versions, zero inverse masses, checked indices") {
  Cloth cloth = yore_test::grid_cloth(3);
  const auto version = cloth.topology_version();
  cloth.fix({0, 2});
  CHECK(cloth.topology_version() != version);
  CHECK(cloth.vertex_states()[0] == yore::VertexState::fixed);
  CHECK(cloth.inverse_masses()[0] == 0.0);
  CHECK(cloth.inverse_masses()[1] == doctest::Approx(90.0).epsilon(1e-12));  // 1 / (0.1/9)
  const auto fixed_version = cloth.topology_version();
  cloth.drive_rotation({6, 7}, Vec3(1, 1, 0), Vec3(0, 0, 2), 3.0);
  CHECK(cloth.topology_version() != fixed_version);
  CHECK(cloth.vertex_states()[7] == yore::VertexState::driven);
  CHECK(cloth.inverse_masses()[7] == 0.0);
  REQUIRE(cloth.drivers().size() == 1);
  CHECK(cloth.drivers()[0].axis == Vec3(0, 0, 1));  // normalised
  CHECK_THROWS_WITH_AS(cloth.fix({9}), doctest::Contains("cannot fix vertex 9: index out of range"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(cloth.fix({7}), doctest::Contains("cannot fix vertex 7: it is already driven"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(cloth.drive_rotation({0}, Vec3::Zero(), Vec3::UnitZ(), 1.0),
                       doctest::Contains("cannot drive vertex 0: it is fixed"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(cloth.drive_rotation({4}, Vec3::Zero(), Vec3::Zero(), 1.0),
                       doctest::Contains("axis must be a finite, non-zero vector"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(cloth.drive_rotation({4}, Vec3::Zero(), Vec3::UnitZ(), std::nan("")),
                       doctest::Contains("omega must be finite"), std::invalid_argument);
}

TEST_CASE("a rotation driver moves its vertices rigidly about the axis at omega") {
  Cloth cloth = yore_test::grid_cloth(3);
  const Vec3 center(0.5, 0.5, 0.0), axis(0, 0, 1);
  const double omega = 2.0;
  const Positions start = cloth.positions();
  cloth.drive_rotation({0, 8}, center, axis, omega);
  const double t = 0.3;
  cloth.apply_drivers(t);
  for (const int v : {0, 8}) {
    const Vec3 arm0 = start.row(v).transpose() - center;
    const Vec3 arm = cloth.positions().row(v).transpose() - center;
    // rotated by ωt about z: the angle between the arms and their lengths (round-off only)
    CHECK(arm.norm() == doctest::Approx(arm0.norm()).epsilon(1e-14));
    CHECK(std::atan2(arm0.cross(arm).z(), arm0.dot(arm)) == doctest::Approx(omega * t).epsilon(1e-12));
    // v = ω × arm
    const Vec3 velocity = cloth.velocities().row(v);
    CHECK((velocity - omega * axis.cross(arm)).norm() < 1e-14);
  }
  // free vertices are untouched
  CHECK(cloth.positions().row(4) == start.row(4));
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

TEST_CASE("state round trip: a restored cloth continues bit for bit; the clock is exact") {
  // A driven chain: from_state(state()) continues exactly like the original, and the clock
  // gives the same time whether 30 steps come in one call or in 13 + 17.
  Cloth original = chain();
  original.drive_rotation({0}, Vec3(0, 0.2, 0), Vec3(0, 0, 1), 3.0);
  yore::ExplicitIntegrator first, second;
  const Vec3 gravity(0, -9.81, 0);
  first.advance(original, gravity, 1e-3, 13);
  Cloth copy = Cloth::from_state(original.state());
  CHECK(copy.topology_version() != original.topology_version());  // unique per cloth
  first.advance(original, gravity, 1e-3, 17);
  second.advance(copy, gravity, 1e-3, 17);
  CHECK(original.positions() == copy.positions());
  CHECK(original.velocities() == copy.velocities());
  CHECK(original.time() == 30 * 1e-3);  // origin + steps × dt, not a sum of 30 increments
  CHECK(original.clock().steps == 30);
}

TEST_CASE("the clock restarts its origin when dt changes; set_time resets it") {
  Cloth cloth = chain();
  for (int k = 0; k < 3; ++k) cloth.advance_time(0.1);
  CHECK(cloth.time() == 3 * 0.1);
  cloth.advance_time(0.25);
  CHECK(cloth.clock().origin == 3 * 0.1);
  CHECK(cloth.clock().steps == 1);
  CHECK(cloth.time() == 3 * 0.1 + 0.25);
  cloth.set_time(2.0);
  CHECK(cloth.time() == 2.0);
  CHECK(cloth.clock().steps == 0);
}

TEST_CASE("from_state names the first inconsistency of a tampered state") {
  const Cloth cloth = yore_test::grid_cloth(3);
  yore::ClothState state = cloth.state();
  SUBCASE("vertex states") {
    state.vertex_states.pop_back();
    CHECK_THROWS_WITH_AS(Cloth::from_state(state),
                         doctest::Contains("vertex_states has 8 entries for 9"),
                         std::invalid_argument);
  }
  SUBCASE("velocities") {
    state.velocities = Positions::Zero(2, 3);
    CHECK_THROWS_WITH_AS(Cloth::from_state(state), doctest::Contains("velocities has 2 rows"),
                         std::invalid_argument);
  }
  SUBCASE("a spring's kind") {
    state.springs.kind[0] = static_cast<SpringKind>(7);
    CHECK_THROWS_WITH_AS(Cloth::from_state(state), doctest::Contains("spring 0 has kind 7"),
                         std::invalid_argument);
  }
  SUBCASE("a spring's rest length") {
    state.springs.rest_length[2] = -1.0;
    CHECK_THROWS_WITH_AS(Cloth::from_state(state), doctest::Contains("spring 2"),
                         std::invalid_argument);
  }
}

TEST_CASE("split 1→3: the paper's counts, eq. (1) rest lengths and 0.95 masses") {
  Cloth cloth = yore_test::grid_cloth(5, 200.0, 20.0, 0.02, 0.3);
  const auto v0 = cloth.vertex_count(), f0 = cloth.face_count();
  const auto s0 = pairs_of_kind(cloth, SpringKind::structural).size();
  const double mass0 = cloth.masses().sum();
  const auto version = cloth.topology_version();
  std::vector<yore::FaceSplit> splits;
  for (const int f : {3, 8, 9, 20}) splits.push_back({f, Eigen::Vector3d(0.2, 0.3, 0.5)});
  const yore::SplitReport report = cloth.split_faces(splits, {});
  const int k = 4;
  CHECK(report.split_faces.size() == 4);
  CHECK(cloth.vertex_count() == v0 + k);
  CHECK(cloth.face_count() == f0 + 2 * k);
  CHECK(pairs_of_kind(cloth, SpringKind::structural).size() == s0 + 3 * k);
  CHECK(report.region_faces.size() == 3 * k);
  CHECK(cloth.topology_version() != version);
  check_wiring(cloth);
  CHECK_NOTHROW(yore::validate_mesh(cloth.positions(), cloth.faces()));
  // every spring at a new vertex: rest = 1.1 × its length at the split (eq. (1))
  const auto& s = cloth.springs();
  int new_springs = 0;
  for (std::size_t q = 0; q < s.size(); ++q) {
    if (s.first[q] < v0 && s.second[q] < v0) continue;
    const double length = (cloth.positions().row(s.first[q]) - cloth.positions().row(s.second[q])).norm();
    CHECK(s.rest_length[q] == doctest::Approx(1.1 * length).epsilon(1e-14));
    CHECK(s.reference_length[q] == doctest::Approx(length).epsilon(1e-14));
    ++new_springs;
  }
  CHECK(new_springs >= 3 * k);
  // masses: 0.95 × the mean of the corners (uniform here); the total grows by that
  for (const auto v : report.new_vertices)
    CHECK(cloth.masses()[v] == doctest::Approx(0.95 * 0.1 / 25).epsilon(1e-14));
  CHECK(report.mass_added == doctest::Approx(k * 0.95 * 0.1 / 25).epsilon(1e-12));
  CHECK(cloth.masses().sum() == doctest::Approx(mass0 + report.mass_added).epsilon(1e-14));
  // the new vertices lie on the plane at the requested barycentric point (none moved inward)
  CHECK(report.moved_inward == 0);
  for (std::size_t q = 0; q < report.new_vertices.size(); ++q)
    CHECK(cloth.positions()(report.new_vertices[q], 2) == 0.0);
  // the rest area of the split region grows (the 1.1 springs) — the partial area expansion
  CHECK(report.rest_area_after > report.rest_area_before);
  CHECK(report.rest_area_before == doctest::Approx(4 * 0.5 / 16).epsilon(1e-12));
}

TEST_CASE("split with conserve_mass keeps the total mass; bad splits are refused") {
  Cloth cloth = yore_test::grid_cloth(5);
  yore::SplitOptions options;
  options.conserve_mass = true;
  const yore::SplitReport report = cloth.split_faces({{10, Eigen::Vector3d::Constant(1.0 / 3)},
                                                      {11, Eigen::Vector3d::Constant(1.0 / 3)}},
                                                     options);
  // redistribution sums of a few terms: round-off ~1e-17 kg
  CHECK(std::abs(cloth.masses().sum() - 0.1) < 1e-15);
  CHECK(std::abs(report.mass_added) < 1e-15);
  CHECK((cloth.masses().array() > 0.0).all());
  yore::SplitOptions bad;
  bad.expansion = 0.0;
  CHECK_THROWS_WITH_AS(cloth.split_faces({{0, Eigen::Vector3d::Constant(1.0 / 3)}}, bad),
                       doctest::Contains("expansion must be finite and > 0"),
                       std::invalid_argument);
  bad = {};
  bad.mass_scale = -1.0;
  CHECK_THROWS_WITH_AS(cloth.split_faces({{0, Eigen::Vector3d::Constant(1.0 / 3)}}, bad),
                       doctest::Contains("mass_scale must be finite and > 0"),
                       std::invalid_argument);
  Cloth net = chain();
  CHECK_THROWS_WITH_AS(net.split_faces({{0, Eigen::Vector3d::Constant(1.0 / 3)}}, {}),
                       doctest::Contains("a spring network has no faces to split"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(net.refine_faces({0}), doctest::Contains("no faces to refine"),
                       std::invalid_argument);
}

TEST_CASE("refine 1→4 keeps the rest metric, the total mass and the wiring") {
  for (const bool tube : {false, true}) {
    CAPTURE(tube);
    const yore_test::Mesh mesh =
        tube ? yore_test::cylinder_mesh(0.3, 0.5, 4, 8) : yore_test::grid_mesh(5, 5);
    const Eigen::Index n = mesh.positions.rows();
    Eigen::VectorXd masses(n);
    for (Eigen::Index i = 0; i < n; ++i) masses[i] = 1e-3 * (1.0 + 0.5 * std::sin(i));  // uneven
    Cloth cloth(mesh.positions, mesh.faces, masses, 200.0, 20.0, 0.0, 0.0);
    const yore::RefineReport report = cloth.refine_faces({3, 4, 12});
    check_wiring(cloth);
    CHECK_NOTHROW(yore::validate_mesh(cloth.positions(), cloth.faces()));
    CHECK(report.refined_faces.size() >= 3);
    CHECK(static_cast<Eigen::Index>(report.new_vertices.size()) == cloth.vertex_count() - n);
    // masses are redistributed: the total is unchanged (sums of ~50 terms, 1e-14 relative)
    CHECK(std::abs(cloth.masses().sum() - masses.sum()) < 1e-14 * masses.sum());
    CHECK(std::abs(report.mass_added) < 1e-14 * masses.sum());
    // children tile their parents in the rest metric
    CHECK(report.rest_area_after == doctest::Approx(report.rest_area_before).epsilon(1e-12));
    CHECK(face_rest_area(cloth, report.region_faces) ==
          doctest::Approx(report.rest_area_after).epsilon(1e-12));
    // an unstrained cloth: every spring's rest length is its current length (square roots of
    // sums of O(edge²) terms: ~1e-15 relative; 1e-12 is ample)
    const auto& s = cloth.springs();
    for (std::size_t k = 0; k < s.size(); ++k) {
      const double length = (cloth.positions().row(s.first[k]) - cloth.positions().row(s.second[k])).norm();
      CHECK(s.rest_length[k] == doctest::Approx(length).epsilon(1e-12));
    }
  }
}

TEST_CASE("without bending springs a refinement adds none") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(25, 1e-3), 200.0, 0.0, 0.0, 0.0);
  cloth.refine_faces({3, 10});
  CHECK(pairs_of_kind(cloth, SpringKind::bending).empty());
  CHECK(pairs_of_kind(cloth, SpringKind::structural).size() ==
        yore::mesh_connectivity(cloth.faces()).edges.size());
}

TEST_CASE("refining a stretched region keeps its rest lengths, not its stretch") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(25, 1e-3), 200.0, 20.0, 0.0,
              0.0);
  Positions stretched = mesh.positions;
  stretched.col(0) *= 1.3;  // 30 % along x, still flat
  cloth.set_positions(stretched);
  cloth.refine_faces({10});
  // the same surgery on the rest pattern: its vertices are where the rest metric puts them
  const yore::Refinement pattern = yore::refine_faces_1to4(mesh.positions, mesh.faces, {10});
  REQUIRE(pattern.mesh.faces == cloth.faces());
  const auto& s = cloth.springs();
  double largest_strain = 0.0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double rest = (pattern.mesh.positions.row(s.first[k]) -
                         pattern.mesh.positions.row(s.second[k])).norm();
    CHECK(s.rest_length[k] == doctest::Approx(rest).epsilon(1e-12));
    largest_strain = std::max(
        largest_strain,
        (cloth.positions().row(s.first[k]) - cloth.positions().row(s.second[k])).norm() / rest);
  }
  CHECK(largest_strain > 1.2);
}

TEST_CASE("symplectic Euler's step limit: the damped oscillator's bound") {
  // h² ω² + 2 h γ = 4 at the limit
  for (const auto& [w2, gamma] : {std::pair{100.0, 0.0}, {100.0, 3.0}, {1e4, 0.5}}) {
    const double h = yore::symplectic_euler_step_limit(w2, gamma);
    CHECK(h * h * w2 + 2 * h * gamma == doctest::Approx(4.0).epsilon(1e-14));
  }
  CHECK(yore::symplectic_euler_step_limit(100.0, 0.0) == doctest::Approx(0.2).epsilon(1e-15));
  CHECK(yore::symplectic_euler_step_limit(0.0, 4.0) == 0.5);
  CHECK(std::isinf(yore::symplectic_euler_step_limit(0.0, 0.0)));
  CHECK(yore::symplectic_euler_step_limit(std::numeric_limits<double>::infinity(), 0.0) == 0.0);
  CHECK(yore::symplectic_euler_step_limit(1.0, std::nan("")) == 0.0);
}

TEST_CASE("stable steps: exact for one spring, ordered as documented on a cloth") {
  // one spring at rest, one end fixed: a single mode of ω² = k/m, h = 2/ω for every estimate
  Positions p(2, 3);
  p << 0, 0, 0, 0, -1, 0;
  Edges e(1, 2);
  e << 0, 1;
  Cloth spring = Cloth::from_springs(p, e, {}, Eigen::Vector2d(0.2, 0.2), 50.0, 0.0, 0.0);
  spring.fix({0});
  const double exact = 2.0 / std::sqrt(50.0 / 0.2);
  // Lanczos on a 3×3 problem converges to round-off
  CHECK(spring.stable_time_step() == doctest::Approx(exact).epsilon(1e-9));
  CHECK(spring.stable_time_step_bound() == doctest::Approx(exact).epsilon(1e-9));
  CHECK(spring.gershgorin_time_step() == doctest::Approx(exact).epsilon(1e-12));
  // a cloth: Gershgorin ≤ the state-independent bound ≤ the estimate at this state
  Cloth cloth = yore_test::grid_cloth(6, 500.0, 50.0, 0.01, 0.1);
  cloth.fix({0, 5});
  const double lanczos = cloth.stable_time_step(), bound = cloth.stable_time_step_bound(),
               gershgorin = cloth.gershgorin_time_step();
  CHECK(gershgorin > 0.0);
  CHECK(gershgorin <= bound * (1 + 1e-9));
  CHECK(bound <= lanczos * (1 + 1e-9));
  // stiffer springs lower every estimate (ω ∝ √k at zero damping)
  Cloth stiffer = yore_test::grid_cloth(6, 2000.0, 200.0, 0.01, 0.1);
  stiffer.fix({0, 5});
  CHECK(stiffer.stable_time_step() < lanczos);
  CHECK(stiffer.gershgorin_time_step() < gershgorin);
}
