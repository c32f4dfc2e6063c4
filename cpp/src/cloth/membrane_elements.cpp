/// @file membrane_elements.cpp
/// The membrane's elements (membrane.hpp's MembraneElements): the rest state's tangent frames
/// (membrane_reference), the faces' constant-strain elements, and the smoothed strain's one
/// element per vertex with its subcells, in each vertex's rest frame (build_membrane_elements).

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "yore/cloth/membrane.hpp"

namespace yore {

namespace {

// Unit axes of vertex p's tangent plane: normal to the area-weighted normal of its faces (any
// plane when they cancel).
std::pair<Vec3, Vec3> tangent_axes(const Vec3& normal) {
  const Vec3 n = normal.norm() > 0.0 ? Vec3(normal.normalized()) : Vec3::UnitZ();
  const Vec3 seed = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 u = (seed - seed.dot(n) * n).normalized();
  return {u, n.cross(u)};
}

}  // namespace

MembraneReference membrane_reference(const Positions& rest_positions, const Faces& faces) {
  MembraneReference reference;
  const Eigen::Index n = rest_positions.rows();
  reference.face_starts.assign(static_cast<std::size_t>(n) + 1, 0);
  std::vector<Vec3> normal(static_cast<std::size_t>(n), Vec3::Zero());
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Vec3 x0 = rest_positions.row(faces(f, 0));
    const Vec3 twice_area = (Vec3(rest_positions.row(faces(f, 1))) - x0)
                                .cross(Vec3(rest_positions.row(faces(f, 2))) - x0);
    for (int k = 0; k < 3; ++k) {
      ++reference.face_starts[static_cast<std::size_t>(faces(f, k)) + 1];
      normal[static_cast<std::size_t>(faces(f, k))] += twice_area;
    }
  }
  for (Eigen::Index p = 0; p < n; ++p) {
    reference.face_starts[static_cast<std::size_t>(p) + 1] +=
        reference.face_starts[static_cast<std::size_t>(p)];
  }
  const auto total = static_cast<std::size_t>(reference.face_starts.back());
  reference.incident_faces.assign(total, -1);
  reference.reference_inverse.assign(4 * total, 0.0);
  std::vector<std::int32_t> fill(reference.face_starts.begin(), reference.face_starts.end() - 1);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Vec3 x0 = rest_positions.row(faces(f, 0));
    const Vec3 e1 = Vec3(rest_positions.row(faces(f, 1))) - x0;
    const Vec3 e2 = Vec3(rest_positions.row(faces(f, 2))) - x0;
    const double twice_area = e1.cross(e2).norm();
    for (int k = 0; k < 3; ++k) {
      const auto p = static_cast<std::size_t>(faces(f, k));
      const auto slot = static_cast<std::size_t>(fill[p]++);
      reference.incident_faces[slot] = static_cast<std::int32_t>(f);
      const auto [u, v] = tangent_axes(normal[p]);
      Eigen::Matrix2d edge_vectors;
      edge_vectors << e1.dot(u), e2.dot(u), e1.dot(v), e2.dot(v);
      // A face nearly edge-on to the vertex's plane (under 1 % of its area seen) cannot be
      // averaged there: it keeps D⁻¹ = 0, and the vertex gives its share back to its faces.
      if (!(std::abs(edge_vectors.determinant()) > 1e-2 * twice_area)) continue;
      Eigen::Map<Eigen::Matrix2d>(&reference.reference_inverse[4 * slot]) = edge_vectors.inverse();
    }
  }
  // each vertex's corners: itself and its 1-ring, in increasing order
  reference.corner_starts.assign(static_cast<std::size_t>(n) + 1, 0);
  std::vector<std::int32_t> corners;
  for (Eigen::Index p = 0; p < n; ++p) {
    corners.clear();
    for (auto slot = static_cast<std::size_t>(reference.face_starts[static_cast<std::size_t>(p)]);
         slot < static_cast<std::size_t>(reference.face_starts[static_cast<std::size_t>(p) + 1]);
         ++slot) {
      for (int k = 0; k < 3; ++k) corners.push_back(faces(reference.incident_faces[slot], k));
    }
    std::sort(corners.begin(), corners.end());
    corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
    reference.corners.insert(reference.corners.end(), corners.begin(), corners.end());
    reference.corner_starts[static_cast<std::size_t>(p) + 1] =
        static_cast<std::int32_t>(reference.corners.size());
  }
  return reference;
}

