/// @file generalized_alpha.cpp
/// The generalized-α step of ImplicitIntegrator (Chung & Hulbert 1993), in the form of Arnold &
/// Brüls (2007): the true accelerations ẍ = M⁻¹f(x, v) satisfy the equations of motion at every
/// step, and the algorithmic accelerations a, a filtered copy of them, drive Newmark's update:
///   (1 − α_m) aₙ₊₁ + α_m aₙ = (1 − α_f) ẍₙ₊₁ + α_f ẍₙ,
///   xₙ₊₁ = xₙ + h vₙ + h² ((½ − β) aₙ + β aₙ₊₁),   vₙ₊₁ = vₙ + h ((1 − γ) aₙ + γ aₙ₊₁).
/// Eliminating aₙ₊₁ and ẍₙ₊₁ leaves one nonlinear system in xₙ₊₁ of the incremental-potential
/// form every Newton step of yore minimises: M (x − x̂)/h̃² = f(x, (x − x̄)/h_v) with
///   x_pred = xₙ + h vₙ + (½ − β) h² aₙ,   h̃² = β h² (1 − α_f)/(1 − α_m),
///   x̂ = x_pred − h̃² (α_m aₙ − α_f ẍₙ)/(1 − α_f),
///   h_v = β h/γ,   x̄ = x_pred − h_v (vₙ + (1 − γ) h aₙ),
/// so the same Newton, line search, projections and CHOLMOD factor serve it. On a linear
/// problem this is Chung & Hulbert's method exactly (second order, unconditionally stable,
/// spectral radius ρ∞ at infinite frequency). aₙ and ẍₙ are the method's memory (the history a
/// state file keeps): ẍₙ₊₁ is taken from the solve, (xₙ₊₁ − x̂)/h̃², not from f at xₙ₊₁, so
/// Newton's error stays a position error instead of becoming a stiff force error. The first
/// step, and the first after a stroke or an edit, is backward Euler's (as BDF2's), and its
/// accelerations as solved for start both.

#include <cmath>

#include "implicit_detail.hpp"
#include "yore/implicit.hpp"

namespace yore {

void ImplicitIntegrator::step_generalized_alpha(Cloth& cloth, const Vec3& gravity, double dt) {
  const double rho = m_options.rho_infinity;
  const double alpha_m = (2.0 * rho - 1.0) / (rho + 1.0);
  const double alpha_f = rho / (rho + 1.0);
  const double gamma = 0.5 - alpha_m + alpha_f;
  const double beta = 0.25 * (1.0 - alpha_m + alpha_f) * (1.0 - alpha_m + alpha_f);
  if (!history_matches(cloth)) {
    restart_with_backward_euler(cloth, gravity, dt);
    return;
  }
  m_gravity = gravity;
  m_dt = dt;
  m_second_order = false;
  m_stage = StageKind::generalized_alpha;
  const Positions& x = cloth.positions();
  const Positions& v = cloth.velocities();
  m_beta_h2 = beta * dt * dt;
  m_error_constant = std::abs(beta - 1.0 / 6.0) * dt * dt;
  m_h = dt * std::sqrt(beta * (1.0 - alpha_f) / (1.0 - alpha_m));
  m_hv = dt * beta / gamma;
  const double blend = m_h * m_h / (1.0 - alpha_f);
  for (const std::int32_t i : m_free_vertices) {
    m_predicted.row(i) = x.row(i) + dt * v.row(i) + (0.5 - beta) * dt * dt * m_acceleration.row(i);
    m_target.row(i) = m_predicted.row(i) - blend * (alpha_m * m_acceleration.row(i) -
                                                    alpha_f * m_force_acceleration.row(i));
    m_anchor.row(i) =
        m_predicted.row(i) - m_hv * (v.row(i) + (1.0 - gamma) * dt * m_acceleration.row(i));
  }
  if (m_options.predictor == NewtonPredictor::extrapolated) {
    m_stage_acceleration = m_force_acceleration;  // ẍₙ held for ẍₙ₊₁; no allocation
    m_stage_extrapolated = true;
  }
  const double new_time = cloth.advance_time(dt);
  cloth.apply_drivers(new_time);
  finish_stage_setup(cloth);

  int iterations = 0, backtracks = 0;
  solve_stage(cloth, iterations, backtracks);
  write_stage(cloth);
  for (const std::int32_t i : m_free_vertices) {
    m_acceleration.row(i) = (m_iterate.row(i) - m_predicted.row(i)) / m_beta_h2;
  }
  keep_stage_accelerations();
  finish_step(cloth, dt, true, iterations, backtracks);
}

}  // namespace yore
