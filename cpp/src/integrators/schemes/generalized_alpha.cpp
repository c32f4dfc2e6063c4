/// @file generalized_alpha.cpp
/// The generalized-α scheme (Chung & Hulbert 1993), in the form of Arnold &
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

#include <algorithm>
#include <cmath>
#include <memory>

#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/time_scheme.hpp"

namespace yore {
namespace {

class GeneralizedAlpha final : public TimeScheme {
 public:
  explicit GeneralizedAlpha(const ImplicitOptions& options) : m_rho(options.rho_infinity) {}

  void resize(Eigen::Index n, bool clear) override {
    m_predicted.setZero(n, 3);
    if (!clear) return;
    m_acceleration.setZero(n, 3);
    m_force_acceleration.setZero(n, 3);
  }

  bool step(StageSolver& solver, Cloth& cloth, double dt, const HistoryKey& history) override;

  double truncation_error(const StageSolver& solver, const Cloth&) const override {
    if (m_restarting) return backward_euler_error(solver);
    // Newmark's estimate |β − 1/6| h² |aₙ₊₁ − aₙ| (Zienkiewicz & Xie 1991) on the algorithmic
    // accelerations, aₙ₊₁ = (x⁺ − x_pred)/(β h²).
    const Positions& x = solver.solution();
    double largest = 0.0;
    for (const std::int32_t i : solver.free_vertices()) {
      const Vec3 acceleration = (x.row(i) - m_predicted.row(i)).transpose() / m_beta_h2;
      largest = std::max(
          largest, m_error_constant * (acceleration - m_acceleration.row(i).transpose()).norm());
    }
    return largest;
  }

  std::vector<std::pair<std::string, Positions*>> history() override {
    return {{"accelerations", &m_acceleration}, {"force_accelerations", &m_force_acceleration}};
  }

 private:
  double m_rho;
  bool m_restarting = false;  // this step is backward Euler's (no history)
  // aₙ (algorithmic accelerations) and ẍₙ (true ones): the history; the Newmark predictor
  // x_pred, β h² and the error constant |β − 1/6| h²
  Positions m_acceleration, m_force_acceleration, m_predicted;
  double m_beta_h2 = 0.0, m_error_constant = 0.0;
};

bool GeneralizedAlpha::step(StageSolver& solver, Cloth& cloth, double dt,
                            const HistoryKey& history) {
  const double rho = m_rho;
  const double alpha_m = (2.0 * rho - 1.0) / (rho + 1.0);
  const double alpha_f = rho / (rho + 1.0);
  const double gamma = 0.5 - alpha_m + alpha_f;
  const double beta = 0.25 * (1.0 - alpha_m + alpha_f) * (1.0 - alpha_m + alpha_f);
  m_restarting = !history.matches(cloth);
  if (m_restarting) {
    // A start far from equilibrium (a gathered stiff cloth: compressed springs pushing with
    // k × 20 % of their length) is a stiff transient generalized-α carries on undamped and, on
    // nonlinear springs, amplifies; backward Euler removes it in one step.
    solver.count_restart();
    backward_euler_step(solver, cloth, dt);
    stage_accelerations(solver, m_force_acceleration);
    m_acceleration = m_force_acceleration;  // same shape: no allocation
    return true;
  }
  const Positions& x = cloth.positions();
  const Positions& v = cloth.velocities();
  Stage& stage = solver.stage();
  m_beta_h2 = beta * dt * dt;
  m_error_constant = std::abs(beta - 1.0 / 6.0) * dt * dt;
  stage.h = dt * std::sqrt(beta * (1.0 - alpha_f) / (1.0 - alpha_m));
  stage.hv = dt * beta / gamma;
  const double blend = stage.h * stage.h / (1.0 - alpha_f);
  for (const std::int32_t i : solver.free_vertices()) {
    m_predicted.row(i) = x.row(i) + dt * v.row(i) + (0.5 - beta) * dt * dt * m_acceleration.row(i);
    stage.target.row(i) = m_predicted.row(i) - blend * (alpha_m * m_acceleration.row(i) -
                                                        alpha_f * m_force_acceleration.row(i));
    stage.anchor.row(i) =
        m_predicted.row(i) - stage.hv * (v.row(i) + (1.0 - gamma) * dt * m_acceleration.row(i));
  }
  if (solver.extrapolating()) {
    stage.acceleration = m_force_acceleration;  // ẍₙ held for ẍₙ₊₁; no allocation
    stage.extrapolated = true;
  }
  const double new_time = cloth.advance_time(dt);
  cloth.apply_drivers(new_time);
  solver.finish_setup(cloth);
  solver.solve(cloth);
  solver.write(cloth);
  const Positions& solved = solver.solution();
  for (const std::int32_t i : solver.free_vertices()) {
    m_acceleration.row(i) = (solved.row(i) - m_predicted.row(i)) / m_beta_h2;
  }
  stage_accelerations(solver, m_force_acceleration);
  return true;
}

}  // namespace

std::unique_ptr<TimeScheme> make_generalized_alpha(const ImplicitOptions& options) {
  return std::make_unique<GeneralizedAlpha>(options);
}

}  // namespace yore
