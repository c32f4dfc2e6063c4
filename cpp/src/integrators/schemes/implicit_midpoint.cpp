/// @file implicit_midpoint.cpp
/// The implicit midpoint rule: xₙ₊₁ = xₙ + h v_m, vₙ₊₁ = vₙ + h M⁻¹f(x_m, v_m) at the midpoint
/// x_m = (xₙ + xₙ₊₁)/2, v_m = (vₙ + vₙ₊₁)/2. Second order, symplectic, A-stable with |R| = 1 on
/// the imaginary axis: no numerical damping, and on linear springs it conserves the energy
/// exactly (the long horizon's non-dissipative row). With x_m as the unknown it is one stage of
/// yore's form, M (x_m − x̂)/h̃² = f(x_m, (x_m − xₙ)/h̃) with h̃ = h/2 and x̂ = xₙ + h̃ vₙ: a
/// backward-Euler stage to the midpoint, then xₙ₊₁ = 2x_m − xₙ, vₙ₊₁ = 2v_m − vₙ. On stiff
/// nonlinear springs it keeps every frequency's oscillation (no L-stability), as the
/// trapezoidal rule does.
/// History: the midpoint acceleration a_m = (x_m − x̂)/h̃² as solved for, for the error estimate
/// (h³ x'''/12, the trapezoidal rule's constant, with h x''' ≈ the change of a_m between the
/// last two midpoints over their spacing) and the extrapolated predictor. The first step, and
/// the first after a stroke, an edit or a restore, has none (counted as a restart): its estimate
/// is 0, so Newton stops by its residual test alone there; the step itself needs no history.

#include <algorithm>
#include <memory>

#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/time_scheme.hpp"

namespace yore {
namespace {

class ImplicitMidpoint final : public TimeScheme {
 public:
  void resize(Eigen::Index n, bool clear) override {
    if (clear) m_acceleration.setZero(n, 3);
  }

  bool step(StageSolver& solver, Cloth& cloth, double dt, const HistoryKey& history) override {
    Stage& stage = solver.stage();
    m_dt = dt;
    m_previous_dt = history.matches(cloth) ? history.dt : 0.0;
    if (!(m_previous_dt > 0.0)) solver.count_restart();  // no history: the estimate begins afresh
    stage.h = stage.hv = 0.5 * dt;
    const Positions& x = cloth.positions();
    const Positions& v = cloth.velocities();
    for (const std::int32_t i : solver.free_vertices()) {
      stage.anchor.row(i) = x.row(i);
      stage.target.row(i) = x.row(i) + stage.h * v.row(i);
    }
    if (solver.extrapolating() && m_previous_dt > 0.0) {
      stage.acceleration = m_acceleration;  // the last midpoint's; same shape: no allocation
      stage.extrapolated = true;
    }
    const double start_time = cloth.time();
    const double new_time = cloth.advance_time(dt);
    cloth.apply_drivers(start_time + 0.5 * dt);
    solver.finish_setup(cloth);
    solver.solve(cloth);
    stage_accelerations(solver, m_acceleration);
    // From the midpoint to the step's end.
    const Positions& midpoint = solver.solution();
    Positions& positions = cloth.integrator_positions();
    Positions& velocities = cloth.integrator_velocities();
    for (const std::int32_t i : solver.free_vertices()) {
      const Vec3 start = positions.row(i).transpose();
      const Vec3 middle = midpoint.row(i).transpose();
      positions.row(i) = 2.0 * middle - start;
      velocities.row(i) = 2.0 * (middle - start) / stage.h - velocities.row(i).transpose();
    }
    cloth.apply_drivers(new_time);
    return true;
  }

  double truncation_error(const StageSolver& solver, const Cloth&) const override {
    if (!(m_previous_dt > 0.0)) return 0.0;  // no earlier midpoint: no estimate
    const Stage& stage = solver.stage();
    const Positions& x = solver.solution();
    const double spacing = 0.5 * (m_previous_dt + m_dt);  // between the two midpoints
    const double scale = m_dt * m_dt * m_dt / (12.0 * spacing);
    double largest = 0.0;
    for (const std::int32_t i : solver.free_vertices()) {
      const Vec3 acceleration = (x.row(i) - stage.target.row(i)).transpose() / (stage.h * stage.h);
      largest =
          std::max(largest, scale * (acceleration - m_acceleration.row(i).transpose()).norm());
    }
    return largest;
  }

  std::vector<std::pair<std::string, Positions*>> history() override {
    return {{"accelerations", &m_acceleration}};
  }

 private:
  double m_dt = 0.0, m_previous_dt = 0.0;  // this step; the last one (0: no history)
  Positions m_acceleration;                // the last midpoint's acceleration (the history)
};

}  // namespace

std::unique_ptr<TimeScheme> make_implicit_midpoint(const ImplicitOptions&) {
  return std::make_unique<ImplicitMidpoint>();
}

}  // namespace yore
