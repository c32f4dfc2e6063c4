// Tests of cpp/src/stroke/stroke_pipeline.cpp (cpp/include/yore/stroke/stroke_pipeline.hpp): one
// stroke in one call gives the cloth the step-by-step primitives give, refuses before changing
// anything, and reports what it did.
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/stroke/stroke_pipeline.hpp"

using yore::Cloth;
using yore::Positions;
using yore::StrokeInput;
using yore::StrokeOptions;

namespace {

Cloth flat_cloth() {
  Cloth cloth = yore_test::grid_cloth(9, 200.0, 200.0, 0.02, 0.3);
  cloth.set_material_coordinates(cloth.positions().leftCols<2>());
  return cloth;
}

StrokeInput closest_stroke() {
  StrokeInput input;
  input.kind = StrokeInput::Kind::closest;
  input.points.resize(3, 3);
  input.points << 0.08, 0.3, 0.0, 0.5, 0.62, 0.0, 0.93, 0.41, 0.0;
  input.max_distance = 0.05;
  return input;
}

void check_same(const Cloth& a, const Cloth& b) {
  CHECK(a.positions() == b.positions());
  CHECK(a.velocities() == b.velocities());
  CHECK(a.masses() == b.masses());
  CHECK(a.faces() == b.faces());
  CHECK(a.springs().first == b.springs().first);
  CHECK(a.springs().second == b.springs().second);
  CHECK(a.springs().rest_length == b.springs().rest_length);
  CHECK(a.springs().reference_length == b.springs().reference_length);
  CHECK(a.material_coordinates() == b.material_coordinates());
}

// The stroke's path on the surface, as the pipeline documents it: barycentric points.
Positions surface_path(const Cloth& cloth, const yore::StrokeTrace& trace) {
  Positions path(static_cast<Eigen::Index>(trace.path.size()), 3);
  for (std::size_t k = 0; k < trace.path.size(); ++k)
    for (int d = 0; d < 3; ++d) {
      double value = 0.0;
      for (int c = 0; c < 3; ++c)
        value += trace.path[k].barycentric[c] *
                 cloth.positions()(cloth.faces()(trace.path[k].face, c), d);
      path(static_cast<Eigen::Index>(k), d) = value;
    }
  return path;
}

std::vector<std::int32_t> crossed(const yore::StrokeTrace& trace) {
  std::vector<std::int32_t> faces;
  for (const auto& c : trace.crossings) faces.push_back(c.face);
  return faces;
}

}  // namespace

TEST_CASE("paper mode: the same cloth as tracing and splitting by hand") {
  Cloth by_hand = flat_cloth(), in_one = flat_cloth();
  const StrokeInput input = closest_stroke();
  const yore::StrokeTrace trace = yore::trace_stroke_input(by_hand, input);
  std::vector<yore::FaceSplit> splits;
  for (const auto& c : trace.crossings) splits.push_back({c.face, c.barycentric});
  const yore::SplitReport split = by_hand.split_faces(splits, yore::SplitOptions{});
  const yore::StrokeResult result = yore::apply_stroke(in_one, input, StrokeOptions{});
  check_same(by_hand, in_one);
  CHECK(result.faces_split == static_cast<std::int64_t>(split.split_faces.size()));
  CHECK(result.faces_split >= 8);  // the stroke crosses the 9×9 sheet
  CHECK(result.new_vertices == split.new_vertices);
  CHECK(result.line_vertices == result.new_vertices);
  CHECK(result.springs_added == split.springs_added);
  CHECK(result.rest_area_after == split.rest_area_after);
  CHECK(result.rest_area_after > result.rest_area_before);
  // eq. (1): the added rest length is (1.1 − 1) × the new springs' lengths
  double reference = 0.0;
  const auto& s = in_one.springs();
  for (std::size_t k = s.size() - static_cast<std::size_t>(result.springs_added); k < s.size(); ++k)
    reference += s.reference_length[k];
  CHECK(result.rest_length_added == doctest::Approx(0.1 * reference).epsilon(1e-12));
  // 0.95 × the corners' mean (uniform 0.1/81 kg) per new vertex
  CHECK(result.mass_added ==
        doctest::Approx(0.95 * 0.1 / 81 * static_cast<double>(result.faces_split)).epsilon(1e-12));
  CHECK(result.samples == trace.samples);
}

