// Construction, topology and rest state of Cloth, and the helpers of cloth_detail.hpp. The
// stepping state is in cloth_state.cpp, subdivision in cloth_rewiring.cpp, the stable-step
// estimates in stable_step.cpp.
#include "yore/cloth/cloth.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cloth_detail.hpp"
#include "yore/platform/errors.hpp"

namespace yore {
namespace detail {

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

[[noreturn]] void fail_argument(const std::string& message, const std::string& name) {
  const std::string prefix = "state: ";
  throw InvalidArgument(message, name.rfind(prefix, 0) == 0 ? name.substr(prefix.size()) : name);
}

// The one counter behind every cloth's topology_version (see cloth_detail.hpp).
std::uint64_t next_topology_version() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

// A subnormal material value (below DBL_MIN, e.g. 5e-324) is refused like a negative one: its
// products with masses and steps underflow, and a stiffness of 5e-324 N/m "diverged at step 0".
void check_non_negative(double value, const char* name) {
  if (!std::isfinite(value) || value < 0.0 || value > kMaxMaterialValue ||
      (value != 0.0 && value < std::numeric_limits<double>::min())) {
    std::ostringstream msg;
    msg << name << " must be 0 or a normal number in [" << std::numeric_limits<double>::min()
        << ", " << kMaxMaterialValue << "], got " << value;
    fail_argument(msg.str(), name);
  }
}

void check_positive(double value, const char* name) {
  if (!std::isfinite(value) || !(value >= std::numeric_limits<double>::min()) ||
      value > kMaxMaterialValue) {
    std::ostringstream msg;
    msg << name << " must be a normal number in [" << std::numeric_limits<double>::min() << ", "
        << kMaxMaterialValue << "] (> 0), got " << value;
    fail_argument(msg.str(), name);
  }
}

// Young's modulus 0 (no membrane) or a normal number up to kMaxMaterialValue; Poisson's ratio
// strictly inside the plane-stress range (−1, 1), where μ > 0 and μ + λ > 0.
void check_membrane(const MembraneMaterial& membrane, const char* prefix) {
  const std::string young = std::string(prefix) + "young_modulus";
  check_non_negative(membrane.young_modulus, young.c_str());
  const double nu = membrane.poisson_ratio;
  if (!std::isfinite(nu) || !(nu > -1.0 && nu < 1.0)) {
    std::ostringstream msg;
    msg << prefix << "poisson_ratio must be in (-1, 1) (a 2-D membrane), got " << nu;
    fail_argument(msg.str(), "poisson_ratio");
  }
  if (membrane.young_modulus == 0.0 && nu != 0.0) {
    std::ostringstream msg;
    msg << prefix << "poisson_ratio is for a membrane (young_modulus > 0), got " << nu;
    fail(msg.str());
  }
}

void check_finite_rows(const Positions& values, const char* name) {
  for (Eigen::Index i = 0; i < values.rows(); ++i) {
    if (!values.row(i).allFinite()) {
      std::ostringstream msg;
      msg << name << " of vertex " << i << " is not finite (" << values(i, 0) << ", "
          << values(i, 1) << ", " << values(i, 2) << ")";
      fail(msg.str());
    }
  }
}

}  // namespace detail

using namespace detail;

namespace {

// The material's constants and models, each named when wrong: a membrane takes no structural
// stiffness, the springs model no modulus and the quadratic and hinge models no bending springs.
void check_material(const ClothMaterial& material) {
  const double stretch_stiffness = material.stretch_stiffness;
  const double bend_stiffness = material.bend_stiffness;
  const BendingModel bending = material.bending;
  const double bending_modulus = material.bending_modulus;
  const MembraneMaterial& membrane = material.membrane;
  check_membrane(membrane, "");
  if (membrane.young_modulus > 0.0) {
    if (stretch_stiffness != 0.0) {
      std::ostringstream msg;
      msg << "a membrane resists stretching instead of springs: stretch_stiffness must be 0, got "
          << stretch_stiffness;
      fail(msg.str());
    }
  } else {
    check_positive(stretch_stiffness, "stretch_stiffness");
  }
  check_non_negative(bend_stiffness, "bend_stiffness");
  check_non_negative(material.damping, "damping");
  check_non_negative(bending_modulus, "bending_modulus");
  if (bending != BendingModel::springs && !is_quadratic(bending)) {
    fail("bending must be springs (0), quadratic (1) or hinge (2)");
  }
  if (bending == BendingModel::springs && bending_modulus != 0.0) {
    fail_argument(
        "bending_modulus is for quadratic bending; with bending springs use "
        "bend_stiffness",
        "bending_modulus");
  }
  if (is_quadratic(bending) && bend_stiffness != 0.0) {
    std::ostringstream msg;
    msg << "quadratic bending creates no bending springs: bend_stiffness must be 0, got "
        << bend_stiffness;
    fail(msg.str());
  }
}

// The faces' other corners of every vertex from `known` on (vertices added since the last
// bending build), with repeats.
std::vector<std::vector<std::int32_t>> new_vertex_neighbours(const Faces& faces, Eigen::Index known,
                                                             Eigen::Index n) {
  std::vector<std::vector<std::int32_t>> neighbours(static_cast<std::size_t>(n));
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const std::int32_t v = faces(f, c);
      if (v < known) continue;
      for (int d = 1; d < 3; ++d) {
        neighbours[static_cast<std::size_t>(v)].push_back(faces(f, (c + d) % 3));
      }
    }
  }
  return neighbours;
}

