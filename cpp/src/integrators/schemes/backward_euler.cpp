/// @file backward_euler.cpp
/// Backward Euler: one stage per step, h̃ = h_v = h, x̄ = xₙ, x̂ = xₙ + h vₙ; first order,
/// L-stable, dissipative. Its stage is also the first step of the schemes that keep a history
/// (BDF2, generalized-α, TR-BDF2), so its pieces are free functions of time_scheme.hpp.

#include <algorithm>
#include <memory>

#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/time_scheme.hpp"

namespace yore {

double backward_euler_error(const StageSolver& solver) {
  // x⁺ − x̂ = h² a⁺ and the local error is ½ h² ẍ.
  const Positions& x = solver.solution();
  const Positions& target = solver.stage().target;
  double largest = 0.0;
  for (const std::int32_t i : solver.free_vertices()) {
    largest = std::max(largest, 0.5 * (x.row(i) - target.row(i)).norm());
  }
  return largest;
}

void backward_euler_step(StageSolver& solver, Cloth& cloth, double dt) {
  solver.pose_backward_euler(cloth, dt);
  const double new_time = cloth.advance_time(dt);
  cloth.apply_drivers(new_time);
  solver.solve(cloth);
  solver.write(cloth);
}

void stage_accelerations(const StageSolver& solver, Positions& into) {
  const Stage& stage = solver.stage();
  const Positions& x = solver.solution();
  for (const std::int32_t i : solver.free_vertices()) {
    into.row(i) = (x.row(i) - stage.target.row(i)) / (stage.h * stage.h);
  }
}

namespace {

class BackwardEuler final : public TimeScheme {
 public:
  void resize(Eigen::Index, bool) override {}
  bool step(StageSolver& solver, Cloth& cloth, double dt, const HistoryKey&) override {
    backward_euler_step(solver, cloth, dt);
    return false;  // no history
  }
  double truncation_error(const StageSolver& solver, const Cloth&) const override {
    return backward_euler_error(solver);
  }
  std::vector<std::pair<std::string, Positions*>> history() override { return {}; }
};

}  // namespace

std::unique_ptr<TimeScheme> make_backward_euler(const ImplicitOptions&) {
  return std::make_unique<BackwardEuler>();
}

}  // namespace yore
