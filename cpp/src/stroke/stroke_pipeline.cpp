// One stroke from start to end. Not a CGAL translation unit: the traces it calls live in
// stroke.cpp.
#include "yore/stroke/stroke_pipeline.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <sstream>
#include <unordered_map>

#include "yore/platform/timer.hpp"

namespace yore {
namespace {

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

/// Σ x in numpy's pairwise order (eight running sums up to 128 values, halves above), so the
/// report's sums and means are the ones numpy gives on the same arrays, to the bit: the Python
/// pipeline this replaces took them with numpy, and a stroke's sampling spacing comes from one.
double pairwise_sum(const double* x, std::size_t n) {
  if (n < 8) {
    double sum = n == 0 ? 0.0 : -0.0;
    for (std::size_t i = 0; i < n; ++i) sum += x[i];
    return sum;
  }
  if (n <= 128) {
    double r[8];
    for (std::size_t j = 0; j < 8; ++j) r[j] = x[j];
    std::size_t i = 8;
    for (; i < n - n % 8; i += 8) {
      for (std::size_t j = 0; j < 8; ++j) r[j] += x[i + j];
    }
    double sum = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for (; i < n; ++i) sum += x[i];
    return sum;
  }
  std::size_t half = n / 2;
  half -= half % 8;
  return pairwise_sum(x, half) + pairwise_sum(x + half, n - half);
}

double pairwise_sum(const std::vector<double>& x) { return pairwise_sum(x.data(), x.size()); }
double pairwise_sum(const Eigen::VectorXd& x) {
  return pairwise_sum(x.data(), static_cast<std::size_t>(x.size()));
}

/// |d| summed as ((x² + y²) + z²), the order of numpy's norm over rows.
double row_norm(const Eigen::Vector3d& d) {
  return std::sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]);
}

/// The mean over the three corner pairs (0, 1), (1, 2), (2, 0) of the mean length of that side
/// over all faces (m): the scale a stroke is sampled at.
double mean_edge_length(const Positions& x, const Faces& faces) {
  const auto count = static_cast<std::size_t>(faces.rows());
  std::vector<double> lengths(count);
  double total = 0.0;
  for (int side = 0; side < 3; ++side) {
    for (std::size_t f = 0; f < count; ++f) {
      const auto row = static_cast<Eigen::Index>(f);
      lengths[f] = row_norm(x.row(faces(row, side)) - x.row(faces(row, (side + 1) % 3)));
    }
    total += pairwise_sum(lengths) / static_cast<double>(count);
  }
  return total / 3.0;
}

/// Current area of each of `faces`, summed (m²); the cross product as numpy's.
double current_area(const Positions& x, const Faces& all, const std::vector<std::int32_t>& faces) {
  std::vector<double> areas;
  areas.reserve(faces.size());
  for (const std::int32_t f : faces) {
    const Eigen::Vector3d a = x.row(all(f, 1)) - x.row(all(f, 0));
    const Eigen::Vector3d b = x.row(all(f, 2)) - x.row(all(f, 0));
    const Eigen::Vector3d cross(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                a[0] * b[1] - a[1] * b[0]);
    areas.push_back(0.5 * row_norm(cross));
  }
  return pairwise_sum(areas);
}

/// Rest area (m²) of `faces` with the structural springs' rest lengths `rest` (s values), Heron.
double rest_area(const Cloth& cloth, const std::vector<std::int32_t>& faces, const double* rest) {
  const SpringSet& springs = cloth.springs();
  std::unordered_map<std::uint64_t, double> side_of;
  side_of.reserve(springs.size());
  auto key = [](std::int32_t i, std::int32_t j) {
    return (static_cast<std::uint64_t>(std::max(i, j)) << 32) |
           static_cast<std::uint64_t>(std::min(i, j));
  };
  for (std::size_t k = 0; k < springs.size(); ++k) {
    if (springs.kind[k] == SpringKind::structural) {
      side_of[key(springs.first[k], springs.second[k])] = rest[k];
    }
  }
  const Faces& all = cloth.faces();
  std::vector<double> areas;
  areas.reserve(faces.size());
  for (const std::int32_t f : faces) {
    const std::int32_t a = all(f, 0), b = all(f, 1), c = all(f, 2);
    areas.push_back(
        area_from_sides(side_of.at(key(a, b)), side_of.at(key(b, c)), side_of.at(key(c, a))));
  }
  return pairwise_sum(areas);
}