// Vertex v's rest point: its current position under the affine map that best takes its placed
// neighbours' current positions to their rest positions (least squares, minimum norm).
Vec3 fitted_rest_point(const Positions& positions, const Positions& rest_positions,
                       const std::vector<std::int32_t>& placed, Eigen::Index v) {
  const auto m = static_cast<Eigen::Index>(placed.size());
  Eigen::Matrix3Xd current(3, m), rest(3, m);
  for (Eigen::Index k = 0; k < m; ++k) {
    current.col(k) = positions.row(placed[static_cast<std::size_t>(k)]).transpose();
    rest.col(k) = rest_positions.row(placed[static_cast<std::size_t>(k)]).transpose();
  }
  const Vec3 current_center = current.rowwise().mean();
  const Vec3 rest_center = rest.rowwise().mean();
  current.colwise() -= current_center;
  rest.colwise() -= rest_center;
  // The centred neighbours are rank deficient by construction (rank 2 for a face's three
  // corners); a threshold far above round-off keeps the solve from inverting noise.
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> fit;
  fit.setThreshold(1e-9);
  fit.compute(current);
  const Vec3 offset = positions.row(v).transpose() - current_center;
  const Eigen::VectorXd weights = fit.solve(Eigen::VectorXd(offset));
  return rest_center + rest * weights;
}

}  // namespace

void Cloth::initialise_state(const Positions& positions, const Eigen::VectorXd& masses,
                             double drag) {
  const Eigen::Index n = positions.rows();
  if (n == 0) fail("cloth has no vertices");
  check_finite_rows(positions, "position");
  if (masses.size() != n) {
    std::ostringstream msg;
    msg << "masses has " << masses.size() << " entries for " << n << " vertices";
    fail_argument(msg.str(), "masses");
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    // A subnormal (or smaller) mass has no finite inverse mass or stable step to go with it.
    if (!std::isfinite(masses[i]) || !(masses[i] >= std::numeric_limits<double>::min()) ||
        masses[i] > kMaxMaterialValue) {
      std::ostringstream msg;
      msg << "mass of vertex " << i << " must be finite, >= " << std::numeric_limits<double>::min()
          << " kg (a normal number > 0) and <= " << kMaxMaterialValue << " kg, got " << masses[i];
      fail_argument(msg.str(), "masses");
    }
  }
  check_non_negative(drag, "drag");
  m_positions = positions;
  m_velocities = Positions::Zero(n, 3);
  m_masses = masses;
  m_drag = drag;
  m_vertex_states.assign(static_cast<std::size_t>(n), VertexState::free);
  update_inverse_masses();
  m_topology_version = next_topology_version();
}

