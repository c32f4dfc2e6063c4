#pragma once
/// @file time_scheme.hpp
/// The time schemes of the implicit integrator, apart from the Newton solver that minimises
/// their stages (ImplicitIntegrator). A scheme turns a step of dt into one or more stages, each
/// the system
///   M (x − x̂)/h̃² = f(x, (x − x̄)/h_v)
/// with an anchor x̄, a target x̂ and two scales h̃ and h_v, which Newton solves as the minimum of
/// an incremental potential. The scheme keeps the history its formula needs between steps
/// (arrays a state file saves) and estimates the local truncation error of the stage being
/// solved (Newton's truncation test, and error control with dt = "auto").
///
/// Adding a scheme: one file under cpp/src/integrators/schemes/ (a TimeScheme and its factory), one
/// row of time_schemes() (cpp/src/integrators/schemes/registry.cpp), one ImplicitMethod value
/// below, and the integrator's row in Python (yore/options.py, INTEGRATOR_SPECS).
/// docs/contributing.md.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "yore/cloth/cloth.hpp"

namespace yore {

/// The time discretisation; each value has one row in time_schemes().
enum class ImplicitMethod {
  backward_euler,     ///< first order, unconditionally stable, dissipative
  bdf2,               ///< second order; the first step (and the first after a change) is BE
  generalized_alpha,  ///< Chung & Hulbert 1993 in Arnold & Brüls' form (second order,
                      ///< unconditionally stable on linear problems; rho_infinity sets how much
                      ///< of the highest frequencies survives a step)
  tr_bdf2,  ///< Bank et al. 1985: a trapezoidal stage to t + γh, γ = 2 − √2, then BDF2 through
            ///< the three points; L-stable, second order, one-step, with Hosea & Shampine's
            ///< embedded error estimate
  implicit_midpoint,  ///< the implicit midpoint rule: second order, symplectic, no numerical
                      ///< damping (energy-conserving on linear springs)
};

struct ImplicitOptions;

/// One stage as a scheme poses it to the solver.
struct Stage {
  Positions anchor;  ///< x̄, n×3
  Positions target;  ///< x̂, n×3
  double h = 0.0;    ///< h̃: the inertia term is ½‖x − x̂‖²_M / h̃²
  double hv = 0.0;   ///< h_v: the velocity at x is (x − x̄)/h_v
  /// predictor extrapolated: ã, the acceleration expected at the stage's end, when
  /// `extrapolated` (Newton then starts at x̂ + h̃² ã instead of x̂); each stage sets its own.
  Positions acceleration;
  bool extrapolated = false;
  /// A trapezoidal stage (TR-BDF2's first): its iterations are counted apart.
  bool trapezoid = false;
};

/// Whether a scheme's history belongs to the cloth as it is (no stroke, edit or restore since)
/// and the step it was taken with.
struct HistoryKey {
  bool valid = false;
  std::uint64_t topology = 0, edits = 0;
  double dt = 0.0;        ///< the last step, s
  double proposal = 0.0;  ///< error control of a multistep scheme: the next interval's first step
  bool matches(const Cloth& cloth) const {
    return valid && topology == cloth.topology_version() && edits == cloth.edit_count();
  }
};

/// What a scheme may ask of the solver of its stages.
class StageSolver {
 public:
  /// The vertex of each block of unknowns (the free vertices, in order).
  virtual const std::vector<std::int32_t>& free_vertices() const = 0;
  virtual Stage& stage() = 0;
  virtual const Stage& stage() const = 0;
  /// The last stage's solution (rows of the free vertices), or the current iterate while a
  /// stage is being solved.
  virtual const Positions& solution() const = 0;
  /// Whether Newton's predictor is `extrapolated` (a scheme then provides ã where it has one).
  virtual bool extrapolating() const = 0;
  /// Backward Euler's stage from the cloth's state, every row: h̃ = h_v = dt, x̄ = x,
  /// x̂ = x + dt v, and the damping directions at x̂.
  virtual void pose_backward_euler(const Cloth& cloth, double dt) = 0;
  /// After the free rows of the anchor and target are set and the drivers are at the stage's
  /// end time: the constrained rows (x̄ = x − h_v v, x̂ = x) and the damping directions.
  virtual void finish_setup(const Cloth& cloth) = 0;
  /// The damping directions alone, at the target (for stages whose every row is set).
  virtual void update_directions(const Cloth& cloth) = 0;
  /// Solves the stage posed; the counters of the step add up.
  virtual void solve(const Cloth& cloth) = 0;
  /// x = the solution, v = (x − x̄)/h_v, into the cloth's free vertices.
  virtual void write(Cloth& cloth) = 0;
  /// Counts a step that began afresh (no history to go on from).
  virtual void count_restart() = 0;

 protected:
  ~StageSolver() = default;
};

/// A time scheme: stages, history and error estimate (see the file's comment).
class TimeScheme {
 public:
  virtual ~TimeScheme() = default;
  /// Sizes the scheme's arrays for n vertices. `clear`: the topology changed, the history is
  /// zeroed (its key is invalidated by the integrator).
  virtual void resize(Eigen::Index n, bool clear) = 0;
  /// One step of dt from the cloth's state: poses and solves its stages, moves the clock,
  /// applies the drivers, writes the cloth and updates the history. `history`: the key of the
  /// history before the step. Returns whether the history is valid after it.
  virtual bool step(StageSolver& solver, Cloth& cloth, double dt, const HistoryKey& history) = 0;
  /// The local truncation error of the stage being solved, at the solver's solution (m, the
  /// largest over the free vertices); the cloth still holds the stage's start.
  virtual double truncation_error(const StageSolver& solver, const Cloth& cloth) const = 0;
  /// The history's arrays, named as state files name them, in order (none: an empty list).
  virtual std::vector<std::pair<std::string, Positions*>> history() = 0;
  /// Whether truncation_error estimates a whole step's error: error control (dt = "auto")
  /// wraps only such schemes.
  virtual bool error_estimate() const { return false; }
  /// A multistep formula needs the history's dt to be the last step taken: error control keeps
  /// its proposal for the next interval apart (next_dt).
  virtual bool multistep() const { return false; }
  /// Error control: the largest factor one step may grow by.
  virtual double max_step_growth() const { return 5.0; }
};

/// One row per scheme: its ImplicitMethod, its name in option tables (the `method` option),
/// the public integrator's name (yore.INTEGRATORS, messages), how to make it.
struct TimeSchemeRow {
  ImplicitMethod method;
  const char* name;
  const char* integrator;
  std::unique_ptr<TimeScheme> (*make)(const ImplicitOptions& options);
};

/// Every scheme, in the order option tables list them (cpp/src/integrators/schemes/registry.cpp).
const std::vector<TimeSchemeRow>& time_schemes();
/// The row of `method`.
const TimeSchemeRow& time_scheme(ImplicitMethod method);

/// Backward Euler's truncation error of the stage being solved: ½|x⁺ − x̂| = ½ h² |a⁺|.
double backward_euler_error(const StageSolver& solver);
/// Backward Euler's step (the first of the multistep and history-keeping schemes): poses,
/// moves the clock and the drivers to t + dt, solves and writes the cloth.
void backward_euler_step(StageSolver& solver, Cloth& cloth, double dt);
/// The accelerations the stage just solved for, (x⁺ − x̂)/h̃² (= M⁻¹(f + the Newton residual)),
/// into `into`'s free rows: a scheme's next step starts from what this one did, not from f at
/// an inexact x⁺ (that would turn the solver's error δ into a force error kδ).
void stage_accelerations(const StageSolver& solver, Positions& into);

}  // namespace yore