namespace {

// Appends the faces' constant-strain elements with their share of the energy.
void add_face_elements(const Faces& faces, const MembraneFaces& map, const SpringSet& springs,
                       double share, MembraneElements& out) {
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const MembraneRest rest = membrane_face_rest(map, springs, static_cast<std::size_t>(f));
    const std::array<Eigen::Vector2d, 3> d = membrane_shape_gradients(rest);
    for (int k = 0; k < 3; ++k) {
      out.corners.push_back(faces(f, k));
      out.gradient_u.push_back(d[static_cast<std::size_t>(k)].x());
      out.gradient_v.push_back(d[static_cast<std::size_t>(k)].y());
    }
    out.area.push_back(share * rest.area);
    out.starts.push_back(static_cast<std::int32_t>(out.corners.size()));
    if (!out.subcell_starts.empty()) out.subcell_starts.push_back(out.subcell_starts.back());
  }
}

// Drops what an unfinished element appended: corners from `corners`, subcells from `subcells`.
void truncate(MembraneElements& out, std::size_t corners, std::size_t subcells) {
  out.corners.resize(corners);
  out.gradient_u.resize(corners);
  out.gradient_v.resize(corners);
  out.subcell_area.resize(subcells);
  out.subcell_corner.resize(3 * subcells);
  out.subcell_gradient_u.resize(3 * subcells);
  out.subcell_gradient_v.resize(3 * subcells);
}

// The fallback of add_vertex_elements: each listed vertex's faces as elements of three corners
// with (1 − kMembraneFaceShare)/3 of the face's area (no subcells).
void add_fallback_elements(const Faces& faces, const MembraneFaces& map, const SpringSet& springs,
                           const MembraneReference& reference,
                           const std::vector<std::size_t>& fallback, bool stabilised,
                           MembraneElements& out) {
  for (const std::size_t p : fallback) {
    for (auto slot = static_cast<std::size_t>(reference.face_starts[p]);
         slot < static_cast<std::size_t>(reference.face_starts[p + 1]); ++slot) {
      const auto f = static_cast<std::size_t>(reference.incident_faces[slot]);
      const MembraneRest rest = membrane_face_rest(map, springs, f);
      const std::array<Eigen::Vector2d, 3> d = membrane_shape_gradients(rest);
      for (int k = 0; k < 3; ++k) {
        out.corners.push_back(faces(static_cast<Eigen::Index>(f), k));
        out.gradient_u.push_back(d[static_cast<std::size_t>(k)].x());
        out.gradient_v.push_back(d[static_cast<std::size_t>(k)].y());
      }
      out.area.push_back((1.0 - kMembraneFaceShare) * rest.area / 3.0);
      out.starts.push_back(static_cast<std::int32_t>(out.corners.size()));
      if (stabilised) out.subcell_starts.push_back(out.subcell_starts.back());
    }
  }
}

// The slot of vertex among a vertex's sorted corners reference.corners[first, last).
std::size_t corner_slot(const MembraneReference& reference, std::size_t first, std::size_t last,
                        std::int32_t vertex) {
  const auto begin = reference.corners.begin() + static_cast<std::ptrdiff_t>(first);
  const auto end = reference.corners.begin() + static_cast<std::ptrdiff_t>(last);
  return static_cast<std::size_t>(std::lower_bound(begin, end, vertex) - begin);
}

// An element's corner gradients from start on, and its subcells' from first_subcell_corner
// on, into the rest frame: d = L⁻¹ c / A_p for the element (lower_inverse = L⁻¹ / A_p), L⁻¹ c
// for the subcells' face gradients (no mean's 1/A_p).
void to_rest_frame(const Eigen::Matrix2d& lower_inverse, double area, std::size_t start,
                   std::size_t first_subcell_corner, MembraneElements& out) {
  for (std::size_t k = start; k < out.corners.size(); ++k) {
    const Eigen::Vector2d d = lower_inverse * Eigen::Vector2d(out.gradient_u[k], out.gradient_v[k]);
    out.gradient_u[k] = d.x();
    out.gradient_v[k] = d.y();
  }
  for (std::size_t k = first_subcell_corner; k < out.subcell_corner.size(); ++k) {
    const Eigen::Vector2d d = area * lower_inverse *
                              Eigen::Vector2d(out.subcell_gradient_u[k], out.subcell_gradient_v[k]);
    out.subcell_gradient_u[k] = d.x();
    out.subcell_gradient_v[k] = d.y();
  }
}

