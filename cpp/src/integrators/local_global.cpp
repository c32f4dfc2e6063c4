#include "yore/integrators/local_global.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "yore/cloth/springs.hpp"
#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/platform/timer.hpp"
#include "yore/solvers/spring_matrix.hpp"

namespace yore {
namespace {

// −κ Q_fc x_c: quadratic bending's coupling of each free vertex to the constrained ones, taken
// from its row of `rhs`.
void subtract_constrained_bending(const QuadraticBendingMatrix& bending, double modulus,
                                  const std::vector<std::int32_t>& free_vertices,
                                  const std::vector<std::int32_t>& free_of_vertex,
                                  const Positions& x, Positions& rhs) {
  for (std::size_t b = 0; b < free_vertices.size(); ++b) {
    const std::int32_t i = free_vertices[b];
    for (std::int32_t k = bending.row_starts[static_cast<std::size_t>(i)];
         k < bending.row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
      const std::int32_t j = bending.columns[static_cast<std::size_t>(k)];
      if (free_of_vertex[static_cast<std::size_t>(j)] >= 0) continue;
      rhs.row(static_cast<Eigen::Index>(b)) -=
          modulus * bending.values[static_cast<std::size_t>(k)] * x.row(j);
    }
  }
}

// The objective's inertia, drag and gravity terms' gradient at x, one row per free vertex:
// m/h² (x − x̂) + drag m/h (x − x₀) − m g.
void inertia_gradient(const Eigen::VectorXd& masses, double dt, double drag, const Vec3& gravity,
                      const std::vector<std::int32_t>& free_vertices, const Positions& x,
                      const Positions& target, const Positions& start, Positions& gradient) {
  for (std::size_t b = 0; b < free_vertices.size(); ++b) {
    const std::int32_t i = free_vertices[b];
    const double m = masses[i];
    gradient.row(static_cast<Eigen::Index>(b)) = m / (dt * dt) * (x.row(i) - target.row(i)) +
                                                 drag * m / dt * (x.row(i) - start.row(i)) -
                                                 m * gravity.transpose();
  }
}

// ∇ of ½ κ xᵀ Q x, κ (Q x)ᵢ, added to each free vertex's row of `gradient`.
void add_bending_gradient(const QuadraticBendingMatrix& bending, double modulus,
                          const std::vector<std::int32_t>& free_vertices, const Positions& x,
                          Positions& gradient) {
  for (std::size_t b = 0; b < free_vertices.size(); ++b) {
    const std::int32_t i = free_vertices[b];
    Eigen::RowVector3d product = Eigen::RowVector3d::Zero();
    for (std::int32_t k = bending.row_starts[static_cast<std::size_t>(i)];
         k < bending.row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
      product += bending.values[static_cast<std::size_t>(k)] *
                 x.row(bending.columns[static_cast<std::size_t>(k)]);
    }
    gradient.row(static_cast<Eigen::Index>(b)) += modulus * product;
  }
}

}  // namespace

LocalGlobalIntegrator::LocalGlobalIntegrator(const LocalGlobalOptions& options)
    : m_options(options),
      m_monitor(options.divergence_energy_factor, options.energy_growth_tolerance) {
  if (options.iterations < 1) {
    std::ostringstream msg;
    msg << "iterations must be >= 1, got " << options.iterations;
    throw std::invalid_argument(msg.str());
  }
  if (!(options.tolerance >= 0.0 && std::isfinite(options.tolerance))) {
    std::ostringstream msg;
    msg << "tolerance must be finite and >= 0, got " << options.tolerance;
    throw std::invalid_argument(msg.str());
  }
  if (!(options.chebyshev_rho >= 0.0 && options.chebyshev_rho < 1.0)) {
    std::ostringstream msg;
    msg << "chebyshev_rho must be in [0, 1), got " << options.chebyshev_rho;
    throw std::invalid_argument(msg.str());
  }
  if (options.stale_pcg_max_iterations < 1 || !(options.stale_pcg_tol > 0.0)) {
    throw std::invalid_argument("stale_pcg_max_iterations must be >= 1 and stale_pcg_tol > 0");
  }
  m_solver = std::make_unique<SparseCholesky>(options.factorization, options.ordering);
}

LocalGlobalIntegrator::~LocalGlobalIntegrator() = default;

const SolverStatistics& LocalGlobalIntegrator::solver_statistics() const {
  return m_solver->statistics();
}

void LocalGlobalIntegrator::build_pattern(const Cloth& cloth) {
  const Eigen::Index n = cloth.vertex_count();
  const SpringSet& springs = cloth.springs();
  build_scalar_spring_pattern(cloth, m_scalar);
  const auto unknowns = m_pattern.size;
  m_values.assign(m_pattern.row_indices.size(), 0.0);
  m_diagonal.resize(unknowns);
  const Eigen::Index rows = unknowns;
  m_base_rhs.resize(rows, 3);
  m_rhs.resize(rows, 3);
  m_rhs_rows.resize(rows, 3);
  m_unknowns.resize(rows, 3);
  m_gradient.resize(rows, 3);
  m_work_rhs.resize(rows);
  m_work_x.resize(rows);
  m_cg.resize(rows);
  m_start.setZero(n, 3);
  m_target.setZero(n, 3);
  m_iterate.setZero(n, 3);
  m_previous_iterate.setZero(n, 3);
  m_solution.setZero(n, 3);
  m_directions.resize(static_cast<Eigen::Index>(springs.size()), 3);
}

void LocalGlobalIntegrator::fill_values(const Cloth& cloth, double dt) {
  fill_scalar_spring_matrix(cloth, dt, m_scalar, m_values);
  for (std::int32_t b = 0; b < m_pattern.size; ++b) {
    m_diagonal[b] = m_values[static_cast<std::size_t>(m_pattern.column_starts[b])];
  }
}

void LocalGlobalIntegrator::factor_fresh(bool keep_ordering) {
  if (m_pattern.size == 0) {
    m_factor_current = true;
    return;
  }
  Stopwatch start;
  m_solver = std::make_unique<SparseCholesky>(m_options.factorization, m_options.ordering);
  m_solver->set_simplicial_solves(true);  // Q is factored once and solved ~10× per step
  if (keep_ordering && !m_previous_permutation.empty() && m_previous_size <= m_pattern.size) {
    // The old ordering, each new unknown placed right after the last of its old neighbours
    // (eliminated after them, like a leaf): little extra fill, no ordering search.
    const std::int32_t old_size = m_previous_size;
    std::vector<std::int32_t> position(static_cast<std::size_t>(old_size));
    for (std::int32_t k = 0; k < old_size; ++k) {
      position[static_cast<std::size_t>(m_previous_permutation[static_cast<std::size_t>(k)])] = k;
    }
    std::vector<std::int32_t> after(static_cast<std::size_t>(m_pattern.size - old_size), -1);
    for (std::int32_t column = 0; column < old_size; ++column) {
      for (std::int32_t p = m_pattern.column_starts[column] + 1;
           p < m_pattern.column_starts[column + 1]; ++p) {
        const std::int32_t row = m_pattern.row_indices[static_cast<std::size_t>(p)];
        if (row < old_size) continue;
        auto& slot = after[static_cast<std::size_t>(row - old_size)];
        slot = std::max(slot, position[static_cast<std::size_t>(column)]);
      }
    }
    std::vector<std::vector<std::int32_t>> inserted(static_cast<std::size_t>(old_size) + 1);
    for (std::size_t k = 0; k < after.size(); ++k) {
      const std::int32_t at = after[k] < 0 ? old_size : after[k];
      inserted[static_cast<std::size_t>(at)].push_back(old_size + static_cast<std::int32_t>(k));
    }
    std::vector<std::int32_t> permutation;
    permutation.reserve(static_cast<std::size_t>(m_pattern.size));
    for (std::int32_t k = 0; k <= old_size; ++k) {
      if (k < old_size) permutation.push_back(m_previous_permutation[static_cast<std::size_t>(k)]);
      for (const std::int32_t unknown : inserted[static_cast<std::size_t>(k)]) {
        permutation.push_back(unknown);
      }
    }
    m_solver->analyze_with_permutation(m_pattern, permutation);
  } else {
    m_solver->analyze(m_pattern);
  }
  m_statistics.analyze_seconds += start.seconds();
  ++m_statistics.analyses;
  start.restart();
  m_solver->factorize(m_values.data());
  m_statistics.factorize_seconds += start.seconds();
  ++m_statistics.factorizations;
  m_previous_permutation = m_solver->permutation();
  m_previous_size = m_pattern.size;
  m_factor_current = true;
  m_stale_solver.reset();
  m_stale_size = 0;
}

void LocalGlobalIntegrator::ensure_matrix(const Cloth& cloth, double dt) {
  const double checksum = spring_material_checksum(cloth);
  if (cloth.topology_version() != m_topology) {
    const std::vector<std::int32_t> old_free = m_free_vertices;
    const bool had_factor = m_topology != std::numeric_limits<std::uint64_t>::max();
    const Stopwatch start;
    build_pattern(cloth);
    fill_values(cloth, dt);
    // Strokes only append vertices: the old unknowns keep their indices (a prefix).
    const bool prefix = had_factor && old_free.size() <= m_free_vertices.size() &&
                        std::equal(old_free.begin(), old_free.end(), m_free_vertices.begin());
    if (!prefix || m_options.rebuild == RebuildStrategy::fresh) {
      factor_fresh(false);
    } else if (m_options.rebuild == RebuildStrategy::reuse_ordering || dt != m_dt) {
      // (the material checksum changes with the stroke's new springs; only dt matters here)
      factor_fresh(true);
    } else {  // stale_pcg: keep the old factor as a preconditioner for now
      if (m_factor_current) {
        m_stale_solver = std::move(m_solver);
        m_stale_size = static_cast<std::int32_t>(old_free.size());
        m_solver = std::make_unique<SparseCholesky>(m_options.factorization, m_options.ordering);
      }
      m_factor_current = false;
    }
    if (had_factor) {
      ++m_statistics.rebuilds;
      m_statistics.rebuild_seconds += start.seconds();
    }
    m_topology = cloth.topology_version();
  } else if (dt != m_dt || checksum != m_material_checksum) {
    fill_values(cloth, dt);
    if (m_factor_current) {
      const Stopwatch start;
      if (m_pattern.size > 0) {
        m_solver->factorize(m_values.data());
        ++m_statistics.factorizations;
      }
      m_statistics.factorize_seconds += start.seconds();
    } else {
      factor_fresh(true);
    }
  }
  m_dt = dt;
  m_material_checksum = checksum;
}

void LocalGlobalIntegrator::global_solve() {
  const Stopwatch start;
  if (m_factor_current) {  // x, y and z in one pass over the factor
    m_solver->solve_columns(m_rhs.data(), m_unknowns.data(), 3);
    m_statistics.solve_seconds += start.seconds();
    return;
  }
  for (int c = 0; c < 3; ++c) {
    m_work_rhs = m_rhs.col(c);
    if (m_factor_current) {
      m_solver->solve(m_work_rhs.data(), m_work_x.data());
      m_unknowns.col(c) = m_work_x;
      continue;
    }
    // CG on the current matrix, preconditioned by the stale factor on the old unknowns and by
    // the diagonal on the new ones; warm-started from the previous iterate.
    m_work_x = m_unknowns.col(c);
    auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
      m_stale_solver->solve(r.data(), z.data());
      const Eigen::Index fresh = m_pattern.size - m_stale_size;
      z.tail(fresh) = r.tail(fresh).cwiseQuotient(m_diagonal.tail(fresh));
    };
    bool converged = false;
    m_statistics.pcg_iterations += preconditioned_cg(
        m_pattern, m_values.data(), m_work_rhs, m_work_x, precondition, m_options.stale_pcg_tol,
        m_options.stale_pcg_max_iterations, m_cg, converged);
    ++m_statistics.stale_solves;
    if (!converged) {
      // The stale factor no longer helps enough: rebuild now (old ordering reused) and solve
      // this column and the remaining ones directly.
      const Stopwatch rebuild_start;
      factor_fresh(true);
      m_statistics.rebuild_seconds += rebuild_start.seconds();
      m_solver->solve(m_work_rhs.data(), m_work_x.data());
    }
    m_unknowns.col(c) = m_work_x;
  }
  m_statistics.solve_seconds += start.seconds();
}

