#pragma once
/// @file stroke_pipeline.hpp
/// One stroke from start to end (target yore_geometry): trace it on the current surface, take
/// its band, refine the band (tracing again after each pass), then split the crossed faces 1→3
/// (the paper) or grow the band's rest lengths. The cloth changes only through Cloth's own
/// mesh mutations (refine_faces, split_faces, set_rest_lengths).

#include <Eigen/Core>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/stroke/growth.hpp"
#include "yore/stroke/stroke.hpp"

namespace yore {

/// How a stroke was drawn: enough to trace it again after the mesh has changed.
struct StrokeInput {
  enum class Kind : std::int8_t {
    closest,   ///< a 3-D polyline near the surface: each point goes to the closest surface point
    rays,      ///< a polyline of pixels: rays of a pinhole camera, nearest hit
    material,  ///< a polyline in the cloth's rest-pattern (material) coordinates
  };
  Kind kind = Kind::closest;
  /// k×3: metres (closest), pixels with z = 0 (rays), rest-pattern metres with z = 0 (material)
  Positions points;
  /// m. closest: points farther from the surface miss; material: the tolerance in the pattern.
  double max_distance = 0.0;
  /// rays: the camera; a pixel (px, py) casts eye + t (base_direction + px · per_pixel_x + py ·
  /// per_pixel_y), t > 0 (see trace_rays)
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();
  Eigen::Vector3d base_direction = Eigen::Vector3d::Zero();
  Eigen::Vector3d per_pixel_x = Eigen::Vector3d::Zero();
  Eigen::Vector3d per_pixel_y = Eigen::Vector3d::Zero();
  double spacing_pixels = 0.5;  ///< rays: first sampling step, pixels
};

/// The first sampling step of a stroke on the cloth as it is now: a quarter of the mean edge
/// length (m) of the current surface (closest) or of the rest pattern (material);
/// spacing_pixels for rays. Throws std::invalid_argument for a material stroke on a cloth
/// without material coordinates.
double stroke_spacing(const Cloth& cloth, const StrokeInput& input);

/// Traces the stroke on the cloth's current mesh at stroke_spacing (trace_closest or
/// trace_rays). Throws std::invalid_argument on bad input (see those functions).
StrokeTrace trace_stroke_input(const Cloth& cloth, const StrokeInput& input);

/// Vertices a refinement pass adds per band face, and the band's growth per pass, at most (an
/// estimate from above for predicted_refined_vertices; measured 1.2–1.9 and 2–4.6).
inline constexpr double kRefineVerticesPerFace = 2.0;
inline constexpr double kRefineBandGrowth = 5.0;

/// An estimate from above of the vertex count after `passes` refinement passes of a band of
/// `band_faces` faces on a mesh of `vertices`: each pass adds at most kRefineVerticesPerFace
/// vertices per band face, and the band (the same width in metres over smaller faces) grows at
/// most kRefineBandGrowth times per pass.
double predicted_refined_vertices(double vertices, double band_faces, int passes);

/// The options of one stroke.
struct StrokeOptions {
  GrowthMode growth = GrowthMode::paper;
  double width = 0.0;  ///< m, the band; 0: the crossed faces only (the paper)
  int refine = 0;      ///< 1→4 refinement passes of the band before the growth, 0..kMaxRefine
  /// expansion (all modes), the new vertices' mass rule and the degenerate-case rules (paper)
  SplitOptions split;
  /// A refinement whose predicted vertex count exceeds this is refused before the cloth changes.
  std::int64_t max_vertices = kMaxMeshVertices;
};

/// What a stroke did. Areas in m², lengths in m, masses in kg, times in s.
struct StrokeResult {
  std::int64_t faces_split = 0;             ///< paper: faces split 1→3
  std::vector<std::int32_t> faces_skipped;  ///< paper: faces left whole (slivers)
  std::int64_t springs_added = 0;           ///< refinement and split together
  std::int64_t springs_removed = 0;         ///< likewise
  std::vector<std::int32_t> region_faces;   ///< paper: the split's children; else the band
  std::vector<std::int32_t> new_vertices;   ///< refinement's, then the split's
  double area_before = 0.0;                 ///< current area of the faces the first trace crossed
  double rest_area_before = 0.0;            ///< rest area of the split faces (paper) or of the band
  double rest_area_after = 0.0;     ///< of the split's children (paper) or of the grown band
  std::int64_t samples = 0;         ///< of the last trace
  std::int64_t missed_samples = 0;  ///< of the last trace
  std::int64_t moved_inward = 0;    ///< paper: split points moved inward
  double locate_seconds = 0.0;      ///< every trace
  double subdivide_seconds = 0.0;   ///< refinement, split or growth (retraces included)
  std::int64_t faces_refined = 0;   ///< split 1→4 by the refinement passes (all passes)
  std::int64_t faces_bisected = 0;  ///< split 1→2 by their conforming closure
  std::int64_t springs_grown = 0;   ///< growth modes: springs whose rest length changed
  /// Σ (new − old rest length) of the grown springs, or of the split's new springs (expansion −
  /// 1 times their length) in paper mode
  double rest_length_added = 0.0;
  double mass_added = 0.0;  ///< total mass after minus before
  /// vertices along the stroke in stroke order: the split's new vertices (paper), else the
  /// corner with the largest weight at each sample of the path, repeats dropped
  std::vector<std::int32_t> line_vertices;
  Eigen::VectorXd spring_weights;  ///< growth modes: s in [0, 1], each spring's band weight
  Eigen::VectorXd vertex_weights;  ///< growth modes: n in [0, 1], each vertex's band weight
};

/// A stroke that touches the cloth nowhere (a std::invalid_argument).
class StrokeMissed : public std::invalid_argument {
 public:
  explicit StrokeMissed(const std::string& message) : std::invalid_argument(message) {}
};

/// A refinement that could make the mesh larger than StrokeOptions::max_vertices, refused
/// before the cloth changed (a std::invalid_argument).
class RefinementTooLarge : public std::invalid_argument {
 public:
  explicit RefinementTooLarge(const std::string& message) : std::invalid_argument(message) {}
};

/// Applies one stroke: traces it; refines its band options.refine times, tracing again after
/// each pass; then splits the crossed faces 1→3 with eq. (1) (paper) or grows the band's rest
/// lengths by the growth rule. Throws StrokeMissed when a trace hits nothing (the first one:
/// before the cloth changes), RefinementTooLarge when the first band predicts more than
/// options.max_vertices vertices after the passes (before the cloth changes), and
/// std::invalid_argument on bad input or options (a cloth without faces, refine outside
/// 0..kMaxRefine, a negative width, ...).
StrokeResult apply_stroke(Cloth& cloth, const StrokeInput& input, const StrokeOptions& options);

}  // namespace yore
