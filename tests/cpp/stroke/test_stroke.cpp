// Tests of cpp/src/stroke/stroke.cpp (cpp/include/yore/stroke/stroke.hpp): closest-point and ray
// queries, tracing a stroke by closest points and by camera rays (the two must agree), clipping,
// polylines and the sample limit.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/stroke/stroke.hpp"

using yore::Positions;

namespace {

constexpr double kLineY = 0.45;

// The faces whose interior the line y = kLineY crosses between x0 and x1 (flat grid, z = 0).
std::set<std::int32_t> faces_crossed_by_line(const yore_test::Mesh& mesh, double x0, double x1) {
  std::set<std::int32_t> out;
  for (std::int32_t f = 0; f < mesh.faces.rows(); ++f) {
    double lo = 1e9, hi = -1e9, left = 1e9, right = -1e9;
    for (int c = 0; c < 3; ++c) {
      lo = std::min(lo, mesh.positions(mesh.faces(f, c), 1));
      hi = std::max(hi, mesh.positions(mesh.faces(f, c), 1));
      left = std::min(left, mesh.positions(mesh.faces(f, c), 0));
      right = std::max(right, mesh.positions(mesh.faces(f, c), 0));
    }
    if (lo < kLineY && kLineY < hi && right > x0 && left < x1) out.insert(f);
  }
  return out;
}

Eigen::Vector3d at(const yore_test::Mesh& mesh, std::int32_t face, const Eigen::Vector3d& w) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int c = 0; c < 3; ++c) p += w[c] * mesh.positions.row(mesh.faces(face, c)).transpose();
  return p;
}

std::set<std::int32_t> crossed(const yore::StrokeTrace& trace) {
  std::set<std::int32_t> out;
  for (const auto& crossing : trace.crossings) out.insert(crossing.face);
  return out;
}

}  // namespace

TEST_CASE("closest points and ray hits on a flat grid") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  const yore::SurfaceLocator locator(mesh.positions, mesh.faces);
  const Eigen::Vector3d query(0.3, 0.6, 0.2);
  const yore::SurfaceHit hit = locator.closest(query);
  REQUIRE(hit.face >= 0);
  CHECK(hit.distance == doctest::Approx(0.2).epsilon(1e-12));
  CHECK(hit.barycentric.sum() == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(hit.barycentric.minCoeff() >= -1e-12);
  CHECK((at(mesh, hit.face, hit.barycentric) - Eigen::Vector3d(0.3, 0.6, 0.0)).norm() < 1e-12);
  // a point beside the sheet goes to its border
  CHECK(locator.closest(Eigen::Vector3d(1.5, 0.5, 0.0)).distance ==
        doctest::Approx(0.5).epsilon(1e-12));
  // a ray down from above (direction not unit) hits where it pierces the plane
  const auto ray = locator.first_hit(Eigen::Vector3d(0.7, 0.2, 2.0), Eigen::Vector3d(0, 0, -4.0));
  REQUIRE(ray.has_value());
  CHECK(ray->distance == doctest::Approx(2.0).epsilon(1e-12));
  CHECK((at(mesh, ray->face, ray->barycentric) - Eigen::Vector3d(0.7, 0.2, 0.0)).norm() < 1e-12);
  CHECK_FALSE(
      locator.first_hit(Eigen::Vector3d(0.7, 0.2, 2.0), Eigen::Vector3d(0, 0, 1)).has_value());
  CHECK_FALSE(
      locator.first_hit(Eigen::Vector3d(3.0, 0.2, 2.0), Eigen::Vector3d(0, 0, -1)).has_value());
}

