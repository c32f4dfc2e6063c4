// Tests of cpp/src/stroke/subdivision.cpp (cpp/include/yore/stroke/subdivision.hpp): the paper's
// 1→3 split and the conforming 1→4 refinement as pure mesh surgery.
#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/stroke/subdivision.hpp"

using yore::Faces;
using yore::Positions;

namespace {

Eigen::Vector3d normal(const Positions& x, const Faces& f, Eigen::Index face) {
  const Eigen::Vector3d a = x.row(f(face, 0)), b = x.row(f(face, 1)), c = x.row(f(face, 2));
  return (b - a).cross(c - a);
}

int boundary_edges(const Faces& faces) {
  return static_cast<int>(yore::mesh_connectivity(faces).boundary_edge_count);
}

// The invariants of every subdivision: a valid mesh with the same Euler characteristic, old
// vertices and untouched faces kept, children tiling their parents with the same orientation,
// new vertices at their stencils, each child's corners from its parent only.
void check_surgery(const yore_test::Mesh& in, const yore::Subdivision& out) {
  const Positions& x = out.positions;
  const Faces& f = out.faces;
  CHECK_NOTHROW(yore::validate_mesh(x, f));
  const auto euler = [](const Positions& p, const Faces& faces) {
    return p.rows() - static_cast<Eigen::Index>(yore::mesh_connectivity(faces).edges.size()) +
           faces.rows();
  };
  CHECK(euler(x, f) == euler(in.positions, in.faces));
  CHECK(x.topRows(in.positions.rows()) == in.positions);
  REQUIRE(out.parents.size() == static_cast<std::size_t>(f.rows()));
  std::vector<double> child_area(static_cast<std::size_t>(in.faces.rows()), 0.0);
  const Eigen::Index n = in.positions.rows();
  for (Eigen::Index g = 0; g < f.rows(); ++g) {
    const std::int32_t p = out.parents[static_cast<std::size_t>(g)];
    REQUIRE(p >= 0);
    REQUIRE(p < in.faces.rows());
    child_area[static_cast<std::size_t>(p)] += 0.5 * normal(x, f, g).norm();
    CHECK(normal(x, f, g).dot(normal(in.positions, in.faces, p)) > 0.0);
    const std::set<std::int32_t> allowed{in.faces(p, 0), in.faces(p, 1), in.faces(p, 2)};
    for (int c = 0; c < 3; ++c) {
      const std::int32_t v = f(g, c);
      if (v < n) {
        CHECK(allowed.count(v) == 1);
      } else {
        for (int q = 0; q < 3; ++q)
          if (out.new_vertex_weights(v - n, q) > 0.0)
            CHECK(allowed.count(out.new_vertex_corners(v - n, q)) == 1);
      }
    }
    if (g < in.faces.rows() && out.parents[static_cast<std::size_t>(g)] == g &&
        std::count(out.parents.begin(), out.parents.end(), g) == 1)
      CHECK(f.row(g) == in.faces.row(g));  // untouched faces keep their rows
  }
  // children tile their parent: areas add up to round-off of O(1) cross products
  for (Eigen::Index p = 0; p < in.faces.rows(); ++p)
    CHECK(child_area[static_cast<std::size_t>(p)] ==
          doctest::Approx(0.5 * normal(in.positions, in.faces, p).norm()).epsilon(1e-12));
  for (Eigen::Index k = 0; k < x.rows() - n; ++k) {
    Eigen::RowVector3d stencil = Eigen::RowVector3d::Zero();
    for (int q = 0; q < 3; ++q)
      stencil += out.new_vertex_weights(k, q) * in.positions.row(out.new_vertex_corners(k, q));
    CHECK((x.row(n + k) - stencil).norm() < 1e-14);
    CHECK(out.new_vertex_weights.row(k).sum() == doctest::Approx(1.0).epsilon(1e-15));
  }
}

}  // namespace