// Appends one smoothed element per vertex (see membrane.hpp). A vertex with no usable metric
// (every face edge-on to its plane, or a metric that is not positive definite) gives its share
// to its faces instead: elements of three corners with (1 − kMembraneFaceShare)/3 of each
// face's area, after the smoothed ones.
void add_vertex_elements(const Faces& faces, const MembraneFaces& map, const SpringSet& springs,
                         const MembraneReference& reference, MembraneElements& out) {
  const bool stabilised = !out.subcell_starts.empty();
  std::vector<std::size_t> fallback;
  for (std::size_t p = 0; p + 1 < reference.face_starts.size(); ++p) {
    const auto first_face = static_cast<std::size_t>(reference.face_starts[p]);
    const auto last_face = static_cast<std::size_t>(reference.face_starts[p + 1]);
    if (first_face == last_face) continue;  // on no face
    const auto first_corner = static_cast<std::size_t>(reference.corner_starts[p]);
    const auto last_corner = static_cast<std::size_t>(reference.corner_starts[p + 1]);
    const std::size_t start = out.corners.size();
    out.corners.insert(out.corners.end(), reference.corners.begin() + first_corner,
                       reference.corners.begin() + last_corner);
    out.gradient_u.resize(out.corners.size(), 0.0);
    out.gradient_v.resize(out.corners.size(), 0.0);
    Eigen::Matrix2d metric = Eigen::Matrix2d::Zero();
    double area = 0.0;
    bool usable = true;
    const std::size_t first_subcell = out.subcell_area.size();
    for (std::size_t slot = first_face; slot < last_face; ++slot) {
      const auto f = static_cast<std::size_t>(reference.incident_faces[slot]);
      const MembraneRest rest = membrane_face_rest(map, springs, f);
      const Eigen::Map<const Eigen::Matrix2d> inverse(&reference.reference_inverse[4 * slot]);
      usable = usable && !inverse.isZero(0.0);
      const Eigen::Matrix2d rest_edges = rest.inverse.inverse();
      metric += rest.area * inverse.transpose() * rest_edges.transpose() * rest_edges * inverse;
      area += rest.area / 3.0;
      // the face's linear gradients in p's tangent axes, weighted by its third of the area
      const Eigen::Vector2d d1 = inverse.row(0).transpose(), d2 = inverse.row(1).transpose();
      const std::array<Eigen::Vector2d, 3> d{-(d1 + d2), d1, d2};
      for (int k = 0; k < 3; ++k) {
        const std::int32_t vertex = faces(static_cast<Eigen::Index>(f), k);
        const std::size_t at = corner_slot(reference, first_corner, last_corner, vertex);
        out.gradient_u[start + at] += rest.area / 3.0 * d[static_cast<std::size_t>(k)].x();
        out.gradient_v[start + at] += rest.area / 3.0 * d[static_cast<std::size_t>(k)].y();
        if (stabilised) {
          out.subcell_corner.push_back(static_cast<std::int32_t>(at));
          out.subcell_gradient_u.push_back(d[static_cast<std::size_t>(k)].x());
          out.subcell_gradient_v.push_back(d[static_cast<std::size_t>(k)].y());
        }
      }
      if (stabilised) out.subcell_area.push_back(kMembraneStabilisation * rest.area / 3.0);
    }
    const Eigen::LLT<Eigen::Matrix2d> cholesky(metric / (3.0 * area));
    if (!usable || !(area > 0.0) || cholesky.info() != Eigen::Success) {
      truncate(out, start, first_subcell);  // the element is dropped
      fallback.push_back(p);
      continue;
    }
    // G_p = Σ_f (A_f/3) G_f / A_p in the tangent axes; F_p = G_p L⁻ᵀ, so d = L⁻¹ c / A_p
    to_rest_frame(Eigen::Matrix2d(cholesky.matrixL()).inverse() / area, area, start,
                  3 * first_subcell, out);
    out.area.push_back((1.0 - kMembraneFaceShare) * area);
    out.starts.push_back(static_cast<std::int32_t>(out.corners.size()));
    if (stabilised) {
      out.subcell_starts.push_back(static_cast<std::int32_t>(out.subcell_area.size()));
    }
  }
  add_fallback_elements(faces, map, springs, reference, fallback, stabilised, out);
}

}  // namespace

void build_membrane_elements(const Faces& faces, const MembraneFaces& map, const SpringSet& springs,
                             const MembraneReference* reference, MembraneElements& out) {
  out.starts.clear();
  out.corners.clear();
  out.gradient_u.clear();
  out.gradient_v.clear();
  out.area.clear();
  out.subcell_starts.clear();
  out.subcell_area.clear();
  out.subcell_corner.clear();
  out.subcell_gradient_u.clear();
  out.subcell_gradient_v.clear();
  out.starts.push_back(0);
  if (reference != nullptr && kMembraneStabilisation > 0.0) out.subcell_starts.push_back(0);
  // (with a reference and no faces' share, the faces carry nothing: no elements)
  const double share = reference != nullptr ? kMembraneFaceShare : 1.0;
  if (share > 0.0) add_face_elements(faces, map, springs, share, out);
  out.face_elements = share > 0.0 ? faces.rows() : 0;
  if (reference != nullptr) add_vertex_elements(faces, map, springs, *reference, out);
}

}  // namespace yore
