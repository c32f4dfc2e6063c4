/// @file tr_bdf2.cpp
/// The TR-BDF2 step of ImplicitIntegrator (Bank et al. 1985; Hosea & Shampine 1996): the
/// trapezoidal rule from tₙ to tₙ + γh, then BDF2 through xₙ, x_γ and xₙ₊₁, with γ = 2 − √2.
/// Both stages are systems M (x − x̂)/h̃² = f(x, (x − x̄)/h̃) with the same h̃ = γh/2:
///   trapezoid: x̄ = x₀ + h̃ v₀,  v̄ = v₀ + h̃ a₀ (a₀ = M⁻¹f(x₀, v₀)),  x̂ = x̄ + h̃ v̄;
///   BDF2:      x̄ = A x_γ − B x₀,  v̄ = A v_γ − B v₀,  x̂ = x̄ + h̃ v̄,
///              A = 1/(γ(2 − γ)), B = (1 − γ)²/(γ(2 − γ)),
/// so Newton minimises the same kind of incremental potential twice per step, on one pattern
/// and one symbolic analysis. L-stable and second order. a₀ is the acceleration the last step's
/// second stage solved for, (xₙ − x̂)/h̃², as stiffly accurate Runge–Kutta codes reuse their
/// last stage's derivative: re-evaluated at the inexact xₙ it would turn Newton's error δ into
/// a force error kδ that the trapezoidal stage passes on undamped. That a₀ is the history a
/// state file keeps; the first step, and the first after a stroke or an edit, is backward
/// Euler's (as BDF2's), whose accelerations as solved for start it.
/// The second stage's truncation error is the method's embedded estimate of the whole step
/// (ImplicitIntegrator::truncation_error).

#include <algorithm>
#include <cmath>
#include <sstream>

#include "implicit_detail.hpp"
#include "yore/errors.hpp"
#include "yore/implicit.hpp"
#include "yore/interrupt.hpp"

