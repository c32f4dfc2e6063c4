#include "yore/cloth/mesh.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace yore {
namespace {

/// One face-side: the undirected edge (a < b), the face it belongs to and the face's third vertex.
struct HalfEdgeRecord {
  std::int32_t a, b, face, opposite;
};

std::vector<HalfEdgeRecord> sorted_face_sides(const Faces& faces) {
  std::vector<HalfEdgeRecord> sides;
  sides.reserve(static_cast<std::size_t>(faces.rows()) * 3);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    for (int corner = 0; corner < 3; ++corner) {
      const std::int32_t u = faces(f, corner), w = faces(f, (corner + 1) % 3);
      const std::int32_t opposite = faces(f, (corner + 2) % 3);
      sides.push_back({std::min(u, w), std::max(u, w), static_cast<std::int32_t>(f), opposite});
    }
  }
  std::sort(sides.begin(), sides.end(), [](const HalfEdgeRecord& l, const HalfEdgeRecord& r) {
    return l.a != r.a ? l.a < r.a : (l.b != r.b ? l.b < r.b : l.face < r.face);
  });
  return sides;
}

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

// A face whose area is below 1e-12 of its longest edge squared has no usable shape (springs
// across it would be collinear or of zero length): throws naming it.
void check_face_shape(const Positions& positions, Eigen::Index f, std::int32_t a, std::int32_t b,
                      std::int32_t c) {
  const Eigen::Vector3d e1 = positions.row(b) - positions.row(a);
  const Eigen::Vector3d e2 = positions.row(c) - positions.row(a);
  const Eigen::Vector3d e3 = positions.row(c) - positions.row(b);
  const double longest_squared = std::max({e1.squaredNorm(), e2.squaredNorm(), e3.squaredNorm()});
  const double twice_area = e1.cross(e2).norm();
  if (!(twice_area > 2e-12 * longest_squared)) {
    std::ostringstream msg;
    msg << "face " << f << " (" << a << ", " << b << ", " << c << ") is degenerate: area "
        << 0.5 * twice_area << " m² for a longest edge of " << std::sqrt(longest_squared) << " m";
    fail(msg.str());
  }
}

// Every edge in at most two faces, and no two faces the same triangle: throws naming them.
void check_manifold(const Faces& faces) {
  const std::vector<HalfEdgeRecord> sides = sorted_face_sides(faces);
  for (std::size_t k = 0; k < sides.size();) {
    std::size_t end = k + 1;
    while (end < sides.size() && sides[end].a == sides[k].a && sides[end].b == sides[k].b) ++end;
    if (end - k > 2) {
      std::ostringstream msg;
      msg << "edge (" << sides[k].a << ", " << sides[k].b << ") is shared by " << end - k
          << " faces: the mesh is not manifold";
      fail(msg.str());
    }
    if (end - k == 2 && sides[k].opposite == sides[k + 1].opposite) {
      std::ostringstream msg;
      msg << "faces " << sides[k].face << " and " << sides[k + 1].face << " are the same triangle";
      fail(msg.str());
    }
    k = end;
  }
}

}  // namespace

void validate_mesh(const Positions& positions, const Faces& faces, bool check_shape) {
  const Eigen::Index n = positions.rows();
  if (n == 0) fail("mesh has no vertices");
  if (faces.rows() == 0) fail("mesh has no faces (a cloth needs at least one triangle)");
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!positions.row(i).allFinite()) {
      std::ostringstream msg;
      msg << "vertex " << i << " has a non-finite position (" << positions(i, 0) << ", "
          << positions(i, 1) << ", " << positions(i, 2) << ")";
      fail(msg.str());
    }
  }
  std::vector<char> used(static_cast<std::size_t>(n), 0);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const std::int32_t v = faces(f, c);
      if (v < 0 || v >= n) {
        std::ostringstream msg;
        msg << "face " << f << " has vertex index " << v << " out of range [0, " << n << ")";
        fail(msg.str());
      }
      used[static_cast<std::size_t>(v)] = 1;
    }
    const std::int32_t a = faces(f, 0), b = faces(f, 1), c = faces(f, 2);
    if (a == b || b == c || a == c) {
      std::ostringstream msg;
      msg << "face " << f << " repeats a vertex (" << a << ", " << b << ", " << c << ")";
      fail(msg.str());
    }
    if (check_shape) check_face_shape(positions, f, a, b, c);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!used[static_cast<std::size_t>(i)]) {
      std::ostringstream msg;
      msg << "vertex " << i << " belongs to no face; remove unused vertices first";
      fail(msg.str());
    }
  }
  check_manifold(faces);
}

MeshConnectivity mesh_connectivity(const Faces& faces) {
  MeshConnectivity result;
  const std::vector<HalfEdgeRecord> sides = sorted_face_sides(faces);
  result.edges.reserve(sides.size() / 2 + 1);
  for (std::size_t k = 0; k < sides.size();) {
    std::size_t end = k + 1;
    while (end < sides.size() && sides[end].a == sides[k].a && sides[end].b == sides[k].b) ++end;
    result.edges.push_back({sides[k].a, sides[k].b});
    if (end - k == 1) {
      ++result.boundary_edge_count;
    } else {
      const std::int32_t p = sides[k].opposite, q = sides[k + 1].opposite;
      result.bending_pairs.push_back({std::min(p, q), std::max(p, q)});
    }
    k = end;
  }
  // edges are already sorted; a bending pair that is also an edge, or that two interior edges
  // share (small closed meshes), is wired once only.
  std::sort(result.bending_pairs.begin(), result.bending_pairs.end());
  result.bending_pairs.erase(std::unique(result.bending_pairs.begin(), result.bending_pairs.end()),
                             result.bending_pairs.end());
  result.bending_pairs.erase(
      std::remove_if(result.bending_pairs.begin(), result.bending_pairs.end(),
                     [&](const VertexPair& pair) {
                       return std::binary_search(result.edges.begin(), result.edges.end(), pair);
                     }),
      result.bending_pairs.end());
  return result;
}

Eigen::VectorXd lumped_vertex_areas(const Positions& positions, const Faces& faces) {
  Eigen::VectorXd area = Eigen::VectorXd::Zero(positions.rows());
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d e1 = positions.row(faces(f, 1)) - positions.row(faces(f, 0));
    const Eigen::Vector3d e2 = positions.row(faces(f, 2)) - positions.row(faces(f, 0));
    const double third = e1.cross(e2).norm() / 6.0;
    for (int c = 0; c < 3; ++c) area[faces(f, c)] += third;
  }
  return area;
}

Eigen::VectorXd lumped_masses(const Positions& positions, const Faces& faces, double density) {
  if (!std::isfinite(density) || density <= 0.0) {
    std::ostringstream msg;
    msg << "density must be finite and > 0 kg/m², got " << density;
    throw std::invalid_argument(msg.str());
  }
  validate_mesh(positions, faces);  // lumping reads the faces
  return density * lumped_vertex_areas(positions, faces);
}

double area_from_sides(double a, double b, double c) {
  const double s = 0.5 * (a + b + c);
  const double product = s * (s - a) * (s - b) * (s - c);
  return product > 0.0 ? std::sqrt(product) : 0.0;
}

}  // namespace yore
