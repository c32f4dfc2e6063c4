#include "yore/stroke/subdivision.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

namespace yore {
namespace {

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

/// Smallest interior angle of a triangle, degrees.
double min_angle_degrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c) {
  auto angle = [](const Eigen::Vector3d& apex, const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
    const Eigen::Vector3d u = p - apex, v = q - apex;
    return std::atan2(u.cross(v).norm(), u.dot(v));
  };
  const double smallest = std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)});
  return smallest * 180.0 / M_PI;
}

void check_face_index(std::int32_t face, Eigen::Index face_count) {
  if (face < 0 || face >= face_count) {
    std::ostringstream msg;
    msg << "face " << face << " out of range [0, " << face_count << ")";
    fail(msg.str());
  }
}

VertexPair sorted_pair(std::int32_t i, std::int32_t j) { return {std::min(i, j), std::max(i, j)}; }

}  // namespace

namespace {

// Every split names a face in range, at most once, with weights >= 0 that sum to 1.
void check_splits(const std::vector<FaceSplit>& splits, Eigen::Index face_count) {
  std::vector<char> seen(static_cast<std::size_t>(face_count), 0);
  for (const FaceSplit& split : splits) {
    check_face_index(split.face, face_count);
    if (seen[static_cast<std::size_t>(split.face)]++) {
      std::ostringstream msg;
      msg << "face " << split.face << " is split twice in one call";
      fail(msg.str());
    }
    if (!split.barycentric.allFinite() || split.barycentric.minCoeff() < -1e-9 ||
        std::abs(split.barycentric.sum() - 1.0) > 1e-6) {
      std::ostringstream msg;
      msg << "barycentric weights of face " << split.face << " must be >= 0 and sum to 1";
      fail(msg.str());
    }
  }
}

// Each split's point: its barycentric weights clamped to >= 0, blended towards the centroid
// until the smallest is min_barycentric, or the centroid itself when a child would have an angle
// below the limit; a face whose centroid fails too is skipped. Into `out`'s split_faces,
// weights, moved_inward and faces_skipped.
void choose_split_points(const Positions& positions, const Faces& faces,
                         const std::vector<FaceSplit>& splits, double min_barycentric,
                         double min_angle_degrees_limit, Split1to3& out) {
  for (const FaceSplit& split : splits) {
    const std::int32_t a = faces(split.face, 0), b = faces(split.face, 1), c = faces(split.face, 2);
    const Eigen::Vector3d xa = positions.row(a), xb = positions.row(b), xc = positions.row(c);
    Eigen::Vector3d weights = split.barycentric.cwiseMax(0.0);
    weights /= weights.sum();
    const double smallest = weights.minCoeff();
    if (smallest < min_barycentric) {
      // Blend towards the centroid until the smallest weight is min_barycentric.
      const double blend = (min_barycentric - smallest) / (1.0 / 3.0 - smallest);
      weights = (1.0 - blend) * weights + Eigen::Vector3d::Constant(blend / 3.0);
      ++out.moved_inward;
    }
    auto children_ok = [&](const Eigen::Vector3d& w) {
      const Eigen::Vector3d p = w[0] * xa + w[1] * xb + w[2] * xc;
      return std::min({min_angle_degrees(xa, xb, p), min_angle_degrees(xb, xc, p),
                       min_angle_degrees(xc, xa, p)}) >= min_angle_degrees_limit;
    };
    if (!children_ok(weights)) weights = Eigen::Vector3d::Constant(1.0 / 3.0);
    if (!children_ok(weights)) {
      out.faces_skipped.push_back(split.face);
      continue;
    }
    out.split_faces.push_back(split.face);
    out.weights.push_back(weights);
  }
}

}  // namespace

