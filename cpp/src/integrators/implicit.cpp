/// @file implicit.cpp
/// ImplicitIntegrator (implicit.hpp): the open choices decided (resolve_choices), the scheme
/// and its history between steps, one step, and what an interrupted call gives back. Newton
/// is NewtonSolver's (newton_solver.cpp); error control is adaptive_steps.cpp.

#include "yore/integrators/implicit.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "yore/platform/errors.hpp"

namespace yore {

namespace {

// The scheme's options and error control's (`estimate`: the scheme estimates its error, which
// error control needs).
void check_scheme_options(const ImplicitOptions& options, bool estimate) {
  if (!std::isfinite(options.rho_infinity) || options.rho_infinity < 0.0 ||
      options.rho_infinity > 1.0) {
    std::ostringstream msg;
    msg << "rho_infinity must be finite and in [0, 1], got " << options.rho_infinity;
    throw std::invalid_argument(msg.str());
  }
  if (options.adaptive && (!estimate || options.minimizer != ImplicitMinimizer::newton)) {
    throw std::invalid_argument(
        "error-controlled steps (adaptive, dt = \"auto\") need a "
        "local error estimate: method tr-bdf2 or bdf2, with Newton");
  }
  if (!(options.rtol > 0.0) || !(options.rtol < 1.0) || !(options.atol > 0.0) ||
      !std::isfinite(options.atol) || options.max_steps < 1) {
    throw std::invalid_argument("rtol must be in (0, 1), atol finite and > 0, max_steps >= 1");
  }
}

// The scheme of `options`, after its options are checked.
std::unique_ptr<TimeScheme> checked_scheme(const ImplicitOptions& options) {
  std::unique_ptr<TimeScheme> scheme = time_scheme(options.method).make(options);
  check_scheme_options(options, scheme->error_estimate());
  return scheme;
}

const char* projection_name(HessianProjection projection) {
  switch (projection) {
    case HessianProjection::clamp:
      return "clamp";
    case HessianProjection::abs:
      return "abs";
    case HessianProjection::exact:
      return "exact";
    case HessianProjection::trust_region:
      return "trust-region";
    case HessianProjection::shifted:
      return "shifted";
    case HessianProjection::steihaug:
      return "steihaug";
  }
  return "clamp";
}

}  // namespace

ImplicitOptions resolve_choices(ImplicitOptions options, const ImplicitChoices& choices) {
  options.predictor = choices.predictor.value_or(options.linearized ? NewtonPredictor::start
                                                                    : NewtonPredictor::inertial);
  if (options.minimizer != ImplicitMinimizer::newton) return options;
  HessianProjection projection = HessianProjection::clamp;
  if (choices.projection) {
    projection = *choices.projection;
  } else if (choices.adaptive_projection) {
    projection = *choices.adaptive_projection ? HessianProjection::exact : HessianProjection::clamp;
  }
  if (choices.adaptive_projection && choices.projection &&
      *choices.adaptive_projection != (projection == HessianProjection::exact)) {
    throw std::invalid_argument(
        std::string("adaptive_projection=") + (*choices.adaptive_projection ? "True" : "False") +
        " contradicts projection='" + projection_name(projection) + "'; give one of them");
  }
  options.projection = projection;
  options.adaptive_projection = false;  // mapped into projection
  // the one linearized step is the same either way (to round-off)
  options.mixed =
      choices.mixed.value_or(projection == HessianProjection::clamp && !options.linearized);
  return options;
}

ImplicitIntegrator::ImplicitIntegrator(const ImplicitOptions& given)
    : m_scheme(checked_scheme(given)),
      m_newton(given),
      m_monitor(given.divergence_energy_factor, given.energy_growth_tolerance) {
  m_history_arrays = m_scheme->history();
  m_newton.set_scheme(m_scheme.get());
}

ImplicitIntegrator::~ImplicitIntegrator() = default;

void ImplicitIntegrator::prepare(const Cloth& cloth) {
  m_newton.ensure_structure(cloth);
  if (m_sized_topology == cloth.topology_version()) return;
  // A history restored by set_history for this very topology survives the first step's setup.
  const bool clear = m_history.topology != cloth.topology_version();
  m_scheme->resize(cloth.vertex_count(), clear);
  if (clear) m_history.valid = false;
  m_sized_topology = cloth.topology_version();
}

namespace {
// Newton's early stops (truncation and step tests) off for a scope.
class EarlyStopsOff {
 public:
  explicit EarlyStopsOff(NewtonSolver& newton) : m_newton(newton) {
    m_newton.set_early_stops(false);
  }
  ~EarlyStopsOff() { m_newton.set_early_stops(true); }
  EarlyStopsOff(const EarlyStopsOff&) = delete;
  EarlyStopsOff& operator=(const EarlyStopsOff&) = delete;

