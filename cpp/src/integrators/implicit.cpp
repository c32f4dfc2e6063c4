#include "yore/integrators/implicit.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "implicit_detail.hpp"
#include "yore/cloth/springs.hpp"
#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/platform/timer.hpp"

namespace yore {
using namespace implicit_detail;

namespace {

// The options' values one by one (tolerances, counts), in the order their errors are reported.
void check_option_values(const ImplicitOptions& options) {
  if (!std::isfinite(options.newton_tol) || options.newton_tol <= 0.0) {
    std::ostringstream msg;
    msg << "newton_tol must be finite and > 0, got " << options.newton_tol;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(options.truncation_fraction) || options.truncation_fraction < 0.0 ||
      options.truncation_fraction > 1.0) {
    std::ostringstream msg;
    msg << "truncation_fraction must be finite and in [0, 1], got " << options.truncation_fraction;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(options.step_tol) || options.step_tol < 0.0) {
    std::ostringstream msg;
    msg << "step_tol must be finite and >= 0, got " << options.step_tol;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(options.rho_infinity) || options.rho_infinity < 0.0 ||
      options.rho_infinity > 1.0) {
    std::ostringstream msg;
    msg << "rho_infinity must be finite and in [0, 1], got " << options.rho_infinity;
    throw std::invalid_argument(msg.str());
  }
  if (options.max_newton < 1) {
    std::ostringstream msg;
    msg << "max_newton must be >= 1, got " << options.max_newton;
    throw std::invalid_argument(msg.str());
  }
}

// Options that exclude one another (solvers, projections, adaptivity); `estimate`: the scheme
// estimates its error (error control needs it).
void check_option_combinations(const ImplicitOptions& options, bool estimate) {
  if (options.lagged_factorization &&
      (options.linear_solver.solver == "pcg" || options.adaptive_projection)) {
    throw std::invalid_argument(
        "lagged factorization needs a Cholesky backend and the projected Hessian "
        "(adaptive_projection off)");
  }
  if (options.lag_max_cg_iterations < 1 || !(options.lag_cg_tol > 0.0)) {
    throw std::invalid_argument("lag_max_cg_iterations must be >= 1 and lag_cg_tol > 0");
  }
  if (options.adaptive && (!estimate || options.minimizer != ImplicitMinimizer::newton)) {
    throw std::invalid_argument(
        "error-controlled steps (adaptive, dt = \"auto\") need a "
        "local error estimate: method tr-bdf2 or bdf2, with Newton");
  }
  if (!(options.rtol > 0.0) || !(options.rtol < 1.0) || !(options.atol > 0.0) ||
      !std::isfinite(options.atol) || options.max_steps < 1) {
    throw std::invalid_argument("rtol must be in (0, 1), atol finite and > 0, max_steps >= 1");
  }
  if (options.adaptive_projection && options.linear_solver.solver == "pcg") {
    throw std::invalid_argument(
        "adaptive projection needs a Cholesky backend (cholmod or eigen-ldlt) to detect an "
        "indefinite Hessian; pcg cannot");
  }
  if (options.projection == HessianProjection::steihaug &&
      (options.linear_solver.solver == "pcg" || options.linearized)) {
    throw std::invalid_argument(
        "the steihaug projection needs a Cholesky backend (cholmod or eigen-ldlt) for its "
        "preconditioner, and is not linearized");
  }
  if (options.projection == HessianProjection::shifted &&
      (options.linear_solver.solver == "pcg" || options.lagged_factorization)) {
    throw std::invalid_argument(
        "the shifted projection needs a Cholesky backend (cholmod or eigen-ldlt) to detect an "
        "indefinite Hessian, and no lagged factorization");
  }
}

// Quasi-Newton's own options.
void check_lbfgs_options(const ImplicitOptions& options) {
  if (options.linearized || options.lagged_factorization) {
    throw std::invalid_argument(
        "quasi-Newton (lbfgs) takes neither linearized nor lagged_factorization");
  }
  if (options.method != ImplicitMethod::backward_euler && options.method != ImplicitMethod::bdf2) {
    throw std::invalid_argument("quasi-Newton (lbfgs) takes method backward-euler or bdf2");
  }
  if (options.lbfgs_history < 1 || options.lbfgs_history > 1000) {
    std::ostringstream msg;
    msg << "lbfgs_history must be in [1, 1000], got " << options.lbfgs_history;
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace

namespace {

/// A projection by its name in the option tables (yore.options, scene and state files).
const char* projection_name(HessianProjection projection) {
  switch (projection) {
    case HessianProjection::clamp:
      return "clamp";
    case HessianProjection::abs:
      return "abs";
    case HessianProjection::exact:
      return "exact";
    case HessianProjection::trust_region:
      return "trust-region";
    case HessianProjection::shifted:
      return "shifted";
    case HessianProjection::steihaug:
      return "steihaug";
  }
  return "clamp";
}

}  // namespace

ImplicitOptions resolve_choices(ImplicitOptions options, const ImplicitChoices& choices) {
  options.predictor = choices.predictor.value_or(options.linearized ? NewtonPredictor::start
                                                                    : NewtonPredictor::inertial);
  if (options.minimizer != ImplicitMinimizer::newton) return options;
  HessianProjection projection = HessianProjection::clamp;
  if (choices.projection) {
    projection = *choices.projection;
  } else if (choices.adaptive_projection) {
    projection = *choices.adaptive_projection ? HessianProjection::exact : HessianProjection::clamp;
  }
  if (choices.adaptive_projection && choices.projection &&
      *choices.adaptive_projection != (projection == HessianProjection::exact)) {
    throw std::invalid_argument(
        std::string("adaptive_projection=") + (*choices.adaptive_projection ? "True" : "False") +
        " contradicts projection='" + projection_name(projection) + "'; give one of them");
  }
  options.projection = projection;
  options.adaptive_projection = false;  // mapped into projection
  // the one linearized step is the same either way (to round-off)
  options.mixed =
      choices.mixed.value_or(projection == HessianProjection::clamp && !options.linearized);
  return options;
}

ImplicitIntegrator::ImplicitIntegrator(const ImplicitOptions& given)
    : m_options(given), m_monitor(given.divergence_energy_factor, given.energy_growth_tolerance) {
  if (m_options.adaptive_projection) m_options.projection = HessianProjection::exact;
  m_options.adaptive_projection = m_options.projection == HessianProjection::exact;
  const ImplicitOptions& options = m_options;
  check_option_values(options);
  m_scheme = time_scheme(options.method).make(options);
  m_history_arrays = m_scheme->history();
  check_option_combinations(options, m_scheme->error_estimate());
  if (options.minimizer == ImplicitMinimizer::lbfgs) {
    check_lbfgs_options(options);
    // the projection never applies (no Hessian is factored); clamp keeps the exact
    // projection's memory untouched
    m_options.projection = HessianProjection::clamp;
    m_options.adaptive_projection = false;
    m_scalar_solver = std::make_unique<SparseCholesky>(options.linear_solver.factorization,
                                                       options.linear_solver.ordering,
                                                       options.linear_solver.supernode_relaxation);
  }
  m_solver = make_linear_solver(options.linear_solver);
}

ImplicitIntegrator::~ImplicitIntegrator() = default;

const SolverStatistics& ImplicitIntegrator::solver_statistics() const {
  if (m_scalar_solver) return m_scalar_solver->statistics();  // lbfgs: Q's factor
  return m_solver->statistics();
}

void ImplicitIntegrator::pose_backward_euler(const Cloth& cloth, double dt) {
  const Positions& x = cloth.positions();
  const Positions& v = cloth.velocities();
  m_stage.h = dt;
  m_stage.anchor = x;
  m_stage.target = x + dt * v;
  m_stage.hv = m_stage.h;
  // Damping directions of the inertial prediction x̂ (constrained vertices included: x̂ − x̄ is
  // their velocity times h̃ too), an O(h̃²) extrapolation of the end-of-step directions: frozen at
  // xₙ they would be O(h) off, which costs BDF2 its order and damps a rigid rotation.
  update_directions(cloth);
}

void ImplicitIntegrator::step(Cloth& cloth, const Vec3& gravity, double dt) {
  ensure_structure(cloth);
  // The stopping tests' length scale follows the rest lengths every step: a growth stroke
  // changes them without changing the topology, and a scale kept from before it made a run
  // resumed after the stroke stop Newton elsewhere than the straight run (issue 53, R05).
  const SpringSet& springs = cloth.springs();
  double rest_sum = 0.0;
  for (const double rest : springs.rest_length) rest_sum += rest;
  m_mean_rest_length = springs.size() ? rest_sum / static_cast<double>(springs.size()) : 1.0;
  m_gravity = gravity;
  m_step_iterations = m_step_backtracks = 0;
  const bool history_valid = m_scheme->step(*this, cloth, dt, m_history);
  finish_step(cloth, dt, history_valid);
}

void ImplicitIntegrator::finish_step(const Cloth& cloth, double dt, bool history_valid) {
  m_history.valid = history_valid;
  m_history.topology = cloth.topology_version();
  m_history.edits = cloth.edit_count();
  m_history.dt = dt;
  ++m_statistics.steps;
  m_statistics.last_newton_iterations = m_step_iterations;
  m_statistics.last_line_search_backtracks = m_step_backtracks;
}

void ImplicitIntegrator::solve(const Cloth& cloth) {
  if (m_options.mixed) reset_tension(cloth, cloth.positions());
  m_iterate = cloth.positions();
  if (m_options.predictor != NewtonPredictor::start) {
    // The stage solves M (x − x̂)/h̃² = f: its solution is x̂ + h̃² a⁺, so the start x̂ + h̃² ã
    // is off by h̃² (a⁺ − ã), the error of ã's extrapolation, where x̂ alone is off by h̃² a⁺.
    const bool extrapolate = m_stage.extrapolated;
    const double scale = m_stage.h * m_stage.h;
    for (const std::int32_t i : m_free_vertices) {
      m_iterate.row(i) = m_stage.target.row(i);
      if (extrapolate) m_iterate.row(i) += scale * m_stage.acceleration.row(i);
    }
    if (extrapolate) ++m_statistics.extrapolated_stages;
  }
  m_stage.extrapolated = false;  // each stage's setup provides its own
  int stage_iterations = 0, stage_backtracks = 0;
  bool converged = m_pattern.size == 0;
  double energy = 0.0, residual = 0.0;
  if (!converged) {
    energy = evaluate(cloth, m_iterate, true, false);
    residual = scaled_residual(cloth);
    if (m_options.minimizer == ImplicitMinimizer::lbfgs) {
      quasi_newton_iterate(cloth, energy, residual, stage_iterations, stage_backtracks, converged);
    } else if (m_options.projection == HessianProjection::steihaug && !m_options.linearized) {
      steihaug_iterate(cloth, energy, residual, stage_iterations, stage_backtracks, converged);
    } else {
      newton_iterate(cloth, energy, residual, stage_iterations, stage_backtracks, converged);
    }
  }
  if (!converged) ++m_statistics.unconverged_steps;
  if (m_pattern.size > 0) {
    evaluate(cloth, m_iterate, true, false);
    m_statistics.last_residual = m_gradient.lpNorm<Eigen::Infinity>();
    m_statistics.last_scaled_residual = scaled_residual(cloth) / m_mean_rest_length;
    m_statistics.last_truncation_error = m_scheme->truncation_error(*this, cloth);
  } else {
    m_statistics.last_residual = 0.0;
    m_statistics.last_scaled_residual = 0.0;
    m_statistics.last_truncation_error = 0.0;
  }
  ++m_statistics.stages;
  m_statistics.newton_iterations += stage_iterations;
  if (m_stage.trapezoid) m_statistics.trapezoid_newton_iterations += stage_iterations;
  m_stage.trapezoid = false;  // each stage's setup says
  m_statistics.line_search_backtracks += stage_backtracks;
  m_statistics.last_dofs = m_pattern.size;
  m_step_iterations += stage_iterations;
  m_step_backtracks += stage_backtracks;
}

void ImplicitIntegrator::write(Cloth& cloth) {
  Positions& x = cloth.integrator_positions();
  Positions& v = cloth.integrator_velocities();
  for (const std::int32_t i : m_free_vertices) {
    x.row(i) = m_iterate.row(i);
    v.row(i) = (m_iterate.row(i) - m_stage.anchor.row(i)) / m_stage.hv;
  }
}

void ImplicitIntegrator::finish_setup(const Cloth& cloth) {
  // Constrained vertices are where the drivers put them at the stage's end, moving at their
  // prescribed velocity: their rows make the damping of springs to them see that velocity.
  const Positions& x = cloth.positions();
  const Positions& v = cloth.velocities();
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    if (m_dof_of_vertex[static_cast<std::size_t>(i)] >= 0) continue;
    m_stage.anchor.row(i) = x.row(i) - m_stage.hv * v.row(i);
    m_stage.target.row(i) = x.row(i);
  }
  update_directions(cloth);
}

double ImplicitIntegrator::line_search(const Cloth& cloth, double energy, double slope,
                                       int& backtracks, double& trial_energy, bool trial_gradient) {
  double alpha = 1.0;
  const double magnitude = m_energy_magnitude;  // of the objective at the iterate
  for (int halvings = 0;; ++halvings) {
    m_trial = m_iterate;
    for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
      m_trial.row(m_free_vertices[b]) +=
          alpha * m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).transpose();
    }
    if (-alpha * slope <= kRoundoff * magnitude) {
      // Close to the minimum the energy cannot resolve the decrease the model predicts (an
      // Armijo test on it accepts noise or halves forever). The trapezoid rule on the
      // directional derivatives, ΔE ≈ α/2 (∇E(x)·d + ∇E(x + αd)·d), measures the change without
      // cancellation; Armijo is tested on it. (m_gradient is the trial's afterwards.)
      trial_energy = evaluate(cloth, m_trial, true, false);
      const double change = 0.5 * alpha * (slope + m_gradient.dot(m_direction));
      if (std::isfinite(trial_energy) && std::isfinite(change) &&
          change <= kArmijo * alpha * slope) {
        break;
      }
    } else {
      trial_energy = evaluate(cloth, m_trial, trial_gradient, false);
      if (trial_energy <= energy + kArmijo * alpha * slope) break;  // sufficient decrease
    }
    if (halvings == kMaxBacktracks) break;  // take the tiny step; the residual decides
    alpha *= 0.5;
    ++backtracks;
  }
  return alpha;
}

ImplicitIntegrator::IterationVerdict ImplicitIntegrator::verdict(double energy, double residual,
                                                                 int iterations) const {
  // A non-finite objective or gradient is divergence (advance_checked restores the state and
  // reports it), never convergence; the residual test comes before the cap, so a step that
  // converges on its last allowed iteration counts as converged.
  if (!std::isfinite(energy) || !std::isfinite(residual)) return IterationVerdict::diverged;
  // The scaled residual of the start is h̃²|a|, a the acceleration the forces would give, so at
  // small steps the length test alone passes a start that ignores every force (at h = 1/3840 s
  // h̃²g is below 1e-5 × a 9 cm rest length: the cloth would not even fall). The start passes
  // only if it also leaves no vertex a net force above newton_tol × its weight; after a Newton
  // step the length test alone decides.
  double tolerance = m_options.newton_tol * m_mean_rest_length;
  if (iterations == 0) {
    tolerance =
        std::min(tolerance, m_options.newton_tol * m_stage.h * m_stage.h * m_gravity.norm());
  }
  if (residual <= tolerance) return IterationVerdict::converged;
  if (iterations >= m_options.max_newton) return IterationVerdict::at_cap;
  return IterationVerdict::go_on;
}

bool ImplicitIntegrator::truncation_test(const Cloth& cloth, double alpha, bool trusted,
                                         double& last_move, double& rate) const {
  if (!(m_options.truncation_fraction > 0.0)) return false;
  double move = 0.0;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    move = std::max(move, m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).norm());
  }
  move *= alpha;
  if (last_move > 0.0) rate = std::max(0.3 * rate, move / last_move);
  last_move = move;
  return trusted && move * std::min(1.0, rate) <=
                        m_options.truncation_fraction * m_scheme->truncation_error(*this, cloth);
}

