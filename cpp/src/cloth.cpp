#include "yore/cloth.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

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
    if (!std::isfinite(masses[i]) || masses[i] <= 0.0) {
      std::ostringstream msg;
      msg << "mass of vertex " << i << " must be finite and > 0, got " << masses[i];
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
             double stretch_stiffness, double bend_stiffness, double damping, double drag) {
  validate_mesh(positions, faces);
  check_positive(stretch_stiffness, "stretch_stiffness");
  check_non_negative(bend_stiffness, "bend_stiffness");
  check_non_negative(damping, "damping");
  initialise_state(positions, masses, drag);
  m_faces = faces;

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
  driver.start_time = m_time;
  m_drivers.push_back(std::move(driver));
  update_inverse_masses();
  apply_drivers(m_time);
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
  return terms;
}

bool Cloth::has_spring_damping() const {
  return std::any_of(m_springs.damping.begin(), m_springs.damping.end(),
                     [](double c) { return c > 0.0; });
}

double Cloth::stable_time_step() const {
  // Row sums of |M^{-1/2} A M^{-1/2}| over free vertices bound the largest eigenvalue of the
  // mass-scaled stiffness (A = K, each spring block has norm <= k while the spring is not
  // compressed) and damping (A = C) matrices.
  double omega_squared = 0.0;
  double gamma = 0.0;
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
    omega_squared = std::max(omega_squared, stiffness_row);
    gamma = std::max(gamma, damping_row);
  }
  gamma += m_drag;
  if (omega_squared == 0.0) {
    // Nothing elastic moves: only damping limits the step (h γ < 2), if anything.
    return gamma > 0.0 ? 2.0 / gamma : std::numeric_limits<double>::infinity();
  }
  return (std::sqrt(gamma * gamma + 4.0 * omega_squared) - gamma) / omega_squared;
}

}  // namespace yore