Cloth::Cloth(const Positions& positions, const Faces& faces, const Eigen::VectorXd& masses,
             const ClothMaterial& material) {
  const double stretch_stiffness = material.stretch_stiffness;
  const double bend_stiffness = material.bend_stiffness;
  const double damping = material.damping, drag = material.drag;
  const BendingModel bending = material.bending;
  const double bending_modulus = material.bending_modulus;
  const MembraneMaterial& membrane = material.membrane;
  validate_mesh(positions, faces);
  check_material(material);
  initialise_state(positions, masses, drag);
  m_bending = bending;
  m_bending_modulus = bending_modulus;
  if (is_quadratic(bending)) {
    m_bending_rest = positions;  // the rest state: the shape of each face as given
    m_faces = faces;
    update_quadratic_bending();  // throws on a face with no rest area
  }
  m_faces = faces;
  m_membrane = membrane;
  m_membrane_smoothed = false;  // the faces' strain unless set_membrane_smoothed (issue 52)
  m_stretch_stiffness = stretch_stiffness;
  m_bend_stiffness = bend_stiffness;
  m_spring_damping = damping;

  const MeshConnectivity connectivity = mesh_connectivity(faces);
  // Zero bend stiffness: the scene does not model bending, so no bending spring exists at all.
  const bool with_bending = bend_stiffness > 0.0;
  m_springs.reserve(connectivity.edges.size() +
                    (with_bending ? connectivity.bending_pairs.size() : 0));
  auto distance = [&](const VertexPair& pair) {
    return (m_positions.row(pair[0]) - m_positions.row(pair[1])).norm();
  };
  for (const VertexPair& edge : connectivity.edges) {
    m_springs.add(edge[0], edge[1], distance(edge), stretch_stiffness, damping,
                  SpringKind::structural);
  }
  if (with_bending) {
    for (const VertexPair& pair : connectivity.bending_pairs) {
      const double rest = distance(pair);
      if (!(rest > 0.0)) {
        std::ostringstream msg;
        msg << "bending pair (" << pair[0] << ", " << pair[1]
            << ") has zero length: two vertices coincide";
        fail(msg.str());
      }
      m_springs.add(pair[0], pair[1], rest, bend_stiffness, damping, SpringKind::bending);
    }
  }
  rebuild_incidence();
  if (has_membrane()) check_membrane_rest();
}