TEST_CASE("a straight stroke crosses exactly the faces under it, closest points and rays alike") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(9, 9);
  Positions stroke(2, 3);
  stroke << 0.03, kLineY, 0.0, 0.97, kLineY, 0.0;
  const double spacing = 0.03;
  const yore::StrokeTrace closest =
      yore::trace_closest(mesh.positions, mesh.faces, stroke, 0.05, spacing);
  CHECK(crossed(closest) == faces_crossed_by_line(mesh, 0.03, 0.97));
  CHECK(closest.missed_samples == 0);
  CHECK(closest.samples >= static_cast<std::int64_t>(0.94 / spacing));
  // every crossing and every path point lies on the line, inside its face
  for (const auto& crossing : closest.crossings) {
    CHECK(crossing.samples >= 1);
    CHECK(crossing.barycentric.minCoeff() >= -1e-12);
    CHECK(at(mesh, crossing.face, crossing.barycentric).y() ==
          doctest::Approx(kLineY).epsilon(1e-12));
  }
  double previous_x = -1.0;
  for (const auto& point : closest.path) {
    const Eigen::Vector3d p = at(mesh, point.face, point.barycentric);
    CHECK(p.y() == doctest::Approx(kLineY).epsilon(1e-12));
    CHECK(p.x() >= previous_x);  // in stroke order
    previous_x = p.x();
  }
  // crossings come in the order the stroke first enters them: left to right
  for (std::size_t k = 1; k < closest.crossings.size(); ++k)
    CHECK(at(mesh, closest.crossings[k].face, closest.crossings[k].barycentric).x() >
          at(mesh, closest.crossings[k - 1].face, closest.crossings[k - 1].barycentric).x() - 0.2);
  // a pinhole camera 2 m above, pixel (px, py) looking at (0.01 px, 0.01 py, 0)
  Positions pixels(2, 3);
  pixels << 3, 45, 0, 97, 45, 0;
  const yore::StrokeTrace rays =
      yore::trace_rays(mesh.positions, mesh.faces, pixels, Eigen::Vector3d(0.5, 0.5, 2.0),
                       Eigen::Vector3d(-0.25, -0.25, -1.0), Eigen::Vector3d(0.005, 0, 0),
                       Eigen::Vector3d(0, 0.005, 0), 1.0);
  CHECK(crossed(rays) == crossed(closest));
  CHECK(rays.missed_samples == 0);
}

TEST_CASE("pick_rays: each pixel's first hit, as trace_rays casts its rays") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  Positions pixels(3, 3);
  pixels << 70, 20, 0, 33, 81, 0, 150, 20, 0;  // the last one looks past the sheet
  // the camera of the test above: pixel (px, py) sees (0.01 px, 0.01 py, 0)
  const auto hits =
      yore::pick_rays(mesh.positions, mesh.faces, pixels, Eigen::Vector3d(0.5, 0.5, 2.0),
                      Eigen::Vector3d(-0.25, -0.25, -1.0), Eigen::Vector3d(0.005, 0, 0),
                      Eigen::Vector3d(0, 0.005, 0));
  REQUIRE(hits.size() == 3);
  REQUIRE(hits[0].has_value());
  REQUIRE(hits[1].has_value());
  CHECK((at(mesh, hits[0]->face, hits[0]->barycentric) - Eigen::Vector3d(0.7, 0.2, 0)).norm() <
        1e-12);
  CHECK((at(mesh, hits[1]->face, hits[1]->barycentric) - Eigen::Vector3d(0.33, 0.81, 0)).norm() <
        1e-12);
  CHECK_FALSE(hits[2].has_value());
}

TEST_CASE("samples beyond max_distance miss; a stroke off the cloth misses entirely") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(5, 5);
  Positions stroke(2, 3);
  stroke << 0.5, 0.5, 0.0, 0.5, 0.5, 1.0;  // rises straight off the sheet
  const yore::StrokeTrace trace =
      yore::trace_closest(mesh.positions, mesh.faces, stroke, 0.1, 0.01);
  CHECK(trace.missed_samples > 0);
  CHECK_FALSE(trace.crossings.empty());
  for (const auto& point : trace.path) CHECK(point.part == trace.path.front().part);
  stroke << 5, 5, 5, 6, 6, 6;
  const yore::StrokeTrace away = yore::trace_closest(mesh.positions, mesh.faces, stroke, 0.1, 0.01);
  CHECK(away.crossings.empty());
  CHECK(away.missed_samples == away.samples);
  CHECK_THROWS_WITH_AS(yore::trace_closest(mesh.positions, mesh.faces, stroke, -1.0, 0.01),
                       doctest::Contains("max_distance must be finite and >= 0"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::trace_closest(mesh.positions, mesh.faces, stroke, 0.1, 0.0),
                       doctest::Contains("spacing must be finite and > 0"), std::invalid_argument);
}

