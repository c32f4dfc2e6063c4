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

#include "implicit_detail.hpp"
#include "yore/implicit.hpp"

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
    m_target.row(i) = m_anchor.row(i) +
                      m_h * (m_start_velocities.row(i) + m_h * m_force_acceleration.row(i));
  }
  const double start_time = cloth.time();
  const double new_time = cloth.advance_time(dt);
  cloth.apply_drivers(start_time + gamma * dt);
  finish_stage_setup(cloth);
  int iterations = 0, backtracks = 0;
  solve_stage(cloth, iterations, backtracks);
  write_stage(cloth);
  m_mid_velocities = cloth.velocities();

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

}  // namespace yore