TEST_CASE("split 1→3: the paper's rows, parents and barycentric points") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(6, 5);
  const std::vector<yore::FaceSplit> splits = {{0, {0.2, 0.3, 0.5}},
                                               {7, Eigen::Vector3d::Constant(1.0 / 3)},
                                               {8, {0.6, 0.2, 0.2}},
                                               {19, {0.1, 0.1, 0.8}}};
  const yore::Split1to3 out = yore::split_faces_1to3(mesh.positions, mesh.faces, splits, 0.1, 5.0);
  check_surgery(mesh, out.mesh);
  const auto F = mesh.faces.rows(), V = mesh.positions.rows();
  CHECK(out.mesh.faces.rows() == F + 8);
  CHECK(out.mesh.positions.rows() == V + 4);
  CHECK(out.split_faces == std::vector<std::int32_t>{0, 7, 8, 19});
  CHECK(out.faces_skipped.empty());
  CHECK(out.moved_inward == 0);
  // (a, b, p) in the parent's row, (b, c, p) and (c, a, p) appended in order
  const std::int32_t a = mesh.faces(7, 0), b = mesh.faces(7, 1), c = mesh.faces(7, 2);
  const auto p = static_cast<std::int32_t>(V + 1);
  CHECK(out.mesh.faces.row(7) == Eigen::RowVector3i(a, b, p));
  CHECK(out.mesh.faces.row(F + 2) == Eigen::RowVector3i(b, c, p));
  CHECK(out.mesh.faces.row(F + 3) == Eigen::RowVector3i(c, a, p));
  for (int k = 0; k < 8; ++k)
    CHECK(out.mesh.parents[static_cast<std::size_t>(F + k)] ==
          splits[static_cast<std::size_t>(k / 2)].face);
  CHECK(out.weights[0] == Eigen::Vector3d(0.2, 0.3, 0.5));
}

TEST_CASE("split 1→3 moves points near a corner inward and skips slivers") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 4);
  // a point almost on a corner: moved towards the centroid until its smallest weight is
  // min_barycentric (the angle rule off: no angle is below 0°)
  const yore::Split1to3 moved =
      yore::split_faces_1to3(mesh.positions, mesh.faces, {{4, {0.98, 0.01, 0.01}}}, 0.1, 0.0);
  CHECK(moved.moved_inward == 1);
  CHECK(moved.weights[0].minCoeff() == doctest::Approx(0.1).epsilon(1e-12));
  CHECK(moved.weights[0].sum() == doctest::Approx(1.0).epsilon(1e-15));
  check_surgery(mesh, moved.mesh);
  // with the angle rule on, that point's children are slivers: the split is tried at the
  // centroid instead, which gives none
  const yore::Split1to3 centred =
      yore::split_faces_1to3(mesh.positions, mesh.faces, {{4, {0.98, 0.01, 0.01}}}, 0.1, 5.0);
  CHECK(centred.split_faces == std::vector<std::int32_t>{4});
  CHECK((centred.weights[0] - Eigen::Vector3d::Constant(1.0 / 3)).norm() < 1e-15);
  // no child of a right triangle split anywhere has all angles above 59°: all skipped
  const yore::Split1to3 skipped = yore::split_faces_1to3(
      mesh.positions, mesh.faces,
      {{0, Eigen::Vector3d::Constant(1.0 / 3)}, {1, Eigen::Vector3d::Constant(1.0 / 3)}}, 0.1,
      59.0);
  CHECK(skipped.faces_skipped == std::vector<std::int32_t>{0, 1});
  CHECK(skipped.split_faces.empty());
  CHECK(skipped.mesh.faces == mesh.faces);
}