double LocalGlobalIntegrator::objective(const Cloth& cloth, const Positions& x) const {
  double energy = 0.0;
  const double h = m_h, drag = cloth.drag();
  for (const std::int32_t i : m_free_vertices) {
    const double m = cloth.masses()[i];
    energy += 0.5 * m / (h * h) * (x.row(i) - m_target.row(i)).squaredNorm() +
              0.5 * drag * m / h * (x.row(i) - m_start.row(i)).squaredNorm() -
              m * x.row(i).dot(m_gravity);
  }
  const SpringSet& springs = cloth.springs();
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t i = springs.first[s], j = springs.second[s];
    energy += spring_energy(x.row(i), x.row(j), springs.rest_length[s], springs.stiffness[s]);
    const Vec3 moved = (x.row(i) - m_start.row(i)) - (x.row(j) - m_start.row(j));
    const double along = moved.dot(m_directions.row(static_cast<Eigen::Index>(s)));
    energy += 0.5 * springs.damping[s] / h * along * along;
  }
  if (cloth.has_quadratic_bending()) {
    energy += quadratic_bending_energy(cloth.quadratic_bending(), cloth.bending_modulus(), x);
  }
  return energy;
}

// The step's constants: the predictor, the right-hand side's constant part (inertia, drag,
// gravity, damping, constrained neighbours, quadratic bending's coupling to them) and the
// damping directions. Returns the mean rest length, the unit of the tolerances.
double LocalGlobalIntegrator::begin_step(Cloth& cloth, const Vec3& gravity, double dt) {
  m_h = dt;
  m_gravity = gravity;
  m_start = cloth.positions();
  m_target = m_start + dt * cloth.velocities();
  const double new_time = cloth.advance_time(dt);
  cloth.apply_drivers(new_time);
  m_iterate = cloth.positions();  // constrained rows: their prescribed positions at t + h
  // free rows start at the inertial guess x̂ = xₙ + h vₙ + h² g
  for (const std::int32_t i : m_free_vertices) {
    m_iterate.row(i) = m_target.row(i) + dt * dt * gravity.transpose();
  }

  Stopwatch start;
  const SpringSet& springs = cloth.springs();
  const double drag = cloth.drag();
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    const std::int32_t i = m_free_vertices[b];
    const double m = cloth.masses()[i];
    m_base_rhs.row(static_cast<Eigen::Index>(b)) =
        m / (dt * dt) * m_target.row(i) + drag * m / dt * m_start.row(i) + m * gravity.transpose();
  }
  double rest_sum = 0.0;
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t i = springs.first[s], j = springs.second[s];
    const std::int32_t a = m_free_of_vertex[static_cast<std::size_t>(i)];
    const std::int32_t b = m_free_of_vertex[static_cast<std::size_t>(j)];
    const double damping = springs.damping[s] / dt;
    const double weight = springs.stiffness[s] + damping;
    const Eigen::RowVector3d previous = m_start.row(i) - m_start.row(j);
    if (a >= 0) {
      m_base_rhs.row(a) += damping * previous;
      if (b < 0) m_base_rhs.row(a) += weight * m_iterate.row(j);
    }
    if (b >= 0) {
      m_base_rhs.row(b) -= damping * previous;
      if (a < 0) m_base_rhs.row(b) += weight * m_iterate.row(i);
    }
    rest_sum += springs.rest_length[s];
    // Damping direction from the predictor x̃ = xₙ + h vₙ (as the Newton integrator): an
    // O(h²) extrapolation of the spring's direction over the step, fixed during the step so
    // the damping stays a quadratic potential. (Frozen at xₙ instead, a rigidly spinning test
    // cloth lost 4.5 % of its angular momentum in 1 s at c = 0.5 N·s/m; from x̃, 0.1 %.)
    const Eigen::RowVector3d d = m_target.row(i) - m_target.row(j);
    const double length = d.norm();
    m_directions.row(static_cast<Eigen::Index>(s)) =
        length > 0.0 ? Eigen::RowVector3d(d / length) : Eigen::RowVector3d::Zero();
  }
  // Quadratic bending is quadratic in x: all of it is in the global matrix (κ Q over the free
  // unknowns); the right-hand side takes its coupling to constrained vertices, −κ Q_fc x_c.
  if (cloth.has_quadratic_bending()) {
    subtract_constrained_bending(cloth.quadratic_bending(), cloth.bending_modulus(),
                                 m_free_vertices, m_free_of_vertex, m_iterate, m_base_rhs);
  }
  // Tolerances and residuals are relative to the mean rest length, as the Newton integrator's.
  const double mean_rest_length =
      springs.size() > 0 ? rest_sum / static_cast<double>(springs.size()) : 1.0;
  m_statistics.assemble_seconds += start.seconds();
  return mean_rest_length;
}

