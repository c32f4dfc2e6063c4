#pragma once
/// @file pattern_mesh.hpp
/// Triangle meshes of flat sewing patterns: an outline polygon with holes meshed by CGAL's 2-D
/// constrained Delaunay mesher (Ruppert-style refinement, Shewchuk's terminator on small input
/// angles) to a largest edge length and a smallest angle: isotropic triangles with no preferred
/// directions, unlike the grid's.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "yore/cloth/mesh.hpp"
#include "yore/platform/limits.hpp"

namespace yore {

/// m×2 row-major points of a polygon, metres (the pattern's (u, v) coordinates).
using Polygon2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

/// The smallest angle CGAL's mesher is asked for at most (degrees). It proves termination up to
/// about 20.7°; in practice it terminates well beyond, and 30° is the usual ceiling.
constexpr double kPatternMaxAngleDegrees = 30.0;

/// Largest |u| or |v| of a pattern point, m: beyond it CGAL's filtered predicates and the
/// mesher's constructions leave double's range of safe arithmetic (a 1e200 m outline ended in
/// SIGFPE); no sewing pattern is a thousand kilometres across.
constexpr double kPatternMaxCoordinate = 1e6;

/// The thinnest feature a pattern may have, as a fraction of its size (the bounding-box
/// diagonal of the outline): no point may lie closer than this to an edge it is not on. The
/// mesher's constructions (circumcentres, split points) lose every digit below it: a needle
/// 1e-9 of its length high crashed it (SIGSEGV) or made it spin.
constexpr double kPatternFeatureFraction = 1e-6;

/// Most points of the outline and the holes together (the thin-feature check compares every
/// point with every edge).
constexpr std::int64_t kPatternMaxPoints = 20'000;

/// What to mesh and how finely.
struct PatternMeshOptions {
  double edge_length = 0.05;        ///< every edge at most this long, m
  double min_angle_degrees = 25.0;  ///< every angle at least this, in (0, kPatternMaxAngleDegrees]
  std::int64_t max_vertices = kMaxMeshVertices;  ///< refinement beyond this is refused
};

/// A meshed pattern: vertices in the pattern's plane and counter-clockwise faces.
struct PatternMesh {
  Polygon2 points;                    ///< n×2, m
  Faces faces;                        ///< f×3, counter-clockwise in (u, v)
  std::int64_t outline_vertices = 0;  ///< vertices on the outline or a hole's boundary
};

/// Meshes the region inside `outline` and outside every hole. The outline and each hole are
/// simple polygons of at least 3 distinct points with non-zero area (either orientation, not
/// closed by repeating the first point); holes lie strictly inside the outline and apart from
/// each other. Throws std::invalid_argument naming the problem (too few points, a non-finite
/// point, zero area, a self-intersecting polygon, a hole that crosses or leaves the outline or
/// another hole, a point beyond kPatternMaxCoordinate, a feature thinner than
/// kPatternFeatureFraction of the outline's size, more than kPatternMaxPoints points, a bad
/// option, or more than max_vertices vertices, or a refinement that stops adding vertices).
PatternMesh pattern_mesh(const Polygon2& outline, const std::vector<Polygon2>& holes,
                         const PatternMeshOptions& options);

}  // namespace yore
