// Subdivision of Cloth: the spring rewiring both subdivisions share, the mass-conserving rule,
// split_faces (the paper's 1→3 split) and refine_faces (1→4 refinement).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "cloth_detail.hpp"
#include "yore/cloth/cloth.hpp"

namespace yore {
using namespace detail;

namespace {

std::uint64_t pair_key(std::int32_t i, std::int32_t j) {
  const auto lo = static_cast<std::uint64_t>(std::min(i, j));
  const auto hi = static_cast<std::uint64_t>(std::max(i, j));
  return (hi << 32) | lo;
}

double triangle_area(const Positions& x, std::int32_t a, std::int32_t b, std::int32_t c) {
  const Vec3 xa = x.row(a), xb = x.row(b), xc = x.row(c);
  return 0.5 * (xb - xa).cross(xc - xa).norm();
}

/// Distance between two points of a triangle given by barycentric weights, in the metric of
/// its side lengths: |d|² = −(d_a d_b |ab|² + d_b d_c |bc|² + d_c d_a |ca|²) for d = u − v
/// (Σ d = 0), so no embedding is needed.
double metric_distance(const Vec3& u, const Vec3& v, double ab, double bc, double ca) {
  const Vec3 d = u - v;
  const double squared = -(d[0] * d[1] * ab * ab + d[1] * d[2] * bc * bc + d[2] * d[0] * ca * ca);
  return std::sqrt(std::max(squared, 0.0));
}

/// Distance between the apexes p and q of two triangles (u, v, p) and (v, u, q) with these side
/// lengths, hinged along (u, v) at the dihedral angle whose cosine is cos_dihedral (−1: flat).
double hinge_distance(double uv, double up, double vp, double uq, double vq, double cos_dihedral) {
  auto foot = [uv](double to_u, double to_v) {
    return (to_u * to_u - to_v * to_v + uv * uv) / (2.0 * uv);
  };
  const double xp = foot(up, vp), xq = foot(uq, vq);
  const double hp = std::sqrt(std::max(up * up - xp * xp, 0.0));
  const double hq = std::sqrt(std::max(uq * uq - xq * xq, 0.0));
  const double squared = (xp - xq) * (xp - xq) + hp * hp + hq * hq - 2.0 * hp * hq * cos_dihedral;
  return std::sqrt(std::max(squared, 0.0));
}

/// The one place a subdivision rewires springs to its new mesh (split_faces and refine_faces).
/// Construction keeps every spring whose pair is still wired (a structural spring on an edge, a
/// bending spring across one), in order, and drops the rest; add_missing then appends a spring
/// for each wired pair that has none, in the connectivity's order. A pair holds at most one
/// spring whatever its kind. The new lengths come from the caller's rule: eq. (1) for the
/// paper's split, the rest metric for refinement.
class SpringRewiring {
 public:
  /// Rest and reference length (m) of a new spring.
  struct Lengths {
    double rest = 0.0;
    double reference = 0.0;
  };

  SpringRewiring(SpringSet& springs, const MeshConnectivity& connectivity)
      : m_springs(springs), m_connectivity(connectivity) {
    std::vector<char> keep(springs.size(), 0);
    m_existing.reserve(springs.size());
    for (std::size_t k = 0; k < springs.size(); ++k) {
      const VertexPair pair{std::min(springs.first[k], springs.second[k]),
                            std::max(springs.first[k], springs.second[k])};
      const auto& wired = springs.kind[k] == SpringKind::structural ? connectivity.edges
                                                                    : connectivity.bending_pairs;
      keep[k] = std::binary_search(wired.begin(), wired.end(), pair);
      if (keep[k]) m_existing.insert(pair_key(pair[0], pair[1]));
    }
    const std::size_t before = springs.size();
    springs.keep(keep);
    m_removed = static_cast<std::int64_t>(before - springs.size());
  }

