#include "yore/cloth.hpp"
#include "yore/errors.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>

namespace yore {
namespace {

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

/// Bad input naming its argument: `name` without a "state: " prefix.
[[noreturn]] void fail_argument(const std::string& message, const std::string& name) {
  const std::string prefix = "state: ";
  throw InvalidArgument(message, name.rfind(prefix, 0) == 0 ? name.substr(prefix.size()) : name);
}

/// Topology versions are unique across all cloths of the process, so a cache keyed by a version
/// can never mistake one cloth (or an earlier topology) for another.
std::uint64_t next_topology_version() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

// Material constants (stiffnesses N/m, damping N·s/m, drag 1/s, bending modulus N·m) and
// masses (kg) are at most this: far beyond any cloth (a steel wire 1 mm² × 1 cm is 2e7 N/m),
// and far enough below overflow that energies, forces and k/m stay finite.
constexpr double kMaxMaterialValue = 1e12;

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
    msg << name << " must be a normal number in [" << std::numeric_limits<double>::min()
        << ", " << kMaxMaterialValue << "] (> 0), got " << value;
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
      msg << "mass of vertex " << i << " must be finite, >= "
          << std::numeric_limits<double>::min() << " kg (a normal number > 0) and <= "
          << kMaxMaterialValue << " kg, got " << masses[i];
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
             double stretch_stiffness, double bend_stiffness, double damping, double drag,
             BendingModel bending, double bending_modulus, const MembraneMaterial& membrane) {
  validate_mesh(positions, faces);
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
  check_non_negative(damping, "damping");
  check_non_negative(bending_modulus, "bending_modulus");
  if (bending != BendingModel::springs && bending != BendingModel::quadratic) {
    fail("bending must be springs (0) or quadratic (1)");
  }
  if (bending == BendingModel::springs && bending_modulus != 0.0) {
    fail_argument("bending_modulus is for quadratic bending; with bending springs use "
                  "bend_stiffness",
                  "bending_modulus");
  }
  if (bending == BendingModel::quadratic && bend_stiffness != 0.0) {
    std::ostringstream msg;
    msg << "quadratic bending creates no bending springs: bend_stiffness must be 0, got "
        << bend_stiffness;
    fail(msg.str());
  }
  initialise_state(positions, masses, drag);
  m_bending = bending;
  m_bending_modulus = bending_modulus;
  if (bending == BendingModel::quadratic) {
    m_bending_rest = positions;  // the rest state: the shape of each face as given
    m_faces = faces;
    update_quadratic_bending();  // throws on a face with no rest area
  }
  m_faces = faces;
  m_membrane = membrane;
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
    const double rest = rest_lengths.size() ? rest_lengths[k]
                                            : (positions.row(i) - positions.row(j)).norm();
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

double Cloth::advance_time(double dt) {
  if (dt != m_clock.dt) m_clock = SimulationClock{m_clock.time(), 0, dt};
  ++m_clock.steps;
  return m_clock.time();
}

ClothState Cloth::state() const {
  ClothState state;
  state.positions = m_positions;
  state.velocities = m_velocities;
  state.masses = m_masses;
  state.faces = m_faces;
  state.springs = m_springs;
  state.drag = m_drag;
  state.stretch_stiffness = m_stretch_stiffness;
  state.bend_stiffness = m_bend_stiffness;
  state.spring_damping = m_spring_damping;
  state.material = m_material;
  state.vertex_states = m_vertex_states;
  state.drivers = m_drivers;
  state.clock = m_clock;
  state.bending = m_bending;
  state.bending_modulus = m_bending_modulus;
  state.bending_rest = bending_rest_positions();
  state.membrane = m_membrane;
  return state;
}

namespace {

// with_membrane: structural springs carry the membrane's rest lengths and must have 0 N/m.
void check_state_springs(const SpringSet& springs, Eigen::Index n, bool with_membrane) {
  const std::size_t s = springs.size();
  if (springs.second.size() != s || springs.rest_length.size() != s ||
      springs.stiffness.size() != s || springs.damping.size() != s || springs.kind.size() != s ||
      springs.reference_length.size() != s) {
    fail("state: the spring arrays differ in length");
  }
  for (std::size_t k = 0; k < s; ++k) {
    const std::int32_t i = springs.first[k], j = springs.second[k];
    if (i < 0 || i >= n || j < 0 || j >= n || i == j) {
      std::ostringstream msg;
      msg << "state: spring " << k << " has ends (" << i << ", " << j
          << "); they must be two different vertices in [0, " << n << ")";
      fail(msg.str());
    }
    const double values[] = {springs.rest_length[k], springs.reference_length[k],
                             springs.stiffness[k]};
    if (with_membrane && springs.kind[k] == SpringKind::structural) {
      if (!(std::isfinite(values[0]) && values[0] > 0.0 && std::isfinite(values[1]) &&
            values[1] > 0.0 && values[2] == 0.0)) {
        std::ostringstream msg;
        msg << "state: structural spring " << k << " of a membrane needs finite, positive rest "
            << "and reference lengths and stiffness 0, got " << values[0] << ", " << values[1]
            << ", " << values[2];
        fail(msg.str());
      }
    } else if (!(std::isfinite(values[0]) && values[0] > 0.0 && std::isfinite(values[1]) &&
          values[1] > 0.0 && std::isfinite(values[2]) &&
          values[2] >= std::numeric_limits<double>::min() &&
          values[2] <= kMaxMaterialValue)) {
      std::ostringstream msg;
      msg << "state: spring " << k << " needs finite, positive rest length, reference length "
          << "and stiffness (at most " << kMaxMaterialValue << " N/m), got " << values[0]
          << ", " << values[1] << ", " << values[2];
      fail(msg.str());
    }
    if (!std::isfinite(springs.damping[k]) || springs.damping[k] < 0.0 ||
        springs.damping[k] > kMaxMaterialValue) {
      std::ostringstream msg;
      msg << "state: spring " << k << " has damping " << springs.damping[k]
          << "; it must be finite, >= 0 and <= " << kMaxMaterialValue;
      fail(msg.str());
    }
    const auto kind = static_cast<int>(springs.kind[k]);
    if (kind != 0 && kind != 1) {
      std::ostringstream msg;
      msg << "state: spring " << k << " has kind " << kind << " (0 structural, 1 bending)";
      fail(msg.str());
    }
  }
  // One structural spring per edge: a duplicate would double the edge's stiffness and break
  // the mesh operations that look springs up by their edge.
  std::vector<std::array<std::int64_t, 3>> edges;
  for (std::size_t k = 0; k < s; ++k) {
    if (springs.kind[k] != SpringKind::structural) continue;
    const std::int32_t i = springs.first[k], j = springs.second[k];
    edges.push_back({std::min(i, j), std::max(i, j), static_cast<std::int64_t>(k)});
  }
  std::sort(edges.begin(), edges.end());
  for (std::size_t e = 1; e < edges.size(); ++e) {
    if (edges[e][0] == edges[e - 1][0] && edges[e][1] == edges[e - 1][1]) {
      std::ostringstream msg;
      msg << "state: structural springs " << edges[e - 1][2] << " and " << edges[e][2]
          << " join the same vertices (" << edges[e][0] << ", " << edges[e][1] << ")";
      fail(msg.str());
    }
  }
}

// Every edge of the faces has its structural spring (the rest areas, the strokes and the
// bending model look springs up by edge): a state whose springs were all marked bending, say,
// is refused here rather than failing later in whatever looks the first edge up.
void check_state_edges(const ClothState& state) {
  std::vector<VertexPair> structural;
  for (std::size_t k = 0; k < state.springs.size(); ++k) {
    if (state.springs.kind[k] != SpringKind::structural) continue;
    const std::int32_t i = state.springs.first[k], j = state.springs.second[k];
    structural.push_back({std::min(i, j), std::max(i, j)});
  }
  std::sort(structural.begin(), structural.end());
  for (const VertexPair& edge : mesh_connectivity(state.faces).edges) {
    if (!std::binary_search(structural.begin(), structural.end(), edge)) {
      std::ostringstream msg;
      msg << "state: edge (" << edge[0] << ", " << edge[1] << ") of the faces has no "
          << "structural spring (kind 0); every edge needs one";
      fail(msg.str());
    }
  }
}

void check_state_constraints(const ClothState& state, Eigen::Index n) {
  if (static_cast<Eigen::Index>(state.vertex_states.size()) != n) {
    std::ostringstream msg;
    msg << "state: vertex_states has " << state.vertex_states.size() << " entries for " << n
        << " vertices";
    fail(msg.str());
  }
  std::vector<int> driven_by(static_cast<std::size_t>(n), 0);
  for (std::size_t d = 0; d < state.drivers.size(); ++d) {
    const RotationDriver& driver = state.drivers[d];
    if (driver.reference.rows() != static_cast<Eigen::Index>(driver.vertices.size()) ||
        !driver.reference.allFinite() || !driver.center.allFinite() ||
        !std::isfinite(driver.omega) || !std::isfinite(driver.start_time) ||
        !(std::abs(driver.axis.norm() - 1.0) < 1e-9)) {
      std::ostringstream msg;
      msg << "state: driver " << d << " needs one finite reference row per vertex, a finite "
          << "center, omega and start time, and a unit axis";
      fail(msg.str());
    }
    for (const std::int32_t v : driver.vertices) {
      if (v < 0 || v >= n) {
        std::ostringstream msg;
        msg << "state: driver " << d << " drives vertex " << v << ", out of range [0, " << n
            << ")";
        fail(msg.str());
      }
      ++driven_by[static_cast<std::size_t>(v)];
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto code = static_cast<int>(state.vertex_states[static_cast<std::size_t>(i)]);
    const bool driven = code == static_cast<int>(VertexState::driven);
    if (code < 0 || code > 2 || driven != (driven_by[static_cast<std::size_t>(i)] == 1) ||
        driven_by[static_cast<std::size_t>(i)] > 1) {
      std::ostringstream msg;
      msg << "state: vertex " << i << " has state " << code << " (0 free, 1 fixed, 2 driven) "
          << "but " << driven_by[static_cast<std::size_t>(i)]
          << " driver(s); a driven vertex needs exactly one";
      fail(msg.str());
    }
  }
}

}  // namespace

Cloth Cloth::from_state(const ClothState& state) {
  const Eigen::Index n = state.positions.rows();
  // The topology is checked, not the shape: a state is wherever the simulation took the cloth,
  // which may have crushed a face flat (gravity 1e15 did).
  if (state.faces.rows() > 0) validate_mesh(state.positions, state.faces, false);
  Cloth cloth;
  cloth.initialise_state(state.positions, state.masses, state.drag);
  if (state.velocities.rows() != n) {
    std::ostringstream msg;
    msg << "state: velocities has " << state.velocities.rows() << " rows for " << n
        << " vertices";
    fail(msg.str());
  }
  check_finite_rows(state.velocities, "velocity");
  check_state_springs(state.springs, n, state.membrane.young_modulus > 0.0);
  if (state.springs.size() == 0) fail("state: the cloth has no springs");
  if (state.faces.rows() > 0) check_state_edges(state);
  check_state_constraints(state, n);
  if (state.material.rows() != 0 && state.material.rows() != n) {
    std::ostringstream msg;
    msg << "state: material coordinates have " << state.material.rows() << " rows for " << n
        << " vertices";
    fail(msg.str());
  }
  if (!state.material.allFinite()) fail("state: material coordinates must be finite");
  check_membrane(state.membrane, "state: ");
  if (state.membrane.young_modulus > 0.0) {
    if (state.faces.rows() == 0) fail("state: a membrane needs faces");
    if (state.stretch_stiffness != 0.0) fail("state: a membrane needs stretch_stiffness 0");
  } else if (state.faces.rows() > 0) {
    check_positive(state.stretch_stiffness, "state: stretch_stiffness");
  }
  check_non_negative(state.bend_stiffness, "state: bend_stiffness");
  check_non_negative(state.spring_damping, "state: spring_damping");
  const SimulationClock& clock = state.clock;
  if (!std::isfinite(clock.origin) || clock.steps < 0 || !std::isfinite(clock.dt) ||
      clock.dt < 0.0 || !std::isfinite(clock.time())) {
    std::ostringstream msg;
    msg << "state: bad clock (origin " << clock.origin << " s, " << clock.steps
        << " steps of " << clock.dt << " s)";
    fail(msg.str());
  }
  cloth.m_velocities = state.velocities;
  cloth.m_faces = state.faces;
  cloth.m_springs = state.springs;
  cloth.m_stretch_stiffness = state.stretch_stiffness;
  cloth.m_bend_stiffness = state.bend_stiffness;
  cloth.m_spring_damping = state.spring_damping;
  cloth.m_material = state.material;
  cloth.m_vertex_states = state.vertex_states;
  cloth.m_drivers = state.drivers;
  cloth.m_clock = clock;
  if (state.bending != BendingModel::springs && state.bending != BendingModel::quadratic) {
    fail("state: bending must be 0 (springs) or 1 (quadratic)");
  }
  check_non_negative(state.bending_modulus, "state: bending_modulus");
  cloth.m_bending = state.bending;
  cloth.m_bending_modulus = state.bending_modulus;
  if (state.bending == BendingModel::springs) {
    if (state.bending_modulus != 0.0 || state.bending_rest.rows() != 0) {
      fail("state: bending springs take no bending_modulus or bending rest positions");
    }
  } else {
    if (state.faces.rows() == 0) fail("state: quadratic bending needs faces");
    if (state.bend_stiffness != 0.0) fail("state: quadratic bending needs bend_stiffness 0");
    if (state.bending_rest.rows() != n) {
      std::ostringstream msg;
      msg << "state: bending rest positions have " << state.bending_rest.rows() << " rows for "
          << n << " vertices";
      fail(msg.str());
    }
    check_finite_rows(state.bending_rest, "state: bending rest position");
    cloth.m_bending_rest = state.bending_rest;
    cloth.update_quadratic_bending();
  }
  cloth.m_membrane = state.membrane;
  cloth.update_inverse_masses();
  cloth.rebuild_incidence();
  if (cloth.has_membrane()) cloth.check_membrane_rest();
  return cloth;
}

void Cloth::rebuild_incidence() {
  const std::size_t n = static_cast<std::size_t>(vertex_count());
  const std::size_t s = m_springs.size();
  m_incidence_offsets.assign(n + 1, 0);
  for (std::size_t k = 0; k < s; ++k) {
    ++m_incidence_offsets[static_cast<std::size_t>(m_springs.first[k]) + 1];
    ++m_incidence_offsets[static_cast<std::size_t>(m_springs.second[k]) + 1];
  }
  for (std::size_t i = 0; i < n; ++i) m_incidence_offsets[i + 1] += m_incidence_offsets[i];
  m_incident_springs.assign(2 * s, 0);
  m_incident_signs.assign(2 * s, 0.0);
  std::vector<std::int32_t> cursor(m_incidence_offsets.begin(), m_incidence_offsets.end() - 1);
  for (std::size_t k = 0; k < s; ++k) {
    const auto slot_first = static_cast<std::size_t>(cursor[m_springs.first[k]]++);
    m_incident_springs[slot_first] = static_cast<std::int32_t>(k);
    m_incident_signs[slot_first] = 1.0;
    const auto slot_second = static_cast<std::size_t>(cursor[m_springs.second[k]]++);
    m_incident_springs[slot_second] = static_cast<std::int32_t>(k);
    m_incident_signs[slot_second] = -1.0;
  }
}

void Cloth::update_inverse_masses() {
  m_inverse_masses.resize(m_masses.size());
  for (Eigen::Index i = 0; i < m_masses.size(); ++i) {
    m_inverse_masses[i] = m_vertex_states[static_cast<std::size_t>(i)] == VertexState::free
                              ? 1.0 / m_masses[i]
                              : 0.0;
  }
}

void Cloth::set_positions(const Positions& positions) {
  if (positions.rows() != vertex_count()) {
    std::ostringstream msg;
    msg << "positions must have shape (" << vertex_count() << ", 3), got (" << positions.rows()
        << ", 3)";
    fail(msg.str());
  }
  check_finite_rows(positions, "position");
  m_positions = positions;
  ++m_edit_count;
}

void Cloth::set_velocities(const Positions& velocities) {
  if (velocities.rows() != vertex_count()) {
    std::ostringstream msg;
    msg << "velocities must have shape (" << vertex_count() << ", 3), got (" << velocities.rows()
        << ", 3)";
    fail(msg.str());
  }
  check_finite_rows(velocities, "velocity");
  for (Eigen::Index i = 0; i < velocities.rows(); ++i) {
    if (m_vertex_states[static_cast<std::size_t>(i)] == VertexState::free) {
      m_velocities.row(i) = velocities.row(i);
    }
  }
  ++m_edit_count;
}

void Cloth::set_rest_lengths(const Eigen::VectorXd& rest_lengths) {
  if (rest_lengths.size() != static_cast<Eigen::Index>(m_springs.size())) {
    std::ostringstream msg;
    msg << "rest lengths must have " << m_springs.size() << " entries, got "
        << rest_lengths.size();
    fail(msg.str());
  }
  for (Eigen::Index k = 0; k < rest_lengths.size(); ++k) {
    if (!std::isfinite(rest_lengths[k]) || rest_lengths[k] <= 0.0) {
      std::ostringstream msg;
      msg << "rest length of spring " << k << " must be finite and > 0, got " << rest_lengths[k];
      fail(msg.str());
    }
  }
  for (Eigen::Index k = 0; k < rest_lengths.size(); ++k) {
    m_springs.rest_length[static_cast<std::size_t>(k)] = rest_lengths[k];
  }
  ++m_edit_count;
}

void Cloth::check_constrainable(const std::vector<std::int32_t>& vertices,
                                const char* what) const {
  for (const std::int32_t v : vertices) {
    if (v < 0 || v >= vertex_count()) {
      std::ostringstream msg;
      msg << "cannot " << what << " vertex " << v << ": index out of range [0, " << vertex_count()
          << ")";
      fail(msg.str());
    }
    const VertexState state = m_vertex_states[static_cast<std::size_t>(v)];
    if (state == VertexState::driven) {
      std::ostringstream msg;
      msg << "cannot " << what << " vertex " << v << ": it is already driven";
      fail(msg.str());
    }
  }
}

void Cloth::fix(const std::vector<std::int32_t>& vertices) {
  check_constrainable(vertices, "fix");
  for (const std::int32_t v : vertices) {
    m_vertex_states[static_cast<std::size_t>(v)] = VertexState::fixed;
    m_velocities.row(v).setZero();
  }
  update_inverse_masses();
  m_topology_version = next_topology_version();
  ++m_edit_count;
}

void Cloth::drive_rotation(const std::vector<std::int32_t>& vertices, const Vec3& center,
                           const Vec3& axis, double omega) {
  check_constrainable(vertices, "drive");
  for (const std::int32_t v : vertices) {
    if (m_vertex_states[static_cast<std::size_t>(v)] == VertexState::fixed) {
      std::ostringstream msg;
      msg << "cannot drive vertex " << v << ": it is fixed";
      fail(msg.str());
    }
  }
  if (!center.allFinite()) fail("drive_rotation: center must be finite");
  if (!std::isfinite(omega)) fail("drive_rotation: omega must be finite");
  const double axis_length = axis.norm();
  if (!std::isfinite(axis_length) || axis_length == 0.0) {
    fail("drive_rotation: axis must be a finite, non-zero vector");
  }
  std::vector<std::int32_t> unique_vertices(vertices);
  std::sort(unique_vertices.begin(), unique_vertices.end());
  unique_vertices.erase(std::unique(unique_vertices.begin(), unique_vertices.end()),
                        unique_vertices.end());
  RotationDriver driver;
  driver.vertices = unique_vertices;
  driver.reference.resize(static_cast<Eigen::Index>(unique_vertices.size()), 3);
  for (std::size_t k = 0; k < unique_vertices.size(); ++k) {
    driver.reference.row(static_cast<Eigen::Index>(k)) = m_positions.row(unique_vertices[k]);
    m_vertex_states[static_cast<std::size_t>(unique_vertices[k])] = VertexState::driven;
  }
  driver.center = center;
  driver.axis = axis / axis_length;
  driver.omega = omega;
  driver.start_time = time();
  m_drivers.push_back(std::move(driver));
  update_inverse_masses();
  apply_drivers(time());
  m_topology_version = next_topology_version();
  ++m_edit_count;
}

void Cloth::apply_drivers(double time) { driver_state(time, m_positions, m_velocities); }

void Cloth::driver_state(double time, Positions& x, Positions& v) const {
  for (const RotationDriver& driver : m_drivers) {
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(driver.omega * (time - driver.start_time), driver.axis)
            .toRotationMatrix();
    const Vec3 angular_velocity = driver.omega * driver.axis;
    for (std::size_t k = 0; k < driver.vertices.size(); ++k) {
      const Vec3 arm = rotation * (driver.reference.row(static_cast<Eigen::Index>(k)).transpose() -
                                   driver.center);
      x.row(driver.vertices[k]) = (driver.center + arm).transpose();
      v.row(driver.vertices[k]) = angular_velocity.cross(arm).transpose();
    }
  }
}

void Cloth::set_material_coordinates(
    const Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>& uv) {
  if (uv.rows() != vertex_count()) {
    std::ostringstream msg;
    msg << "material coordinates must have shape (" << vertex_count() << ", 2), got ("
        << uv.rows() << ", 2)";
    fail(msg.str());
  }
  if (!uv.allFinite()) fail("material coordinates must be finite");
  m_material = uv;
}

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
double hinge_distance(double uv, double up, double vp, double uq, double vq,
                      double cos_dihedral) {
  auto foot = [uv](double to_u, double to_v) { return (to_u * to_u - to_v * to_v + uv * uv) / (2.0 * uv); };
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
    m_velocities.row(p) = w[0] * m_velocities.row(a) + w[1] * m_velocities.row(b) +
                          w[2] * m_velocities.row(c);
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
      areas.push_back(triangle_area(mesh.positions, mesh.faces(g, 0), mesh.faces(g, 1),
                                    mesh.faces(g, 2)));
      total += areas.back();
    }
    for (std::size_t k = 0; k < kids.size(); ++k) {
      const double fraction = total > 0.0 ? areas[k] / total : 1.0 / static_cast<double>(kids.size());
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

SplitReport Cloth::split_faces(const std::vector<FaceSplit>& splits,
                               const SplitOptions& options) {
  if (face_count() == 0) fail("a spring network has no faces to split");
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
  const Split1to3 surgery = split_faces_1to3(m_positions, m_faces, splits,
                                             options.min_barycentric, options.min_angle_degrees);

  SplitReport report;
  report.skipped_faces = surgery.skipped_faces;
  report.moved_inward = surgery.moved_inward;
  // Rest lengths of the structural springs by vertex pair, for rest areas.
  std::unordered_map<std::uint64_t, double> structural_rest;
  structural_rest.reserve(m_springs.size());
  for (std::size_t k = 0; k < m_springs.size(); ++k) {
    if (m_springs.kind[k] == SpringKind::structural) {
      structural_rest[pair_key(m_springs.first[k], m_springs.second[k])] = m_springs.rest_length[k];
    }
  }
  auto rest_of = [&](std::int32_t i, std::int32_t j) {
    const auto it = structural_rest.find(pair_key(i, j));
    return it == structural_rest.end() ? (m_positions.row(i) - m_positions.row(j)).norm()
                                       : it->second;
  };
  Eigen::VectorXd conserved;
  if (options.conserve_mass) {
    conserved = conserving_masses(surgery.mesh);  // checked before anything changes
  } else {
    for (const std::int32_t face : surgery.split_faces) {  // checked before anything changes
      const double mass = options.mass_scale *
                          (m_masses[m_faces(face, 0)] + m_masses[m_faces(face, 1)] +
                           m_masses[m_faces(face, 2)]) / 3.0;
      if (!(mass >= std::numeric_limits<double>::min()) || !std::isfinite(mass) ||
          mass > kMaxMaterialValue) {
        std::ostringstream msg;
        msg << "mass_scale " << options.mass_scale << " gives face " << face
            << "'s new vertex the mass " << mass << " kg, not a normal number > 0 and <= "
            << kMaxMaterialValue << " kg";
        fail(msg.str());
      }
    }
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
    m_masses.conservativeResize(old_vertices + added);
    for (Eigen::Index k = 0; k < added; ++k) {
      const std::int32_t face = surgery.split_faces[static_cast<std::size_t>(k)];
      const std::int32_t a = m_faces(face, 0), b = m_faces(face, 1), c = m_faces(face, 2);
      m_masses[old_vertices + k] = options.mass_scale * (m_masses[a] + m_masses[b] + m_masses[c]) / 3.0;
    }
  }
  adopt_subdivision(surgery.mesh);
  for (Eigen::Index k = 0; k < added; ++k) {
    const std::int32_t face = surgery.split_faces[static_cast<std::size_t>(k)];
    const auto second_child = static_cast<std::int32_t>(old_faces + 2 * k);
    report.split_faces.push_back(face);
    report.new_vertices.push_back(static_cast<std::int32_t>(old_vertices + k));
    report.region_faces.insert(report.region_faces.end(), {face, second_child, second_child + 1});
  }
  update_inverse_masses();
  report.mass_added = m_masses.sum() - mass_before;

  // Springs: keep every spring whose pair is still wired, drop the rest, add the new pairs with
  // eq. (1) rest lengths.
  const MeshConnectivity connectivity = mesh_connectivity(m_faces);
  SpringRewiring rewiring(m_springs, connectivity);
  auto eq1 = [&](const VertexPair& pair) {
    const double length = (m_positions.row(pair[0]) - m_positions.row(pair[1])).norm();
    return SpringRewiring::Lengths{options.expansion * length, length};
  };
  rewiring.add_missing(SpringKind::structural, m_stretch_stiffness, m_spring_damping,
                       [&](const VertexPair& pair) {
                         const SpringRewiring::Lengths lengths = eq1(pair);
                         structural_rest[pair_key(pair[0], pair[1])] = lengths.rest;
                         return lengths;
                       });
  if (m_bend_stiffness > 0.0) {
    rewiring.add_missing(SpringKind::bending, m_bend_stiffness, m_spring_damping, eq1);
  }
  report.springs_removed = rewiring.removed();
  report.springs_added = rewiring.added();
  for (const std::int32_t f : report.region_faces) {
    const std::int32_t a = m_faces(f, 0), b = m_faces(f, 1), c = m_faces(f, 2);
    report.rest_area_after += area_from_sides(rest_of(a, b), rest_of(b, c), rest_of(c, a));
  }
  finish_topology_change();  // quadratic bending: rest at split time
  return report;
}

const QuadraticBendingMatrix& Cloth::quadratic_bending() const {
  if (m_bending == BendingModel::quadratic && m_quadratic_topology != m_topology_version) {
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
    std::vector<std::vector<std::int32_t>> neighbours(static_cast<std::size_t>(n));
    for (Eigen::Index f = 0; f < m_faces.rows(); ++f) {
      for (int c = 0; c < 3; ++c) {
        const std::int32_t v = m_faces(f, c);
        if (v < known) continue;
        for (int d = 1; d < 3; ++d) {
          neighbours[static_cast<std::size_t>(v)].push_back(m_faces(f, (c + d) % 3));
        }
      }
    }
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
        const auto m = static_cast<Eigen::Index>(placed.size());
        Eigen::Matrix3Xd current(3, m), rest(3, m);
        for (Eigen::Index k = 0; k < m; ++k) {
          current.col(k) = m_positions.row(placed[static_cast<std::size_t>(k)]).transpose();
          rest.col(k) = m_bending_rest.row(placed[static_cast<std::size_t>(k)]).transpose();
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
        const Vec3 offset = m_positions.row(v).transpose() - current_center;
        const Eigen::VectorXd weights = fit.solve(Eigen::VectorXd(offset));
        m_bending_rest.row(v) = (rest_center + rest * weights).transpose();
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
  m_quadratic = quadratic_bending_matrix(m_bending_rest, m_faces);
  m_quadratic_topology = m_topology_version;
}

RefineReport Cloth::refine_faces(const std::vector<std::int32_t>& faces) {
  if (face_count() == 0) fail("a spring network has no faces to refine");
  const Refinement surgery = refine_faces_1to4(m_positions, m_faces, faces);
  RefineReport report;
  report.refined_faces = surgery.refined_faces;
  report.bisected_faces = surgery.bisected_faces;
  if (surgery.split_edges.empty()) return report;
  const Subdivision& mesh = surgery.mesh;

  // Structural rest and reference lengths by pair: the rest metric the new springs inherit.
  std::unordered_map<std::uint64_t, double> rest, reference;
  rest.reserve(2 * m_springs.size());
  reference.reserve(2 * m_springs.size());
  for (std::size_t k = 0; k < m_springs.size(); ++k) {
    if (m_springs.kind[k] != SpringKind::structural) continue;
    const std::uint64_t key = pair_key(m_springs.first[k], m_springs.second[k]);
    rest[key] = m_springs.rest_length[k];
    reference[key] = m_springs.reference_length[k];
  }
  // Every face edge has a structural spring; the fallback only guards a hand-edited state.
  auto side = [&](const std::unordered_map<std::uint64_t, double>& metric, std::int32_t i,
                  std::int32_t j) {
    const auto it = metric.find(pair_key(i, j));
    return it == metric.end() ? (mesh.positions.row(i) - mesh.positions.row(j)).norm() : it->second;
  };
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

  // Springs: keep every spring whose pair is still wired, add the new pairs in the rest metric.
  // Built aside and committed with the vertices at the end, so a failure leaves the cloth as it was.
  SpringSet springs = m_springs;
  const MeshConnectivity connectivity = mesh_connectivity(mesh.faces);
  SpringRewiring rewiring(springs, connectivity);
  const std::size_t kept = springs.size();

  // A face of the new mesh around each edge, and the apexes on either side of each edge.
  struct EdgeFaces {
    std::int32_t face = -1;  // a face of the new mesh around the edge
    std::array<std::int32_t, 2> apexes{-1, -1};
    int count = 0;
  };
  std::unordered_map<std::uint64_t, EdgeFaces> around_edge;
  around_edge.reserve(static_cast<std::size_t>(2 * mesh.faces.rows()));
  for (Eigen::Index g = 0; g < mesh.faces.rows(); ++g) {
    for (int c = 0; c < 3; ++c) {
      EdgeFaces& entry = around_edge[pair_key(mesh.faces(g, c), mesh.faces(g, (c + 1) % 3))];
      entry.face = static_cast<std::int32_t>(g);
      if (entry.count < 2) entry.apexes[static_cast<std::size_t>(entry.count)] = mesh.faces(g, (c + 2) % 3);
      ++entry.count;
    }
  }
  // Barycentric weights of a vertex in an old face: a corner, or the midpoint of two corners.
  auto weights_in = [&](std::int32_t v, std::int32_t parent) {
    Vec3 w = Vec3::Zero();
    if (v < old_vertices) {
      for (int c = 0; c < 3; ++c) w[c] = old_faces(parent, c) == v ? 1.0 : 0.0;
      return w;
    }
    const VertexPair& edge = surgery.split_edges[static_cast<std::size_t>(v - old_vertices)];
    for (int c = 0; c < 3; ++c) {
      if (old_faces(parent, c) == edge[0] || old_faces(parent, c) == edge[1]) w[c] = 0.5;
    }
    return w;
  };
  rewiring.add_missing(SpringKind::structural, m_stretch_stiffness, m_spring_damping,
                       [&](const VertexPair& edge) {
    const std::uint64_t key = pair_key(edge[0], edge[1]);
    const std::int32_t parent = mesh.parents[static_cast<std::size_t>(around_edge.at(key).face)];
    const std::int32_t a = old_faces(parent, 0), b = old_faces(parent, 1), c = old_faces(parent, 2);
    const Vec3 u = weights_in(edge[0], parent), v = weights_in(edge[1], parent);
    return SpringRewiring::Lengths{
        metric_distance(u, v, side(rest, a, b), side(rest, b, c), side(rest, c, a)),
        metric_distance(u, v, side(reference, a, b), side(reference, b, c), side(reference, c, a))};
  });
  // The new structural springs are the sides of the triangles the bending springs hinge on.
  for (std::size_t k = kept; k < springs.size(); ++k) {
    const std::uint64_t key = pair_key(springs.first[k], springs.second[k]);
    rest[key] = springs.rest_length[k];
    reference[key] = springs.reference_length[k];
  }
  if (m_bend_stiffness > 0.0) {
    std::unordered_map<std::uint64_t, VertexPair> hinge_of;  // bending pair → the edge it crosses
    hinge_of.reserve(around_edge.size());
    for (const auto& entry : around_edge) {
      if (entry.second.count != 2) continue;
      const std::int32_t u = static_cast<std::int32_t>(entry.first & 0xffffffffu);
      const std::int32_t v = static_cast<std::int32_t>(entry.first >> 32);
      hinge_of.emplace(pair_key(entry.second.apexes[0], entry.second.apexes[1]), VertexPair{u, v});
    }
    rewiring.add_missing(SpringKind::bending, m_bend_stiffness, m_spring_damping,
                         [&](const VertexPair& pair) {
      const VertexPair hinge = hinge_of.at(pair_key(pair[0], pair[1]));
      const std::int32_t u = hinge[0], v = hinge[1], p = pair[0], q = pair[1];
      const Vec3 xu = mesh.positions.row(u), xv = mesh.positions.row(v);
      const Vec3 axis = (xv - xu).normalized();
      Vec3 arm_p = Vec3(mesh.positions.row(p)) - xu, arm_q = Vec3(mesh.positions.row(q)) - xu;
      arm_p -= arm_p.dot(axis) * axis;
      arm_q -= arm_q.dot(axis) * axis;
      const double norms = arm_p.norm() * arm_q.norm();
      const double cos_dihedral = norms > 0.0 ? std::clamp(arm_p.dot(arm_q) / norms, -1.0, 1.0) : -1.0;
      auto hinged = [&](const std::unordered_map<std::uint64_t, double>& metric) {
        return hinge_distance(side(metric, u, v), side(metric, u, p), side(metric, v, p),
                              side(metric, u, q), side(metric, v, q), cos_dihedral);
      };
      const double rest_length = hinged(rest);
      if (!(rest_length > 0.0)) {
        std::ostringstream msg;
        msg << "refinement gives the bending pair (" << p << ", " << q
            << ") a zero rest length: degenerate rest triangles";
        fail(msg.str());
      }
      return SpringRewiring::Lengths{rest_length, hinged(reference)};
    });
  }
  report.springs_removed = rewiring.removed();
  report.springs_added = rewiring.added();
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

void Cloth::finish_topology_change() {
  rebuild_incidence();
  m_topology_version = next_topology_version();
  ++m_edit_count;
  if (m_bending == BendingModel::quadratic) update_quadratic_bending();
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
    terms.spring += spring_energy(m_positions.row(m_springs.first[k]),
                                  m_positions.row(m_springs.second[k]),
                                  m_springs.rest_length[k], m_springs.stiffness[k]);
  }
  if (has_quadratic_bending()) {
    terms.bending = quadratic_bending_energy(quadratic_bending(), m_bending_modulus, m_positions);
  }
  if (has_membrane()) {
    terms.membrane = membrane_energy(m_faces, membrane_faces(), m_springs, m_membrane, m_positions);
  }
  return terms;
}

bool Cloth::has_spring_damping() const {
  return std::any_of(m_springs.damping.begin(), m_springs.damping.end(),
                     [](double c) { return c > 0.0; });
}

namespace {

// A membrane face's stiffness is bounded by c (L ⊗ I₃), L_kl = A d_k·d_l (its rest
// "Laplacian", d_k the gradients of the shape functions): at rest the St. Venant–Kirchhoff
// Hessian in F is at most max(2(μ + λ), 2μ) (pure dilation or pure shear), and the map from the
// corners to F has Gram matrix L ⊗ I₃. StVK stiffens as it stretches: along a stretch s its
// tangent modulus is Y (3s² − 1)/2, 1.315 Y at 10 %, the allowance taken here, so the bound
// covers faces stretched by up to 10 %.
constexpr double kMembraneStretchAllowance = 1.315;

double membrane_bound_constant(const MembraneMaterial& material) {
  const double mu = material.mu(), lambda = material.lambda();
  return kMembraneStretchAllowance * std::max(2.0 * (mu + lambda), 2.0 * mu);
}

Eigen::Matrix3d membrane_rest_laplacian(const MembraneRest& rest) {
  const std::array<Eigen::Vector2d, 3> d = membrane_shape_gradients(rest);
  Eigen::Matrix3d laplacian;
  for (std::size_t k = 0; k < 3; ++k) {
    for (std::size_t l = 0; l < 3; ++l) {
      laplacian(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(l)) =
          rest.area * d[k].dot(d[l]);
    }
  }
  return laplacian;
}

}  // namespace

double Cloth::gershgorin_time_step() const {
  // Row sums of |M^{-1/2} A M^{-1/2}| over free vertices bound the largest eigenvalue of the
  // mass-scaled stiffness (A = K, each spring block has norm <= k while the spring is not
  // compressed) and damping (A = C) matrices.
  double omega_squared = 0.0;
  double gamma = 0.0;
  const QuadraticBendingMatrix* bending = has_quadratic_bending() ? &quadratic_bending() : nullptr;
  // The membrane's rows: Σ_faces c |L_kl| √(wₖ wₗ) (see membrane_bound_constant).
  Eigen::VectorXd membrane_rows;
  if (has_membrane()) {
    membrane_rows.setZero(vertex_count());
    const double c = membrane_bound_constant(m_membrane);
    const MembraneFaces& map = membrane_faces();
    for (Eigen::Index f = 0; f < face_count(); ++f) {
      const Eigen::Matrix3d laplacian =
          membrane_rest_laplacian(membrane_face_rest(map, m_springs, static_cast<std::size_t>(f)));
      for (int k = 0; k < 3; ++k) {
        for (int l = 0; l < 3; ++l) {
          membrane_rows[m_faces(f, k)] +=
              c * std::abs(laplacian(k, l)) *
              std::sqrt(m_inverse_masses[m_faces(f, k)] * m_inverse_masses[m_faces(f, l)]);
        }
      }
    }
  }
  for (Eigen::Index i = 0; i < vertex_count(); ++i) {
    if (m_inverse_masses[i] == 0.0) continue;
    double stiffness_row = membrane_rows.size() > 0 ? membrane_rows[i] : 0.0, damping_row = 0.0;
    for (std::int32_t slot = m_incidence_offsets[static_cast<std::size_t>(i)];
         slot < m_incidence_offsets[static_cast<std::size_t>(i) + 1]; ++slot) {
      const auto s = static_cast<std::size_t>(m_incident_springs[static_cast<std::size_t>(slot)]);
      const std::int32_t other = m_springs.first[s] == i ? m_springs.second[s] : m_springs.first[s];
      const double coupling =
          m_inverse_masses[i] + std::sqrt(m_inverse_masses[i] * m_inverse_masses[other]);
      stiffness_row += m_springs.stiffness[s] * coupling;
      damping_row += m_springs.damping[s] * coupling;
    }
    if (bending != nullptr) {
      // κ Q ⊗ I₃ adds κ Σ_j |Q_ij| √(wᵢ wⱼ) to the row (constrained j have w = 0).
      for (std::int32_t k = bending->row_starts[static_cast<std::size_t>(i)];
           k < bending->row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
        const std::int32_t j = bending->columns[static_cast<std::size_t>(k)];
        stiffness_row += m_bending_modulus * std::abs(bending->values[static_cast<std::size_t>(k)]) *
                         std::sqrt(m_inverse_masses[i] * m_inverse_masses[j]);
      }
    }
    omega_squared = std::max(omega_squared, stiffness_row);
    gamma = std::max(gamma, damping_row);
  }
  gamma += m_drag;
  return symplectic_euler_step_limit(omega_squared, gamma);
}

double Cloth::stable_time_step() const { return lanczos_time_step(false); }

double Cloth::stable_time_step_bound() const { return lanczos_time_step(true); }

double Cloth::lanczos_time_step(bool every_state) const {
  const double gershgorin = gershgorin_time_step();
  // Overflowing k / m (no step is stable) or nothing elastic moving (only damping limits the
  // step): the Gershgorin answer is exact, and Lanczos would only see zeros or non-finite values.
  if (!(gershgorin > 0.0) || !std::isfinite(gershgorin) || m_springs.size() == 0) return gershgorin;
  bool any_free = false;
  for (Eigen::Index i = 0; i < vertex_count(); ++i) any_free = any_free || m_inverse_masses[i] > 0.0;
  if (!any_free) return gershgorin;

  // Per-spring 3×3 stiffness and damping blocks. every_state: k·I and c·I, which bound the
  // spring's Hessian k[d̂d̂ᵀ + (1 − L/ℓ)(I − d̂d̂ᵀ)] (ℓ >= 0) and its damping c d̂d̂ᵀ whatever
  // the cloth's shape. Otherwise the Hessian at the current positions, projected to PSD (the
  // transverse factor clamped to [0, 1]), and the damping along the current directions.
  const std::size_t spring_count = m_springs.size();
  std::vector<Mat3> stiffness_blocks(spring_count), damping_blocks(spring_count);
  for (std::size_t s = 0; s < spring_count; ++s) {
    const double k = m_springs.stiffness[s], c = m_springs.damping[s];
    const Vec3 d = m_positions.row(m_springs.first[s]) - m_positions.row(m_springs.second[s]);
    const double length = d.norm();
    if (every_state || !(length > 0.0) || !std::isfinite(length)) {
      stiffness_blocks[s] = k * Mat3::Identity();
      damping_blocks[s] = c * Mat3::Identity();
      continue;
    }
    const Vec3 direction = d / length;
    const Mat3 along = direction * direction.transpose();
    const double transverse = std::clamp(1.0 - m_springs.rest_length[s] / length, 0.0, 1.0);
    stiffness_blocks[s] = k * (along + transverse * (Mat3::Identity() - along));
    damping_blocks[s] = c * along;
  }
  // Constrained (fixed or driven) vertices have zero inverse mass, so S = M^{-1/2} eliminates
  // their rows and columns.
  const Eigen::VectorXd scale = m_inverse_masses.cwiseSqrt();
  const Eigen::Index n = vertex_count();
  // Quadratic bending's κ Q ⊗ I₃ is constant: the same in both modes, added to the stiffness.
  const QuadraticBendingMatrix* bending = has_quadratic_bending() ? &quadratic_bending() : nullptr;
  // The membrane's per-face 9×9 stiffness: every_state, c (L ⊗ I₃) (membrane_bound_constant);
  // otherwise its Hessian at the current positions, the stress term clamped (PSD).
  std::vector<Mat9> membrane_blocks;
  if (has_membrane()) {
    membrane_blocks.resize(static_cast<std::size_t>(face_count()));
    const MembraneFaces& map = membrane_faces();
    const double c = membrane_bound_constant(m_membrane);
    for (Eigen::Index f = 0; f < face_count(); ++f) {
      const MembraneRest rest = membrane_face_rest(map, m_springs, static_cast<std::size_t>(f));
      Mat9& block = membrane_blocks[static_cast<std::size_t>(f)];
      if (every_state) {
        const Eigen::Matrix3d laplacian = membrane_rest_laplacian(rest);
        block.setZero();
        for (int k = 0; k < 3; ++k) {
          for (int l = 0; l < 3; ++l) {
            block.block<3, 3>(3 * k, 3 * l) = c * laplacian(k, l) * Mat3::Identity();
          }
        }
      } else {
        membrane_face(m_positions.row(m_faces(f, 0)), m_positions.row(m_faces(f, 1)),
                      m_positions.row(m_faces(f, 2)), rest, m_membrane.mu(), m_membrane.lambda(),
                      nullptr, &block, TransverseFilter::clamp);
      }
    }
  }
  auto apply = [&](const std::vector<Mat3>& blocks, const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    y.setZero(3 * n);
    for (std::size_t s = 0; s < spring_count; ++s) {
      const std::int32_t i = m_springs.first[s], j = m_springs.second[s];
      const Vec3 f = blocks[s] * (scale[i] * x.segment<3>(3 * i) - scale[j] * x.segment<3>(3 * j));
      y.segment<3>(3 * i) += scale[i] * f;
      y.segment<3>(3 * j) -= scale[j] * f;
    }
    if (bending != nullptr && &blocks == &stiffness_blocks) {
      for (Eigen::Index i = 0; i < n; ++i) {
        if (scale[i] == 0.0) continue;
        Vec3 sum = Vec3::Zero();
        for (std::int32_t k = bending->row_starts[static_cast<std::size_t>(i)];
             k < bending->row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
          const std::int32_t j = bending->columns[static_cast<std::size_t>(k)];
          sum += bending->values[static_cast<std::size_t>(k)] * scale[j] * x.segment<3>(3 * j);
        }
        y.segment<3>(3 * i) += m_bending_modulus * scale[i] * sum;
      }
    }
    if (!membrane_blocks.empty() && &blocks == &stiffness_blocks) {
      Vec9 local;
      for (Eigen::Index f = 0; f < face_count(); ++f) {
        for (int k = 0; k < 3; ++k) {
          local.segment<3>(3 * k) = scale[m_faces(f, k)] * x.segment<3>(3 * m_faces(f, k));
        }
        const Vec9 product = membrane_blocks[static_cast<std::size_t>(f)] * local;
        for (int k = 0; k < 3; ++k) {
          y.segment<3>(3 * m_faces(f, k)) += scale[m_faces(f, k)] * product.segment<3>(3 * k);
        }
      }
    }
  };

  // Lanczos with full reorthogonalization on S K S. Ritz values approach λ_max from below; the
  // top one usually converges in a few dozen iterations (the top of the spectrum is where
  // Krylov methods are fastest). A fixed deterministic start vector keeps the estimate
  // reproducible.
  const Eigen::Index dim = 3 * n;
  const int max_iterations = static_cast<int>(std::min<Eigen::Index>(dim, kLanczosMaxIterations));
  Eigen::MatrixXd basis(dim, max_iterations);
  Eigen::VectorXd q(dim), w(dim);
  std::uint64_t seed = 0x9E3779B97F4A7C15ULL;
  for (Eigen::Index r = 0; r < dim; ++r) {
    seed ^= seed >> 12; seed ^= seed << 25; seed ^= seed >> 27;  // xorshift64*
    const double u = static_cast<double>((seed * 0x2545F4914F6CDD1DULL) >> 11) * 0x1.0p-53;
    q[r] = scale[r / 3] > 0.0 ? 2.0 * u - 1.0 : 0.0;
  }
  q.normalize();
  std::vector<double> alpha, beta;
  double top = 0.0, previous_top = -1.0;
  Eigen::VectorXd ritz_coefficients;
  int steps = 0;
  for (int it = 0; it < max_iterations; ++it) {
    basis.col(it) = q;
    apply(stiffness_blocks, q, w);
    alpha.push_back(q.dot(w));
    // Two passes of classical Gram–Schmidt against the whole basis.
    for (int pass = 0; pass < 2; ++pass) {
      w -= basis.leftCols(it + 1) * (basis.leftCols(it + 1).transpose() * w);
    }
    steps = it + 1;
    const double b = w.norm();
    const bool last = it + 1 == max_iterations || !(b > 1e-12 * std::abs(alpha.front()) + 1e-300);
    if ((it + 1) % 5 == 0 || last) {
      Eigen::MatrixXd tridiagonal = Eigen::MatrixXd::Zero(steps, steps);
      for (int r = 0; r < steps; ++r) {
        tridiagonal(r, r) = alpha[static_cast<std::size_t>(r)];
        if (r + 1 < steps) {
          tridiagonal(r, r + 1) = tridiagonal(r + 1, r) = beta[static_cast<std::size_t>(r)];
        }
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(tridiagonal);
      if (eigen.info() != Eigen::Success) break;
      top = eigen.eigenvalues()[steps - 1];
      ritz_coefficients = eigen.eigenvectors().col(steps - 1);
      if (!std::isfinite(top)) return 0.0;
      if (last || std::abs(top - previous_top) <= kLanczosRelativeTolerance * top) break;
      previous_top = top;
    }
    beta.push_back(b);
    q = w / b;
  }
  if (!(top > 0.0) || ritz_coefficients.size() != steps) return gershgorin;
  // Damping of the top mode: the Rayleigh quotient of S C S at its Ritz vector (exact when the
  // damping is proportional to the stiffness, as with the scenes' uniform springs), plus drag.
  const Eigen::VectorXd mode = (basis.leftCols(steps) * ritz_coefficients).normalized();
  apply(damping_blocks, mode, w);
  const double gamma = std::max(0.0, mode.dot(w)) + m_drag;
  return symplectic_euler_step_limit(top, gamma);
}

double symplectic_euler_step_limit(double omega_squared, double gamma) {
  // Masses are normal numbers, but k / m can still overflow: then no step is stable.
  if (!std::isfinite(omega_squared) || !std::isfinite(gamma)) return 0.0;
  if (omega_squared == 0.0) {
    // Nothing elastic moves: only damping limits the step (h γ < 2), if anything.
    return gamma > 0.0 ? 2.0 / gamma : std::numeric_limits<double>::infinity();
  }
  // The mode x'' = −ω² x − γ x' under v⁺ = v + h a(x, v), x⁺ = x + h v⁺ is stable while
  // h² ω² + 2 h γ < 4 (and h γ < 2, implied).
  return (std::sqrt(gamma * gamma + 4.0 * omega_squared) - gamma) / omega_squared;
}

}  // namespace yore