Cloth Cloth::from_springs(const Positions& positions, const Edges& edges,
                          const Eigen::VectorXd& rest_lengths, const Eigen::VectorXd& masses,
                          double stiffness, double damping, double drag) {
  Cloth network;
  network.initialise_state(positions, masses, drag);
  check_positive(stiffness, "stiffness");
  check_non_negative(damping, "damping");
  const Eigen::Index n = positions.rows();
  const Eigen::Index s = edges.rows();
  if (s == 0) fail("a spring network needs at least one spring (edges is empty)");
  if (rest_lengths.size() != 0 && rest_lengths.size() != s) {
    std::ostringstream msg;
    msg << "rest_lengths has " << rest_lengths.size() << " entries for " << s << " springs";
    fail(msg.str());
  }
  std::vector<VertexPair> seen;
  seen.reserve(static_cast<std::size_t>(s));
  network.m_springs.reserve(static_cast<std::size_t>(s));
  for (Eigen::Index k = 0; k < s; ++k) {
    const std::int32_t i = edges(k, 0), j = edges(k, 1);
    if (i < 0 || i >= n || j < 0 || j >= n) {
      std::ostringstream msg;
      msg << "spring " << k << " has vertex index out of range [0, " << n << "): (" << i << ", "
          << j << ")";
      fail(msg.str());
    }
    if (i == j) {
      std::ostringstream msg;
      msg << "spring " << k << " joins vertex " << i << " to itself";
      fail(msg.str());
    }
    const double rest =
        rest_lengths.size() ? rest_lengths[k] : (positions.row(i) - positions.row(j)).norm();
    if (!std::isfinite(rest) || rest <= 0.0) {
      std::ostringstream msg;
      msg << "spring " << k << " (" << i << ", " << j << ") has rest length " << rest
          << "; it must be finite and > 0";
      fail(msg.str());
    }
    seen.push_back({std::min(i, j), std::max(i, j)});
    network.m_springs.add(i, j, rest, stiffness, damping, SpringKind::structural);
  }
  std::sort(seen.begin(), seen.end());
  const auto repeated = std::adjacent_find(seen.begin(), seen.end());
  if (repeated != seen.end()) {
    std::ostringstream msg;
    msg << "the pair (" << (*repeated)[0] << ", " << (*repeated)[1]
        << ") is joined by more than one spring";
    fail(msg.str());
  }
  network.rebuild_incidence();
  return network;
}

const QuadraticBendingMatrix& Cloth::quadratic_bending() const {
  if (is_quadratic(m_bending) && m_quadratic_topology != m_topology_version) {
    update_quadratic_bending();
  }
  return m_quadratic;
}

void Cloth::update_quadratic_bending() const {
  // Rest positions of vertices added since the last build (strokes append vertices). A new
  // vertex gets the point of the rest state that corresponds to where it is now, by the affine
  // map that best takes its neighbours' current positions to their rest positions (least
  // squares, minimum norm): for the paper's 1→3 split, whose new vertex lies in its parent
  // face, this is the same barycentric point of the parent's rest triangle, so the children
  // tile the parent's rest shape exactly and a stroke changes no rest curvature or area of the
  // bending term (the stroke's growth acts through the springs' rest lengths). Called at the
  // end of split_faces, the current positions are those at split time.
  const Eigen::Index n = vertex_count();
  Eigen::Index known = m_bending_rest.rows();
  if (known < n) {
    const std::vector<std::vector<std::int32_t>> neighbours =
        new_vertex_neighbours(m_faces, known, n);
    m_bending_rest.conservativeResize(n, 3);
    std::vector<char> has_rest(static_cast<std::size_t>(n), 0);
    std::fill(has_rest.begin(), has_rest.begin() + known, 1);
    // Passes until every new vertex is placed: one that touches only new vertices waits for
    // them (a vertex with no placed neighbour at all keeps its current position).
    for (bool progress = true; progress;) {
      progress = false;
      bool waiting = false;
      for (Eigen::Index v = known; v < n; ++v) {
        if (has_rest[static_cast<std::size_t>(v)]) continue;
        std::vector<std::int32_t> placed;
        for (const std::int32_t u : neighbours[static_cast<std::size_t>(v)]) {
          if (has_rest[static_cast<std::size_t>(u)] &&
              std::find(placed.begin(), placed.end(), u) == placed.end()) {
            placed.push_back(u);
          }
        }
        if (placed.empty()) {
          waiting = true;
          continue;
        }
        m_bending_rest.row(v) =
            fitted_rest_point(m_positions, m_bending_rest, placed, v).transpose();
        has_rest[static_cast<std::size_t>(v)] = 1;
        progress = true;
      }
      if (!progress && waiting) {
        for (Eigen::Index v = known; v < n; ++v) {
          if (!has_rest[static_cast<std::size_t>(v)]) m_bending_rest.row(v) = m_positions.row(v);
        }
      }
    }
  }
  m_quadratic = m_bending == BendingModel::hinge ? quadratic_bending_matrix(m_bending_rest, m_faces)
                                                 : fitted_bending_matrix(m_bending_rest, m_faces);
  m_quadratic_topology = m_topology_version;
}