// The local step: every spring's ideal vector into the right-hand side. With `with_gradient`
// (the step's last pass: the residual is reported, never tested) also the objective's gradient
// at the iterate (m_gradient) in the same pass; returns the Newton-style residual max |∇ᵢE| h²/mᵢ
// then, NaN when the right-hand side is not finite, 0 otherwise.
double LocalGlobalIntegrator::local_step(const Cloth& cloth, bool with_gradient) {
  const double dt = m_h;
  const Vec3& gravity = m_gravity;
  const SpringSet& springs = cloth.springs();
  const double drag = cloth.drag();
  ScopedTimer timer(m_statistics.assemble_seconds);
  m_rhs_rows = m_base_rhs;
  if (with_gradient) {
    inertia_gradient(cloth.masses(), dt, drag, gravity, m_free_vertices, m_iterate, m_target,
                     m_start, m_gradient);
  }
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t i = springs.first[s], j = springs.second[s];
    const std::int32_t a = m_free_of_vertex[static_cast<std::size_t>(i)];
    const std::int32_t b = m_free_of_vertex[static_cast<std::size_t>(j)];
    if (a < 0 && b < 0) continue;
    const Eigen::RowVector3d d = m_iterate.row(i) - m_iterate.row(j);
    const double length = d.norm();
    Eigen::RowVector3d force = Eigen::RowVector3d::Zero();     // into the right-hand side
    Eigen::RowVector3d gradient = Eigen::RowVector3d::Zero();  // ∂E/∂xᵢ of this spring
    if (length > 0.0) {
      // local step: the spring's ideal vector, its current direction at its rest length
      const double stretch = springs.stiffness[s] / length;
      force = (stretch * springs.rest_length[s]) * d;
      if (with_gradient) gradient = (stretch * (length - springs.rest_length[s])) * d;
    }
    if (springs.damping[s] > 0.0) {
      // The matrix damps the whole relative motion (c/h); give back its part across the
      // damping direction, at the current iterate, so that at convergence only the motion
      // along that direction is damped — exactly the Newton integrator's damping.
      const Eigen::RowVector3d moved =
          (m_iterate.row(i) - m_start.row(i)) - (m_iterate.row(j) - m_start.row(j));
      const Eigen::RowVector3d n0 = m_directions.row(static_cast<Eigen::Index>(s));
      const double along = moved.dot(n0);
      force += (springs.damping[s] / dt) * (moved - along * n0);
      if (with_gradient) gradient += (springs.damping[s] / dt * along) * n0;
    }
    if (a >= 0) m_rhs_rows.row(a) += force;
    if (b >= 0) m_rhs_rows.row(b) -= force;
    if (with_gradient) {
      if (a >= 0) m_gradient.row(a) += gradient;
      if (b >= 0) m_gradient.row(b) -= gradient;
    }
  }
  m_rhs = m_rhs_rows;  // column-major for the solver
  if (!with_gradient) return m_rhs.allFinite() ? 0.0 : std::numeric_limits<double>::quiet_NaN();
  if (cloth.has_quadratic_bending()) {
    add_bending_gradient(cloth.quadratic_bending(), cloth.bending_modulus(), m_free_vertices,
                         m_iterate, m_gradient);
  }
  double residual = 0.0;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    const double scale = dt * dt * cloth.inverse_masses()[m_free_vertices[b]];
    residual = std::max(
        residual, scale * m_gradient.row(static_cast<Eigen::Index>(b)).lpNorm<Eigen::Infinity>());
  }
  return residual;
}

