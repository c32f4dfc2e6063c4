/// @file bdf2.cpp
/// BDF2: x⁺ = x̄ + h̃ v⁺, v⁺ = v̄ + h̃ a⁺ with x̄, v̄ the blends (4·now − previous)/3 and
/// h̃ = 2h/3; variable steps (dt = "auto") blend with w = h/hₙ₋₁. Second order, L-stable; the
/// history is the state one step back, valid while nothing changed: the first step, and the
/// first after a stroke, an edit, a restore or (fixed steps) a change of dt, is backward Euler.

#include <algorithm>
#include <memory>

#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/time_scheme.hpp"

namespace yore {
namespace {

class Bdf2 final : public TimeScheme {
 public:
  explicit Bdf2(const ImplicitOptions& options) : m_adaptive(options.adaptive) {}

  void resize(Eigen::Index n, bool clear) override {
    if (!clear) return;
    m_previous_positions.setZero(n, 3);
    m_previous_velocities.setZero(n, 3);
  }

  bool step(StageSolver& solver, Cloth& cloth, double dt, const HistoryKey& history) override {
    // (fixed steps: BDF2 restarts when dt changes; error-controlled ones change it every step)
    m_second_order = history.matches(cloth) && (m_adaptive ? history.dt > 0.0 : history.dt == dt);
    if (!m_second_order) solver.count_restart();
    m_dt = dt;
    m_ratio = m_second_order ? dt / history.dt : 1.0;
    if (m_second_order) {
      pose(solver, cloth, dt, history.dt);
    } else {
      solver.pose_backward_euler(cloth, dt);
    }
    m_previous_positions = cloth.positions();  // same size: no allocation
    m_previous_velocities = cloth.velocities();
    const double new_time = cloth.advance_time(dt);
    cloth.apply_drivers(new_time);
    solver.solve(cloth);
    solver.write(cloth);
    return true;
  }

  double truncation_error(const StageSolver& solver, const Cloth& cloth) const override;

  std::vector<std::pair<std::string, Positions*>> history() override {
    return {{"positions", &m_previous_positions}, {"velocities", &m_previous_velocities}};
  }
  bool error_estimate() const override { return true; }
  bool multistep() const override { return true; }
  // variable-step BDF2 is zero-stable for step ratios below 1 + √2: at most 2 per step
  double max_step_growth() const override { return 2.0; }

 private:
  void pose(StageSolver& solver, const Cloth& cloth, double dt, double previous_dt);

  bool m_adaptive;
  bool m_second_order = false;  // this step is BDF2's (else backward Euler's)
  double m_dt = 0.0;
  // w = h / h_previous of the step being solved, and its blend x̄ = a xₙ − b xₙ₋₁,
  // a = (1 + w)²/(1 + 2w), b = w²/(1 + 2w), h̃ = h (1 + w)/(1 + 2w) (w = 1: 4/3, 1/3 and 2h/3,
  // computed as the fixed-step formulas always were).
  double m_ratio = 1.0, m_a = 4.0 / 3.0, m_b = 1.0 / 3.0;
  Positions m_previous_positions, m_previous_velocities;  // the history
};

void Bdf2::pose(StageSolver& solver, const Cloth& cloth, double dt, double previous_dt) {
  Stage& stage = solver.stage();
  const Positions& x = cloth.positions();
  const Positions& v = cloth.velocities();
  if (m_ratio == 1.0) {
    m_a = 4.0 / 3.0;
    m_b = 1.0 / 3.0;
    stage.h = 2.0 * dt / 3.0;
    stage.anchor = (4.0 * x - m_previous_positions) / 3.0;
    stage.target = stage.anchor + stage.h * (4.0 * v - m_previous_velocities) / 3.0;
  } else {
    // Variable-step BDF2 (dt = "auto"): the quadratic through xₙ₋₁, xₙ, x⁺ differentiated at
    // tₙ₊₁: a = (1 + w)²/(1 + 2w), b = w²/(1 + 2w) (a − b = 1), h̃ = h (1 + w)/(1 + 2w).
    const double w = m_ratio;
    m_a = (1.0 + w) * (1.0 + w) / (1.0 + 2.0 * w);
    m_b = w * w / (1.0 + 2.0 * w);
    stage.h = dt * (1.0 + w) / (1.0 + 2.0 * w);
    stage.anchor = m_a * x - m_b * m_previous_positions;
    stage.target = stage.anchor + stage.h * (m_a * v - m_b * m_previous_velocities);
  }
  stage.hv = stage.h;
  if (solver.extrapolating()) {
    // The last step's mean acceleration, from the history alone (a state file holds it).
    for (const std::int32_t i : solver.free_vertices()) {
      stage.acceleration.row(i) = (v.row(i) - m_previous_velocities.row(i)) / previous_dt;
    }
    stage.extrapolated = true;
  }
  // Damping directions of the inertial prediction x̂ (constrained vertices included: x̂ − x̄ is
  // their velocity times h̃ too), an O(h̃²) extrapolation of the end-of-step directions.
  solver.update_directions(cloth);
}

double Bdf2::truncation_error(const StageSolver& solver, const Cloth& cloth) const {
  if (!m_second_order) return backward_euler_error(solver);
  // (2/9) h³ x''' with h² x''' ≈ v⁺ − 2vₙ + vₙ₋₁, where v⁺ = (x⁺ − x̄)/h̃ and vₙ₋₁ comes back
  // from x̂ − x̄ = h̃ (4vₙ − vₙ₋₁)/3; vₙ is the cloth's velocity until the step ends.
  const Stage& stage = solver.stage();
  const Positions& x = solver.solution();
  const Positions& v = cloth.velocities();
  double largest = 0.0;
  for (const std::int32_t i : solver.free_vertices()) {
    double error = 0.0;
    const Vec3 next = (x.row(i) - stage.anchor.row(i)).transpose() / stage.hv;
    const Vec3 now = v.row(i).transpose();
    if (m_ratio == 1.0) {
      const Vec3 before =
          4.0 * now - 3.0 * (stage.target.row(i) - stage.anchor.row(i)).transpose() / stage.h;
      error = 2.0 / 9.0 * m_dt * (next - 2.0 * now + before).norm();
    } else {
      // Variable steps: the Taylor expansion of the blend gives the local error
      // (1 + w)²/(6w(1 + 2w)) h³ x⁽³⁾ (2/9 at w = 1), x⁽³⁾ = v'' from the divided difference
      // of vₙ₋₁, vₙ, v⁺ (vₙ₋₁ comes back from x̂ − x̄ = h̃ (a vₙ − b vₙ₋₁)).
      const double w = m_ratio, previous_h = m_dt / w;
      const Vec3 before =
          (m_a * now - (stage.target.row(i) - stage.anchor.row(i)).transpose() / stage.h) / m_b;
      const Vec3 curvature =
          2.0 * ((next - now) / m_dt - (now - before) / previous_h) / (m_dt + previous_h);
      error = (1.0 + w) * (1.0 + w) / (6.0 * w * (1.0 + 2.0 * w)) * m_dt * m_dt * m_dt *
              curvature.norm();
    }
    largest = std::max(largest, error);
  }
  return largest;
}

}  // namespace

std::unique_ptr<TimeScheme> make_bdf2(const ImplicitOptions& options) {
  return std::make_unique<Bdf2>(options);
}

}  // namespace yore
