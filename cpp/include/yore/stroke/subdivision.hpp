#pragma once
/// @file subdivision.hpp
/// Mesh surgery as pure functions (no springs, no masses): vertices, faces and the requested
/// splits in; new vertices, faces and the parent of every child face out, in the shape of
/// libigl's false_barycentric_subdivision. Cloth::split_faces and Cloth::refine_faces call these
/// and only rewire springs and masses.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "yore/cloth/mesh.hpp"

namespace yore {

/// The result of a subdivision. The input vertices keep their indices and come first; the new
/// ones follow. A face that is not subdivided keeps its row; a subdivided face's first child
/// takes the parent's row and its other children are appended, so face indices of untouched
/// faces are stable too.
struct Subdivision {
  Positions positions;  ///< (n + k)×3, metres: the input vertices, then the k new ones
  Faces faces;          ///< f'×3, every child with its parent's orientation
  std::vector<std::int32_t> parents;  ///< f', the input face each output face lies in
  /// k×3 input vertices and k×3 barycentric weights that interpolate each new vertex (for
  /// velocities, material coordinates, ...): new vertex = Σ weights(k, c) · vertex corners(k, c).
  Faces new_vertex_corners;
  Positions new_vertex_weights;
};

/// One face to split 1→3 and where: the new vertex at these barycentric weights of its corners.
struct FaceSplit {
  std::int32_t face = -1;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Constant(1.0 / 3.0);
};

/// The outcome of the paper's 1→3 split (split_faces_1to3).
struct Split1to3 {
  Subdivision mesh;
  std::vector<std::int32_t> split_faces;    ///< the faces split, in the order given
  std::vector<std::int32_t> faces_skipped;  ///< faces left whole (their children would be slivers)
  std::vector<Eigen::Vector3d> weights;     ///< per split face, the barycentric point used
  std::int64_t moved_inward = 0;            ///< split points moved by the min_barycentric rule
};

/// The paper's subdivision: each requested face (a, b, c) gets a new vertex p at a barycentric
/// point and becomes (a, b, p) in its own row, (b, c, p) and (c, a, p) appended (two rows per
/// split, in order). A point with a weight below min_barycentric is moved towards the centroid
/// until its smallest weight equals it; a split whose children have an angle below
/// min_angle_degrees is tried at the centroid, and skipped if that too gives a sliver.
/// positions n×3 (m), faces f×3. Throws std::invalid_argument on faces out of range or repeated,
/// weights that are negative, non-finite or do not sum to 1, or min_barycentric outside [0, 1/3).
Split1to3 split_faces_1to3(const Positions& positions, const Faces& faces,
                           const std::vector<FaceSplit>& splits, double min_barycentric,
                           double min_angle_degrees);

/// The outcome of a 1→4 refinement with its conforming closure (refine_faces_1to4).
struct Refinement {
  Subdivision mesh;
  std::vector<std::int32_t> refined_faces;   ///< faces split 1→4 (requested + closure), sorted
  std::vector<std::int32_t> bisected_faces;  ///< faces split 1→2 to close the refinement, sorted
  std::vector<VertexPair> split_edges;       ///< the edges (i < j) that got a midpoint, sorted;
                                             ///< new vertex k is the midpoint of split_edges[k]
};

/// Refines faces 1→4 at their edge midpoints, with a conforming closure (no hanging vertex):
/// a face with two or three split edges is refined 1→4 too, repeated until every other face has
/// at most one; a face with exactly one split edge is bisected 1→2 from its midpoint to the
/// opposite corner. A face (a, b, c) with midpoints m_ab, m_bc, m_ca becomes (a, m_ab, m_ca) in
/// its own row, then (m_ab, b, m_bc), (m_ca, m_bc, c), (m_ab, m_bc, m_ca); a bisected face with
/// split edge (b, c) becomes (a, b, m) and (a, m, c). New vertices follow the sorted split edges.
/// positions n×3 (m), faces f×3 (a valid mesh). Throws std::invalid_argument on faces out of range.
Refinement refine_faces_1to4(const Positions& positions, const Faces& faces,
                             const std::vector<std::int32_t>& refine);

}  // namespace yore