double LocalGlobalIntegrator::global_step(int iteration, double& omega, double rho) {
  // The global solve, blended with the iterate two back by Chebyshev acceleration (Wang 2015)
  // of spectral radius rho (0: none); returns ‖Q⁻¹ ∇E(x_k)‖∞, the plain global step before any
  // blending.
  global_solve();
  if (rho > 0.0) {
    omega = iteration == 0
                ? 1.0
                : (iteration == 1 ? 2.0 / (2.0 - rho * rho) : 4.0 / (4.0 - rho * rho * omega));
  }
  double change = 0.0;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    const std::int32_t i = m_free_vertices[b];
    const Eigen::RowVector3d solved = m_unknowns.row(static_cast<Eigen::Index>(b));
    change = std::max(change, (solved - m_iterate.row(i)).lpNorm<Eigen::Infinity>());
    const Eigen::RowVector3d blended =
        omega * (solved - m_previous_iterate.row(i)) + m_previous_iterate.row(i);
    m_previous_iterate.row(i) = m_iterate.row(i);
    m_iterate.row(i) = blended;
    m_unknowns.row(static_cast<Eigen::Index>(b)) = blended;
  }
  return change;
}

double LocalGlobalIntegrator::ErrorEstimate::update(double change, int iteration, double rho) {
  // The error left, estimated from the plain step p = Q⁻¹∇E and the contraction ρ of the
  // plain iteration (slow modes: p ≈ (1 − ρ) e): without acceleration ρ is the largest of
  // the last three ratios of successive steps and the new iterate's error is at most
  // ρ/(1 − ρ) p; with Chebyshev, ρ is chebyshev_rho and the estimate p/(1 − ρ). (p alone
  // would stop a stiff sheet far from the solution: its slow modes converge at ρ ≈ 0.997;
  // ‖h² M⁻¹ ∇E‖∞, the Newton measure, is ~k h²/m ≈ 10⁴× the error there, so it cannot be
  // the test.)
  ratios[iteration % 3] = previous_change > 0.0 ? change / previous_change : 0.0;
  previous_change = change;
  if (rho > 0.0) {
    error = change / (1.0 - rho);
  } else if (iteration >= 2) {
    const double rho_estimate = std::min(0.9999, std::max({ratios[0], ratios[1], ratios[2]}));
    error = change * rho_estimate / (1.0 - rho_estimate);
  }
  return error;
}