TEST_CASE("split 1→3 refuses bad requests, naming them") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 4);
  const Eigen::Vector3d centre = Eigen::Vector3d::Constant(1.0 / 3);
  const auto split = [&](std::vector<yore::FaceSplit> splits, double min_barycentric = 0.1) {
    return yore::split_faces_1to3(mesh.positions, mesh.faces, splits, min_barycentric, 5.0);
  };
  CHECK_THROWS_WITH_AS(split({{18, centre}}), doctest::Contains("face 18 out of range [0, 18)"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(split({{1, centre}, {1, centre}}),
                       doctest::Contains("face 1 is split twice"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(split({{1, {0.5, 0.5, 0.5}}}), doctest::Contains("sum to 1"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(split({{1, {1.2, -0.2, 0.0}}}), doctest::Contains("must be >= 0"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(split({{1, centre}}, 0.4), doctest::Contains("min_barycentric"),
                       std::invalid_argument);
}

TEST_CASE("refine 1→4 of one interior face bisects its three neighbours") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  const yore::Refinement out = yore::refine_faces_1to4(mesh.positions, mesh.faces, {10});
  check_surgery(mesh, out.mesh);
  CHECK(out.refined_faces == std::vector<std::int32_t>{10});
  CHECK(out.bisected_faces.size() == 3);
  CHECK(out.mesh.positions.rows() == 25 + 3);
  CHECK(out.mesh.faces.rows() == 32 + 3 + 3);
  // new vertex k is the midpoint of split_edges[k]; children are quarters and halves
  REQUIRE(out.split_edges.size() == 3);
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& e = out.split_edges[k];
    CHECK(e[0] < e[1]);
    CHECK((out.mesh.positions.row(25 + static_cast<Eigen::Index>(k)) -
           0.5 * (mesh.positions.row(e[0]) + mesh.positions.row(e[1])))
              .norm() < 1e-15);
  }
  const double parent = 0.5 * normal(mesh.positions, mesh.faces, 10).norm();
  for (Eigen::Index g = 0; g < out.mesh.faces.rows(); ++g)
    if (out.mesh.parents[static_cast<std::size_t>(g)] == 10)
      CHECK(0.5 * normal(out.mesh.positions, out.mesh.faces, g).norm() ==
            doctest::Approx(parent / 4).epsilon(1e-12));
  // no hanging vertex: no boundary edge appears inside (face 10 is interior)
  CHECK(boundary_edges(out.mesh.faces) == boundary_edges(mesh.faces));
}

TEST_CASE("the conforming closure refines a face left with two split edges") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  // the neighbours of face 10 (sharing an edge with it)
  std::vector<std::int32_t> neighbours;
  for (std::int32_t g = 0; g < mesh.faces.rows(); ++g) {
    int shared = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) shared += mesh.faces(10, i) == mesh.faces(g, j);
    if (g != 10 && shared == 2) neighbours.push_back(g);
  }
  REQUIRE(neighbours.size() == 3);
  const yore::Refinement out =
      yore::refine_faces_1to4(mesh.positions, mesh.faces, {neighbours[0], neighbours[1]});
  check_surgery(mesh, out.mesh);
  CHECK(std::binary_search(out.refined_faces.begin(), out.refined_faces.end(), 10));
  // the closure: every face not refined has at most one split edge, and is bisected iff one
  std::set<yore::VertexPair> split(out.split_edges.begin(), out.split_edges.end());
  for (std::int32_t f = 0; f < mesh.faces.rows(); ++f) {
    if (std::binary_search(out.refined_faces.begin(), out.refined_faces.end(), f)) continue;
    int count = 0;
    for (int i = 0; i < 3; ++i) {
      const std::int32_t a = mesh.faces(f, i), b = mesh.faces(f, (i + 1) % 3);
      count += static_cast<int>(split.count({std::min(a, b), std::max(a, b)}));
    }
    CHECK(count <= 1);
    CHECK((count == 1) ==
          std::binary_search(out.bisected_faces.begin(), out.bisected_faces.end(), f));
  }
}

TEST_CASE("refinement of a tube and a second pass keep the invariants; bad faces refused") {
  const yore_test::Mesh tube = yore_test::cylinder_mesh(0.3, 0.5, 4, 8);
  const yore::Refinement once = yore::refine_faces_1to4(tube.positions, tube.faces, {0, 5, 17, 30});
  check_surgery(tube, once.mesh);
  const yore_test::Mesh refined{once.mesh.positions, once.mesh.faces};
  const yore::Refinement twice =
      yore::refine_faces_1to4(refined.positions, refined.faces, {0, 1, 50});
  check_surgery(refined, twice.mesh);
  CHECK_THROWS_WITH_AS(yore::refine_faces_1to4(tube.positions, tube.faces, {-1}),
                       doctest::Contains("out of range"), std::invalid_argument);
}
