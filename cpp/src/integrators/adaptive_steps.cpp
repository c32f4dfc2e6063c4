/// @file adaptive_steps.cpp
/// Error control (dt = "auto") around any time scheme with an error estimate: ImplicitIntegrator's
/// output intervals in steps chosen by the scheme's local truncation error (TR-BDF2's embedded
/// pair, variable-step BDF2's divided difference).

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "yore/integrators/implicit.hpp"
#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"

namespace yore {

namespace {
// An output interval that needs more than max_steps steps, or a step below 1e-12 dt: the
// error naming the tolerance and what to change.
[[noreturn]] void throw_interval_failure(const Cloth& cloth, const ImplicitOptions& options,
                                         const char* name, double dt, double step_size,
                                         bool over_budget, std::int64_t steps_done) {
  std::ostringstream msg;
  msg << "simulation diverged at t = " << cloth.time() << " s (output interval dt = " << dt
      << " s, " << name << " with dt = \"auto\"): "
      << (over_budget ? "more than max_steps = " + std::to_string(options.max_steps) +
                            " steps in one output interval"
                      : std::string("the step fell below 1e-12 dt"))
      << "; the last step tried was " << step_size << " s, tolerance rtol = " << options.rtol
      << ", atol = " << options.atol
      << ". Loosen the tolerance, raise max_steps, or check the forces.";
  throw SimulationDiverged(msg.str(), steps_done, cloth.time(), dt, step_size);
}
}  // namespace

void ImplicitIntegrator::adaptive_interval(Cloth& cloth, const Vec3& gravity, double dt) {
  // The interval's end on the clock the fixed-step integrators keep (origin + k dt): the
  // substeps move the clock by their own sizes, and it is set to this at the end, so frames
  // land exactly where they would with fixed steps.
  SimulationClock end = cloth.clock();
  if (end.dt != dt) end = SimulationClock{end.time(), 0, dt};
  ++end.steps;
  const double end_time = end.time();
  prepare(cloth);
  // The proposal carried from the last interval (a multistep scheme's next_dt, else the
  // history's dt); afresh: a tenth of dt.
  const bool multistep = m_scheme->multistep();
  const double carried = multistep ? m_history.proposal : m_history.dt;
  double h = m_history.matches(cloth) && carried > 0.0 ? carried : 0.1 * dt;
  const double most = m_scheme->max_step_growth();
  int taken = 0;
  while (true) {
    const double remaining = end_time - cloth.time();
    if (remaining <= 1e-12 * dt) break;
    // Steps spread evenly over what is left, none longer than the proposal.
    const double pieces = std::ceil(remaining / h * (1.0 - 1e-12));
    const double step_size = remaining / std::max(pieces, 1.0);
    if (++taken > options().max_steps || !(step_size > 1e-12 * dt)) {
      throw_interval_failure(cloth, options(), time_scheme(options().method).integrator, dt,
                             step_size, taken > options().max_steps, m_newton.statistics().steps);
    }
    poll_interrupt();
    // What a rejected step must give back: the state, the clock and the history.
    keep_step_state(cloth);
    const SimulationClock clock = cloth.clock();
    const HistoryKey key = m_history;
    const double tolerance = step_tolerance(cloth);

    step(cloth, gravity, step_size, /*state_kept=*/true);
    const double error = m_newton.statistics().last_truncation_error;
    const double ratio =
        std::isfinite(error) ? error / tolerance : std::numeric_limits<double>::infinity();
    // The estimate is of the local error, O(h³): the step that meets the tolerance with a
    // margin of 0.9 is h (tol/err)^(1/3), changed by at most `most` up and 5× down per step.
    const double factor = ratio > 0.0 ? std::clamp(0.9 * std::cbrt(1.0 / ratio), 0.2, most) : most;
    if (ratio <= 1.0) {
      h = step_size * factor;
      continue;
    }
    ++m_newton.statistics().rejected_steps;
    restore_step_state(cloth);
    cloth.set_clock(clock);
    m_history = key;
    h = step_size * std::min(factor, 0.9);
  }
  cloth.set_clock(end);
  cloth.apply_drivers(end_time);
  // The proposal, saved and restored with the history: a multistep scheme's next_dt (its dt
  // stays the last step, which its next blend needs), else the history's dt.
  (multistep ? m_history.proposal : m_history.dt) = h;
  ++m_newton.statistics().intervals;
}

void ImplicitIntegrator::keep_step_state(const Cloth& cloth) {
  const Eigen::Index n = cloth.vertex_count();
  if (m_step_positions.rows() != n) {
    m_step_positions.resize(n, 3);
    m_step_velocities.resize(n, 3);
  }
  m_step_history.resize(m_history_arrays.size());
  m_step_positions = cloth.positions();
  m_step_velocities = cloth.velocities();
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a) {
    m_step_history[a] = *m_history_arrays[a].second;  // same shape: no allocation
  }
}

void ImplicitIntegrator::restore_step_state(Cloth& cloth) {
  cloth.integrator_positions() = m_step_positions;
  cloth.integrator_velocities() = m_step_velocities;
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a) {
    *m_history_arrays[a].second = m_step_history[a];
  }
}

double ImplicitIntegrator::step_tolerance(const Cloth& cloth) const {
  // atol + rtol × the largest |coordinate| of a free vertex
  double largest = 0.0;
  for (const std::int32_t i : m_newton.free_vertices()) {
    largest = std::max(largest, cloth.positions().row(i).cwiseAbs().maxCoeff());
  }
  return options().atol + options().rtol * largest;
}

}  // namespace yore