void LocalGlobalIntegrator::step(Cloth& cloth, const Vec3& gravity, double dt) {
  if (cloth.has_membrane()) {
    // Its local step projects springs (and bending's linear term): a membrane would need a
    // projection of each face onto its rest shape, which it does not have.
    throw std::invalid_argument(
        "the local-global integrator takes springs and quadratic bending, not a membrane "
        "(stretch=\"membrane\"); use the implicit or explicit integrator");
  }
  ensure_matrix(cloth, dt);
  // A step whose energy rises past the growth check's allowance is redone once without
  // Chebyshev's extrapolation, whose iterates need not lower the objective: where the local
  // step is far from linear (a spring whose ends coincide has no direction) it overshot
  // (issue 53, N19: two coincident ends 0.1 m apart at rest gained 14 J at 1/60 s; the plain
  // iteration lowers the objective at every iteration and finished).
  const double rho = m_options.chebyshev_rho;
  const bool may_redo = rho > 0.0 && std::isfinite(m_monitor.allowance());
  if (may_redo) {
    m_step_positions = cloth.positions();  // same size step to step: no reallocation
    m_step_velocities = cloth.velocities();
  }
  const SimulationClock clock = cloth.clock();  // (begin_step advances it)
  bool converged = solve_step(cloth, gravity, dt, rho);
  if (may_redo && m_monitor.would_gain(DivergenceMonitor::monitored_energy(cloth, gravity))) {
    cloth.integrator_positions() = m_step_positions;
    cloth.integrator_velocities() = m_step_velocities;
    cloth.set_clock(clock);
    ++m_statistics.energy_retries;
    converged = solve_step(cloth, gravity, dt, 0.0);
  }
  if (!converged && m_options.tolerance > 0.0) ++m_statistics.unconverged_steps;
  ++m_statistics.steps;
}

