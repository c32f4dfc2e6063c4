#include "yore/cloth.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace yore {
namespace {

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

/// Topology versions are unique across all cloths of the process, so a cache keyed by a version
/// can never mistake one cloth (or an earlier topology) for another.
std::uint64_t next_topology_version() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

void check_non_negative(double value, const char* name) {
  if (!std::isfinite(value) || value < 0.0) {
    std::ostringstream msg;
    msg << name << " must be finite and >= 0, got " << value;
    fail(msg.str());
  }
}

void check_positive(double value, const char* name) {
  if (!std::isfinite(value) || value <= 0.0) {
    std::ostringstream msg;
    msg << name << " must be finite and > 0, got " << value;
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
    fail(msg.str());
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    // A subnormal (or smaller) mass has no finite inverse mass or stable step to go with it.
    if (!std::isfinite(masses[i]) || !(masses[i] >= std::numeric_limits<double>::min())) {
      std::ostringstream msg;
      msg << "mass of vertex " << i << " must be finite and >= "
          << std::numeric_limits<double>::min() << " kg (a normal number > 0), got "
          << masses[i];
      fail(msg.str());
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
             BendingModel bending, double bending_modulus) {
  validate_mesh(positions, faces);
  check_positive(stretch_stiffness, "stretch_stiffness");
  check_non_negative(bend_stiffness, "bend_stiffness");
  check_non_negative(damping, "damping");
  check_non_negative(bending_modulus, "bending_modulus");
  if (bending != BendingModel::springs && bending != BendingModel::quadratic) {
    fail("bending must be springs (0) or quadratic (1)");
  }
  if (bending == BendingModel::springs && bending_modulus != 0.0) {
    fail("bending_modulus is for quadratic bending; with bending springs use bend_stiffness");
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
  return state;
}

namespace {

void check_state_springs(const SpringSet& springs, Eigen::Index n) {
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
    if (!(std::isfinite(values[0]) && values[0] > 0.0 && std::isfinite(values[1]) &&
          values[1] > 0.0 && std::isfinite(values[2]) && values[2] > 0.0)) {
      std::ostringstream msg;
      msg << "state: spring " << k << " needs finite, positive rest length, reference length "
          << "and stiffness, got " << values[0] << ", " << values[1] << ", " << values[2];
      fail(msg.str());
    }
    if (!std::isfinite(springs.damping[k]) || springs.damping[k] < 0.0) {
      std::ostringstream msg;
      msg << "state: spring " << k << " has damping " << springs.damping[k]
          << "; it must be finite and >= 0";
      fail(msg.str());
    }
    const auto kind = static_cast<int>(springs.kind[k]);
    if (kind != 0 && kind != 1) {
      std::ostringstream msg;
      msg << "state: spring " << k << " has kind " << kind << " (0 structural, 1 bending)";
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
  if (state.faces.rows() > 0) validate_mesh(state.positions, state.faces);
  Cloth cloth;
  cloth.initialise_state(state.positions, state.masses, state.drag);
  if (state.velocities.rows() != n) {
    std::ostringstream msg;
    msg << "state: velocities has " << state.velocities.rows() << " rows for " << n
        << " vertices";
    fail(msg.str());
  }
  check_finite_rows(state.velocities, "velocity");
  check_state_springs(state.springs, n);
  if (state.springs.size() == 0) fail("state: the cloth has no springs");
  check_state_constraints(state, n);
  if (state.material.rows() != 0 && state.material.rows() != n) {
    std::ostringstream msg;
    msg << "state: material coordinates have " << state.material.rows() << " rows for " << n
        << " vertices";
    fail(msg.str());
  }
  if (!state.material.allFinite()) fail("state: material coordinates must be finite");
  if (state.faces.rows() > 0) check_positive(state.stretch_stiffness, "state: stretch_stiffness");
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
  cloth.update_inverse_masses();
  cloth.rebuild_incidence();
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

void Cloth::apply_drivers(double time) {
  for (const RotationDriver& driver : m_drivers) {
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(driver.omega * (time - driver.start_time), driver.axis)
            .toRotationMatrix();
    const Vec3 angular_velocity = driver.omega * driver.axis;
    for (std::size_t k = 0; k < driver.vertices.size(); ++k) {
      const Vec3 arm = rotation * (driver.reference.row(static_cast<Eigen::Index>(k)).transpose() -
                                   driver.center);
      m_positions.row(driver.vertices[k]) = (driver.center + arm).transpose();
      m_velocities.row(driver.vertices[k]) = angular_velocity.cross(arm).transpose();
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

/// Area of a triangle with these side lengths (Heron); 0 if they violate the triangle inequality.
double area_from_sides(double a, double b, double c) {
  const double s = 0.5 * (a + b + c);
  const double product = s * (s - a) * (s - b) * (s - c);
  return product > 0.0 ? std::sqrt(product) : 0.0;
}

/// Smallest interior angle of a triangle, degrees.
double min_angle_degrees(const Vec3& a, const Vec3& b, const Vec3& c) {
  auto angle = [](const Vec3& apex, const Vec3& p, const Vec3& q) {
    const Vec3 u = p - apex, v = q - apex;
    return std::atan2(u.cross(v).norm(), u.dot(v));
  };
  const double smallest = std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)});
  return smallest * 180.0 / M_PI;
}

std::uint64_t pair_key(std::int32_t i, std::int32_t j) {
  const auto lo = static_cast<std::uint64_t>(std::min(i, j));
  const auto hi = static_cast<std::uint64_t>(std::max(i, j));
  return (hi << 32) | lo;
}

}  // namespace

SplitReport Cloth::split_faces(const std::vector<FaceSplit>& splits,
                               const SplitOptions& options) {
  if (face_count() == 0) fail("a spring network has no faces to split");
  if (!std::isfinite(options.expansion) || options.expansion <= 0.0) {
    std::ostringstream msg;
    msg << "expansion must be finite and > 0, got " << options.expansion;
    fail(msg.str());
  }
  if (!std::isfinite(options.mass_scale) || options.mass_scale <= 0.0) {
    std::ostringstream msg;
    msg << "mass_scale must be finite and > 0, got " << options.mass_scale;
    fail(msg.str());
  }
  if (!(options.min_barycentric >= 0.0 && options.min_barycentric < 1.0 / 3.0)) {
    fail("min_barycentric must be in [0, 1/3)");
  }
  std::vector<char> seen(static_cast<std::size_t>(face_count()), 0);
  for (const FaceSplit& split : splits) {
    if (split.face < 0 || split.face >= face_count()) {
      std::ostringstream msg;
      msg << "face " << split.face << " out of range [0, " << face_count() << ")";
      fail(msg.str());
    }
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

  SplitReport report;
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

  // Choose the split points.
  struct Planned {
    std::int32_t face;
    Vec3 weights;
  };
  std::vector<Planned> planned;
  planned.reserve(splits.size());
  for (const FaceSplit& split : splits) {
    const std::int32_t a = m_faces(split.face, 0), b = m_faces(split.face, 1),
                       c = m_faces(split.face, 2);
    const Vec3 xa = m_positions.row(a), xb = m_positions.row(b), xc = m_positions.row(c);
    Vec3 weights = split.barycentric.cwiseMax(0.0);
    weights /= weights.sum();
    const double smallest = weights.minCoeff();
    if (smallest < options.min_barycentric) {
      // Blend towards the centroid until the smallest weight is min_barycentric.
      const double blend = (options.min_barycentric - smallest) / (1.0 / 3.0 - smallest);
      weights = (1.0 - blend) * weights + Vec3::Constant(blend / 3.0);
      ++report.moved_inward;
    }
    auto children_ok = [&](const Vec3& w) {
      const Vec3 p = w[0] * xa + w[1] * xb + w[2] * xc;
      return std::min({min_angle_degrees(xa, xb, p), min_angle_degrees(xb, xc, p),
                       min_angle_degrees(xc, xa, p)}) >= options.min_angle_degrees;
    };
    if (!children_ok(weights)) weights = Vec3::Constant(1.0 / 3.0);
    if (!children_ok(weights)) {
      report.skipped_faces.push_back(split.face);
      continue;
    }
    planned.push_back({split.face, weights});
  }
  for (const Planned& plan : planned) {  // checked before anything changes
    const double mass = options.mass_scale *
                        (m_masses[m_faces(plan.face, 0)] + m_masses[m_faces(plan.face, 1)] +
                         m_masses[m_faces(plan.face, 2)]) / 3.0;
    if (!(mass >= std::numeric_limits<double>::min()) || !std::isfinite(mass)) {
      std::ostringstream msg;
      msg << "mass_scale " << options.mass_scale << " gives face " << plan.face
          << "'s new vertex the mass " << mass << " kg, not a normal number > 0";
      fail(msg.str());
    }
  }

  // New vertices and faces.
  const Eigen::Index old_vertices = vertex_count();
  const Eigen::Index added = static_cast<Eigen::Index>(planned.size());
  if (added == 0) return report;
  const Eigen::Index old_faces = face_count();
  m_positions.conservativeResize(old_vertices + added, 3);
  m_velocities.conservativeResize(old_vertices + added, 3);
  m_masses.conservativeResize(old_vertices + added);
  if (m_material.rows() == old_vertices) m_material.conservativeResize(old_vertices + added, 2);
  m_faces.conservativeResize(old_faces + 2 * added, 3);
  for (Eigen::Index k = 0; k < added; ++k) {
    const Planned& plan = planned[static_cast<std::size_t>(k)];
    const std::int32_t a = m_faces(plan.face, 0), b = m_faces(plan.face, 1),
                       c = m_faces(plan.face, 2);
    const auto p = static_cast<std::int32_t>(old_vertices + k);
    const Vec3& w = plan.weights;
    m_positions.row(p) = w[0] * m_positions.row(a) + w[1] * m_positions.row(b) +
                         w[2] * m_positions.row(c);
    m_velocities.row(p) = w[0] * m_velocities.row(a) + w[1] * m_velocities.row(b) +
                          w[2] * m_velocities.row(c);
    m_masses[p] = options.mass_scale * (m_masses[a] + m_masses[b] + m_masses[c]) / 3.0;

    if (m_material.rows() == old_vertices + added) {
      m_material.row(p) =
          w[0] * m_material.row(a) + w[1] * m_material.row(b) + w[2] * m_material.row(c);
    }
    report.rest_area_before +=
        area_from_sides(rest_of(a, b), rest_of(b, c), rest_of(c, a));
    // Children keep the parent's orientation: (a, b, p), (b, c, p), (c, a, p).
    const auto second_child = static_cast<std::int32_t>(old_faces + 2 * k);
    m_faces.row(plan.face) << a, b, p;
    m_faces.row(second_child) << b, c, p;
    m_faces.row(second_child + 1) << c, a, p;
    report.split_faces.push_back(plan.face);
    report.new_vertices.push_back(p);
    report.region_faces.insert(report.region_faces.end(),
                               {plan.face, second_child, second_child + 1});
  }
  m_vertex_states.resize(static_cast<std::size_t>(old_vertices + added), VertexState::free);
  update_inverse_masses();

  // Springs: keep every spring whose pair is still wired, drop the rest, add the new pairs with
  // eq. (1) rest lengths.
  const MeshConnectivity connectivity = mesh_connectivity(m_faces);
  const bool with_bending = m_bend_stiffness > 0.0;
  std::vector<char> keep(m_springs.size(), 0);
  std::unordered_map<std::uint64_t, char> existing;
  existing.reserve(m_springs.size());
  for (std::size_t k = 0; k < m_springs.size(); ++k) {
    const VertexPair pair{std::min(m_springs.first[k], m_springs.second[k]),
                          std::max(m_springs.first[k], m_springs.second[k])};
    const auto& wired = m_springs.kind[k] == SpringKind::structural ? connectivity.edges
                                                                    : connectivity.bending_pairs;
    keep[k] = std::binary_search(wired.begin(), wired.end(), pair);
    if (keep[k]) existing[pair_key(pair[0], pair[1])] = 1;
  }
  const std::size_t before = m_springs.size();
  m_springs.keep(keep);
  report.springs_removed = static_cast<std::int64_t>(before - m_springs.size());
  auto add_new = [&](const VertexPair& pair, double stiffness, SpringKind kind) {
    if (existing.count(pair_key(pair[0], pair[1]))) return;
    const double length = (m_positions.row(pair[0]) - m_positions.row(pair[1])).norm();
    m_springs.add(pair[0], pair[1], options.expansion * length, stiffness, m_spring_damping, kind,
                  length);
    if (kind == SpringKind::structural) {
      structural_rest[pair_key(pair[0], pair[1])] = options.expansion * length;
    }
    ++report.springs_added;
  };
  for (const VertexPair& edge : connectivity.edges) {
    add_new(edge, m_stretch_stiffness, SpringKind::structural);
  }
  if (with_bending) {
    for (const VertexPair& pair : connectivity.bending_pairs) {
      add_new(pair, m_bend_stiffness, SpringKind::bending);
    }
  }
  for (const std::int32_t f : report.region_faces) {
    const std::int32_t a = m_faces(f, 0), b = m_faces(f, 1), c = m_faces(f, 2);
    report.rest_area_after += area_from_sides(rest_of(a, b), rest_of(b, c), rest_of(c, a));
  }
  rebuild_incidence();
  m_topology_version = next_topology_version();
  ++m_edit_count;
  if (m_bending == BendingModel::quadratic) update_quadratic_bending();  // rest at split time
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
  return terms;
}

bool Cloth::has_spring_damping() const {
  return std::any_of(m_springs.damping.begin(), m_springs.damping.end(),
                     [](double c) { return c > 0.0; });
}

double Cloth::gershgorin_time_step() const {
  // Row sums of |M^{-1/2} A M^{-1/2}| over free vertices bound the largest eigenvalue of the
  // mass-scaled stiffness (A = K, each spring block has norm <= k while the spring is not
  // compressed) and damping (A = C) matrices.
  double omega_squared = 0.0;
  double gamma = 0.0;
  const QuadraticBendingMatrix* bending = has_quadratic_bending() ? &quadratic_bending() : nullptr;
  for (Eigen::Index i = 0; i < vertex_count(); ++i) {
    if (m_inverse_masses[i] == 0.0) continue;
    double stiffness_row = 0.0, damping_row = 0.0;
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