void Cloth::finish_topology_change() {
  rebuild_incidence();
  m_topology_version = next_topology_version();
  ++m_edit_count;
  if (is_quadratic(m_bending)) update_quadratic_bending();
}

const MembraneFaces& Cloth::membrane_faces() const {
  if (!has_membrane()) {
    m_membrane_faces.edge_springs.clear();
  } else if (m_membrane_topology != m_topology_version) {
    m_membrane_faces = yore::membrane_faces(m_faces, m_springs);
    m_membrane_topology = m_topology_version;
  }
  return m_membrane_faces;
}

void Cloth::set_membrane_smoothed(bool smoothed) {
  if (!has_membrane()) {
    throw std::invalid_argument("membrane_strain is for stretch=\"membrane\"");
  }
  if (smoothed && !is_quadratic(m_bending)) {
    throw std::invalid_argument(
        "membrane_strain=\"smoothed\" needs the rest state a bending model keeps: "
        "bending=\"quadratic\" or \"hinge\"");
  }
  if (smoothed == m_membrane_smoothed) return;
  m_membrane_smoothed = smoothed;
  ++m_topology_version;
}

const MembraneElements& Cloth::membrane_elements() const {
  if (!has_membrane()) {
    build_membrane_elements(Faces(0, 3), MembraneFaces{}, m_springs, nullptr, m_membrane_elements);
    m_membrane_elements_topology = 0;
    return m_membrane_elements;
  }
  const MembraneFaces& map = membrane_faces();
  const MembraneReference* reference = nullptr;
  if (has_smoothed_membrane()) {
    const Positions& rest = bending_rest_positions();
    if (m_membrane_reference_topology != m_topology_version) {
      m_membrane_reference = membrane_reference(rest, m_faces);
      m_membrane_reference_topology = m_topology_version;
    }
    reference = &m_membrane_reference;
  }
  if (m_membrane_elements_topology != m_topology_version ||
      m_membrane_elements_rest != m_springs.rest_length) {
    build_membrane_elements(m_faces, map, m_springs, reference, m_membrane_elements);
    m_membrane_elements_topology = m_topology_version;
    m_membrane_elements_rest = m_springs.rest_length;
  }
  return m_membrane_elements;
}

void Cloth::check_membrane_rest() const {
  membrane_faces();  // throws on an edge without a structural spring
}

MembraneStatus Cloth::membrane_status() const {
  if (!has_membrane()) return MembraneStatus{};
  return yore::membrane_status(m_faces, membrane_faces(), m_springs, m_positions);
}

EnergyTerms Cloth::energy(const Vec3& gravity) const {
  EnergyTerms terms;
  for (Eigen::Index i = 0; i < vertex_count(); ++i) {
    terms.kinetic += 0.5 * m_masses[i] * m_velocities.row(i).squaredNorm();
    terms.gravity -= m_masses[i] * m_positions.row(i).dot(gravity);
  }
  for (std::size_t k = 0; k < m_springs.size(); ++k) {
    terms.spring +=
        spring_energy(m_positions.row(m_springs.first[k]), m_positions.row(m_springs.second[k]),
                      m_springs.rest_length[k], m_springs.stiffness[k]);
  }
  if (has_quadratic_bending()) {
    terms.bending = quadratic_bending_energy(quadratic_bending(), m_bending_modulus, m_positions);
  }
  if (has_membrane()) {
    terms.membrane = membrane_energy(membrane_elements(), m_membrane, m_positions);
  }
  return terms;
}

bool Cloth::has_spring_damping() const {
  return std::any_of(m_springs.damping.begin(), m_springs.damping.end(),
                     [](double c) { return c > 0.0; });
}

}  // namespace yore