bool LocalGlobalIntegrator::solve_step(Cloth& cloth, const Vec3& gravity, double dt, double rho) {
  const double mean_rest_length = begin_step(cloth, gravity, dt);
  const double tolerance = m_options.tolerance * mean_rest_length;

  m_objective_history.clear();
  double omega = 1.0;
  m_previous_iterate = m_iterate;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    m_unknowns.row(static_cast<Eigen::Index>(b)) = m_iterate.row(m_free_vertices[b]);
  }
  double residual = 0.0;
  ErrorEstimate estimate;
  int solves = 0;
  bool converged = m_pattern.size == 0;
  for (int iteration = 0; m_pattern.size > 0; ++iteration) {
    poll_interrupt();  // iterations is user-typed
    const bool tolerance_met = m_options.tolerance > 0.0 && estimate.error <= tolerance;
    const bool last = tolerance_met || iteration == m_options.iterations;
    residual = local_step(cloth, last);
    if (tolerance_met) {
      converged = true;
      break;
    }
    if (!std::isfinite(residual)) break;  // the divergence monitor reports it
    if (last) break;
    const double change = global_step(iteration, omega, rho);
    ++solves;
    estimate.update(change, iteration, rho);
    ++m_statistics.iterations;
    if (m_options.record_objective) m_objective_history.push_back(objective(cloth, m_iterate));
  }
  m_statistics.last_iterations = solves;
  m_statistics.last_residual = residual / mean_rest_length;
  m_statistics.last_error_estimate = m_pattern.size == 0 ? 0.0 : estimate.error / mean_rest_length;

  Positions& x = cloth.integrator_positions();
  Positions& v = cloth.integrator_velocities();
  for (const std::int32_t i : m_free_vertices) {
    x.row(i) = m_iterate.row(i);
    v.row(i) = (m_iterate.row(i) - m_start.row(i)) / dt;
  }
  m_statistics.last_dofs = m_pattern.size;
  return converged;
}

void LocalGlobalIntegrator::advance(Cloth& cloth, const Vec3& gravity, double dt,
                                    std::int64_t steps) {
  advance_checked(
      cloth, gravity, dt, steps, m_monitor, {integrator_name::kLocalGlobal, Remedy::local_global},
      m_checkpoint_positions, m_checkpoint_velocities, [&] { step(cloth, gravity, dt); },
      [&] { return m_statistics.steps - 1; }, {});
}

}  // namespace yore
