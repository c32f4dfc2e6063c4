/// @file newton_solver.cpp
/// NewtonSolver (newton_solver.hpp): its options, the stage's setup and solve that the time
/// schemes call (StageSolver), the line search, the stopping tests and the decisions kept
/// across steps. The structure and assembly are in assembly.cpp, the iterations and
/// projections in newton.cpp, quasi-Newton in quasi_newton.cpp.

#include "yore/integrators/newton_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "implicit_detail.hpp"
#include "yore/cloth/springs.hpp"

namespace yore {
using namespace implicit_detail;

namespace {

// Newton's values one by one (tolerances, counts), in the order their errors are reported.
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
  if (options.max_newton < 1) {
    std::ostringstream msg;
    msg << "max_newton must be >= 1, got " << options.max_newton;
    throw std::invalid_argument(msg.str());
  }
}

// Options that exclude one another (solvers, projections, factor policy).
void check_option_combinations(const ImplicitOptions& options) {
  if (options.lagged_factorization &&
      (options.linear_solver.solver == "pcg" || options.adaptive_projection)) {
    throw std::invalid_argument(
        "lagged factorization needs a Cholesky backend and the projected Hessian "
        "(adaptive_projection off)");
  }
  if (options.lag_max_cg_iterations < 1 || !(options.lag_cg_tol > 0.0)) {
    throw std::invalid_argument("lag_max_cg_iterations must be >= 1 and lag_cg_tol > 0");
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

NewtonSolver::NewtonSolver(const ImplicitOptions& given) : m_options(given) {
  if (m_options.adaptive_projection) m_options.projection = HessianProjection::exact;
  m_options.adaptive_projection = m_options.projection == HessianProjection::exact;
  const ImplicitOptions& options = m_options;
  check_option_values(options);
  check_option_combinations(options);
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

NewtonSolver::~NewtonSolver() = default;

const SolverStatistics& NewtonSolver::solver_statistics() const {
  if (m_scalar_solver) return m_scalar_solver->statistics();  // lbfgs: Q's factor
  return m_solver->statistics();
}

void NewtonSolver::begin_step(const Cloth& cloth, const Vec3& gravity) {
  // The stopping tests' length scale follows the rest lengths every step: a growth stroke
  // changes them without changing the topology, and a scale kept from before it made a run
  // resumed after the stroke stop Newton elsewhere than the straight run (issue 53, R05).
  const SpringSet& springs = cloth.springs();
  double rest_sum = 0.0;
  for (const double rest : springs.rest_length) rest_sum += rest;
  m_mean_rest_length = springs.size() ? rest_sum / static_cast<double>(springs.size()) : 1.0;
  m_gravity = gravity;
  m_step_iterations = m_step_backtracks = 0;
}

double NewtonSolver::truncation_error(const Cloth& cloth) const {
  return m_scheme ? m_scheme->truncation_error(*this, cloth)
                  : std::numeric_limits<double>::quiet_NaN();
}

void NewtonSolver::restore_decisions(const Decisions& decisions) {
  m_exact_skip = decisions.projection.exact_skip;
  m_exact_backoff = decisions.projection.exact_backoff;
  m_shift = decisions.projection.shift;
  m_radius = decisions.projection.radius;
  m_lag_skip = decisions.lag_skip;
  m_lag_backoff = decisions.lag_backoff;
  m_factor_valid = false;  // lagged mode: the kept factor is of a later matrix
}

void NewtonSolver::pose_backward_euler(const Cloth& cloth, double dt) {
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

void NewtonSolver::solve(const Cloth& cloth) {
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
    m_statistics.last_truncation_error = truncation_error(cloth);
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

void NewtonSolver::write(Cloth& cloth) {
  Positions& x = cloth.integrator_positions();
  Positions& v = cloth.integrator_velocities();
  for (const std::int32_t i : m_free_vertices) {
    x.row(i) = m_iterate.row(i);
    v.row(i) = (m_iterate.row(i) - m_stage.anchor.row(i)) / m_stage.hv;
  }
}

void NewtonSolver::finish_setup(const Cloth& cloth) {
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

double NewtonSolver::line_search(const Cloth& cloth, double energy, double slope, int& backtracks,
                                 double& trial_energy, bool trial_gradient) {
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

NewtonSolver::IterationVerdict NewtonSolver::verdict(double energy, double residual,
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

bool NewtonSolver::truncation_test(const Cloth& cloth, double alpha, bool trusted,
                                   double& last_move, double& rate) const {
  if (!m_early_stops || !(m_options.truncation_fraction > 0.0)) return false;
  double move = 0.0;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    move = std::max(move, m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).norm());
  }
  move *= alpha;
  if (last_move > 0.0) rate = std::max(0.3 * rate, move / last_move);
  last_move = move;
  return trusted &&
         move * std::min(1.0, rate) <= m_options.truncation_fraction * truncation_error(cloth);
}

void NewtonSolver::set_projection_memory(const ProjectionMemory& memory) {
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

}  // namespace yore
