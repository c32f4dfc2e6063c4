// Tests of cpp/src/geometry/pattern_mesh.cpp (cpp/include/yore/geometry/pattern_mesh.hpp): CGAL's
// constrained Delaunay meshing of sewing patterns — a valid, counter-clockwise mesh of the region's
// area, within the asked edge length and angle, around holes, and errors naming the problem.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/geometry/pattern_mesh.hpp"

using yore::PatternMeshOptions;
using yore::Polygon2;

namespace {

Polygon2 rectangle(double x0, double y0, double x1, double y1) {
  Polygon2 p(4, 2);
  p << x0, y0, x1, y0, x1, y1, x0, y1;
  return p;
}

struct Measures {
  double area = 0.0, longest = 0.0, smallest_angle = 180.0;
  bool counter_clockwise = true;
};

Measures measure(const yore::PatternMesh& mesh) {
  Measures m;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    Eigen::Vector2d p[3];
    for (int c = 0; c < 3; ++c) p[c] = mesh.points.row(mesh.faces(f, c)).transpose();
    const Eigen::Vector2d e1 = p[1] - p[0], e2 = p[2] - p[0];
    const double signed_area = 0.5 * (e1.x() * e2.y() - e1.y() * e2.x());
    m.counter_clockwise = m.counter_clockwise && signed_area > 0.0;
    m.area += signed_area;
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector2d a = p[(c + 1) % 3] - p[c], b = p[(c + 2) % 3] - p[c];
      m.longest = std::max(m.longest, a.norm());
      m.smallest_angle =
          std::min(m.smallest_angle, std::acos(a.dot(b) / (a.norm() * b.norm())) * 180.0 / M_PI);
    }
  }
  return m;
}

yore::Positions lifted(const Polygon2& points) {
  yore::Positions x = yore::Positions::Zero(points.rows(), 3);
  x.leftCols<2>() = points;
  return x;
}

}  // namespace

TEST_CASE("a rectangle: a valid CCW mesh of its area, within the edge length and angle") {
  PatternMeshOptions options;
  options.edge_length = 0.1;
  options.min_angle_degrees = 25.0;
  const yore::PatternMesh mesh = yore::pattern_mesh(rectangle(0, 0, 1.0, 0.5), {}, options);
  CHECK_NOTHROW(yore::validate_mesh(lifted(mesh.points), mesh.faces));
  const Measures m = measure(mesh);
  CHECK(m.counter_clockwise);
  CHECK(m.area == doctest::Approx(0.5).epsilon(1e-12));  // the triangles tile the region
  CHECK(m.longest <= 0.1 * (1 + 1e-9));
  // Ruppert's refinement bounds circumradius / shortest edge, which bounds the angle
  CHECK(m.smallest_angle >= 25.0 - 1e-6);
  // a disk: Euler characteristic 1; the outline's vertices are counted
  const auto edges = static_cast<Eigen::Index>(yore::mesh_connectivity(mesh.faces).edges.size());
  CHECK(mesh.points.rows() - edges + mesh.faces.rows() == 1);
  CHECK(mesh.outline_vertices >= 30);  // 3 m of outline at ≤ 0.1 m per edge
  CHECK(mesh.outline_vertices ==
        static_cast<std::int64_t>(yore::mesh_connectivity(mesh.faces).boundary_edge_count));
  // a clockwise outline gives the same region
  Polygon2 clockwise = rectangle(0, 0, 1.0, 0.5).colwise().reverse();
  CHECK(measure(yore::pattern_mesh(clockwise, {}, options)).area ==
        doctest::Approx(0.5).epsilon(1e-12));
}

TEST_CASE("a hole is left out: an annulus of the right area") {
  PatternMeshOptions options;
  options.edge_length = 0.1;
  const yore::PatternMesh mesh =
      yore::pattern_mesh(rectangle(0, 0, 1, 1), {rectangle(0.3, 0.3, 0.7, 0.6)}, options);
  CHECK_NOTHROW(yore::validate_mesh(lifted(mesh.points), mesh.faces));
  const Measures m = measure(mesh);
  CHECK(m.area == doctest::Approx(1.0 - 0.4 * 0.3).epsilon(1e-12));
  CHECK(m.counter_clockwise);
  const auto edges = static_cast<Eigen::Index>(yore::mesh_connectivity(mesh.faces).edges.size());
  CHECK(mesh.points.rows() - edges + mesh.faces.rows() == 0);  // one hole
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Eigen::RowVector2d centroid =
        (mesh.points.row(mesh.faces(f, 0)) + mesh.points.row(mesh.faces(f, 1)) +
         mesh.points.row(mesh.faces(f, 2))) /
        3.0;
    const bool in_hole =
        centroid.x() > 0.3 && centroid.x() < 0.7 && centroid.y() > 0.3 && centroid.y() < 0.6;
    CHECK_FALSE(in_hole);
  }
}

TEST_CASE("bad patterns and options are std::invalid_argument naming the problem") {
  PatternMeshOptions options;
  const auto refuses = [&](const Polygon2& outline, const std::vector<Polygon2>& holes,
                           const char* what) {
    CHECK_THROWS_WITH_AS(yore::pattern_mesh(outline, holes, options), doctest::Contains(what),
                         std::invalid_argument);
  };
  Polygon2 two(2, 2);
  two << 0, 0, 1, 0;
  refuses(two, {}, "distinct points; a polygon needs at least 3");
  Polygon2 bowtie(4, 2);
  bowtie << 0, 0, 1, 1, 1, 0, 0, 1;
  refuses(bowtie, {}, "intersects itself");
  Polygon2 nan = rectangle(0, 0, 1, 1);
  nan(2, 0) = std::nan("");
  refuses(nan, {}, "is not finite");
  refuses(two, {}, "the outline has 2 distinct points");
  refuses(rectangle(0, 0, 1, 1), {rectangle(0.5, 0.5, 1.5, 0.8)},
          "hole 0 is not inside the outline");
  // a hole whose corners are inside a non-convex outline but whose edge leaves it
  Polygon2 notch(7, 2);
  notch << 0, 0, 1, 0, 1, 1, 0.6, 1, 0.5, 0.4, 0.4, 1, 0, 1;  // a V cut down to (0.5, 0.4)
  Polygon2 across(4, 2);
  across << 0.2, 0.6, 0.8, 0.6, 0.8, 0.9, 0.2, 0.9;  // corners beside the notch, top edge crosses
  refuses(notch, {across}, "hole 0 crosses the outline");
  refuses(rectangle(0, 0, 1, 1), {rectangle(0.2, 0.2, 0.5, 0.5), rectangle(0.4, 0.4, 0.7, 0.7)},
          "hole 1 overlaps hole 0");
  options.min_angle_degrees = 31.0;
  refuses(rectangle(0, 0, 1, 1), {}, "min_angle must be in (0, 30]");
  options = {};
  options.edge_length = 0.0;
  refuses(rectangle(0, 0, 1, 1), {}, "edge_length must be finite and > 0");
  options = {};
  options.edge_length = 0.01;
  options.max_vertices = 100;
  refuses(rectangle(0, 0, 1, 1), {}, "needs more than");
}