/// The stroke's path on the current surface: its samples' barycentric points, m×3 (m).
Positions surface_path(const Cloth& cloth, const StrokeTrace& trace) {
  Positions path(static_cast<Eigen::Index>(trace.path.size()), 3);
  const Positions& x = cloth.positions();
  const Faces& faces = cloth.faces();
  for (std::size_t k = 0; k < trace.path.size(); ++k) {
    const StrokePoint& point = trace.path[k];
    for (int d = 0; d < 3; ++d) {
      double value = 0.0;
      for (int c = 0; c < 3; ++c) value += point.barycentric[c] * x(faces(point.face, c), d);
      path(static_cast<Eigen::Index>(k), d) = value;
    }
  }
  return path;
}

std::vector<std::int32_t> path_parts(const StrokeTrace& trace) {
  std::vector<std::int32_t> parts;
  parts.reserve(trace.path.size());
  for (const StrokePoint& point : trace.path) parts.push_back(point.part);
  return parts;
}

std::vector<std::int32_t> crossed_faces(const StrokeTrace& trace) {
  std::vector<std::int32_t> faces;
  faces.reserve(trace.crossings.size());
  for (const StrokeCrossing& crossing : trace.crossings) faces.push_back(crossing.face);
  return faces;
}

/// Per path sample the corner of its face with the largest weight (the first on ties),
/// consecutive repeats dropped.
std::vector<std::int32_t> nearest_corners(const Cloth& cloth, const StrokeTrace& trace) {
  std::vector<std::int32_t> corners;
  for (const StrokePoint& point : trace.path) {
    int best = 0;
    for (int c = 1; c < 3; ++c) {
      if (point.barycentric[c] > point.barycentric[best]) best = c;
    }
    const std::int32_t corner = cloth.faces()(point.face, best);
    if (corners.empty() || corners.back() != corner) corners.push_back(corner);
  }
  return corners;
}

void check_hit(const StrokeTrace& trace) {
  if (!trace.crossings.empty()) return;
  std::ostringstream msg;
  msg << "the stroke touches the cloth nowhere (" << trace.samples << " samples, all missed)";
  throw StrokeMissed(msg.str());
}

void check_refined_size(const Cloth& cloth, std::size_t band_faces, const StrokeOptions& options) {
  const double predicted = predicted_refined_vertices(
      static_cast<double>(cloth.vertex_count()), static_cast<double>(band_faces), options.refine);
  if (predicted > static_cast<double>(options.max_vertices)) {
    std::ostringstream msg;
    msg.precision(3);
    msg << "refine: " << options.refine << " passes over a band of " << band_faces
        << " faces could make the mesh " << predicted << " vertices, more than the limit of "
        << options.max_vertices << " (checked before refining; the cloth is unchanged); use "
        << "fewer passes or a narrower width";
    throw RefinementTooLarge(msg.str());
  }
}

}  // namespace

double stroke_spacing(const Cloth& cloth, const StrokeInput& input) {
  switch (input.kind) {
    case StrokeInput::Kind::closest:
      return 0.25 * mean_edge_length(cloth.positions(), cloth.faces());
    case StrokeInput::Kind::material: {
      if (cloth.material_coordinates().rows() == 0) {
        fail("the cloth has no material coordinates; set cloth.material_coordinates (n×2)");
      }
      Positions flat = Positions::Zero(cloth.vertex_count(), 3);
      flat.leftCols<2>() = cloth.material_coordinates();
      return 0.25 * mean_edge_length(flat, cloth.faces());
    }
    case StrokeInput::Kind::rays:
      return input.spacing_pixels;
  }
  fail("unknown stroke input kind");
}