namespace {

std::vector<std::int32_t> path_parts(const yore::StrokeTrace& trace) {
  std::vector<std::int32_t> parts;
  for (const auto& p : trace.path) parts.push_back(p.part);
  return parts;
}

// What one apply_stroke call must equal: the stroke from the primitives, one at a time (trace,
// band and refine `refine` times tracing again after each pass, then split or grow).
struct ByHand {
  std::int64_t faces_refined = 0, faces_split = 0, springs_grown = 0, springs_added = 0;
  std::vector<std::int32_t> region_faces;
};

ByHand step_by_step(Cloth& cloth, const StrokeInput& input, const StrokeOptions& options) {
  ByHand out;
  yore::StrokeTrace trace = yore::trace_stroke_input(cloth, input);
  for (int pass = 0; pass < options.refine; ++pass) {
    const yore::StrokeBand band =
        yore::stroke_band(cloth.positions(), cloth.faces(), surface_path(cloth, trace),
                          path_parts(trace), crossed(trace), options.width);
    const yore::RefineReport refined = cloth.refine_faces(band.faces);
    out.faces_refined += static_cast<std::int64_t>(refined.refined_faces.size());
    out.springs_added += refined.springs_added;
    trace = yore::trace_stroke_input(cloth, input);
  }
  if (options.growth == yore::GrowthMode::paper) {
    std::vector<yore::FaceSplit> splits;
    for (const auto& c : trace.crossings) splits.push_back({c.face, c.barycentric});
    const yore::SplitReport split = cloth.split_faces(splits, options.split);
    out.faces_split = static_cast<std::int64_t>(split.split_faces.size());
    out.springs_added += split.springs_added;
    out.region_faces = split.region_faces;
  } else {
    const yore::StrokeBand band =
        yore::stroke_band(cloth.positions(), cloth.faces(), surface_path(cloth, trace),
                          path_parts(trace), crossed(trace), options.width);
    const yore::Growth grown = yore::grow_rest_lengths(cloth.positions(), cloth.springs(), band,
                                                       options.growth, options.split.expansion);
    cloth.set_rest_lengths(grown.rest_lengths);
    out.springs_grown = grown.springs_grown;
    out.region_faces = band.faces;
  }
  return out;
}

}  // namespace

TEST_CASE("every mode and refinement: the same cloth as the primitives one at a time") {
  // the six cases the Python pipeline was checked with before it moved into the core
  const struct {
    yore::GrowthMode growth;
    int refine;
    double width;
  } cases[] = {{yore::GrowthMode::paper, 0, 0.0},  {yore::GrowthMode::paper, 1, 0.0},
               {yore::GrowthMode::paper, 2, 0.2},  {yore::GrowthMode::isotropic, 0, 0.2},
               {yore::GrowthMode::along, 1, 0.15}, {yore::GrowthMode::across, 2, 0.1}};
  for (const auto& c : cases) {
    CAPTURE(static_cast<int>(c.growth));
    CAPTURE(c.refine);
    Cloth by_hand = flat_cloth(), in_one = flat_cloth();
    StrokeOptions options;
    options.growth = c.growth;
    options.refine = c.refine;
    options.width = c.width;
    const ByHand expected = step_by_step(by_hand, closest_stroke(), options);
    const yore::StrokeResult result = yore::apply_stroke(in_one, closest_stroke(), options);
    check_same(by_hand, in_one);  // to the bit: the same numbers in the same order
    CHECK(result.faces_refined == expected.faces_refined);
    CHECK(result.faces_split == expected.faces_split);
    CHECK(result.springs_grown == expected.springs_grown);
    CHECK(result.springs_added == expected.springs_added);
    CHECK(result.region_faces == expected.region_faces);
    CHECK(result.faces_split + result.springs_grown > 0);  // the stroke did something
    CHECK(result.new_vertices.size() == static_cast<std::size_t>(in_one.vertex_count() - 81));
  }
}

TEST_CASE("a material stroke is traced in the rest pattern, wherever the cloth has moved") {
  Cloth moved = flat_cloth();
  Positions x = moved.positions();
  for (Eigen::Index i = 0; i < x.rows(); ++i) x(i, 2) = 0.3 * std::sin(3.0 * x(i, 0));  // draped
  moved.set_positions(x);
  StrokeInput material = closest_stroke();
  material.kind = StrokeInput::Kind::material;
  material.max_distance = 1e-9;
  const yore::StrokeTrace in_pattern = yore::trace_stroke_input(moved, material);
  // the same polyline traced by closest points on the flat, unmoved sheet
  const Cloth flat = flat_cloth();
  StrokeInput on_flat = closest_stroke();
  on_flat.max_distance = 1e-9;
  const yore::StrokeTrace reference = yore::trace_stroke_input(flat, on_flat);
  CHECK(crossed(in_pattern) == crossed(reference));
  CHECK(in_pattern.missed_samples == 0);
  CHECK(yore::stroke_spacing(moved, material) == yore::stroke_spacing(flat, on_flat));
}