namespace yore {
using implicit_detail::kTrBdf2Gamma;

void ImplicitIntegrator::step_tr_bdf2(Cloth& cloth, const Vec3& gravity, double dt) {
  if (!history_matches(cloth)) {
    restart_with_backward_euler(cloth, gravity, dt);
    return;
  }
  const double gamma = kTrBdf2Gamma;
  m_gravity = gravity;
  m_dt = dt;
  m_second_order = false;
  m_h = m_hv = 0.5 * gamma * dt;
  m_start_positions = cloth.positions();  // same shape: no allocation
  m_start_velocities = cloth.velocities();

  // The trapezoidal stage to tₙ + γh.
  m_stage = StageKind::trapezoid;
  for (const std::int32_t i : m_free_vertices) {
    m_anchor.row(i) = m_start_positions.row(i) + m_h * m_start_velocities.row(i);
    m_target.row(i) =
        m_anchor.row(i) + m_h * (m_start_velocities.row(i) + m_h * m_force_acceleration.row(i));
  }
  const bool extrapolate = m_options.predictor == NewtonPredictor::extrapolated;
  if (extrapolate) {
    m_stage_acceleration = m_force_acceleration;  // a₀ held for a_γ; same shape: no allocation
    m_stage_extrapolated = true;
  }
  const double start_time = cloth.time();
  const double new_time = cloth.advance_time(dt);
  cloth.apply_drivers(start_time + gamma * dt);
  finish_stage_setup(cloth);
  int iterations = 0, backtracks = 0;
  solve_stage(cloth, iterations, backtracks);
  write_stage(cloth);
  m_mid_velocities = cloth.velocities();
  if (extrapolate) {
    // a_γ as the stage solved for it, (x_γ − x̂)/h̃², held for a₁
    for (const std::int32_t i : m_free_vertices) {
      m_stage_acceleration.row(i) = (m_iterate.row(i) - m_target.row(i)) / (m_h * m_h);
    }
    m_stage_extrapolated = true;
  }

  // The BDF2 stage through xₙ, x_γ and xₙ₊₁.
  m_stage = StageKind::tr_bdf2;
  const double blend_mid = 1.0 / (gamma * (2.0 - gamma));
  const double blend_start = (1.0 - gamma) * (1.0 - gamma) / (gamma * (2.0 - gamma));
  const Positions& x = cloth.positions();
  for (const std::int32_t i : m_free_vertices) {
    m_anchor.row(i) = blend_mid * x.row(i) - blend_start * m_start_positions.row(i);
    m_target.row(i) = m_anchor.row(i) + m_h * (blend_mid * m_mid_velocities.row(i) -
                                               blend_start * m_start_velocities.row(i));
  }
  cloth.apply_drivers(new_time);
  finish_stage_setup(cloth);
  solve_stage(cloth, iterations, backtracks);
  write_stage(cloth);
  keep_stage_accelerations();
  finish_step(cloth, dt, true, iterations, backtracks);
}

// over 80 lines: the error-controlled loop of one output interval (propose, take, estimate,
// accept or restore state, clock and history) shares the proposal and the saved state across
// its stages; the controller reads best as the one loop it is.
void ImplicitIntegrator::adaptive_interval(Cloth& cloth, const Vec3& gravity, double dt) {
  // The interval's end on the clock the fixed-step integrators keep (origin + k dt): the
  // substeps move the clock by their own sizes, and it is set to this at the end, so frames
  // land exactly where they would with fixed steps.
  SimulationClock end = cloth.clock();
  if (end.dt != dt) end = SimulationClock{end.time(), 0, dt};
  ++end.steps;
  const double end_time = end.time();
  ensure_structure(cloth);
  // The proposal carried from the last interval (TR-BDF2: the history's dt; BDF2: its next_dt);
  // afresh: a tenth of dt.
  const bool bdf2 = m_options.method == ImplicitMethod::bdf2;
  const double carried = bdf2 ? m_history_proposal : m_history_dt;
  double h = history_matches(cloth) && carried > 0.0 ? carried : 0.1 * dt;
  const Eigen::Index n = cloth.vertex_count();
  if (m_step_positions.rows() != n) {
    m_step_positions.resize(n, 3);
    m_step_velocities.resize(n, 3);
    m_step_accelerations.resize(n, 3);
    m_step_previous_positions.resize(n, 3);
    m_step_previous_velocities.resize(n, 3);
  }
  const char* name = bdf2 ? "bdf2" : "tr-bdf2";
  // variable-step BDF2 is zero-stable for step ratios below 1 + √2: at most 2 per step
  const double most = bdf2 ? 2.0 : 5.0;
  int taken = 0;
  while (true) {
    const double remaining = end_time - cloth.time();
    if (remaining <= 1e-12 * dt) break;
    // Steps spread evenly over what is left, none longer than the proposal.
    const double pieces = std::ceil(remaining / h * (1.0 - 1e-12));
    const double step_size = remaining / std::max(pieces, 1.0);
    if (++taken > m_options.max_steps || !(step_size > 1e-12 * dt)) {
      std::ostringstream msg;
      msg << "simulation diverged at t = " << cloth.time() << " s (output interval dt = " << dt
          << " s, " << name << " with dt = \"auto\"): "
          << (taken > m_options.max_steps
                  ? "more than max_steps = " + std::to_string(m_options.max_steps) +
                        " steps in one output interval"
                  : std::string("the step fell below 1e-12 dt"))
          << "; the last step tried was " << step_size << " s, tolerance rtol = " << m_options.rtol
          << ", atol = " << m_options.atol
          << ". Loosen the tolerance, raise max_steps, or check the forces.";
      throw SimulationDiverged(msg.str(), m_statistics.steps, cloth.time(), dt, step_size);
    }
    poll_interrupt();
    // What a rejected step must give back: the state, the clock and the history.
    m_step_positions = cloth.positions();
    m_step_velocities = cloth.velocities();
    m_step_accelerations = m_force_acceleration;
    if (bdf2) {
      m_step_previous_positions = m_previous_positions;
      m_step_previous_velocities = m_previous_velocities;
    }
    const SimulationClock clock = cloth.clock();
    const bool history_valid = m_history_valid;
    const std::uint64_t history_topology = m_history_topology, history_edits = m_history_edits;
    const double history_dt = m_history_dt;
    double largest = 0.0;
    for (const std::int32_t i : m_free_vertices) {
      largest = std::max(largest, cloth.positions().row(i).cwiseAbs().maxCoeff());
    }
    const double tolerance = m_options.atol + m_options.rtol * largest;

    step(cloth, gravity, step_size);
    const double error = m_statistics.last_truncation_error;
    const double ratio =
        std::isfinite(error) ? error / tolerance : std::numeric_limits<double>::infinity();
    // The estimate is of the local error, O(h³): the step that meets the tolerance with a
    // margin of 0.9 is h (tol/err)^(1/3), changed by at most 5× up and 5× down per step.
    const double factor = ratio > 0.0 ? std::clamp(0.9 * std::cbrt(1.0 / ratio), 0.2, most) : most;
    if (ratio <= 1.0) {
      h = step_size * factor;
      continue;
    }
    ++m_statistics.rejected_steps;
    cloth.integrator_positions() = m_step_positions;
    cloth.integrator_velocities() = m_step_velocities;
    cloth.set_clock(clock);
    m_force_acceleration = m_step_accelerations;
    if (bdf2) {
      m_previous_positions = m_step_previous_positions;
      m_previous_velocities = m_step_previous_velocities;
    }
    m_history_valid = history_valid;
    m_history_topology = history_topology;
    m_history_edits = history_edits;
    m_history_dt = history_dt;
    h = step_size * std::min(factor, 0.9);
  }
  cloth.set_clock(end);
  cloth.apply_drivers(end_time);
  // The proposal, saved and restored with the history: TR-BDF2's dt; BDF2's next_dt (its dt
  // stays the last step, which its next blend needs).
  (bdf2 ? m_history_proposal : m_history_dt) = h;
  ++m_statistics.intervals;
}

}  // namespace yore