StrokeTrace trace_stroke_input(const Cloth& cloth, const StrokeInput& input) {
  const double spacing = stroke_spacing(cloth, input);
  switch (input.kind) {
    case StrokeInput::Kind::closest:
      return trace_closest(cloth.positions(), cloth.faces(), input.points, input.max_distance,
                           spacing);
    case StrokeInput::Kind::material: {
      Positions flat = Positions::Zero(cloth.vertex_count(), 3);
      flat.leftCols<2>() = cloth.material_coordinates();
      return trace_closest(flat, cloth.faces(), input.points, input.max_distance, spacing);
    }
    case StrokeInput::Kind::rays:
      return trace_rays(cloth.positions(), cloth.faces(), input.points, input.eye,
                        input.base_direction, input.per_pixel_x, input.per_pixel_y, spacing);
  }
  fail("unknown stroke input kind");
}

double predicted_refined_vertices(double vertices, double band_faces, int passes) {
  double growth = 0.0;
  for (int k = 0; k < passes; ++k) growth += std::pow(kRefineBandGrowth, k);
  return vertices + kRefineVerticesPerFace * band_faces * growth;
}

namespace {

// The options apply_stroke checks before the cloth changes.
void check_stroke_options(const StrokeOptions& options) {
  if (options.refine < 0 || options.refine > kMaxRefine) {
    std::ostringstream msg;
    msg << "refine: got " << options.refine << "; expected an integer in [0, " << kMaxRefine
        << "] (refinement passes; each quadruples the band's faces)";
    fail(msg.str());
  }
  if (!(options.width >= 0.0) || !std::isfinite(options.width)) {
    std::ostringstream msg;
    msg << "width must be finite and >= 0 (m), got " << options.width;
    fail(msg.str());
  }
  // The split and the growth check these too, but only after the refinement changed the cloth.
  if (!(options.split.expansion > 0.0) || !std::isfinite(options.split.expansion)) {
    std::ostringstream msg;
    msg << "expansion must be finite and > 0, got " << options.split.expansion;
    fail(msg.str());
  }
  if (!options.split.conserve_mass &&
      (!(options.split.mass_scale > 0.0) || !std::isfinite(options.split.mass_scale))) {
    std::ostringstream msg;
    msg << "mass_scale must be finite and > 0, got " << options.split.mass_scale;
    fail(msg.str());
  }
}

// Σ (rest − reference length) of the split's springs, the last `springs_added` ones (m).
double split_rest_length_added(const SpringSet& springs, std::int64_t springs_added) {
  std::vector<double> added;
  for (std::size_t k = springs.size() - static_cast<std::size_t>(springs_added); k < springs.size();
       ++k) {
    added.push_back(springs.rest_length[k] - springs.reference_length[k]);
  }
  return pairwise_sum(added);
}

// The paper's 1→3 split of every crossed face at its crossing, into `result`.
void split_crossed_faces(Cloth& cloth, const StrokeTrace& trace, const StrokeOptions& options,
                         double mass_before, StrokeResult& result) {
  std::vector<FaceSplit> splits(trace.crossings.size());
  for (std::size_t k = 0; k < splits.size(); ++k) {
    splits[k].face = trace.crossings[k].face;
    splits[k].barycentric = trace.crossings[k].barycentric;
  }
  SplitOptions split_options = options.split;
  if (split_options.conserve_mass) split_options.mass_scale = 1.0;  // unused: a valid value
  const SplitReport split = cloth.split_faces(splits, split_options);
  result.faces_split = static_cast<std::int64_t>(split.split_faces.size());
  result.faces_skipped = split.faces_skipped;
  result.springs_added += split.springs_added;
  result.springs_removed += split.springs_removed;
  result.region_faces = split.region_faces;
  result.new_vertices.insert(result.new_vertices.end(), split.new_vertices.begin(),
                             split.new_vertices.end());
  result.rest_area_before = split.rest_area_before;
  result.rest_area_after = split.rest_area_after;
  result.moved_inward = split.moved_inward;
  result.rest_length_added = split_rest_length_added(cloth.springs(), split.springs_added);
  result.mass_added = pairwise_sum(cloth.masses()) - mass_before;
  result.line_vertices = split.new_vertices;
}

// `options.refine` 1→4 passes over the stroke's band, the stroke traced again after each (into
// `trace`); the figures go to `result`. Returns the vertices the passes added.
std::vector<std::int32_t> refine_band(Cloth& cloth, const StrokeInput& input,
                                      const StrokeOptions& options, StrokeTrace& trace,
                                      StrokeResult& result) {
  std::vector<std::int32_t> refined_vertices;
  for (int pass = 0; pass < options.refine; ++pass) {
    const StrokeBand band =
        stroke_band(cloth.positions(), cloth.faces(), surface_path(cloth, trace), path_parts(trace),
                    crossed_faces(trace), options.width);
    if (pass == 0) check_refined_size(cloth, band.faces.size(), options);
    const RefineReport refined = cloth.refine_faces(band.faces);
    result.faces_refined += static_cast<std::int64_t>(refined.refined_faces.size());
    result.faces_bisected += static_cast<std::int64_t>(refined.bisected_faces.size());
    result.springs_added += refined.springs_added;
    result.springs_removed += refined.springs_removed;
    refined_vertices.insert(refined_vertices.end(), refined.new_vertices.begin(),
                            refined.new_vertices.end());
    Stopwatch located;
    trace = trace_stroke_input(cloth, input);
    result.locate_seconds += located.seconds();
    check_hit(trace);
  }
  return refined_vertices;
}

}  // namespace