TEST_CASE("clip_polyline keeps the parts inside the box, cut at its faces") {
  Positions line(3, 3);
  line << -1, 0.5, 0, 0.5, 0.5, 0, 0.5, 2, 0;  // enters at x = 0, leaves at y = 1
  const auto parts = yore::clip_polyline(line, Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 1, 1));
  REQUIRE(parts.size() == 1);  // the corner is inside: one part
  const Positions& part = parts[0];
  REQUIRE(part.rows() == 3);
  CHECK((part.row(0) - Eigen::RowVector3d(0, 0.5, 0)).norm() < 1e-15);
  CHECK((part.row(1) - Eigen::RowVector3d(0.5, 0.5, 0)).norm() < 1e-15);
  CHECK((part.row(2) - Eigen::RowVector3d(0.5, 1.0, 0)).norm() < 1e-15);
  // leaving and coming back: two parts; entirely outside: none
  Positions zigzag(3, 3);
  zigzag << 0.2, 0.5, 0, 0.5, 3.0, 0, 0.8, 0.5, 0;
  CHECK(yore::clip_polyline(zigzag, Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 1, 1)).size() ==
        2);
  CHECK(yore::clip_polyline(line, Eigen::Vector3d(5, 5, 5), Eigen::Vector3d(6, 6, 6)).empty());
}

TEST_CASE("a polyline by arc length") {
  Positions points(3, 3);
  points << 0, 0, 0, 3, 0, 0, 3, 4, 0;
  const yore::Polyline polyline(points);
  CHECK(polyline.length() == 7.0);
  CHECK(polyline.corners() == std::vector<double>{0.0, 3.0, 7.0});
  CHECK((polyline.at(1.5) - Eigen::Vector3d(1.5, 0, 0)).norm() < 1e-15);
  CHECK((polyline.at(5.0) - Eigen::Vector3d(3, 2, 0)).norm() < 1e-15);
  CHECK(polyline.at(-1.0) == Eigen::Vector3d(0, 0, 0));  // clamped to the ends
  CHECK(polyline.at(9.0) == Eigen::Vector3d(3, 4, 0));
  CHECK_THROWS_WITH_AS(yore::Polyline(Positions(0, 3)), doctest::Contains("no points"),
                       std::invalid_argument);
  points(1, 1) = std::nan("");
  CHECK_THROWS_WITH_AS(yore::Polyline{points}, doctest::Contains("non-finite"),
                       std::invalid_argument);
}

TEST_CASE("trace_stroke: no crossed face is skipped, and the sample limit is named") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(9, 9);
  const yore::SurfaceLocator locator(mesh.positions, mesh.faces);
  // a curve sampled far more coarsely than the faces: bisection still finds every face
  const auto query = [&](double s) -> std::optional<yore::SurfaceHit> {
    return locator.closest(Eigen::Vector3d(s, kLineY, 0.0));
  };
  const yore::StrokeTrace trace = yore::trace_stroke(query, 1.0, 0.5, 1e-9, mesh.faces);
  CHECK(crossed(trace) == faces_crossed_by_line(mesh, 0.0, 1.0));
  CHECK_THROWS_WITH_AS(yore::trace_stroke(query, 1.0, 1e-3, 1e-9, mesh.faces, {}, 100),
                       doctest::Contains("needs more than 100 samples (the limit"),
                       std::invalid_argument);
}
