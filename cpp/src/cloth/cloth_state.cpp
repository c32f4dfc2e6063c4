// The stepping state of Cloth: state()/from_state() and their checks, the setters, constraints
// and drivers, incidence and inverse masses, the clock.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "cloth_detail.hpp"
#include "yore/cloth/cloth.hpp"

namespace yore {
using namespace detail;

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
  state.membrane_smoothed = has_smoothed_membrane();
  return state;
}

namespace {

// Spring k's ends, lengths, stiffness, damping and kind (a membrane's structural springs
// carry its rest lengths and 0 N/m).
void check_state_spring(const SpringSet& springs, std::size_t k, Eigen::Index n,
                        bool with_membrane) {
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
          << "and reference lengths and stiffness 0, got " << values[0] << ", " << values[1] << ", "
          << values[2];
      fail(msg.str());
    }
  } else if (!(std::isfinite(values[0]) && values[0] > 0.0 && std::isfinite(values[1]) &&
               values[1] > 0.0 && std::isfinite(values[2]) &&
               values[2] >= std::numeric_limits<double>::min() && values[2] <= kMaxMaterialValue)) {
    std::ostringstream msg;
    msg << "state: spring " << k << " needs finite, positive rest length, reference length "
        << "and stiffness (at most " << kMaxMaterialValue << " N/m), got " << values[0] << ", "
        << values[1] << ", " << values[2];
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

// One structural spring per edge: a duplicate would double the edge's stiffness and break the
// mesh operations that look springs up by their edge.
void check_unique_structural(const SpringSet& springs) {
  std::vector<std::array<std::int64_t, 3>> edges;
  for (std::size_t k = 0; k < springs.size(); ++k) {
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

// with_membrane: structural springs carry the membrane's rest lengths and must have 0 N/m.
void check_state_springs(const SpringSet& springs, Eigen::Index n, bool with_membrane) {
  const std::size_t s = springs.size();
  if (springs.second.size() != s || springs.rest_length.size() != s ||
      springs.stiffness.size() != s || springs.damping.size() != s || springs.kind.size() != s ||
      springs.reference_length.size() != s) {
    fail("state: the spring arrays differ in length");
  }
  for (std::size_t k = 0; k < s; ++k) check_state_spring(springs, k, n, with_membrane);
  check_unique_structural(springs);
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
        msg << "state: driver " << d << " drives vertex " << v << ", out of range [0, " << n << ")";
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

// Material coordinates: none, or one finite row per vertex.
void check_state_material(const ClothState& state, Eigen::Index n) {
  if (state.material.rows() != 0 && state.material.rows() != n) {
    std::ostringstream msg;
    msg << "state: material coordinates have " << state.material.rows() << " rows for " << n
        << " vertices";
    fail(msg.str());
  }
  if (!state.material.allFinite()) fail("state: material coordinates must be finite");
}

void check_state_clock(const SimulationClock& clock) {
  if (!std::isfinite(clock.origin) || clock.steps < 0 || !std::isfinite(clock.dt) ||
      clock.dt < 0.0 || !std::isfinite(clock.time())) {
    std::ostringstream msg;
    msg << "state: bad clock (origin " << clock.origin << " s, " << clock.steps << " steps of "
        << clock.dt << " s)";
    fail(msg.str());
  }
}

// The bending model and what it takes: springs no modulus or rest positions; the quadratic
// and hinge models faces, no bending springs and finite rest positions for every vertex.
void check_state_bending(const ClothState& state, Eigen::Index n) {
  if (state.bending != BendingModel::springs && !is_quadratic(state.bending)) {
    fail("state: bending must be 0 (springs), 1 (quadratic) or 2 (hinge)");
  }
  check_non_negative(state.bending_modulus, "state: bending_modulus");
  if (state.bending == BendingModel::springs) {
    if (state.bending_modulus != 0.0 || state.bending_rest.rows() != 0) {
      fail("state: bending springs take no bending_modulus or bending rest positions");
    }
    return;
  }
  if (state.faces.rows() == 0) fail("state: quadratic bending needs faces");
  if (state.bend_stiffness != 0.0) fail("state: quadratic bending needs bend_stiffness 0");
  if (state.bending_rest.rows() != n) {
    std::ostringstream msg;
    msg << "state: bending rest positions have " << state.bending_rest.rows() << " rows for " << n
        << " vertices";
    fail(msg.str());
  }
  check_finite_rows(state.bending_rest, "state: bending rest position");
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
    msg << "state: velocities has " << state.velocities.rows() << " rows for " << n << " vertices";
    fail(msg.str());
  }
  check_finite_rows(state.velocities, "velocity");
  check_state_springs(state.springs, n, state.membrane.young_modulus > 0.0);
  if (state.springs.size() == 0) fail("state: the cloth has no springs");
  if (state.faces.rows() > 0) check_state_edges(state);
  check_state_constraints(state, n);
  check_state_material(state, n);
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
  check_state_clock(clock);
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
  check_state_bending(state, n);
  cloth.m_bending = state.bending;
  cloth.m_bending_modulus = state.bending_modulus;
  if (state.bending != BendingModel::springs) {
    cloth.m_bending_rest = state.bending_rest;
    cloth.update_quadratic_bending();
  }
  cloth.m_membrane = state.membrane;
  if (state.membrane_smoothed && !(is_quadratic(state.bending) && cloth.has_membrane())) {
    fail(
        "state: the smoothed membrane strain needs a membrane and bending \"quadratic\" or "
        "\"hinge\"");
  }
  cloth.m_membrane_smoothed = state.membrane_smoothed;
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
    m_inverse_masses[i] =
        m_vertex_states[static_cast<std::size_t>(i)] == VertexState::free ? 1.0 / m_masses[i] : 0.0;
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
    msg << "rest lengths must have " << m_springs.size() << " entries, got " << rest_lengths.size();
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

void Cloth::check_constrainable(const std::vector<std::int32_t>& vertices, const char* what) const {
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
    msg << "material coordinates must have shape (" << vertex_count() << ", 2), got (" << uv.rows()
        << ", 2)";
    fail(msg.str());
  }
  if (!uv.allFinite()) fail("material coordinates must be finite");
  m_material = uv;
}

}  // namespace yore
