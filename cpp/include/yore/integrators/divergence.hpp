#pragma once
/// @file divergence.hpp
/// The blow-up check shared by all integrators: a finite state whose energy stays below a bound.

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>

#include "yore/cloth/cloth.hpp"
#include "yore/platform/errors.hpp"

namespace yore {

/// Energy checks of a run. The monitored energy is the spring (and quadratic bending and
/// membrane) energy plus the kinetic and gravitational energy of the free vertices.
///
/// The divergence bound is its value at the baseline plus factor × E_scale, E_scale = kinetic +
/// spring + bending energy + M|g|D + ½M(ω_max D)² + ½Σ k L² + κ Σ_e 6|e|²/A_e (M total mass, D
/// bounding-box diagonal, ω_max the fastest driver, the last term quadratic bending with every
/// hinge folded flat): the energy at which every spring would be compressed to nothing and every
/// hinge folded, plus what gravity and drivers can legitimately feed in.
///
/// The growth check: with damping and drag ≥ 0 nothing but the drivers feeds energy in, so the
/// monitored energy may not rise above the lowest it reached since the baseline by more than
/// growth × (kinetic + elastic energy at the baseline + M|g|D), plus 1e-12 of (|baseline| +
/// E_scale) for round-off. Off while a driver turns: its work has no bound the monitor knows
/// (a rotating tube's twist stores elastic energy; the rotating cylinder's stroke scene rose
/// 3.5 J above its lowest, legitimately). Far below the divergence bound on stiff cloth (where ½Σ k
/// L² dominates E_scale), it catches an integrator that feeds energy in before the energy runs
/// away.
class DivergenceMonitor {
 public:
  /// factor > 0 (finite); growth >= 0 (finite; 0 turns the growth check off). Throws
  /// std::invalid_argument otherwise.
  explicit DivergenceMonitor(double factor = 10.0, double growth = 0.1);

  /// Takes a new baseline if the cloth was edited or its topology, g or dt changed since the last.
  void prepare(const Cloth& cloth, const Vec3& gravity, double dt);

  /// What a new state's monitored energy says.
  enum class Verdict { ok, past_bound, gained };

  /// Judges a state's monitored energy (finite) against the bound and the growth allowance;
  /// keeps the lowest energy and the largest rise above it.
  Verdict judge(double energy);
  /// Whether judge(energy) would say "gained" now (nothing kept): the implicit integrators
  /// redo such a step with Newton's early stops off before the call fails.
  bool would_gain(double energy) const {
    return energy <= m_limit && energy - std::min(m_lowest, energy) > m_allowance;
  }

  /// Monitored energy, J, above which the run counts as diverged.
  double limit() const { return m_limit; }
  /// Lowest monitored energy since the baseline, J.
  double lowest() const { return m_lowest; }
  /// Largest rise allowed above the lowest, J (infinity with the check off).
  double allowance() const { return m_allowance; }
  /// Puts back the lowest energy a call started with, when the call is undone (its states are
  /// gone, and so is what they reached).
  void restore_lowest(double lowest) { m_lowest = lowest; }
  /// Largest rise above the lowest seen by judge() over the monitor's life, J.
  double largest_gain() const { return m_largest_gain; }
  double growth() const { return m_growth; }

  /// Spring energy plus kinetic and gravitational energy of the free vertices, J.
  static double monitored_energy(const Cloth& cloth, const Vec3& gravity);

 private:
  double m_factor;
  double m_growth;
  double m_limit = 0.0;
  double m_lowest = std::numeric_limits<double>::infinity();
  double m_allowance = std::numeric_limits<double>::infinity();
  double m_largest_gain = 0.0;
  std::uint64_t m_topology = std::numeric_limits<std::uint64_t>::max();
  std::uint64_t m_edits = std::numeric_limits<std::uint64_t>::max();
  Vec3 m_gravity = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  double m_dt = 0.0;
};

/// What a failed run should change, by the kind of integrator that failed: each integrator
/// names its own kind, so the messages below never branch on an integrator's name.
enum class Remedy {
  stable_step,   ///< explicit: a dt under the stable-step bound, or an implicit integrator
  newton,        ///< yore's Newton integrators: a tighter Newton stop or a shorter dt
  quasi_newton,  ///< L-BFGS: a lower newton_tol or a shorter dt
  local_global,  ///< its tolerance or dt
  tolerance,     ///< SUNDIALS: rtol and atol, or max_dt
};

/// The integrator a failure message names: its public name (as yore.Simulation takes it) and
/// what to change when it fails.
struct IntegratorIdentity {
  const char* name;
  Remedy remedy;
};

/// Checks the arguments every integrator's advance() takes: dt finite and > 0 (s), gravity
/// finite, steps >= 0. Throws std::invalid_argument naming the bad one.
void check_advance_arguments(double dt, const Vec3& gravity, std::int64_t steps);

/// Runs `steps` calls of step(cloth) (each advancing the cloth by dt), checking the state after
/// each against the monitor (baselined here). On a blow-up, or on any exception from step(), the
/// cloth goes back to its state at the start (kept in the two checkpoint buffers, reused across
/// calls), on_restore() runs, and SimulationDiverged (naming step_index(), the failing step) or
/// the exception is thrown. Used by the implicit integrators; the explicit one fuses the check
/// into its own loop.
void advance_checked(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps,
                     DivergenceMonitor& monitor, IntegratorIdentity integrator,
                     Positions& checkpoint_positions, Positions& checkpoint_velocities,
                     const std::function<void()>& step,
                     const std::function<std::int64_t()>& step_index,
                     const std::function<void()>& on_restore);

/// The exception for a failed step: where it failed, why, and what the stability estimate says.
SimulationDiverged diverged_error(const Cloth& cloth, IntegratorIdentity integrator,
                                  std::int64_t step, double time, double dt, bool finite);

/// The exception for a step that gained energy (DivergenceMonitor::Verdict::gained): how much,
/// against what allowance, and what to change.
SimulationDiverged energy_gain_error(const Cloth& cloth, const DivergenceMonitor& monitor,
                                     double energy, IntegratorIdentity integrator,
                                     std::int64_t step, double time, double dt);

}  // namespace yore
