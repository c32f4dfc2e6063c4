// Tests of cpp/src/cloth/cloth_rewiring.cpp (cpp/include/yore/cloth/cloth.hpp): the paper's 1→3
// split and 1→4 refinement as the Cloth rewires them: counts, rest lengths, masses and wiring.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/cloth/cloth.hpp"

using yore::Cloth;
using yore::Positions;
using yore::SpringKind;
using yore::Vec3;
using yore_test::chain;
using yore_test::check_wiring;
using yore_test::pairs_of_kind;

namespace {

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
    const double length =
        (cloth.positions().row(s.first[q]) - cloth.positions().row(s.second[q])).norm();
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
  const yore::SplitReport report = cloth.split_faces(
      {{10, Eigen::Vector3d::Constant(1.0 / 3)}, {11, Eigen::Vector3d::Constant(1.0 / 3)}},
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
    Cloth cloth(mesh.positions, mesh.faces, masses, yore_test::material(200.0, 20.0, 0.0, 0.0));
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
      const double length =
          (cloth.positions().row(s.first[k]) - cloth.positions().row(s.second[k])).norm();
      CHECK(s.rest_length[k] == doctest::Approx(length).epsilon(1e-12));
    }
  }
}

TEST_CASE("without bending springs a refinement adds none") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(25, 1e-3),
              yore_test::material(200.0, 0.0, 0.0, 0.0));
  cloth.refine_faces({3, 10});
  CHECK(pairs_of_kind(cloth, SpringKind::bending).empty());
  CHECK(pairs_of_kind(cloth, SpringKind::structural).size() ==
        yore::mesh_connectivity(cloth.faces()).edges.size());
}

TEST_CASE("refining a stretched region keeps its rest lengths, not its stretch") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(25, 1e-3),
              yore_test::material(200.0, 20.0, 0.0, 0.0));
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
    const double rest =
        (pattern.mesh.positions.row(s.first[k]) - pattern.mesh.positions.row(s.second[k])).norm();
    CHECK(s.rest_length[k] == doctest::Approx(rest).epsilon(1e-12));
    largest_strain = std::max(
        largest_strain,
        (cloth.positions().row(s.first[k]) - cloth.positions().row(s.second[k])).norm() / rest);
  }
  CHECK(largest_strain > 1.2);
}
