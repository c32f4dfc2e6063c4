#pragma once
/// @file pattern_mesh.hpp
/// Triangle meshes of flat sewing patterns: an outline polygon with holes meshed by CGAL's 2-D
/// constrained Delaunay mesher (Ruppert-style refinement, Shewchuk's terminator on small input
/// angles) to a largest edge length and a smallest angle: isotropic triangles with no preferred
/// directions, unlike the grid's.

#include "yore/mesh.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace yore {

/// m×2 row-major points of a polygon, metres (the pattern's (u, v) coordinates).
using Polygon2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

/// The smallest angle CGAL's mesher is asked for at most (degrees). It proves termination up to
/// about 20.7°; in practice it terminates well beyond, and 30° is the usual ceiling.
constexpr double kPatternMaxAngleDegrees = 30.0;

/// What to mesh and how finely.
struct PatternMeshOptions {
  double edge_length = 0.05;       ///< every edge at most this long, m
  double min_angle_degrees = 25.0;  ///< every angle at least this, in (0, kPatternMaxAngleDegrees]
  std::int64_t max_vertices = 1'000'000;  ///< refinement beyond this many vertices is refused
};

/// A meshed pattern: vertices in the pattern's plane and counter-clockwise faces.
struct PatternMesh {
  Polygon2 points;  ///< n×2, m
  Faces faces;      ///< f×3, counter-clockwise in (u, v)
  std::int64_t outline_vertices = 0;  ///< vertices on the outline or a hole's boundary
};

/// Meshes the region inside `outline` and outside every hole. The outline and each hole are
/// simple polygons of at least 3 distinct points with non-zero area (either orientation, not
/// closed by repeating the first point); holes lie strictly inside the outline and apart from
/// each other. Throws std::invalid_argument naming the problem (too few points, a non-finite
/// point, zero area, a self-intersecting polygon, a hole that crosses or leaves the outline or
/// another hole, a bad option, or more than max_vertices vertices).
PatternMesh pattern_mesh(const Polygon2& outline, const std::vector<Polygon2>& holes,
                         const PatternMeshOptions& options);

}  // namespace yore