  /// Adds a spring of this kind on every wired pair of that kind without one (edges for
  /// structural, bending pairs for bending), lengths by `lengths(pair)`.
  template <class LengthRule>
  void add_missing(SpringKind kind, double stiffness, double damping, LengthRule&& lengths) {
    const auto& pairs =
        kind == SpringKind::structural ? m_connectivity.edges : m_connectivity.bending_pairs;
    for (const VertexPair& pair : pairs) {
      if (m_existing.count(pair_key(pair[0], pair[1]))) continue;
      const Lengths length = lengths(pair);
      m_springs.add(pair[0], pair[1], length.rest, stiffness, damping, kind, length.reference);
      ++m_added;
    }
  }

  std::int64_t removed() const { return m_removed; }
  std::int64_t added() const { return m_added; }

 private:
  SpringSet& m_springs;
  const MeshConnectivity& m_connectivity;
  std::unordered_set<std::uint64_t> m_existing;  // pairs of the kept springs
  std::int64_t m_removed = 0;
  std::int64_t m_added = 0;
};

/// The cosine of the dihedral angle at hinge (u, v) between the arms to p and to q (−1, flat,
/// when an arm has no length across the axis).
double hinge_cos_dihedral(const Positions& positions, std::int32_t u, std::int32_t v,
                          std::int32_t p, std::int32_t q) {
  const Vec3 xu = positions.row(u), xv = positions.row(v);
  const Vec3 axis = (xv - xu).normalized();
  Vec3 arm_p = Vec3(positions.row(p)) - xu, arm_q = Vec3(positions.row(q)) - xu;
  arm_p -= arm_p.dot(axis) * axis;
  arm_q -= arm_q.dot(axis) * axis;
  const double norms = arm_p.norm() * arm_q.norm();
  return norms > 0.0 ? std::clamp(arm_p.dot(arm_q) / norms, -1.0, 1.0) : -1.0;
}

[[noreturn]] void fail_zero_bending_rest(std::int32_t p, std::int32_t q) {
  std::ostringstream msg;
  msg << "refinement gives the bending pair (" << p << ", " << q
      << ") a zero rest length: degenerate rest triangles";
  fail(msg.str());
}

/// The split faces, their new vertices (appended in order) and the region's faces (each split
/// face and its two children, appended in order) into the report.
void record_split(const std::vector<std::int32_t>& split_faces, Eigen::Index old_vertices,
                  Eigen::Index old_faces, SplitReport& report) {
  for (std::size_t k = 0; k < split_faces.size(); ++k) {
    const std::int32_t face = split_faces[k];
    const auto second_child =
        static_cast<std::int32_t>(old_faces + 2 * static_cast<Eigen::Index>(k));
    report.split_faces.push_back(face);
    report.new_vertices.push_back(
        static_cast<std::int32_t>(old_vertices + static_cast<Eigen::Index>(k)));
    report.region_faces.insert(report.region_faces.end(), {face, second_child, second_child + 1});
  }
}

/// The springs' stiffness and damping the paper's split gives its new springs.
struct SplitMaterial {
  double stretch_stiffness = 0.0;
  double bend_stiffness = 0.0;  // 0: no bending springs
  double damping = 0.0;
};

/// The springs after a 1→3 split: every spring whose pair is still wired is kept, the rest
/// dropped, and the new pairs get eq. (1) rest lengths (expansion × their current length);
/// new structural rest lengths go into structural_rest, the counts into the report.
void rewire_split(SpringSet& springs, const Faces& faces, const Positions& positions,
                  double expansion, const SplitMaterial& material,
                  std::unordered_map<std::uint64_t, double>& structural_rest, SplitReport& report) {
  const MeshConnectivity connectivity = mesh_connectivity(faces);
  SpringRewiring rewiring(springs, connectivity);
  auto eq1 = [&](const VertexPair& pair) {
    const double length = (positions.row(pair[0]) - positions.row(pair[1])).norm();
    return SpringRewiring::Lengths{expansion * length, length};
  };
  rewiring.add_missing(SpringKind::structural, material.stretch_stiffness, material.damping,
                       [&](const VertexPair& pair) {
                         const SpringRewiring::Lengths lengths = eq1(pair);
                         structural_rest[pair_key(pair[0], pair[1])] = lengths.rest;
                         return lengths;
                       });
  if (material.bend_stiffness > 0.0) {
    rewiring.add_missing(SpringKind::bending, material.bend_stiffness, material.damping, eq1);
  }
  report.springs_removed = rewiring.removed();
  report.springs_added = rewiring.added();
}

/// Bad split options (the ones split_faces uses; the rest are split_faces_1to3's).
void check_split_options(const SplitOptions& options) {
  if (!std::isfinite(options.expansion) || options.expansion <= 0.0) {
    std::ostringstream msg;
    msg << "expansion must be finite and > 0, got " << options.expansion;
    fail(msg.str());
  }
  if (!options.conserve_mass && (!std::isfinite(options.mass_scale) || options.mass_scale <= 0.0)) {
    std::ostringstream msg;
    msg << "mass_scale must be finite and > 0, got " << options.mass_scale;
    fail(msg.str());
  }
}

/// Rest lengths of the structural springs by vertex pair (pair_key).
std::unordered_map<std::uint64_t, double> structural_rest_lengths(const SpringSet& springs) {
  std::unordered_map<std::uint64_t, double> structural_rest;
  structural_rest.reserve(springs.size());
  for (std::size_t k = 0; k < springs.size(); ++k) {
    if (springs.kind[k] == SpringKind::structural) {
      structural_rest[pair_key(springs.first[k], springs.second[k])] = springs.rest_length[k];
    }
  }
  return structural_rest;
}

}  // namespace

void Cloth::adopt_subdivision(const Subdivision& mesh) {
  const Eigen::Index old_vertices = vertex_count();
  const Eigen::Index added = mesh.new_vertex_corners.rows();
  const bool with_material = m_material.rows() == old_vertices;
  m_velocities.conservativeResize(old_vertices + added, 3);
  if (with_material) m_material.conservativeResize(old_vertices + added, 2);
  for (Eigen::Index k = 0; k < added; ++k) {
    const std::int32_t a = mesh.new_vertex_corners(k, 0), b = mesh.new_vertex_corners(k, 1),
                       c = mesh.new_vertex_corners(k, 2);
    const Vec3 w = mesh.new_vertex_weights.row(k).transpose();
    const Eigen::Index p = old_vertices + k;
    m_velocities.row(p) =
        w[0] * m_velocities.row(a) + w[1] * m_velocities.row(b) + w[2] * m_velocities.row(c);
    if (with_material) {
      m_material.row(p) =
          w[0] * m_material.row(a) + w[1] * m_material.row(b) + w[2] * m_material.row(c);
    }
  }
  m_positions = mesh.positions;
  m_faces = mesh.faces;
  m_vertex_states.resize(static_cast<std::size_t>(old_vertices + added), VertexState::free);
}

Eigen::VectorXd Cloth::conserving_masses(const Subdivision& mesh) const {
  const Eigen::Index old_vertices = vertex_count(), old_faces = face_count();
  // Each vertex's mass is spread over its faces by area; a changed face collects its corners'
  // shares and hands them to its children by area, a third to each child's corner.
  Eigen::VectorXd face_area(old_faces), vertex_area = Eigen::VectorXd::Zero(old_vertices);
  Eigen::VectorXd vertex_faces = Eigen::VectorXd::Zero(old_vertices);
  for (Eigen::Index f = 0; f < old_faces; ++f) {
    face_area[f] = triangle_area(m_positions, m_faces(f, 0), m_faces(f, 1), m_faces(f, 2));
    for (int c = 0; c < 3; ++c) {
      vertex_area[m_faces(f, c)] += face_area[f];
      vertex_faces[m_faces(f, c)] += 1.0;
    }
  }
  const auto new_faces = static_cast<Eigen::Index>(mesh.parents.size());
  std::vector<std::vector<std::int32_t>> children(static_cast<std::size_t>(old_faces));
  for (Eigen::Index g = 0; g < new_faces; ++g) {
    children[static_cast<std::size_t>(mesh.parents[static_cast<std::size_t>(g)])].push_back(
        static_cast<std::int32_t>(g));
  }
  Eigen::VectorXd masses = Eigen::VectorXd::Zero(mesh.positions.rows());
  masses.head(old_vertices) = m_masses;
  for (Eigen::Index f = 0; f < old_faces; ++f) {
    const auto& kids = children[static_cast<std::size_t>(f)];
    if (kids.size() < 2) continue;  // unchanged face
    double face_mass = 0.0;
    for (int c = 0; c < 3; ++c) {
      const std::int32_t i = m_faces(f, c);
      // A collapsed neighbourhood (zero area) shares by face count instead.
      const double share = vertex_area[i] > 0.0 ? m_masses[i] * face_area[f] / vertex_area[i]
                                                : m_masses[i] / vertex_faces[i];
      masses[i] -= share;
      face_mass += share;
    }
    std::vector<double> areas;
    double total = 0.0;
    for (const std::int32_t g : kids) {
      areas.push_back(
          triangle_area(mesh.positions, mesh.faces(g, 0), mesh.faces(g, 1), mesh.faces(g, 2)));
      total += areas.back();
    }
    for (std::size_t k = 0; k < kids.size(); ++k) {
      const double fraction =
          total > 0.0 ? areas[k] / total : 1.0 / static_cast<double>(kids.size());
      for (int c = 0; c < 3; ++c) masses[mesh.faces(kids[k], c)] += face_mass * fraction / 3.0;
    }
  }
  for (Eigen::Index i = 0; i < masses.size(); ++i) {
    if (!(masses[i] >= std::numeric_limits<double>::min()) || !std::isfinite(masses[i])) {
      std::ostringstream msg;
      msg << "redistributing masses gives vertex " << i << " the mass " << masses[i]
          << " kg, not a normal number > 0 (degenerate faces?)";
      fail(msg.str());
    }
  }
  return masses;
}

void Cloth::check_split_masses(const std::vector<std::int32_t>& faces,
                               const SplitOptions& options) const {
  for (const std::int32_t face : faces) {
    const double mass =
        options.mass_scale *
        (m_masses[m_faces(face, 0)] + m_masses[m_faces(face, 1)] + m_masses[m_faces(face, 2)]) /
        3.0;
    if (!(mass >= std::numeric_limits<double>::min()) || !std::isfinite(mass) ||
        mass > kMaxMaterialValue) {
      std::ostringstream msg;
      msg << "mass_scale " << options.mass_scale << " gives face " << face
          << "'s new vertex the mass " << mass
          << " kg, not a normal number > 0 and <= " << kMaxMaterialValue << " kg";
      fail(msg.str());
    }
  }
}

void Cloth::append_split_masses(const std::vector<std::int32_t>& faces, double mass_scale) {
  const Eigen::Index old_vertices = vertex_count();
  const auto added = static_cast<Eigen::Index>(faces.size());
  m_masses.conservativeResize(old_vertices + added);
  for (Eigen::Index k = 0; k < added; ++k) {
    const std::int32_t face = faces[static_cast<std::size_t>(k)];
    const std::int32_t a = m_faces(face, 0), b = m_faces(face, 1), c = m_faces(face, 2);
    m_masses[old_vertices + k] = mass_scale * (m_masses[a] + m_masses[b] + m_masses[c]) / 3.0;
  }
}

SplitReport Cloth::split_faces(const std::vector<FaceSplit>& splits, const SplitOptions& options) {
  if (face_count() == 0) fail("a spring network has no faces to split");
  check_split_options(options);
  const Split1to3 surgery = split_faces_1to3(m_positions, m_faces, splits, options.min_barycentric,
                                             options.min_angle_degrees);

  SplitReport report;
  report.faces_skipped = surgery.faces_skipped;
  report.moved_inward = surgery.moved_inward;
  // Rest lengths of the structural springs by vertex pair, for rest areas.
  std::unordered_map<std::uint64_t, double> structural_rest = structural_rest_lengths(m_springs);
  auto rest_of = [&](std::int32_t i, std::int32_t j) {
    const auto it = structural_rest.find(pair_key(i, j));
    return it == structural_rest.end() ? (m_positions.row(i) - m_positions.row(j)).norm()
                                       : it->second;
  };
  Eigen::VectorXd conserved;
  if (options.conserve_mass) {
    conserved = conserving_masses(surgery.mesh);  // checked before anything changes
  } else {
    check_split_masses(surgery.split_faces, options);  // checked before anything changes
  }

  // New vertices and faces.
  const Eigen::Index old_vertices = vertex_count();
  const auto added = static_cast<Eigen::Index>(surgery.split_faces.size());
  if (added == 0) return report;
  const Eigen::Index old_faces = face_count();
  const double mass_before = m_masses.sum();
  for (const std::int32_t face : surgery.split_faces) {
    report.rest_area_before += area_from_sides(rest_of(m_faces(face, 0), m_faces(face, 1)),
                                               rest_of(m_faces(face, 1), m_faces(face, 2)),
                                               rest_of(m_faces(face, 2), m_faces(face, 0)));
  }
  if (options.conserve_mass) {
    m_masses = conserved;
  } else {
    append_split_masses(surgery.split_faces, options.mass_scale);
  }
  adopt_subdivision(surgery.mesh);
  record_split(surgery.split_faces, old_vertices, old_faces, report);
  update_inverse_masses();
  report.mass_added = m_masses.sum() - mass_before;

  // Springs: keep every spring whose pair is still wired, drop the rest, add the new pairs with
  // eq. (1) rest lengths.
  const SplitMaterial material{m_stretch_stiffness, m_bend_stiffness, m_spring_damping};
  rewire_split(m_springs, m_faces, m_positions, options.expansion, material, structural_rest,
               report);
  for (const std::int32_t f : report.region_faces) {
    const std::int32_t a = m_faces(f, 0), b = m_faces(f, 1), c = m_faces(f, 2);
    report.rest_area_after += area_from_sides(rest_of(a, b), rest_of(b, c), rest_of(c, a));
  }
  finish_topology_change();  // quadratic bending: rest at split time
  return report;
}

/// The rest metric refine_faces' new springs inherit: structural rest and reference lengths by
/// vertex pair (pair_key), and the refined mesh's positions for a pair with no spring.
struct Cloth::RestMetric {
  const Positions& positions;  ///< n×3 of the refined mesh, m
  std::unordered_map<std::uint64_t, double> rest, reference;

