#pragma once
/// @file implicit_options.hpp
/// The settings, counters and results shared by the implicit integrator (implicit.hpp), its
/// Newton solver (newton_solver.hpp) and the SUNDIALS integrators that borrow its assembly
/// (error_controlled.hpp): the Hessian projections, Newton's predictor, the minimizer, the
/// options, the statistics, a Newton system for tools, and the projection memory a state keeps.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "yore/integrators/time_scheme.hpp"
#include "yore/solvers/linear_solver.hpp"

namespace yore {

/// How the Hessian of a compressed spring (ℓ < L, transverse factor 1 − L/ℓ < 0) is made
/// positive semidefinite; stretched springs are exact in every mode.
enum class HessianProjection {
  clamp,         ///< transverse factor clamped at 0 (always SPD)
  abs,           ///< |λ| filtering: transverse factor |1 − L/ℓ| (always SPD)
  exact,         ///< exact Hessian; the clamp when the factorization finds it indefinite, and the
                 ///< decision kept for the rest of the step and (with back-off) later steps
  trust_region,  ///< Chen et al. 2024: abs after an iteration whose quadratic model fit poorly
                 ///< (trust-region ratio ρ < 0.01), the clamp otherwise (always SPD)
  shifted,   ///< Levenberg–Marquardt: the exact Hessian plus μ M/h̃², μ ≥ 0 raised when the
             ///< factorization finds it indefinite or the quadratic model fits poorly and
             ///< lowered when it fits well; μ carries over to the next step
  steihaug,  ///< trust-region Newton–CG (Steihaug–Toint): CG on the exact Hessian,
             ///< preconditioned by the factor of the clamped one (always SPD), inside a
             ///< trust region in that factor's norm; a refused step is solved again on the
             ///< same factor (none thrown away). Negative curvature past the clamped step
             ///< is not followed (see newton.cpp)
};

/// Where Newton starts each step.
enum class NewtonPredictor {
  start,     ///< xₙ (BE) or x̄ (BDF2): the step's start; linearized mode's Baraff–Witkin step
  inertial,  ///< x̂ = x̄ + h̃ v̄, the inertial (free-flight, no gravity) prediction
  extrapolated,  ///< x̂ + h̃² ã: a stage's solution is x̂ + h̃² a⁺ (a⁺ = M⁻¹f at its end), and
                 ///< ã holds the latest acceleration the method knows (TR-BDF2: a₀ for the
                 ///< trapezoid stage, a_γ as solved for the BDF2 stage; generalized-α: ẍₙ;
                 ///< BDF2: (vₙ − vₙ₋₁)/hₙ₋₁, from its history); x̂ where there is none
                 ///< (backward Euler, the first step, after a stroke or an edit). Exact under
                 ///< a constant force (free fall), but on hanging sheets it takes more Newton
                 ///< iterations than `inertial` (docs/integrators.md), so it is not the default
};

/// How each step's incremental potential is minimised.
enum class ImplicitMinimizer {
  newton,  ///< Newton's method on the 3n×3n Hessian (projected as `projection` says)
  lbfgs,   ///< quasi-Newton (Liu, Bouaziz & Kavan 2017): L-BFGS whose initial Hessian is the
           ///< constant scalar matrix Q of spring_matrix.hpp, analysed once per topology and
           ///< factored once per (topology, h̃, stiffness); the same line search and residual test
};

/// Settings of the implicit integrator and its Newton solver.
struct ImplicitOptions {
  ImplicitMethod method = ImplicitMethod::backward_euler;
  ImplicitMinimizer minimizer = ImplicitMinimizer::newton;
  /// lbfgs: correction pairs kept within a step (the history starts empty every step).
  int lbfgs_history = 8;
  /// One Newton step from the current state, no line search (Baraff & Witkin 1998).
  bool linearized = false;
  /// false: every spring Hessian is projected to PSD (the default; always SPD). true: each
  /// iteration first tries the exact Hessian and falls back to the projected one when the
  /// Cholesky factorization reports it indefinite — quadratic convergence near a minimum, where
  /// the exact Hessian is positive definite. Every system solved is still SPD. Cholesky
  /// backends only (PCG cannot tell an indefinite matrix).
  bool adaptive_projection = false;
  /// The projection of compressed springs' Hessians. adaptive_projection = true means exact
  /// (kept for compatibility: the constructor maps it).
  HessianProjection projection = HessianProjection::clamp;
  NewtonPredictor predictor = NewtonPredictor::start;
  /// Lagged factorization: keep the last factor across Newton iterations and steps and solve
  /// with CG preconditioned by it on the current matrix; refactor only when CG needs more than
  /// lag_max_cg_iterations to reach lag_cg_tol. Uses the projected Hessian (CG needs SPD);
  /// Cholesky backends only. With projection steihaug the matrix is the exact Hessian, CG's
  /// tolerance is the trust-region solver's own, and a factor is made only where CG on the kept
  /// one needs more than lag_max_cg_iterations. After the k-th failed CG in a row the next
  /// min(2^(k−1), 32) iterations refactor without trying the kept factor.
  bool lagged_factorization = false;
  int lag_max_cg_iterations = 20;
  double lag_cg_tol = 1e-10;
  /// Newton stops when the residual max_i |∇ᵢE| h̃²/mᵢ (the gradient as a displacement, m) is
  /// at most newton_tol × the mean rest length, at a finite objective; the step's start (no
  /// iteration yet) also needs h̃²|g| × newton_tol, no vertex's net force above newton_tol × its
  /// weight, or small steps would pass it whatever the forces. A step cut short by the
  /// line search is not converged; a step that reaches max_newton is counted in
  /// ImplicitStatistics::unconverged_steps.
  double newton_tol = 1e-5;
  /// Newton also stops after a full step (no backtracking) that moved no vertex by more than
  /// step_tol × the mean rest length: the step is the quadratic model's estimate of the
  /// distance to the solution (IPC's ‖Δx‖∞ test). The residual test above turns a force into a
  /// displacement through the inertia alone (h̃²/m), so on stiff springs it asks for a
  /// k h̃²/m times smaller error along the springs than it says; this test does not. 0 (the
  /// default) turns it off.
  double step_tol = 0.0;
  /// The truncation test, on by default: Newton also stops after a full step (no backtracking;
  /// steihaug: CG ended inside the region, converged, on positive curvature) once its estimated
  /// distance to the solution is at most truncation_fraction × the step's estimated local
  /// truncation error, both the largest over the vertices. The distance is the step's largest
  /// move times min(1, θ), θ the contraction rate (the largest move over the last one,
  /// max(0.3 θ_before, that) after the first step; 1 before it), as CVODE's Newton test does
  /// (Hindmarsh et al. 2005); the truncation error is backward Euler's ½ h² a ≈ ½ |x⁺ − x̂|
  /// (x̂ = xₙ + h vₙ) or BDF2's (2/9) h³ x''' ≈ (2/9) h |v⁺ − 2vₙ + vₙ₋₁| at the iterate.
  /// Stiff integrators stop there because solving further does not make the step more
  /// accurate: the step's own error dominates. 0 turns it off (the residual test alone).
  double truncation_fraction = 0.1;
  /// Mixed (stress) form of the springs' geometric stiffness: the transverse term of each
  /// spring's Hessian, (f/ℓ)(I − n nᵀ), takes its force f from λ, which starts each step at the
  /// springs' forces k(ℓ − L) at xₙ and follows each Newton step's linearization,
  /// λ ← λ + α(k(ℓ + n·Δd − L) − λ), instead of the actual force at the iterate. The energy,
  /// the gradient and so the solution are unchanged; the matrices are those of Newton on the
  /// mixed formulation with the spring forces as unknowns, eliminated spring by spring (Trusty
  /// et al. 2022). On stiff springs the actual force at an iterate carries k times the length
  /// error of the step's out-of-plane moves (ℓ grows by w²/2ℓ), λ does not. Off by default: it
  /// saves ~40 % of the clamp's iterations on stiff sheets but measured mixed with steihaug
  /// (fewer at 32²–64², more at 128² and on easy scenes) and far worse with steihaug's lagged
  /// factors (docs/integrators.md).
  bool mixed = false;
  int max_newton = 1000;
  /// generalized_alpha: the spectral radius of a step at infinite frequency, in [0, 1]. 1 is
  /// the trapezoidal rule (no numerical damping, the energy-conserving reference on linear
  /// problems); 0 annihilates the highest frequencies in one step. α_m = (2ρ∞ − 1)/(ρ∞ + 1),
  /// α_f = ρ∞/(ρ∞ + 1), γ = ½ − α_m + α_f, β = ¼(1 − α_m + α_f)². 0.3 by default:
  /// generalized-α's unconditional stability is linear only, and on stiff nonlinear springs
  /// (2e5 N/m, 1/32 s) the flat 32² sheet gains energy without bound from ρ∞ ≈ 0.6 up (even
  /// with Newton solved to its residual test) and the gathered 21² cloth at 0.5; 0.2–0.35 kept
  /// both bounded (docs/integrators.md).
  double rho_infinity = 0.3;
  /// tr_bdf2 and bdf2 (Newton): error-controlled steps. advance(dt, steps)'s dt becomes an
  /// output interval, inside which the steps are chosen by the method's local error estimate
  /// (last_truncation_error: TR-BDF2's embedded pair; variable-step BDF2's from the second
  /// divided difference of the velocities): a step is accepted when its estimate is at most
  /// atol + rtol × the largest |x| of a free vertex, else retaken shorter; the next step is
  /// h × clamp(0.9 (tol/err)^(1/3), 0.2, 5) (BDF2: at most 2, inside variable-step BDF2's
  /// zero-stability bound 1 + √2), and steps are spread evenly to end each interval exactly.
  /// The step proposed for the next interval is part of the history (TR-BDF2: its dt; BDF2:
  /// its next_dt, its dt being the last step, which the formula needs), so a state file
  /// resumes bit for bit. More than max_steps steps (taken or retaken) in one interval is
  /// SimulationDiverged.
  bool adaptive = false;
  double rtol = 1e-3;
  double atol = 1e-4;  ///< m
  int max_steps = 5000;
  LinearSolverOptions linear_solver;
  double divergence_energy_factor = 10.0;
  /// Largest rise of the energy above its lowest since the last change, in energy scales
  /// (DivergenceMonitor); 0 = no growth check.
  double energy_growth_tolerance = 0.1;
};

/// Counters and wall time per phase, cumulative, plus the last step's figures.
struct ImplicitStatistics {
  std::int64_t steps = 0;
  std::int64_t newton_iterations = 0;
  std::int64_t line_search_backtracks = 0;
  std::int64_t unconverged_steps = 0;  ///< steps that reached max_newton
  std::int64_t step_test_stops = 0;    ///< steps the step test (step_tol) ended
  std::int64_t truncation_stops = 0;   ///< steps the truncation test (truncation_fraction) ended
  std::int64_t exact_hessian_rejected = 0;  ///< projection exact: exact Hessians found indefinite
  std::int64_t exact_hessian_accepted = 0;  ///< projection exact: exact Hessians factorized
  std::int64_t abs_projections = 0;         ///< trust_region: iterations that used |λ| filtering
  std::int64_t shifted_factorizations = 0;  ///< shifted: factorizations with μ > 0 that succeeded
  std::int64_t lagged_solves = 0;           ///< Newton systems solved by CG on a lagged factor (not
                                            ///< counting CG runs that failed and were refactored)
  std::int64_t lagged_cg_iterations = 0;
  std::int64_t lagged_failures = 0;        ///< CG runs on a kept factor that missed their bound
  std::int64_t lbfgs_skipped_updates = 0;  ///< lbfgs: pairs with sᵀy ≤ 0, not stored
  std::int64_t trust_region_cg_iterations = 0;  ///< steihaug: CG iterations (one solve each)
  std::int64_t trust_region_rejections = 0;     ///< steihaug: trial steps the ratio test refused
  std::int64_t negative_curvature_steps = 0;    ///< steihaug: steps CG ended on ≤ 0 curvature
  std::int64_t stages = 0;  ///< nonlinear solves (one per step; two for tr_bdf2)
  std::int64_t trapezoid_newton_iterations = 0;  ///< tr_bdf2: the trapezoid stages' share of
                                                 ///< newton_iterations
  std::int64_t extrapolated_stages = 0;  ///< stages Newton started from x̂ + h̃² ã (predictor
                                         ///< extrapolated with a history to extrapolate from)
  std::int64_t history_restarts = 0;     ///< bdf2, generalized_alpha: steps that began afresh
  /// Steps redone with Newton's early stops (truncation and step tests) off because their
  /// energy rose above the growth check's allowance.
  std::int64_t energy_retries = 0;
  ///< (first step, after a stroke, an edit or a restore)
  std::int64_t rejected_steps = 0;  ///< adaptive: steps retaken shorter (counted in steps too)
  std::int64_t intervals = 0;       ///< adaptive: output intervals completed
  double assemble_seconds = 0.0;    ///< energy, gradient and Hessian values (incl. line search)
  double analyze_seconds = 0.0;     ///< pattern build + symbolic analysis
  double factorize_seconds = 0.0;
  double solve_seconds = 0.0;
  int last_newton_iterations = 0;
  int last_line_search_backtracks = 0;
  double last_residual = std::numeric_limits<double>::quiet_NaN();  ///< ‖∇E‖∞ at the end, N
  /// The stopping residual at the end of the last step: max_i |∇ᵢE| h̃²/mᵢ / mean rest length.
  double last_scaled_residual = std::numeric_limits<double>::quiet_NaN();
  /// The last step's estimated local truncation error (see truncation_fraction), m, largest
  /// over the free vertices (tr_bdf2: the embedded estimate of the whole step).
  double last_truncation_error = std::numeric_limits<double>::quiet_NaN();
  std::int64_t last_dofs = 0;
};

/// The incremental potential's value, gradient and Hessian at a point, for tests and tools.
struct NewtonSystem {
  double energy = 0.0;                      ///< J
  Eigen::VectorXd gradient;                 ///< N (3 per free vertex), newtons
  SymmetricPattern pattern;                 ///< lower-triangle CSC of the Hessian
  std::vector<double> hessian;              ///< values in pattern order, N/m
  Eigen::VectorXd direction;                ///< solution of H d = −g with the configured solver
  std::vector<std::int32_t> free_vertices;  ///< vertex of each block of 3 unknowns
};

/// The exact projection's memory across steps: steps still to take projected after a
/// rejection, and the back-off the next rejection starts (both 1..32, skip may be 0). Part of
/// a saved state, so a resumed run makes the same projection decisions.
struct ProjectionMemory {
  int exact_skip = 0;
  int exact_backoff = 1;
  double shift = 0.0;   ///< projection shifted: the μ the next iteration starts with (≥ 0)
  double radius = 0.0;  ///< projection steihaug: the trust radius (0: not set yet), √J
};

}  // namespace yore