std::vector<std::string> ImplicitIntegrator::history_fields() const {
  std::vector<std::string> names;
  for (const auto& entry : m_history_arrays) names.push_back(entry.first);
  return names;
}

IntegratorHistory ImplicitIntegrator::history(const Cloth& cloth) const {
  IntegratorHistory out;
  out.valid = !m_history_arrays.empty() && m_history.matches(cloth);
  if (!out.valid) return out;
  out.dt = m_history.dt;
  for (const auto& [name, array] : m_history_arrays) out.arrays.emplace_back(name, *array);
  if (m_options.adaptive && m_scheme->multistep()) out.next_dt = m_history.proposal;
  return out;
}

void ImplicitIntegrator::set_projection_memory(const ProjectionMemory& memory) {
  if (memory.exact_skip < 0 || memory.exact_skip > kMaxExactBackoff || memory.exact_backoff < 1 ||
      memory.exact_backoff > kMaxExactBackoff) {
    std::ostringstream msg;
    msg << "projection memory must have exact_skip in [0, " << kMaxExactBackoff
        << "] and exact_backoff in [1, " << kMaxExactBackoff << "], got " << memory.exact_skip
        << " and " << memory.exact_backoff;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(memory.shift) || memory.shift < 0.0 || memory.shift > kMaxShift) {
    std::ostringstream msg;
    msg << "projection memory must have shift in [0, " << kMaxShift << "], got " << memory.shift;
    throw std::invalid_argument(msg.str());
  }
  m_exact_skip = memory.exact_skip;
  m_exact_backoff = memory.exact_backoff;
  m_shift = memory.shift;
  if (!std::isfinite(memory.radius) || memory.radius < 0.0) {
    std::ostringstream msg;
    msg << "projection memory must have a finite radius >= 0, got " << memory.radius;
    throw std::invalid_argument(msg.str());
  }
  m_radius = memory.radius;
}