TEST_CASE("refusals leave the cloth as it was") {
  Cloth cloth = flat_cloth();
  const auto version = cloth.topology_version();
  const Positions start = cloth.positions();
  StrokeInput away = closest_stroke();
  away.points.col(2).setConstant(3.0);  // 3 m above the sheet
  CHECK_THROWS_WITH_AS(yore::apply_stroke(cloth, away, StrokeOptions{}),
                       doctest::Contains("touches the cloth nowhere"), yore::StrokeMissed);
  StrokeOptions huge;
  huge.growth = yore::GrowthMode::isotropic;
  huge.width = 0.3;
  huge.refine = 3;
  huge.max_vertices = 200;
  CHECK_THROWS_WITH_AS(yore::apply_stroke(cloth, closest_stroke(), huge),
                       doctest::Contains("more than the limit of 200"), yore::RefinementTooLarge);
  StrokeOptions bad;
  bad.refine = yore::kMaxRefine + 1;
  CHECK_THROWS_WITH_AS(yore::apply_stroke(cloth, closest_stroke(), bad),
                       doctest::Contains("refine: got 5"), std::invalid_argument);
  bad = {};
  bad.width = -1.0;
  CHECK_THROWS_WITH_AS(yore::apply_stroke(cloth, closest_stroke(), bad),
                       doctest::Contains("width must be finite and >= 0"), std::invalid_argument);
  bad = {};
  bad.split.expansion = 0.0;
  CHECK_THROWS_WITH_AS(yore::apply_stroke(cloth, closest_stroke(), bad),
                       doctest::Contains("expansion must be finite and > 0"),
                       std::invalid_argument);
  CHECK(cloth.topology_version() == version);
  CHECK(cloth.positions() == start);
  // a material stroke on a cloth without material coordinates
  Cloth plain = yore_test::grid_cloth(5);
  StrokeInput material = closest_stroke();
  material.kind = StrokeInput::Kind::material;
  CHECK_THROWS_WITH_AS(yore::apply_stroke(plain, material, StrokeOptions{}),
                       doctest::Contains("no material coordinates"), std::invalid_argument);
}

TEST_CASE("the sampling spacing and the refinement size prediction") {
  const Cloth cloth = flat_cloth();
  // grid faces: two legs of 1/8 m and a diagonal of √2/8 m each: spacing a quarter of the mean
  const double mean = (4 * 0.125 + 2 * 0.125 * std::sqrt(2.0)) / 6;
  CHECK(yore::stroke_spacing(cloth, closest_stroke()) ==
        doctest::Approx(0.25 * mean).epsilon(1e-14));
  StrokeInput rays;
  rays.kind = StrokeInput::Kind::rays;
  rays.spacing_pixels = 0.75;
  CHECK(yore::stroke_spacing(cloth, rays) == 0.75);
  // v + 2 b (1 + 5 + … + 5^(passes−1)); zero passes predict no growth
  CHECK(yore::predicted_refined_vertices(100, 10, 0) == 100);
  CHECK(yore::predicted_refined_vertices(100, 10, 2) == 100 + 2 * 10 * (1 + 5));
  // and it bounds what a refined stroke really makes, from its first band
  Cloth refined = flat_cloth();
  StrokeOptions options;
  options.growth = yore::GrowthMode::along;
  options.width = 0.15;
  options.refine = 2;
  const yore::StrokeTrace trace = yore::trace_stroke_input(refined, closest_stroke());
  std::vector<std::int32_t> parts;
  for (const auto& p : trace.path) parts.push_back(p.part);
  const yore::StrokeBand first =
      yore::stroke_band(refined.positions(), refined.faces(), surface_path(refined, trace), parts,
                        crossed(trace), options.width);
  const auto before = refined.vertex_count();
  const yore::StrokeResult result = yore::apply_stroke(refined, closest_stroke(), options);
  CHECK(result.faces_refined > 0);
  CHECK(refined.vertex_count() > before);
  CHECK(static_cast<double>(refined.vertex_count()) <=
        yore::predicted_refined_vertices(static_cast<double>(before),
                                         static_cast<double>(first.faces.size()), 2));
}
