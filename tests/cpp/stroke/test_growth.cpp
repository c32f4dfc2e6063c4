// Tests of cpp/src/stroke/growth.cpp (cpp/include/yore/stroke/growth.hpp): the falloff, the growth
// table, a stroke's band and the rest lengths each growth rule gives.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/stroke/growth.hpp"

using yore::GrowthMode;
using yore::Positions;

namespace {

constexpr double kLineY = 0.45;  // the stroke: the line y = 0.45 across a flat unit square

struct Setup {
  yore::Cloth cloth;
  Positions path;
  std::vector<std::int32_t> part;
  std::vector<std::int32_t> crossed;
};

Setup straight_stroke() {
  Setup s{yore_test::grid_cloth(9), Positions(21, 3), std::vector<std::int32_t>(21, 0), {}};
  for (int k = 0; k < 21; ++k) s.path.row(k) << k / 20.0, kLineY, 0.0;
  const auto& x = s.cloth.positions();
  const auto& f = s.cloth.faces();
  for (std::int32_t face = 0; face < f.rows(); ++face) {
    const double lo = std::min({x(f(face, 0), 1), x(f(face, 1), 1), x(f(face, 2), 1)});
    const double hi = std::max({x(f(face, 0), 1), x(f(face, 1), 1), x(f(face, 2), 1)});
    if (lo < kLineY && kLineY < hi) s.crossed.push_back(face);
  }
  return s;
}

}  // namespace

TEST_CASE("falloff: 1 on the stroke, 0 from half the width on, smoothstep between") {
  CHECK(yore::falloff_weight(0.0, 0.2) == 1.0);
  CHECK(yore::falloff_weight(0.1, 0.2) == 0.5);  // 1 − (3/4 − 2/8): exact in binary
  CHECK(yore::falloff_weight(0.2, 0.2) == 0.0);
  CHECK(yore::falloff_weight(0.7, 0.2) == 0.0);
  double previous = 1.0;
  for (int k = 1; k <= 1000; ++k) {
    const double w = yore::falloff_weight(2e-4 * k, 0.2);
    CHECK(w <= previous);  // monotone
    CHECK(w >= 0.0);
    previous = w;
  }
  // C¹: flat at both ends; a slope over 1e-6 m of O(1e-6 / h²) ≈ 1e-4 at most
  const double h = 1e-6;
  CHECK(std::abs(yore::falloff_weight(h, 0.2) - 1.0) / h < 1e-3);
  CHECK(std::abs(yore::falloff_weight(0.2 - h, 0.2)) / h < 1e-3);
  // half width 0: the stroke alone
  CHECK(yore::falloff_weight(0.0, 0.0) == 1.0);
  CHECK(yore::falloff_weight(1e-9, 0.0) == 0.0);
}

TEST_CASE("the growth table: names round-trip, and an unknown name lists the valid ones") {
  for (const GrowthMode mode :
       {GrowthMode::paper, GrowthMode::isotropic, GrowthMode::along, GrowthMode::across})
    CHECK(yore::growth_mode(yore::growth_rule(mode).name) == mode);
  CHECK(yore::growth_rule(GrowthMode::paper).splits_crossed_faces);
  CHECK_FALSE(yore::growth_rule(GrowthMode::isotropic).splits_crossed_faces);
  CHECK(yore::growth_rule(GrowthMode::along).grows_along);
  CHECK_FALSE(yore::growth_rule(GrowthMode::along).grows_across);
  CHECK(yore::growth_rule(GrowthMode::across).grows_across);
  CHECK_THROWS_WITH_AS(yore::growth_mode("x"),
                       doctest::Contains("unknown growth 'x'; expected one of 'paper' "
                                         "'isotropic' 'along' 'across'"),
                       std::invalid_argument);
}

TEST_CASE("the band: distances, weights and tangents of a straight stroke") {
  const Setup s = straight_stroke();
  const double width = 0.5;
  const yore::StrokeBand band =
      yore::stroke_band(s.cloth.positions(), s.cloth.faces(), s.path, s.part, s.crossed, width);
  const auto& x = s.cloth.positions();
  std::vector<char> crossed_corner(static_cast<std::size_t>(x.rows()), 0);
  for (const auto f : s.crossed)
    for (int c = 0; c < 3; ++c) crossed_corner[static_cast<std::size_t>(s.cloth.faces()(f, c))] = 1;
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    CAPTURE(i);
    const double distance = std::abs(x(i, 1) - kLineY);
    if (distance < 0.5 * width) {
      // the path runs over the whole width of the square: the nearest point is straight down
      CHECK(band.vertex_distance[i] == doctest::Approx(distance).epsilon(1e-12));
      CHECK(std::abs(band.vertex_tangent(i, 0)) == doctest::Approx(1.0).epsilon(1e-12));
    }
    // with a width the falloff alone (the crossed faces' corners are not forced to 1)
    CHECK(band.vertex_weight[i] ==
          doctest::Approx(yore::falloff_weight(distance, 0.5 * width)).epsilon(1e-12));
  }
  // the band: crossed faces and faces with a corner within width/2, sorted
  CHECK(std::is_sorted(band.faces.begin(), band.faces.end()));
  for (const auto f : s.crossed) CHECK(std::binary_search(band.faces.begin(), band.faces.end(), f));
  for (std::int32_t f = 0; f < s.cloth.faces().rows(); ++f) {
    bool near = false;
    for (int c = 0; c < 3; ++c)
      near |= std::abs(x(s.cloth.faces()(f, c), 1) - kLineY) < 0.5 * width;
    const bool crossed = std::find(s.crossed.begin(), s.crossed.end(), f) != s.crossed.end();
    CHECK((near || crossed) == std::binary_search(band.faces.begin(), band.faces.end(), f));
  }
  // width 0 (the paper): weight 1 on crossed corners, 0 elsewhere, band = crossed faces
  const yore::StrokeBand paper =
      yore::stroke_band(x, s.cloth.faces(), s.path, s.part, s.crossed, 0.0);
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    CHECK(paper.vertex_weight[i] == (crossed_corner[static_cast<std::size_t>(i)] ? 1.0 : 0.0));
  CHECK(paper.faces == s.crossed);
}

