#pragma once
/// @file explicit.hpp
/// Symplectic Euler for the mass-spring cloth: the reference integrator.

#include <cstdint>
#include <limits>

#include "yore/cloth/cloth.hpp"
#include "yore/integrators/divergence.hpp"
#include "yore/integrators/integrator.hpp"

namespace yore {

/// Settings of the explicit integrator.
struct ExplicitOptions {
  /// Provot strain limiting: largest allowed length / rest length of a structural spring after a
  /// step (e.g. 1.1). 0 turns it off (the default).
  double strain_limit = 0.0;
  /// Gauss–Seidel passes over the structural springs per step when strain limiting is on.
  int strain_limit_passes = 4;
  /// The run counts as diverged when its total energy rises by more than this many times the
  /// cloth's energy scale (see ExplicitIntegrator::advance).
  double divergence_energy_factor = 10.0;
  /// Largest rise of the energy above its lowest since the last change, in energy scales
  /// (DivergenceMonitor); 0 = no growth check, the default here: symplectic Euler keeps a
  /// modified energy, and the true one swings about it by up to 1/(1 − (ωh/2)²) of a mode's
  /// energy (25× at 0.98 of the stable step, a gathered cloth's first step +11 %), which no
  /// allowance tells from a gain. Its instabilities grow exponentially and cross the divergence
  /// bound within a few steps.
  double energy_growth_tolerance = 0.0;
};

/// Wall time per phase and counters, cumulative over the integrator's life.
struct ExplicitStatistics {
  std::int64_t steps = 0;
  double forces_seconds = 0.0;          ///< spring forces (elastic and damping) per spring
  double update_seconds = 0.0;          ///< per-vertex gather, gravity, drag, update, drivers
  double constraints_seconds = 0.0;     ///< strain limiting
  double checks_seconds = 0.0;          ///< divergence checks and checkpoints
  std::int64_t strain_corrections = 0;  ///< spring corrections made by strain limiting
  std::int64_t parallel_steps = 0;      ///< steps whose loops ran on more than one thread
  std::int64_t thread_probes = 0;       ///< blocks of steps run to re-time the other choice
  int last_step_threads = 0;            ///< threads the last step's loops ran on (0: no step)
};

/// Chooses, block of steps by block, whether the step's loops run on all the configured threads
/// or on one: whichever ran its last block faster per step, starting with one. The other choice
/// is re-timed after a wait that grows while it keeps losing and is at least kOverheadFactor ×
/// what the last re-timing lost, so re-timing costs a bounded fraction of the run. On a busy
/// machine a parallel region waits for its slowest, possibly descheduled, thread, and one
/// thread wins; on an idle one the parallel step does. The choice itself allocates nothing.
class StepThreadChooser {
 public:
  /// Threads for the next step: 1 or `configured` (>= 1).
  int threads_for_next_step(int configured);
  /// Records the wall time (s) of the step just run; returns true when it ended a re-timing
  /// block.
  bool record(double seconds);
  /// Threads the chooser currently prefers (0 before the first step).
  int preferred() const { return m_preferred; }

  /// A block lasts at least this long (s) and kMinBlockSteps steps, so that a timer tick or
  /// one interruption does not decide. A re-timing that is already 2× slower per step ends
  /// early.
  static constexpr double kBlockSeconds = 2e-3;
  static constexpr int kMinBlockSteps = 2;
  /// After a lost re-timing, the winner runs for at least kOverheadFactor × the time the
  /// re-timing lost (and at least twice the previous wait) before the loser is tried again:
  /// re-timings cost at most 1 / kOverheadFactor of the run, however long a step on a thread
  /// that the machine has descheduled takes.
  static constexpr double kOverheadFactor = 50.0;
  /// Longest wait between two re-timings of the losing choice, s.
  static constexpr double kMaxWaitSeconds = 30.0;

 private:
  int m_configured = 0;
  int m_preferred = 0;  // threads of the winning choice
  int m_running = 0;    // threads of the current block (the preferred or a probe)
  int m_block_steps = 0;
  double m_block_seconds = 0.0;
  double m_preferred_seconds_per_step = 0.0;  // of the preferred choice's last block
  double m_wait_seconds = 0.0;                // the winner's running time between re-timings
  double m_seconds_until_probe = 0.0;
};

/// Symplectic (semi-implicit) Euler: v⁺ = v + h M⁻¹ f(x, v), x⁺ = x + h v⁺, then optional strain
/// limiting with velocities recomputed from the corrected positions. Fixed vertices never move;
/// driven vertices follow their drivers exactly.
class ExplicitIntegrator : public Integrator {
 public:
  /// Throws std::invalid_argument on a negative or non-finite option.
  explicit ExplicitIntegrator(const ExplicitOptions& options = {});

  /// Runs `steps` steps of size dt (s) under gravity (m/s²). The energy is checked after every
  /// step (see DivergenceMonitor): a non-finite state or an energy past the bound throws
  /// SimulationDiverged and restores the cloth to its state at the start of this call.
  /// Throws std::invalid_argument on dt <= 0, non-finite dt or gravity, or steps < 0.
  void advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) override;

  /// The options this integrator was built with.
  const ExplicitOptions& options() const { return m_options; }
  /// Cumulative counters and wall time per phase.
  const ExplicitStatistics& statistics() const { return m_statistics; }
  /// The energy checks (their largest gain is reported as the energy_gain counter).
  const DivergenceMonitor& monitor() const { return m_monitor; }

 private:
  void prepare(const Cloth& cloth);
  double compute_spring_forces(const Cloth& cloth, int threads);
  void update_velocities_and_positions(Cloth& cloth, const Vec3& gravity, double dt, int threads);
  void limit_strain(Cloth& cloth);
  // advance's stages: Ctrl-C between steps (undoing the call); the forces and the
  // potentials' energy at the step's start; the velocities after the strain limit; kinetic
  // energy minus gravity's work (and the positions' sum) for the divergence check.
  void poll_interrupt_or_undo(Cloth& cloth, const SimulationClock& clock);
  double forces_and_energy(Cloth& cloth, int threads);
  void strain_limited_velocities(Cloth& cloth, double dt);
  double kinetic_and_gravity(const Cloth& cloth, const Vec3& gravity, int threads,
                             double& position_sum) const;

  ExplicitOptions m_options;
  ExplicitStatistics m_statistics;

  // Buffers sized once per topology; the step itself allocates nothing.
  Positions m_spring_forces;  // s×3, force on each spring's first end
  // n×3, the gradient of the energies that are not springs: κ Q x of quadratic bending and
  // the membrane's (when the cloth has them)
  Positions m_potential_gradient;
  MembraneElementWork m_membrane_work;  // scratch of the membrane's elements
  bool m_with_potentials = false;
  Positions m_previous_positions;
  Positions m_checkpoint_positions;
  Positions m_checkpoint_velocities;
  bool m_with_spring_damping = false;
  DivergenceMonitor m_monitor;
  double m_lowest_at_start = 0.0;  // the monitor's lowest energy when the call began
  /// Judges a step's monitored energy; on a blow-up or a gain restores the call's checkpoint and
  /// throws SimulationDiverged.
  void judge_or_restore(Cloth& cloth, bool finite, double energy, std::int64_t step, double time,
                        double dt, const SimulationClock& checkpoint_clock);
  StepThreadChooser m_thread_chooser;
};

}  // namespace yore