void ImplicitIntegrator::set_history(const Cloth& cloth, const IntegratorHistory& history) {
  check_history(cloth, history);
  if (!history.valid) {
    m_history.valid = false;
    return;
  }
  for (const auto& [name, array] : m_history_arrays) *array = history.array(name);
  if (m_scheme->multistep()) m_history.proposal = history.next_dt;
  m_history.dt = history.dt;
  m_history.topology = cloth.topology_version();
  m_history.edits = cloth.edit_count();
  m_history.valid = true;
}

void ImplicitIntegrator::advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) {
  const char* name = m_options.minimizer == ImplicitMinimizer::lbfgs
                         ? "quasi-newton"
                         : time_scheme(m_options.method).integrator;
  const Remedy remedy =
      m_options.minimizer == ImplicitMinimizer::lbfgs ? Remedy::quasi_newton : Remedy::newton;
  if (steps > 0) keep_memory();
  advance_checked(
      cloth, gravity, dt, steps, m_monitor, {name, remedy}, m_checkpoint_positions,
      m_checkpoint_velocities,
      [&] {
        if (m_options.adaptive) {
          adaptive_interval(cloth, gravity, dt);
        } else {
          step(cloth, gravity, dt);
        }
      },
      [&] { return m_statistics.steps - 1; }, [&] { restore_memory(); });
}

void ImplicitIntegrator::keep_memory() {
  Memory& k = m_memory;
  // the scheme's history arrays (assignment reuses their storage)
  k.history.resize(m_history_arrays.size());
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a)
    k.history[a] = *m_history_arrays[a].second;
  k.key = m_history;
  k.exact_skip = m_exact_skip;
  k.exact_backoff = m_exact_backoff;
  k.lag_skip = m_lag_skip;
  k.lag_backoff = m_lag_backoff;
  k.shift = m_shift;
  k.radius = m_radius;
}

void ImplicitIntegrator::restore_memory() {
  const Memory& k = m_memory;
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a)
    *m_history_arrays[a].second = k.history[a];
  m_history = k.key;
  m_exact_skip = k.exact_skip;
  m_exact_backoff = k.exact_backoff;
  m_lag_skip = k.lag_skip;
  m_lag_backoff = k.lag_backoff;
  m_shift = k.shift;
  m_radius = k.radius;
  m_factor_valid = false;  // lagged mode: the kept factor is of a later matrix
}

}  // namespace yore