TEST_CASE("the band refuses bad input, naming it") {
  const Setup s = straight_stroke();
  const auto& x = s.cloth.positions();
  const auto& f = s.cloth.faces();
  CHECK_THROWS_WITH_AS(yore::stroke_band(x, f, s.path, s.part, s.crossed, -0.1),
                       doctest::Contains("width must be finite and >= 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::stroke_band(x, f, s.path, {0, 0}, s.crossed, 0.1),
                       doctest::Contains("path and path_part differ in length"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::stroke_band(x, f, s.path, s.part, {1000}, 0.1),
                       doctest::Contains("face 1000 out of range"), std::invalid_argument);
}

TEST_CASE("growth rules: L(1 + (e − 1)w) for isotropic, the projected components otherwise") {
  const Setup s = straight_stroke();
  const auto& x = s.cloth.positions();
  const auto& springs = s.cloth.springs();
  const double expansion = 1.2;
  const yore::StrokeBand band =
      yore::stroke_band(x, s.cloth.faces(), s.path, s.part, s.crossed, 0.5);
  const yore::Growth paper =
      yore::grow_rest_lengths(x, springs, band, GrowthMode::paper, expansion);
  CHECK(paper.springs_grown == 0);  // the paper's growth is the split's eq. (1)
  for (const GrowthMode mode : {GrowthMode::isotropic, GrowthMode::along, GrowthMode::across}) {
    CAPTURE(static_cast<int>(mode));
    const yore::Growth growth = yore::grow_rest_lengths(x, springs, band, mode, expansion);
    REQUIRE(growth.rest_lengths.size() == static_cast<Eigen::Index>(springs.size()));
    double added = 0.0;
    std::int64_t grown = 0;
    for (std::size_t k = 0; k < springs.size(); ++k) {
      // Simpson's mean of the falloff along the spring: its ends and its midpoint
      const double middle_y = 0.5 * (x(springs.first[k], 1) + x(springs.second[k], 1));
      const double w = (band.vertex_weight[springs.first[k]] +
                        4.0 * yore::falloff_weight(std::abs(middle_y - kLineY), 0.25) +
                        band.vertex_weight[springs.second[k]]) /
                       6.0;
      CHECK(growth.weights[static_cast<Eigen::Index>(k)] == doctest::Approx(w).epsilon(1e-12));
      const double g = 1.0 + (expansion - 1.0) * w, rest = springs.rest_length[k];
      // the path's tangent is x everywhere: c = |d̂_x|, s = |d̂_y| on the flat cloth
      const Eigen::RowVector3d d =
          (x.row(springs.second[k]) - x.row(springs.first[k])).normalized();
      const double a = mode == GrowthMode::across ? 1.0 : g,
                   b = mode == GrowthMode::along ? 1.0 : g;
      const double expected = rest * std::sqrt(a * a * d.x() * d.x() + b * b * d.y() * d.y());
      // a few roundings of O(1) numbers: 1e-14 relative
      CHECK(growth.rest_lengths[static_cast<Eigen::Index>(k)] ==
            doctest::Approx(expected).epsilon(1e-14));
      if (w == 0.0) CHECK(growth.rest_lengths[static_cast<Eigen::Index>(k)] == rest);
      added += growth.rest_lengths[static_cast<Eigen::Index>(k)] - rest;
      grown += growth.rest_lengths[static_cast<Eigen::Index>(k)] != rest;
    }
    CHECK(growth.springs_grown == grown);
    CHECK(growth.springs_grown > 0);
    CHECK(growth.rest_added == doctest::Approx(added).epsilon(1e-12));
  }
  CHECK_THROWS_WITH_AS(yore::grow_rest_lengths(x, springs, band, GrowthMode::isotropic, 0.0),
                       doctest::Contains("expansion must be finite and > 0"),
                       std::invalid_argument);
  const yore::Cloth other = yore_test::grid_cloth(4);
  CHECK_THROWS_WITH_AS(
      yore::grow_rest_lengths(other.positions(), other.springs(), band, GrowthMode::isotropic, 1.1),
      doctest::Contains("the band was made for another mesh"), std::invalid_argument);
}
