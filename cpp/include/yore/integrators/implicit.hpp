#pragma once
/// @file implicit.hpp
/// The implicit integrator: a time scheme (time_scheme.hpp, cpp/src/integrators/schemes/)
/// whose stages Newton's method minimises (newton_solver.hpp), with the history between steps,
/// error control and the divergence checks.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/integrators/divergence.hpp"
#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/integrator.hpp"
#include "yore/integrators/newton_solver.hpp"
#include "yore/integrators/time_scheme.hpp"

namespace yore {

/// The options whose value a caller may leave open (std::nullopt) for yore to decide from the
/// others: resolve_choices is the one place that decides them (Python's
/// yore.options.resolve_options asks it).
struct ImplicitChoices {
  std::optional<bool> adaptive_projection;
  std::optional<HessianProjection> projection;
  std::optional<NewtonPredictor> predictor;
  std::optional<bool> mixed;
};

/// `options` with the open choices decided (the given ones kept):
/// - predictor: the start for the linearized step (Baraff–Witkin's), the inertial guess
///   otherwise;
/// - Newton's minimizer only: projection exact when adaptive_projection is true, else the
///   clamp (pcg and the linearized step need it; on stiff and buckling scenes it takes the
///   fewest iterations); mixed on with the clamp (it saves ~40 % of its iterations on stiff
///   sheets) unless linearized, off with the other projections. adaptive_projection is mapped
///   into projection and set false.
/// Throws std::invalid_argument when adaptive_projection and projection are both given and
/// disagree.
ImplicitOptions resolve_choices(ImplicitOptions options, const ImplicitChoices& choices);

/// The implicit integrator: a time scheme (time_scheme.hpp: backward Euler, BDF2,
/// generalized-α, TR-BDF2, implicit midpoint) whose stages a NewtonSolver minimises
/// (newton_solver.hpp: the incremental potential, its projections and stopping tests). This
/// class keeps what lies between steps: the scheme's history and its key, error control
/// (dt = "auto", adaptive_steps.cpp), the divergence checks, and what an interrupted call
/// gives back. v⁺ = (x⁺ − x̄)/h̃ as the scheme poses each stage.
class ImplicitIntegrator : public Integrator {
 public:
  /// Throws std::invalid_argument on bad options (unknown solver, negative tolerances, ...).
  explicit ImplicitIntegrator(const ImplicitOptions& options = {});
  ~ImplicitIntegrator();

  /// Runs `steps` steps of dt (s) under gravity (m/s²). Throws SimulationDiverged (cloth
  /// restored to its state at the start of the call) on a non-finite state or an energy past
  /// the bound, NotPositiveDefinite if the solver rejects the matrix, std::invalid_argument on
  /// bad dt, gravity or steps.
  void advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) override;

  /// The backward-Euler incremental potential of the next step from the cloth's current state,
  /// evaluated at free-vertex positions `positions` (n×3; rows of constrained vertices are
  /// ignored), with the solver's Newton direction. The Hessian is projected as `projection`
  /// says (clamp or abs; exact: the true Hessian, and NotPositiveDefinite when the solver
  /// rejects it — how Simulation::settle tells a saddle from a minimum).
  NewtonSystem newton_system(const Cloth& cloth, const Vec3& gravity, double dt,
                             const Positions& positions,
                             HessianProjection projection = HessianProjection::clamp);

  /// The scheme's history arrays: BDF2's state one step back ("positions", m; "velocities", m/s),
  /// generalized-α's algorithmic accelerations and its true ones as solved for
  /// ("accelerations", "force_accelerations", m/s²), TR-BDF2's accelerations at the step's
  /// end as solved for ("accelerations"); none for backward Euler. Each n×3.
  std::vector<std::string> history_fields() const override;
  /// The history the next step of `cloth` would use (invalid for backward Euler, and when the
  /// next step restarts: no step yet, or the cloth was edited since). Its dt is the last step's.
  IntegratorHistory history(const Cloth& cloth) const override;
  /// Restores a history taken by history(), for `cloth` as it is now (a resumed run); see
  /// Integrator::set_history for what it throws.
  void set_history(const Cloth& cloth, const IntegratorHistory& history) override;

  using ProjectionMemory = yore::ProjectionMemory;
  /// The exact, shifted and steihaug projections' memory across steps (ProjectionMemory).
  ProjectionMemory projection_memory() const { return m_newton.projection_memory(); }
  /// Restores a memory taken by projection_memory(); throws std::invalid_argument out of range.
  void set_projection_memory(const ProjectionMemory& memory) {
    m_newton.set_projection_memory(memory);
  }

  const ImplicitOptions& options() const { return m_newton.options(); }
  const ImplicitStatistics& statistics() const { return m_newton.statistics(); }
  /// The energy checks (their largest gain is reported as the energy_gain counter).
  const DivergenceMonitor& monitor() const { return m_monitor; }
  /// The linear solver's counters (analyses, factorizations, nnz(L), flops, ordering).
  const SolverStatistics& solver_statistics() const { return m_newton.solver_statistics(); }

 private:
  /// The solver's structure for `cloth`, and the scheme's arrays sized for it (its history
  /// cleared, unless set_history restored one for this very topology).
  void prepare(const Cloth& cloth);
  /// One step of dt by the time scheme (its stages solved by m_newton), then finish_step; a
  /// step that gains energy is redone with Newton's early stops off. state_kept: the caller
  /// (adaptive_interval) already kept the step's start (keep_step_state).
  void step(Cloth& cloth, const Vec3& gravity, double dt, bool state_kept = false);
  /// The end of every step: whether the scheme's history is now valid (keyed to the cloth as
  /// it is, and to dt), and the step's counters.
  void finish_step(const Cloth& cloth, double dt, bool history_valid);
  /// adaptive: one output interval of dt in error-controlled steps of a scheme with an error
  /// estimate (adaptive_steps.cpp).
  void adaptive_interval(Cloth& cloth, const Vec3& gravity, double dt);
  // adaptive_interval's parts: a step's state and history kept for a rejection, and given
  // back; the step's tolerance atol + rtol × the largest |coordinate| of a free vertex.
  void keep_step_state(const Cloth& cloth);
  void restore_step_state(Cloth& cloth);
  double step_tolerance(const Cloth& cloth) const;

  std::unique_ptr<TimeScheme> m_scheme;
  NewtonSolver m_newton;
  DivergenceMonitor m_monitor;
  // the scheme's history arrays, named (pointers into m_scheme), and their key
  std::vector<std::pair<std::string, Positions*>> m_history_arrays;
  HistoryKey m_history;
  std::uint64_t m_sized_topology = std::numeric_limits<std::uint64_t>::max();  // of m_scheme
  // adaptive: the state, velocities and the scheme's history at a step's start, for a
  // rejection
  Positions m_step_positions, m_step_velocities;
  std::vector<Positions> m_step_history;
  Positions m_checkpoint_positions, m_checkpoint_velocities;

  // What an advance() call gives back when it is interrupted or fails: the history and the
  // decisions kept across steps as they were at its start (the cloth goes back with them), so
  // the simulation is exactly as it was before the call.
  struct Memory {
    std::vector<Positions> history;  // the scheme's arrays, in m_history_arrays' order
    HistoryKey key;
    NewtonSolver::Decisions decisions;
  };
  Memory m_memory;
  void keep_memory();
  void restore_memory();
};

}  // namespace yore
