// Tests of cpp/src/cloth/cloth_state.cpp (cpp/include/yore/cloth/cloth.hpp): incidence, the state
// setters, constraints and drivers, the state round trip, the clock, and from_state's checks.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/integrators/explicit.hpp"

using yore::Cloth;
using yore::Positions;
using yore::SpringKind;
using yore::Vec3;
using yore_test::chain;

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
  CHECK_THROWS_WITH_AS(cloth.fix({7}),
                       doctest::Contains("cannot fix vertex 7: it is already driven"),
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
    CHECK(std::atan2(arm0.cross(arm).z(), arm0.dot(arm)) ==
          doctest::Approx(omega * t).epsilon(1e-12));
    // v = ω × arm
    const Vec3 velocity = cloth.velocities().row(v);
    CHECK((velocity - omega * axis.cross(arm)).norm() < 1e-14);
  }
  // free vertices are untouched
  CHECK(cloth.positions().row(4) == start.row(4));
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