Split1to3 split_faces_1to3(const Positions& positions, const Faces& faces,
                           const std::vector<FaceSplit>& splits, double min_barycentric,
                           double min_angle_degrees_limit) {
  if (!(min_barycentric >= 0.0 && min_barycentric < 1.0 / 3.0)) {
    fail("min_barycentric must be in [0, 1/3)");
  }
  const Eigen::Index face_count = faces.rows();
  check_splits(splits, face_count);

  Split1to3 out;
  choose_split_points(positions, faces, splits, min_barycentric, min_angle_degrees_limit, out);

  const Eigen::Index old_vertices = positions.rows();
  const auto added = static_cast<Eigen::Index>(out.split_faces.size());
  Subdivision& mesh = out.mesh;
  mesh.positions = positions;
  mesh.faces = faces;
  mesh.parents.resize(static_cast<std::size_t>(face_count + 2 * added));
  for (Eigen::Index f = 0; f < face_count; ++f) {
    mesh.parents[static_cast<std::size_t>(f)] = static_cast<std::int32_t>(f);
  }
  mesh.positions.conservativeResize(old_vertices + added, 3);
  mesh.faces.conservativeResize(face_count + 2 * added, 3);
  mesh.new_vertex_corners.resize(added, 3);
  mesh.new_vertex_weights.resize(added, 3);
  for (Eigen::Index k = 0; k < added; ++k) {
    const std::int32_t face = out.split_faces[static_cast<std::size_t>(k)];
    const Eigen::Vector3d& w = out.weights[static_cast<std::size_t>(k)];
    const std::int32_t a = faces(face, 0), b = faces(face, 1), c = faces(face, 2);
    const auto p = static_cast<std::int32_t>(old_vertices + k);
    mesh.positions.row(p) =
        w[0] * positions.row(a) + w[1] * positions.row(b) + w[2] * positions.row(c);
    mesh.new_vertex_corners.row(k) << a, b, c;
    mesh.new_vertex_weights.row(k) = w.transpose();
    // Children keep the parent's orientation: (a, b, p), (b, c, p), (c, a, p).
    const auto second_child = static_cast<std::int32_t>(face_count + 2 * k);
    mesh.faces.row(face) << a, b, p;
    mesh.faces.row(second_child) << b, c, p;
    mesh.faces.row(second_child + 1) << c, a, p;
    mesh.parents[static_cast<std::size_t>(second_child)] = face;
    mesh.parents[static_cast<std::size_t>(second_child + 1)] = face;
  }
  return out;
}

