#pragma once
/// @file stroke.hpp
/// Locating a user's stroke on the current cloth surface (target yore_geometry, CGAL AABB trees):
/// the faces it crosses and where, for the paper's partial area expansion.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "yore/cloth/mesh.hpp"
#include "yore/platform/limits.hpp"

namespace yore {

/// A point on a triangle of the surface.
struct SurfaceHit {
  std::int32_t face = -1;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();  ///< weights of the face's corners
  double distance = 0.0;  ///< from the query point (closest-point queries) or ray origin, m
};

/// Closest-point and ray queries on a triangle mesh (an AABB tree over its faces). Built for
/// one set of positions; rebuild after the surface moves.
class SurfaceLocator {
 public:
  /// positions n×3 (m), faces f×3; the mesh must be valid (see validate_mesh).
  SurfaceLocator(const Positions& positions, const Faces& faces);
  ~SurfaceLocator();
  SurfaceLocator(const SurfaceLocator&) = delete;
  SurfaceLocator& operator=(const SurfaceLocator&) = delete;

  /// The closest surface point to `point`.
  SurfaceHit closest(const Eigen::Vector3d& point) const;
  /// The first surface point along the ray, if any. direction need not be unit.
  std::optional<SurfaceHit> first_hit(const Eigen::Vector3d& origin,
                                      const Eigen::Vector3d& direction) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

/// Where a stroke crosses one face: the mean of its sample points in the face.
struct StrokeCrossing {
  std::int32_t face = -1;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
  std::int32_t samples = 0;  ///< how many stroke samples fell in the face
};

/// One sample of a stroke that hit the surface.
struct StrokePoint {
  std::int32_t face = -1;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
  std::int32_t part = 0;  ///< stretches of the stroke between misses (and clipped parts) differ
};

/// The faces a stroke crosses, in the order it first enters them.
struct StrokeTrace {
  std::vector<StrokeCrossing> crossings;
  /// Every sample that hit, in stroke order: the stroke's path on the surface.
  std::vector<StrokePoint> path;
  std::int64_t samples = 0;  ///< samples evaluated (after refinement) + counted
  /// samples that did not touch the surface, including those of the parts of a stroke clipped
  /// away before sampling (counted at the sampling spacing, not evaluated)
  std::int64_t missed_samples = 0;
};

/// Traces a stroke given as a curve s ∈ [0, length] → hit (or none). Samples at `spacing` and at
/// every breakpoint (the polyline's corners, where the curve may turn back into a face), then
/// bisects between consecutive samples until they fall in the same or edge-adjacent faces (so no
/// face the curve crosses is skipped) or are closer than `resolution`; also refines where the
/// stroke leaves or enters the surface. faces is the mesh the hits refer to.
/// Throws std::invalid_argument naming the limit when the stroke needs more than max_samples
/// samples (before sampling, from length / spacing, or while refining); polls for interrupts.
StrokeTrace trace_stroke(const std::function<std::optional<SurfaceHit>(double)>& query,
                         double length, double spacing, double resolution, const Faces& faces,
                         const std::vector<double>& breakpoints = {},
                         std::int64_t max_samples = kMaxStrokeSamples);

/// The parts of a polyline (k×3) inside the closed box [lower, upper] (bounds may be
/// infinite), in order; consecutive parts that meet at a corner inside the box are one part.
/// A stroke's samples outside a box that bounds everything a query can hit would all miss:
/// clipping first keeps the sampling cost bounded by the box, not by the polyline's length.
std::vector<Positions> clip_polyline(const Positions& points, const Eigen::Vector3d& lower,
                                     const Eigen::Vector3d& upper);

/// A polyline parametrised by arc length (2-D strokes are stored with z = 0).
class Polyline {
 public:
  /// points k×3 (k >= 1, finite). Throws std::invalid_argument otherwise.
  explicit Polyline(const Positions& points);
  /// Total length.
  double length() const { return m_lengths.back(); }
  /// The point at arc length s (clamped to the ends).
  Eigen::Vector3d at(double s) const;
  /// Arc length at each of the polyline's points.
  const std::vector<double>& corners() const { return m_lengths; }

 private:
  Positions m_points;
  std::vector<double> m_lengths;
};

/// Traces a 3-D polyline near the surface: each point goes to the closest surface point; points
/// farther than max_distance (m) miss. spacing: first sampling step along the stroke (m). The
/// polyline is first clipped to the surface's bounding box grown by max_distance (outside it
/// everything misses); throws std::invalid_argument if what remains needs more than
/// kMaxStrokeSamples samples, or on bad max_distance or spacing.
StrokeTrace trace_closest(const Positions& positions, const Faces& faces, const Positions& stroke,
                          double max_distance, double spacing);

/// Traces a polyline of pixels (k×3, z ignored) by casting rays from `eye` with direction
/// base_direction + px · direction_per_pixel_x + py · direction_per_pixel_y (a pinhole camera
/// is affine in pixel coordinates); the nearest hit counts. spacing_pixels: first sampling step.
/// When every vertex is in front of the camera the polyline is first clipped to the pixel
/// bounding box of the projected vertices plus a margin (outside it no ray hits); throws
/// std::invalid_argument if what remains needs more than kMaxStrokeSamples samples.
StrokeTrace trace_rays(const Positions& positions, const Faces& faces, const Positions& pixels,
                       const Eigen::Vector3d& eye, const Eigen::Vector3d& base_direction,
                       const Eigen::Vector3d& direction_per_pixel_x,
                       const Eigen::Vector3d& direction_per_pixel_y, double spacing_pixels);

/// The first surface hit of each pixel's ray, cast as trace_rays casts them (eye + t (base +
/// px · per_pixel_x + py · per_pixel_y), t > 0; pixels k×3 with z = 0), with one AABB tree for
/// all: picking under a mouse. std::nullopt where a ray misses.
std::vector<std::optional<SurfaceHit>> pick_rays(const Positions& positions, const Faces& faces,
                                                 const Positions& pixels,
                                                 const Eigen::Vector3d& eye,
                                                 const Eigen::Vector3d& base_direction,
                                                 const Eigen::Vector3d& direction_per_pixel_x,
                                                 const Eigen::Vector3d& direction_per_pixel_y);

}  // namespace yore
