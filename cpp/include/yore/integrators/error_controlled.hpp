#pragma once
/// @file error_controlled.hpp
/// Error-controlled implicit stepping on SUNDIALS: CVODE (variable-order BDF) and ARKODE's
/// ARKStep with a stiffly accurate ESDIRK table, on the first-order form y = (x, v) of the
/// free vertices, with their Newton systems reduced to yore's own 3n-unknown SPD matrix on
/// CHOLMOD (factored only when SUNDIALS asks for a linear-solver setup).

#include <cstdint>
#include <exception>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/integrators/divergence.hpp"
#include "yore/integrators/integrator.hpp"
#include "yore/integrators/newton_solver.hpp"

namespace yore {

/// Which SUNDIALS integrator.
enum class ErrorControlledMethod {
  cvode,   ///< CVODE's BDF, orders 1..max_order (≤ 5), with stability-limit detection
  arkode,  ///< ARKStep with a stiffly accurate ESDIRK table of the given order (2, 3 or 4)
};

/// Settings of the error-controlled integrators.
struct ErrorControlledOptions {
  ErrorControlledMethod method = ErrorControlledMethod::cvode;
  /// Relative tolerance of the local error test (SUNDIALS' weighted RMS norm over y = (x, v):
  /// the error of component i is weighed by 1/(rtol |yᵢ| + atolᵢ)).
  double rtol = 1e-3;
  /// Absolute tolerance of the positions, m.
  double atol = 1e-4;
  /// Absolute tolerance of the velocities, m/s; 0 means the same number as atol. Measured
  /// (benchmarks/error_control.py --velocity-time): atol per 1/60 s (60 atol) was about
  /// twice as cheap at rtol 1e-4 with 2–5× the error, but at rtol 1e-2 cvode's error grew
  /// 7–37× and on the 32² sheet at 2e6 N/m it diverged; the same number keeps the error
  /// falling with the tolerance in every cell measured.
  double atol_velocity = 0.0;
  /// cvode: the highest BDF order (1..5). 2 by default: BDF of order 3 to 5 is not A-stable,
  /// and a cloth's stiff springs are undamped oscillators (eigenvalues near the imaginary
  /// axis); with orders up to 5 the 32² sheet at 2e5 N/m failed where order 2 ran (stability-
  /// limit detection did not catch it; docs/integrators.md).
  int max_order = 2;
  /// arkode: the ESDIRK table's order: 2 (TR-BDF2, ARKODE_TRBDF2_3_3_2), 3
  /// (ARKODE_ARK324L2SA_DIRK_4_2_3, ARKODE's default) or 4 (ARKODE_ARK436L2SA_DIRK_6_3_4).
  int order = 3;
  /// Largest internal step, s; 0: no limit but the output interval.
  double max_dt = 0.0;
  /// Internal steps allowed within one output interval (dt) before the run stops with
  /// SimulationDiverged: a tolerance the integrator cannot meet never hangs.
  int max_steps = 5000;
  /// Newton iterations SUNDIALS allows a step's (stage's) nonlinear solve before it counts a
  /// convergence failure and retries with a smaller step and a fresh Jacobian (SUNDIALS: 3).
  int max_nonlinear_iterations = 3;
  /// The stiffness Hessian's projection in the iteration matrix: clamp (default) or abs.
  HessianProjection projection = HessianProjection::clamp;
  LinearSolverOptions linear_solver;
  double divergence_energy_factor = 10.0;
  /// Largest rise of the energy above its lowest since the last change, in energy scales
  /// (DivergenceMonitor); 0 = no growth check.
  double energy_growth_tolerance = 0.1;
};

/// Counters, cumulative over the integrator's life (across re-initializations), plus the
/// current figures. "steps" are output intervals (calls' dt); the rest are SUNDIALS'.
struct ErrorControlledStatistics {
  std::int64_t steps = 0;           ///< output intervals completed
  std::int64_t internal_steps = 0;  ///< SUNDIALS steps taken (accepted)
  std::int64_t error_test_failures = 0;
  std::int64_t nonlinear_iterations = 0;
  std::int64_t nonlinear_failures = 0;  ///< nonlinear convergence failures
  std::int64_t linear_setups = 0;       ///< setups SUNDIALS asked for (= factorizations)
  std::int64_t linear_solves = 0;
  std::int64_t rhs_evaluations = 0;
  std::int64_t jacobian_evaluations = 0;  ///< setups that re-evaluated J (the rest reused it)
  std::int64_t restarts = 0;         ///< (re)initializations: the first, after a stroke, an edit, a
                                     ///< restore or an interrupted call
  int current_order = 0;             ///< the order the next internal step will use (0: none yet)
  double current_internal_dt = 0.0;  ///< the step size the next internal step will try, s
  double last_internal_dt = 0.0;     ///< the last internal step taken, s
  double rhs_seconds = 0.0;          ///< force evaluations
  double setup_seconds = 0.0;        ///< assembling and factoring the iteration matrix
  double solve_seconds = 0.0;        ///< applying the factor (linear solves)
};

/// CVODE or ARKODE on the cloth's free vertices, y = (x, v), ẏ = (v, M⁻¹ f(x, v) + g):
/// the same forces as the explicit integrator (springs with damping along their current
/// directions, quadratic bending, drag, gravity; fixed and driven vertices are not unknowns,
/// drivers are evaluated at each stage's time). advance(dt, steps) takes `steps` output
/// intervals of dt, each ending exactly at its time (a stop time); inside one SUNDIALS takes
/// as many internal steps as its error test asks for. Each Newton system (I − γJ) z = r is
/// reduced to the velocity block (M + γ(C + drag M) + γ²H) z_v = M r_v − γ H r_x,
/// z_x = r_x + γ z_v (H the projected stiffness Hessian, C the spring damping, both at the
/// state of the last Jacobian evaluation), which the inner NewtonSolver's CHOLMOD
/// factor solves; a factorization happens only when SUNDIALS calls the setup (its γ-ratio
/// and step-count rules, a convergence failure).
/// SUNDIALS' memory (Nordsieck array or stage history) cannot be saved: history() is always
/// invalid, and a restored state, an edit, a stroke, a change of gravity or an interrupted
/// call restarts the integrator (order 1, a small first step) at the cloth's state.
class ErrorControlledIntegrator : public Integrator {
 public:
  /// Throws std::invalid_argument on bad options (tolerances not finite and > 0, orders out
  /// of the method's range, ...).
  explicit ErrorControlledIntegrator(const ErrorControlledOptions& options = {});
  ~ErrorControlledIntegrator() override;
  ErrorControlledIntegrator(const ErrorControlledIntegrator&) = delete;
  ErrorControlledIntegrator& operator=(const ErrorControlledIntegrator&) = delete;