  /// A side's length in `metric` (rest or reference), m. Every face edge has a structural
  /// spring; the fallback only guards a hand-edited state.
  double side(const std::unordered_map<std::uint64_t, double>& metric, std::int32_t i,
              std::int32_t j) const {
    const auto it = metric.find(pair_key(i, j));
    return it == metric.end() ? (positions.row(i) - positions.row(j)).norm() : it->second;
  }
};

namespace {

// A face of the new mesh around each edge, and the apexes on either side of each edge.
struct EdgeFaces {
  std::int32_t face = -1;  // a face of the new mesh around the edge
  std::array<std::int32_t, 2> apexes{-1, -1};
  int count = 0;
};

/// The faces and apexes around every edge of `faces`, by pair_key.
std::unordered_map<std::uint64_t, EdgeFaces> faces_around_edges(const Faces& faces) {
  std::unordered_map<std::uint64_t, EdgeFaces> around_edge;
  around_edge.reserve(static_cast<std::size_t>(2 * faces.rows()));
  for (Eigen::Index g = 0; g < faces.rows(); ++g) {
    for (int c = 0; c < 3; ++c) {
      EdgeFaces& entry = around_edge[pair_key(faces(g, c), faces(g, (c + 1) % 3))];
      entry.face = static_cast<std::int32_t>(g);
      if (entry.count < 2)
        entry.apexes[static_cast<std::size_t>(entry.count)] = faces(g, (c + 2) % 3);
      ++entry.count;
    }
  }
  return around_edge;
}

/// Bending pair (pair_key of the two apexes) → the interior edge it crosses.
std::unordered_map<std::uint64_t, VertexPair> hinges_of(
    const std::unordered_map<std::uint64_t, EdgeFaces>& around_edge) {
  std::unordered_map<std::uint64_t, VertexPair> hinge_of;  // bending pair → the edge it crosses
  hinge_of.reserve(around_edge.size());
  for (const auto& entry : around_edge) {
    if (entry.second.count != 2) continue;
    const std::int32_t u = static_cast<std::int32_t>(entry.first & 0xffffffffu);
    const std::int32_t v = static_cast<std::int32_t>(entry.first >> 32);
    hinge_of.emplace(pair_key(entry.second.apexes[0], entry.second.apexes[1]), VertexPair{u, v});
  }
  return hinge_of;
}

/// Barycentric weights of vertex v in the old face `parent` of a 1→4 refinement: a corner (v
/// below old_vertices), or the midpoint of two corners (a new vertex on split_edges).
Vec3 weights_in_parent(std::int32_t v, std::int32_t parent, const Faces& old_faces,
                       Eigen::Index old_vertices, const std::vector<VertexPair>& split_edges) {
  Vec3 w = Vec3::Zero();
  if (v < old_vertices) {
    for (int c = 0; c < 3; ++c) w[c] = old_faces(parent, c) == v ? 1.0 : 0.0;
    return w;
  }
  const VertexPair& edge = split_edges[static_cast<std::size_t>(v - old_vertices)];
  for (int c = 0; c < 3; ++c) {
    if (old_faces(parent, c) == edge[0] || old_faces(parent, c) == edge[1]) w[c] = 0.5;
  }
  return w;
}

}  // namespace

RefineReport Cloth::refine_faces(const std::vector<std::int32_t>& faces) {
  if (face_count() == 0) fail("a spring network has no faces to refine");
  const Refinement surgery = refine_faces_1to4(m_positions, m_faces, faces);
  RefineReport report;
  report.refined_faces = surgery.refined_faces;
  report.bisected_faces = surgery.bisected_faces;
  if (surgery.split_edges.empty()) return report;
  const Subdivision& mesh = surgery.mesh;

  // Structural rest and reference lengths by pair: the rest metric the new springs inherit.
  RestMetric metric{mesh.positions, {}, {}};
  std::unordered_map<std::uint64_t, double>& rest = metric.rest;
  rest.reserve(2 * m_springs.size());
  metric.reference.reserve(2 * m_springs.size());
  for (std::size_t k = 0; k < m_springs.size(); ++k) {
    if (m_springs.kind[k] != SpringKind::structural) continue;
    const std::uint64_t key = pair_key(m_springs.first[k], m_springs.second[k]);
    rest[key] = m_springs.rest_length[k];
    metric.reference[key] = m_springs.reference_length[k];
  }
  auto side = [&](const std::unordered_map<std::uint64_t, double>& lengths, std::int32_t i,
                  std::int32_t j) { return metric.side(lengths, i, j); };
  const Faces old_faces = m_faces;
  const Eigen::Index old_vertices = vertex_count();
  for (const auto* changed : {&surgery.refined_faces, &surgery.bisected_faces}) {
    for (const std::int32_t f : *changed) {
      const std::int32_t a = old_faces(f, 0), b = old_faces(f, 1), c = old_faces(f, 2);
      report.rest_area_before +=
          area_from_sides(side(rest, a, b), side(rest, b, c), side(rest, c, a));
    }
  }
  const Eigen::VectorXd masses = conserving_masses(mesh);  // checked before anything changes
  for (Eigen::Index k = 0; k < mesh.new_vertex_corners.rows(); ++k) {
    report.new_vertices.push_back(static_cast<std::int32_t>(old_vertices + k));
  }
  for (std::size_t g = 0; g < mesh.parents.size(); ++g) {
    const std::int32_t parent = mesh.parents[g];
    if (static_cast<std::int32_t>(g) != parent || mesh.faces.row(parent) != old_faces.row(parent)) {
      report.region_faces.push_back(static_cast<std::int32_t>(g));
    }
  }

  // Built aside and committed with the vertices at the end, so a failure leaves the cloth as it
  // was.
  SpringSet springs = refined_springs(surgery, metric, report);
  for (const std::int32_t g : report.region_faces) {
    const std::int32_t a = mesh.faces(g, 0), b = mesh.faces(g, 1), c = mesh.faces(g, 2);
    report.rest_area_after += area_from_sides(side(rest, a, b), side(rest, b, c), side(rest, c, a));
  }
  const double mass_before = m_masses.sum();
  adopt_subdivision(mesh);
  m_masses = masses;
  m_springs = std::move(springs);
  update_inverse_masses();
  report.mass_added = m_masses.sum() - mass_before;
  finish_topology_change();  // quadratic bending: rest at refine time
  return report;
}

SpringSet Cloth::refined_springs(const Refinement& surgery, RestMetric& rest_metric,
                                 RefineReport& report) const {
  const Subdivision& mesh = surgery.mesh;
  std::unordered_map<std::uint64_t, double>& rest = rest_metric.rest;
  std::unordered_map<std::uint64_t, double>& reference = rest_metric.reference;
  auto side = [&](const std::unordered_map<std::uint64_t, double>& lengths, std::int32_t i,
                  std::int32_t j) { return rest_metric.side(lengths, i, j); };
  const Faces& old_faces = m_faces;
  const Eigen::Index old_vertices = vertex_count();

  // Springs: keep every spring whose pair is still wired, add the new pairs in the rest metric.
  SpringSet springs = m_springs;
  const MeshConnectivity connectivity = mesh_connectivity(mesh.faces);
  SpringRewiring rewiring(springs, connectivity);
  const std::size_t kept = springs.size();

  const std::unordered_map<std::uint64_t, EdgeFaces> around_edge = faces_around_edges(mesh.faces);
  auto weights_in = [&](std::int32_t v, std::int32_t parent) {
    return weights_in_parent(v, parent, old_faces, old_vertices, surgery.split_edges);
  };
  rewiring.add_missing(
      SpringKind::structural, m_stretch_stiffness, m_spring_damping, [&](const VertexPair& edge) {
        const std::uint64_t key = pair_key(edge[0], edge[1]);
        const std::int32_t parent =
            mesh.parents[static_cast<std::size_t>(around_edge.at(key).face)];
        const std::int32_t a = old_faces(parent, 0), b = old_faces(parent, 1),
                           c = old_faces(parent, 2);
        const Vec3 u = weights_in(edge[0], parent), v = weights_in(edge[1], parent);
        return SpringRewiring::Lengths{
            metric_distance(u, v, side(rest, a, b), side(rest, b, c), side(rest, c, a)),
            metric_distance(u, v, side(reference, a, b), side(reference, b, c),
                            side(reference, c, a))};
      });
  // The new structural springs are the sides of the triangles the bending springs hinge on.
  for (std::size_t k = kept; k < springs.size(); ++k) {
    const std::uint64_t key = pair_key(springs.first[k], springs.second[k]);
    rest[key] = springs.rest_length[k];
    reference[key] = springs.reference_length[k];
  }
  if (m_bend_stiffness > 0.0) {
    const std::unordered_map<std::uint64_t, VertexPair> hinge_of = hinges_of(around_edge);
    rewiring.add_missing(
        SpringKind::bending, m_bend_stiffness, m_spring_damping, [&](const VertexPair& pair) {
          const VertexPair hinge = hinge_of.at(pair_key(pair[0], pair[1]));
          const std::int32_t u = hinge[0], v = hinge[1], p = pair[0], q = pair[1];
          const double cos_dihedral = hinge_cos_dihedral(mesh.positions, u, v, p, q);
          auto hinged = [&](const std::unordered_map<std::uint64_t, double>& metric) {
            return hinge_distance(side(metric, u, v), side(metric, u, p), side(metric, v, p),
                                  side(metric, u, q), side(metric, v, q), cos_dihedral);
          };
          const double rest_length = hinged(rest);
          if (!(rest_length > 0.0)) fail_zero_bending_rest(p, q);
          return SpringRewiring::Lengths{rest_length, hinged(reference)};
        });
  }
  report.springs_removed = rewiring.removed();
  report.springs_added = rewiring.added();
  return springs;
}

}  // namespace yore