 private:
  NewtonSolver& m_newton;
};
}  // namespace

void ImplicitIntegrator::step(Cloth& cloth, const Vec3& gravity, double dt, bool state_kept) {
  prepare(cloth);
  // A step whose energy rises past the growth check's allowance is redone once with Newton's
  // early stops off (to the residual test): with damping and drag nothing feeds energy in, and
  // the rise comes from a stage stopped short of its solution (measured: BDF2 at 1/32 s on the
  // damped 64² sheet gains 0.15 J stopped at 0.1 of the truncation error, none at 0.01).
  const bool may_redo = m_newton.has_early_stops() && std::isfinite(m_monitor.allowance());
  if (may_redo && !state_kept) keep_step_state(cloth);
  const SimulationClock clock = cloth.clock();
  const HistoryKey key = m_history;
  const NewtonSolver::Decisions decisions = m_newton.decisions();
  m_newton.begin_step(cloth, gravity);
  bool history_valid = m_scheme->step(m_newton, cloth, dt, m_history);
  if (may_redo && m_monitor.would_gain(DivergenceMonitor::monitored_energy(cloth, gravity))) {
    restore_step_state(cloth);
    cloth.set_clock(clock);
    m_history = key;
    m_newton.restore_decisions(decisions);
    ++m_newton.statistics().energy_retries;
    const EarlyStopsOff tight(m_newton);  // on again however the redo ends (Ctrl-C included)
    m_newton.begin_step(cloth, gravity);
    history_valid = m_scheme->step(m_newton, cloth, dt, m_history);
  }
  finish_step(cloth, dt, history_valid);
}

void ImplicitIntegrator::finish_step(const Cloth& cloth, double dt, bool history_valid) {
  m_history.valid = history_valid;
  m_history.topology = cloth.topology_version();
  m_history.edits = cloth.edit_count();
  m_history.dt = dt;
  ImplicitStatistics& statistics = m_newton.statistics();
  ++statistics.steps;
  statistics.last_newton_iterations = m_newton.step_iterations();
  statistics.last_line_search_backtracks = m_newton.step_backtracks();
}

NewtonSystem ImplicitIntegrator::newton_system(const Cloth& cloth, const Vec3& gravity, double dt,
                                               const Positions& positions,
                                               HessianProjection projection) {
  return m_newton.newton_system(cloth, gravity, dt, positions, projection);
}

std::vector<std::string> ImplicitIntegrator::history_fields() const {
  std::vector<std::string> names;
  for (const auto& entry : m_history_arrays) names.push_back(entry.first);
  return names;
}

IntegratorHistory ImplicitIntegrator::history(const Cloth& cloth) const {
  IntegratorHistory out;
  out.valid = !m_history_arrays.empty() && m_history.matches(cloth);
  if (!out.valid) return out;
  out.dt = m_history.dt;
  for (const auto& [name, array] : m_history_arrays) out.arrays.emplace_back(name, *array);
  if (options().adaptive && m_scheme->multistep()) out.next_dt = m_history.proposal;
  return out;
}

void ImplicitIntegrator::set_history(const Cloth& cloth, const IntegratorHistory& history) {
  check_history(cloth, history);
  if (!history.valid) {
    m_history.valid = false;
    return;
  }
  for (const auto& [name, array] : m_history_arrays) *array = history.array(name);
  if (m_scheme->multistep()) m_history.proposal = history.next_dt;
  m_history.dt = history.dt;
  m_history.topology = cloth.topology_version();
  m_history.edits = cloth.edit_count();
  m_history.valid = true;
}

void ImplicitIntegrator::advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) {
  const char* name = options().minimizer == ImplicitMinimizer::lbfgs
                         ? integrator_name::kQuasiNewton
                         : time_scheme(options().method).integrator;
  const Remedy remedy =
      options().minimizer == ImplicitMinimizer::lbfgs ? Remedy::quasi_newton : Remedy::newton;
  if (steps > 0) keep_memory();
  advance_checked(
      cloth, gravity, dt, steps, m_monitor, {name, remedy}, m_checkpoint_positions,
      m_checkpoint_velocities,
      [&] {
        if (options().adaptive) {
          adaptive_interval(cloth, gravity, dt);
        } else {
          step(cloth, gravity, dt);
        }
      },
      [&] { return statistics().steps - 1; }, [&] { restore_memory(); });
}

void ImplicitIntegrator::keep_memory() {
  Memory& k = m_memory;
  // the scheme's history arrays (assignment reuses their storage)
  k.history.resize(m_history_arrays.size());
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a)
    k.history[a] = *m_history_arrays[a].second;
  k.key = m_history;
  k.decisions = m_newton.decisions();
}

void ImplicitIntegrator::restore_memory() {
  const Memory& k = m_memory;
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a)
    *m_history_arrays[a].second = k.history[a];
  m_history = k.key;
  m_newton.restore_decisions(k.decisions);
}

}  // namespace yore