StrokeResult apply_stroke(Cloth& cloth, const StrokeInput& input, const StrokeOptions& options) {
  if (cloth.face_count() == 0) fail("a spring network has no faces to stroke");
  check_stroke_options(options);
  StrokeResult result;
  Stopwatch watch;
  StrokeTrace trace = trace_stroke_input(cloth, input);
  result.locate_seconds = watch.seconds();
  check_hit(trace);
  result.area_before = current_area(cloth.positions(), cloth.faces(), crossed_faces(trace));
  watch.restart();
  const double mass_before = pairwise_sum(cloth.masses());

  result.new_vertices = refine_band(cloth, input, options, trace, result);
  result.samples = trace.samples;
  result.missed_samples = trace.missed_samples;

  if (growth_rule(options.growth).splits_crossed_faces) {
    split_crossed_faces(cloth, trace, options, mass_before, result);
    result.subdivide_seconds = watch.seconds();
    return result;
  }

  const StrokeBand band = stroke_band(cloth.positions(), cloth.faces(), surface_path(cloth, trace),
                                      path_parts(trace), crossed_faces(trace), options.width);
  const Growth grown = grow_rest_lengths(cloth.positions(), cloth.springs(), band, options.growth,
                                         options.split.expansion);
  result.region_faces = band.faces;
  result.rest_area_before = rest_area(cloth, band.faces, cloth.springs().rest_length.data());
  result.rest_area_after = rest_area(cloth, band.faces, grown.rest_lengths.data());
  if (grown.springs_grown > 0) cloth.set_rest_lengths(grown.rest_lengths);
  result.subdivide_seconds = watch.seconds();
  result.springs_grown = grown.springs_grown;
  result.rest_length_added = grown.rest_added;
  result.mass_added = pairwise_sum(cloth.masses()) - mass_before;
  result.spring_weights = grown.weights;
  result.vertex_weights = band.vertex_weight;
  result.line_vertices = nearest_corners(cloth, trace);
  return result;
}

}  // namespace yore
