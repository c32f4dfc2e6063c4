#pragma once
/// @file growth.hpp
/// How a stroke grows area: a falloff weight around the stroke and a small table of growth
/// rules over it (pure functions; Cloth::split_faces does the paper's eq. (1) on new springs).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "yore/cloth/mesh.hpp"
#include "yore/cloth/springs.hpp"

namespace yore {

/// Which springs a stroke lengthens and how.
enum class GrowthMode : std::int8_t {
  paper = 0,      ///< split the crossed faces 1→3; only the new springs grow (eq. (1))
  isotropic = 1,  ///< every spring in the band: L × (1 + (expansion − 1) w)
  along = 2,      ///< only the component along the stroke tangent grows
  across = 3,     ///< only the component across the stroke tangent grows
};
/// Number of growth modes (the rows of the growth table).
inline constexpr int kGrowthModeCount = 4;

/// One row of the growth table. A spring of rest length L at angle θ to the stroke tangent
/// (c = |cos θ|, s = sin θ) and weight w gets L √((a c)² + (b s)²), a and b being g = 1 +
/// (expansion − 1) w where the row grows that component and 1 where it does not (a = b = g
/// gives exactly L g).
struct GrowthRule {
  const char* name;
  bool splits_crossed_faces;  ///< the paper's 1→3 split of the faces the stroke crosses
  bool grows_along;           ///< the component along the stroke tangent scales by g
  bool grows_across;          ///< the component across it scales by g
};

/// The row of the table for a mode.
const GrowthRule& growth_rule(GrowthMode mode);
/// The mode named "paper", "isotropic", "along" or "across". Throws std::invalid_argument
/// listing the valid names.
GrowthMode growth_mode(const std::string& name);

/// Falloff weight at a distance from the stroke: 1 − smoothstep(distance / half_width), with
/// smoothstep(t) = 3t² − 2t³ on [0, 1]: 1 on the stroke, 0 from half_width on, monotone and
/// C¹. half_width 0 gives 1 at distance 0 and 0 elsewhere. distance and half_width in metres.
double falloff_weight(double distance, double half_width);

/// The region a stroke affects, per vertex.
struct StrokeBand {
  Eigen::VectorXd vertex_distance;  ///< n, m, to the stroke's path (+inf beyond `reach`)
  /// n in [0, 1]: the falloff of the distance (width > 0), or 1 on every corner of a crossed
  /// face and 0 elsewhere (width 0, the paper)
  Eigen::VectorXd vertex_weight;
  Positions vertex_tangent;         ///< n×3, unit tangent of the path at the nearest point (or 0)
  std::vector<std::int32_t> faces;  ///< the band: crossed faces and faces with a corner within
                                    ///< width/2, sorted
  Positions path;                   ///< m×3, the path it was made from, metres
  std::vector<std::int32_t> path_part;  ///< m
  /// m, the span over which the path's tangent is taken: the mean edge length of the crossed
  /// faces (a chord of the path that long, centred on the nearest point, so sampling noise
  /// and the bisection's tiny steps do not turn it)
  double tangent_span = 0.0;
  double reach = 0.0;  ///< m, distances are measured up to this: max(width/2, longest crossed edge)
  double half_width = 0.0;  ///< m, width/2 (0: the crossed faces only)
};

/// The band of a stroke whose path on the surface is the polyline `path` (m×3, metres, points
/// on the current surface in stroke order; consecutive points with the same `path_part` are
/// joined) crossing `crossed_faces`. Distances are Euclidean, in the frame of `positions` (n×3,
/// metres). width (m) 0 means the crossed faces only (the paper): weight 1 on their corners, 0
/// elsewhere. Throws std::invalid_argument on mismatched sizes, faces out of range, or a
/// negative or non-finite width.
StrokeBand stroke_band(const Positions& positions, const Faces& faces, const Positions& path,
                       const std::vector<std::int32_t>& path_part,
                       const std::vector<std::int32_t>& crossed_faces, double width);

/// Rest lengths after growth (grow_rest_lengths).
struct Growth {
  Eigen::VectorXd rest_lengths;  ///< s, metres
  /// s in [0, 1]: with a width, the falloff's mean along the spring by Simpson's rule (its
  /// ends and its midpoint), so the grown rest length is ∫ g ds along it to O(h³) and the band
  /// grows the same area on every mesh; without one, the smaller of its ends' vertex weights
  Eigen::VectorXd weights;
  std::int64_t springs_grown = 0;  ///< springs whose rest length changed
  double rest_added = 0.0;         ///< m, Σ (new − old rest length)
};

/// The rest lengths of `springs` after the growth rule of `mode` with this expansion (> 0) over
/// the band's weights; spring directions from `positions` (n×3, metres) against the path's
/// tangent at the point nearest the spring's midpoint. The paper mode changes nothing here (its
/// growth is the split's eq. (1)). Throws std::invalid_argument on a non-positive or non-finite
/// expansion or mismatched sizes.
Growth grow_rest_lengths(const Positions& positions, const SpringSet& springs,
                         const StrokeBand& band, GrowthMode mode, double expansion);

}  // namespace yore