namespace {

/// The conforming closure of a 1→4 refinement: the faces refined ("red": those asked for and
/// every face left with two or three split edges) and the edges that get a midpoint.
struct Closure {
  std::vector<char> red;
  std::map<VertexPair, char> split;
};

Closure conforming_closure(const Faces& faces, const std::vector<std::int32_t>& refine) {
  const Eigen::Index face_count = faces.rows();
  std::vector<char> red(static_cast<std::size_t>(face_count), 0);
  for (const std::int32_t f : refine) {
    check_face_index(f, face_count);
    red[static_cast<std::size_t>(f)] = 1;
  }
  // Faces around each edge, for the closure: (edge, face) sorted by edge.
  std::vector<std::pair<VertexPair, std::int32_t>> faces_of_edge;
  faces_of_edge.reserve(static_cast<std::size_t>(3 * face_count));
  for (Eigen::Index f = 0; f < face_count; ++f) {
    for (int c = 0; c < 3; ++c) {
      faces_of_edge.emplace_back(sorted_pair(faces(f, c), faces(f, (c + 1) % 3)),
                                 static_cast<std::int32_t>(f));
    }
  }
  std::sort(faces_of_edge.begin(), faces_of_edge.end());
  auto around = [&](const VertexPair& edge) {
    return std::equal_range(faces_of_edge.begin(), faces_of_edge.end(),
                            std::pair<VertexPair, std::int32_t>{edge, -1},
                            [](const auto& x, const auto& y) { return x.first < y.first; });
  };
  Closure closure;
  std::map<VertexPair, char>& split = closure.split;  // edges with a midpoint
  std::vector<std::int32_t> queue;
  for (Eigen::Index f = 0; f < face_count; ++f) {
    if (red[static_cast<std::size_t>(f)]) queue.push_back(static_cast<std::int32_t>(f));
  }
  auto split_count = [&](std::int32_t f) {
    int count = 0;
    for (int c = 0; c < 3; ++c) {
      count += split.count(sorted_pair(faces(f, c), faces(f, (c + 1) % 3))) > 0;
    }
    return count;
  };
  // Closure: a red face splits its three edges; a neighbour left with two split edges turns red.
  while (!queue.empty()) {
    const std::int32_t f = queue.back();
    queue.pop_back();
    for (int c = 0; c < 3; ++c) {
      const VertexPair edge = sorted_pair(faces(f, c), faces(f, (c + 1) % 3));
      if (!split.emplace(edge, 1).second) continue;
      const auto range = around(edge);
      for (auto it = range.first; it != range.second; ++it) {
        const std::int32_t g = it->second;
        if (!red[static_cast<std::size_t>(g)] && split_count(g) >= 2) {
          red[static_cast<std::size_t>(g)] = 1;
          queue.push_back(g);
        }
      }
    }
  }
  closure.red = std::move(red);
  return closure;
}

/// The midpoints of the split edges, numbered after the old vertices in the edges' order;
/// fills `out`'s split edges, positions and new vertices' interpolation, returns the numbering.
std::map<VertexPair, std::int32_t> add_midpoints(const Positions& positions,
                                                 const std::map<VertexPair, char>& split,
                                                 Refinement& out) {
  std::map<VertexPair, std::int32_t> midpoint;
  const Eigen::Index old_vertices = positions.rows();
  for (const auto& entry : split) {
    midpoint[entry.first] = static_cast<std::int32_t>(old_vertices + out.split_edges.size());
    out.split_edges.push_back(entry.first);
  }
  const auto added = static_cast<Eigen::Index>(out.split_edges.size());
  Subdivision& mesh = out.mesh;
  mesh.positions = positions;
  mesh.positions.conservativeResize(old_vertices + added, 3);
  mesh.new_vertex_corners.resize(added, 3);
  mesh.new_vertex_weights.resize(added, 3);
  for (Eigen::Index k = 0; k < added; ++k) {
    const VertexPair& edge = out.split_edges[static_cast<std::size_t>(k)];
    mesh.positions.row(old_vertices + k) = 0.5 * (positions.row(edge[0]) + positions.row(edge[1]));
    mesh.new_vertex_corners.row(k) << edge[0], edge[1], edge[1];
    mesh.new_vertex_weights.row(k) << 0.5, 0.5, 0.0;
  }
  return midpoint;
}

/// The children: a red face becomes four (its corner children in place, three appended), a
/// face with one split edge two (bisected); parents listed for every face.
void make_children(const Faces& faces, const std::vector<char>& red,
                   const std::map<VertexPair, std::int32_t>& midpoint, Refinement& out) {
  const Eigen::Index face_count = faces.rows();
  Subdivision& mesh = out.mesh;
  std::vector<std::array<std::int32_t, 3>> appended;
  std::vector<std::int32_t> appended_parents;
  mesh.faces = faces;
  mesh.parents.resize(static_cast<std::size_t>(face_count));
  for (Eigen::Index f = 0; f < face_count; ++f) {
    mesh.parents[static_cast<std::size_t>(f)] = static_cast<std::int32_t>(f);
    const auto face = static_cast<std::int32_t>(f);
    if (red[static_cast<std::size_t>(f)]) {
      const std::int32_t a = faces(f, 0), b = faces(f, 1), c = faces(f, 2);
      const std::int32_t ab = midpoint.at(sorted_pair(a, b)), bc = midpoint.at(sorted_pair(b, c)),
                         ca = midpoint.at(sorted_pair(c, a));
      mesh.faces.row(f) << a, ab, ca;
      appended.push_back({ab, b, bc});
      appended.push_back({ca, bc, c});
      appended.push_back({ab, bc, ca});
      appended_parents.insert(appended_parents.end(), {face, face, face});
      out.refined_faces.push_back(face);
      continue;
    }
    for (int c = 0; c < 3; ++c) {
      // Rotate so that the split edge is (b, c): the face (a, b, c) → (a, b, m), (a, m, c).
      const std::int32_t b = faces(f, c), cc = faces(f, (c + 1) % 3), a = faces(f, (c + 2) % 3);
      const auto it = midpoint.find(sorted_pair(b, cc));
      if (it == midpoint.end()) continue;
      mesh.faces.row(f) << a, b, it->second;
      appended.push_back({a, it->second, cc});
      appended_parents.push_back(face);
      out.bisected_faces.push_back(face);
      break;  // the closure leaves at most one split edge on a face that is not red
    }
  }
  mesh.faces.conservativeResize(face_count + static_cast<Eigen::Index>(appended.size()), 3);
  for (std::size_t k = 0; k < appended.size(); ++k) {
    const auto row = face_count + static_cast<Eigen::Index>(k);
    mesh.faces.row(row) << appended[k][0], appended[k][1], appended[k][2];
  }
  mesh.parents.insert(mesh.parents.end(), appended_parents.begin(), appended_parents.end());
}

}  // namespace

Refinement refine_faces_1to4(const Positions& positions, const Faces& faces,
                             const std::vector<std::int32_t>& refine) {
  const Closure closure = conforming_closure(faces, refine);
  Refinement out;
  const std::map<VertexPair, std::int32_t> midpoint = add_midpoints(positions, closure.split, out);
  make_children(faces, closure.red, midpoint, out);
  return out;
}

}  // namespace yore
