/// @file tr_bdf2.cpp
/// The TR-BDF2 scheme (Bank et al. 1985; Hosea & Shampine 1996): the
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
/// (TimeScheme::truncation_error).

#include <algorithm>
#include <cmath>
#include <memory>

#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/time_scheme.hpp"

namespace yore {
namespace {

// γ = 2 − √2: the one value for which both stages have the same h̃ (γh/2 = h(1 − γ)/(2 − γ)),
// so the trapezoidal and the BDF2 stage share one iteration matrix M/h̃² + D/h̃ + K.
const double kGamma = 2.0 - 1.4142135623730950488;

class TrBdf2 final : public TimeScheme {
 public:
  void resize(Eigen::Index n, bool clear) override {
    m_start_positions.setZero(n, 3);
    m_start_velocities.setZero(n, 3);
    m_mid_velocities.setZero(n, 3);
    if (clear) m_force_acceleration.setZero(n, 3);
  }
  bool step(StageSolver& solver, Cloth& cloth, double dt, const HistoryKey& history) override;
  double truncation_error(const StageSolver& solver, const Cloth& cloth) const override;
  std::vector<std::pair<std::string, Positions*>> history() override {
    return {{"accelerations", &m_force_acceleration}};
  }
  bool error_estimate() const override { return true; }

 private:
  enum class Kind { backward_euler, trapezoid, bdf2 };
  Kind m_kind = Kind::backward_euler;  // the stage being solved
  double m_dt = 0.0;
  // a₀ (the history), the step's start (x₀, v₀) and the first stage's velocities
  Positions m_force_acceleration, m_start_positions, m_start_velocities, m_mid_velocities;
};

bool TrBdf2::step(StageSolver& solver, Cloth& cloth, double dt, const HistoryKey& history) {
  if (!history.matches(cloth)) {
    // A start far from equilibrium is a stiff transient the trapezoidal stage carries on
    // undamped; backward Euler removes it in one step, and its accelerations start a₀.
    m_kind = Kind::backward_euler;
    solver.count_restart();
    backward_euler_step(solver, cloth, dt);
    stage_accelerations(solver, m_force_acceleration);
    return true;
  }
  const double gamma = kGamma;
  Stage& stage = solver.stage();
  m_dt = dt;
  stage.h = stage.hv = 0.5 * gamma * dt;
  m_start_positions = cloth.positions();  // same shape: no allocation
  m_start_velocities = cloth.velocities();

  // The trapezoidal stage to tₙ + γh.
  m_kind = Kind::trapezoid;
  stage.trapezoid = true;
  for (const std::int32_t i : solver.free_vertices()) {
    stage.anchor.row(i) = m_start_positions.row(i) + stage.h * m_start_velocities.row(i);
    stage.target.row(i) = stage.anchor.row(i) + stage.h * (m_start_velocities.row(i) +
                                                           stage.h * m_force_acceleration.row(i));
  }
  const bool extrapolate = solver.extrapolating();
  if (extrapolate) {
    stage.acceleration = m_force_acceleration;  // a₀ held for a_γ; same shape: no allocation
    stage.extrapolated = true;
  }
  const double start_time = cloth.time();
  const double new_time = cloth.advance_time(dt);
  cloth.apply_drivers(start_time + gamma * dt);
  solver.finish_setup(cloth);
  solver.solve(cloth);
  solver.write(cloth);
  m_mid_velocities = cloth.velocities();
  if (extrapolate) {
    // a_γ as the stage solved for it, (x_γ − x̂)/h̃², held for a₁
    stage_accelerations(solver, stage.acceleration);
    stage.extrapolated = true;
  }

  // The BDF2 stage through xₙ, x_γ and xₙ₊₁.
  m_kind = Kind::bdf2;
  const double blend_mid = 1.0 / (gamma * (2.0 - gamma));
  const double blend_start = (1.0 - gamma) * (1.0 - gamma) / (gamma * (2.0 - gamma));
  const Positions& x = cloth.positions();
  for (const std::int32_t i : solver.free_vertices()) {
    stage.anchor.row(i) = blend_mid * x.row(i) - blend_start * m_start_positions.row(i);
    stage.target.row(i) = stage.anchor.row(i) + stage.h * (blend_mid * m_mid_velocities.row(i) -
                                                           blend_start * m_start_velocities.row(i));
  }
  cloth.apply_drivers(new_time);
  solver.finish_setup(cloth);
  solver.solve(cloth);
  solver.write(cloth);
  stage_accelerations(solver, m_force_acceleration);
  return true;
}

double TrBdf2::truncation_error(const StageSolver& solver, const Cloth&) const {
  if (m_kind == Kind::backward_euler) return backward_euler_error(solver);
  // The trapezoidal stage (length γh = 2h̃): (γh)³ x'''/12 with γh x''' ≈ a⁺ − a₀,
  // a⁺ = (v⁺ − v̄)/h̃. The BDF2 stage: the embedded estimate of the whole step (Bank et al.
  // 1985; Hosea & Shampine 1996), 2|k| h |v₀/γ − v_γ/(γ(1 − γ)) + v⁺/(1 − γ)|, k =
  // (−3γ² + 4γ − 2)/(12(2 − γ)), which is |k| h³ x''' to leading order.
  const Stage& stage = solver.stage();
  const Positions& x = solver.solution();
  double largest = 0.0;
  for (const std::int32_t i : solver.free_vertices()) {
    double error = 0.0;
    const Vec3 next = (x.row(i) - stage.anchor.row(i)).transpose() / stage.hv;
    if (m_kind == Kind::trapezoid) {
      const Vec3 blended = (stage.target.row(i) - stage.anchor.row(i)).transpose() / stage.h;
      const Vec3 acceleration = (next - blended) / stage.h;
      const double length = 2.0 * stage.h;  // γh
      error =
          length * length / 12.0 * (acceleration - m_force_acceleration.row(i).transpose()).norm();
    } else {
      const double gamma = kGamma;
      const double k = (-3.0 * gamma * gamma + 4.0 * gamma - 2.0) / (12.0 * (2.0 - gamma));
      const Vec3 combination = m_start_velocities.row(i).transpose() / gamma -
                               m_mid_velocities.row(i).transpose() / (gamma * (1.0 - gamma)) +
                               next / (1.0 - gamma);
      error = 2.0 * std::abs(k) * m_dt * combination.norm();
    }
    largest = std::max(largest, error);
  }
  return largest;
}

}  // namespace

std::unique_ptr<TimeScheme> make_tr_bdf2(const ImplicitOptions&) {
  return std::make_unique<TrBdf2>();
}

}  // namespace yore