  /// Runs `steps` output intervals of dt (s). Throws SimulationDiverged (cloth restored to its
  /// state at the start of the call) when SUNDIALS fails a step (repeated error-test or
  /// convergence failures, more than max_steps internal steps in one interval) or the energy
  /// passes the divergence bound; std::invalid_argument on bad arguments.
  void advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) override;

  /// The next interval starts SUNDIALS afresh at the cloth's state (order 1, a new first step),
  /// as it does after an edit or a resume from a state: a run that restarts where another was
  /// resumed takes the same steps from there.
  void request_restart() { m_restart = true; }

  const ErrorControlledOptions& options() const { return m_options; }
  const ErrorControlledStatistics& statistics() const;
  /// The energy checks (their largest gain is reported as the energy_gain counter).
  const DivergenceMonitor& monitor() const { return m_monitor; }
  /// The linear solver's counters (analyses, factorizations, nnz(L), ...).
  const SolverStatistics& solver_statistics() const;
  /// Wall time of the inner assembly, analysis and factorization, s.
  const ImplicitStatistics& assembly_statistics() const { return m_newton.statistics(); }

  /// Name of the method ("cvode" or "arkode").
  const char* name() const;

  struct Backend;  // SUNDIALS' objects (error_controlled.cpp)

 private:
  friend struct Backend;
  void ensure_backend(const Cloth& cloth, const Vec3& gravity);
  void interval(Cloth& cloth, const Vec3& gravity, double dt);
  void fold_counters() const;  // SUNDIALS' counters of the current memory into m_base
  // Callbacks' work (y, ẏ as raw arrays of 6 n_free).
  void right_hand_side(double t, const double* y, double* ydot);
  void setup(double t, const double* y, bool jacobian_ok, bool& jacobian_current, double gamma);
  void solve(const double* r, double* z, double gamma);
  void load(double t, const double* y);  // y → m_x, m_v (constrained rows from the drivers)

  ErrorControlledOptions m_options;
  NewtonSolver m_newton;  // structure, assembly and CHOLMOD factor of the 3n system
  std::unique_ptr<Backend> m_backend;
  DivergenceMonitor m_monitor;
  mutable ErrorControlledStatistics m_statistics;  // refreshed from SUNDIALS on read
  mutable ErrorControlledStatistics m_base;        // counters of memories already folded

  const Cloth* m_cloth = nullptr;  // the cloth being advanced (callbacks read it)
  Vec3 m_gravity = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());  // SUNDIALS' g
  std::vector<std::int32_t> m_free;  // vertex of each block of 3 unknowns
  std::uint64_t m_topology = std::numeric_limits<std::uint64_t>::max();
  std::uint64_t m_edits = std::numeric_limits<std::uint64_t>::max();
  double m_time = std::numeric_limits<double>::quiet_NaN();  // SUNDIALS' time after the last
  bool m_restart = true;  // the next interval re-initializes SUNDIALS at the cloth's state
  Positions m_x, m_v, m_force, m_bending;  // n×3 work arrays (m_bending: non-spring gradients)
  MembraneElementWork m_membrane_work;     // scratch of the membrane's elements
  Positions m_jacobian_positions;          // n×3: where J was last evaluated
  std::vector<double> m_stiffness;         // H at m_jacobian_positions, pattern order
  double m_setup_gamma = 0.0;              // γ of the current factor
  Eigen::VectorXd m_rhs, m_zv, m_rx, m_product;  // 3 n_free
  std::exception_ptr m_error;  // an exception a callback caught (rethrown after SUNDIALS)
  std::string m_message;       // SUNDIALS' last error message
  Positions m_checkpoint_positions, m_checkpoint_velocities;
};

}  // namespace yore
