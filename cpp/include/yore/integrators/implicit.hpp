#pragma once
/// @file implicit.hpp
/// Implicit stepping as minimisation of the incremental potential, by Newton's method with a
/// backtracking line search on a sparse SPD solver; the time schemes that pose its stages are
/// apart (time_scheme.hpp, cpp/src/integrators/schemes/).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/integrators/divergence.hpp"
#include "yore/integrators/integrator.hpp"
#include "yore/integrators/time_scheme.hpp"
#include "yore/solvers/linear_solver.hpp"
#include "yore/solvers/sparse_cholesky.hpp"
#include "yore/solvers/spring_matrix.hpp"

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

/// Settings of the implicit integrator.
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
                                         ///< (first step, after a stroke, an edit or a restore)
  std::int64_t rejected_steps = 0;       ///< adaptive: steps retaken shorter (counted in steps too)
  std::int64_t intervals = 0;            ///< adaptive: output intervals completed
  double assemble_seconds = 0.0;  ///< energy, gradient and Hessian values (incl. line search)
  double analyze_seconds = 0.0;   ///< pattern build + symbolic analysis
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

/// Newton's method on the stages of an implicit time scheme (time_scheme.hpp: backward Euler,
/// BDF2, generalized-α, TR-BDF2, implicit midpoint) for the mass-spring cloth. The unknowns are the
/// positions of the free vertices (fixed and driven ones are eliminated, not penalised). x⁺
/// minimises
///   E(x) = ½‖x − x̂‖²_M / h̃² + U(x) + D(x) − Σ m g·x,
/// with h̃, x̄ and x̂ as the scheme poses the stage (backward Euler: h̃ = h, x̄ = xₙ,
/// x̂ = xₙ + h vₙ; BDF2: h̃ = 2h/3, x̄ = (4xₙ − xₙ₋₁)/3, x̂ = x̄ + h̃ v̄), and
/// the damping potential D(x) = Σ c/(2h̃) ((Δxᵢ − Δxⱼ)·d̂)² + Σ drag·m/(2h̃)|Δx|², Δx = x − x̄, with
/// d̂ the spring directions of the inertial prediction x̂ (an O(h²) extrapolation of the
/// end-of-step directions: −∇D is the damping force at v = Δx/h̃ along them, D stays quadratic,
/// BDF2 stays second order, and a rigid rotation is barely damped). Compressed springs'
/// Hessians are projected as ImplicitOptions::projection says; every system solved is SPD.
/// v⁺ = (x⁺ − x̄)/h̃.
/// The sparsity pattern and the symbolic analysis are rebuilt only when topology_version
/// changes; every Newton iteration refills the values in place.
class ImplicitIntegrator : public Integrator, private StageSolver {
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

  /// The exact projection's memory across steps: steps still to take projected after a
  /// rejection, and the back-off the next rejection starts (both 1..32, skip may be 0). Part of
  /// a saved state, so a resumed run makes the same projection decisions.
  struct ProjectionMemory {
    int exact_skip = 0;
    int exact_backoff = 1;
    double shift = 0.0;   ///< projection shifted: the μ the next iteration starts with (≥ 0)
    double radius = 0.0;  ///< projection steihaug: the trust radius (0: not set yet), √J
  };
  ProjectionMemory projection_memory() const {
    return {m_exact_skip, m_exact_backoff, m_shift, m_radius};
  }
  /// Restores a memory taken by projection_memory(); throws std::invalid_argument out of range.
  void set_projection_memory(const ProjectionMemory& memory);

  // -- The iteration matrix of the first-order (x, v) integrators (error_controlled.cpp) ---
  /// Builds the pattern and its symbolic analysis when `cloth`'s topology changed; returns the
  /// vertex of each block of 3 unknowns (the free vertices, in order).
  const std::vector<std::int32_t>& prepare_structure(const Cloth& cloth);
  /// Assembles at positions x (n×3) and factors V = M/γ² + (C + drag M)/γ + H, the matrix this
  /// integrator's Newton factors for a step of h̃ = γ: C the springs' damping along x's spring
  /// directions, H the stiffness Hessian of springs and bending at x projected as the options
  /// say. γ² V = M + γ(C + drag M) + γ² H is M(I − γJ)'s velocity block for y = (x, v),
  /// J = ∂(v, M⁻¹f)/∂(x, v). Writes H alone (pattern order) into `stiffness`.
  void factor_iteration_matrix(const Cloth& cloth, const Positions& x, double gamma,
                               std::vector<double>& stiffness);
  /// Solves V z = rhs with the last factor_iteration_matrix (both of its pattern's size).
  void solve_iteration_matrix(const double* rhs, double* solution);
  /// The lower-triangle pattern of the 3n_free system (after prepare_structure).
  const SymmetricPattern& pattern() const { return m_pattern; }

  const ImplicitOptions& options() const { return m_options; }
  const ImplicitStatistics& statistics() const { return m_statistics; }
  /// The energy checks (their largest gain is reported as the energy_gain counter).
  const DivergenceMonitor& monitor() const { return m_monitor; }
  /// The linear solver's counters (analyses, factorizations, nnz(L), flops, ordering).
  const SolverStatistics& solver_statistics() const;

 private:
  void ensure_structure(const Cloth& cloth);
  // ensure_structure's last stage: every work array sized for the topology (dofs unknowns).
  void size_workspace(const Cloth& cloth, Eigen::Index dofs);
  double evaluate(const Cloth& cloth, const Positions& x, bool with_gradient, bool with_hessian,
                  HessianProjection projection = HessianProjection::clamp);
  // The membrane's pair ranks in the pattern (ensure_structure's coupled blocks).
  void membrane_ranks(const MembraneElements* elements,
                      const std::vector<std::pair<std::int32_t, std::int32_t>>& coupled,
                      const std::vector<std::int32_t>& first_neighbour);
  // The membrane's share of evaluate: adds to energy, magnitude, m_gradient and m_values.
  void evaluate_membrane(const Cloth& cloth, const Positions& x, bool with_gradient,
                         bool with_hessian, TransverseFilter filter, double& energy,
                         double& magnitude);
  double scaled_residual(const Cloth& cloth) const;
  /// Backtracking (Armijo) line search along m_direction from m_iterate (energy at it; slope =
  /// ∇E·d < 0); returns the step length, leaves the last trial's energy in trial_energy and
  /// counts halvings in backtracks. May overwrite m_gradient; with trial_gradient it is the
  /// last trial's on return (m_trial holds that trial).
  double line_search(const Cloth& cloth, double energy, double slope, int& backtracks,
                     double& trial_energy, bool trial_gradient = false);
  /// lbfgs: refactors Q if the topology, h̃ or the material changed since the last factor.
  void ensure_scalar_matrix(const Cloth& cloth);
  /// lbfgs: minimises from m_iterate until the residual test or max_newton (quasi_newton.cpp).
  void quasi_newton_iterate(const Cloth& cloth, double& energy, double& residual, int& iterations,
                            int& backtracks, bool& converged);
  /// The stopping verdict Newton and quasi-Newton share: diverged on a non-finite objective
  /// or gradient, converged when the scaled residual is at most newton_tol × the mean rest
  /// length, at the cap after max_newton iterations.
  enum class IterationVerdict { go_on, converged, at_cap, diverged };
  IterationVerdict verdict(double energy, double residual, int iterations) const;

  // Newton, in parts (newton.cpp).
  /// The projection decisions of one step (exact: whether this iteration tries the exact
  /// Hessian, whether one was rejected this step and at what residual; trust_region: whether
  /// the next iteration filters by |λ|). The decisions kept across steps live in members.
  struct ProjectionChoice {
    bool try_exact = false;
    bool rejected = false;
    double residual_at_rejection = 0.0;
    bool use_abs = false;
  };
  ProjectionChoice begin_projection();
  void end_projection(const ProjectionChoice& choice, int iterations);
  /// Assembles the Hessian the projection picks at m_iterate and leaves the Newton direction
  /// (H d = −∇E) in m_direction; returns the objective there.
  double newton_direction(const Cloth& cloth, ProjectionChoice& choice, double residual);
  /// After a line search: the trust-region filter choice and the shift μ, from the fit of the
  /// quadratic model to the actual decrease.
  void adapt_projection(const Cloth& cloth, ProjectionChoice& choice, double energy,
                        double trial_energy, double slope, double alpha, double magnitude);
  /// Minimises from m_iterate by Newton until the verdict stops it (one iteration, linearized).
  void newton_iterate(const Cloth& cloth, double& energy, double& residual, int& iterations,
                      int& backtracks, bool& converged);
  bool factorize_shifted(const Cloth& cloth);
  /// projection steihaug: minimises from m_iterate by trust-region Newton–CG (newton.cpp).
  void steihaug_iterate(const Cloth& cloth, double& energy, double& residual, int& iterations,
                        int& backtracks, bool& converged);
  /// Steihaug–Toint CG for the trust-region subproblem at m_iterate (exact Hessian in
  /// m_exact_values, the factor of the clamped one in m_solver, gradient in m_gradient); leaves
  /// the step in m_direction and returns the model's decrease −(g·d + ½ dᵀHd). `first`: the
  /// step's first subproblem; `same`: the two Hessians are equal (one solve is Newton's step);
  /// `exhausted`: CG stopped at max_iterations; `negative`: it met curvature ≤ 0.
  double steihaug_direction(double forcing, bool first, bool same, int max_iterations,
                            bool& boundary, double& length, bool& exhausted, bool& negative);
  /// projection steihaug: assembles the clamped Hessian at m_iterate into m_values and factors
  /// it; `same` tells whether it equals the exact one in m_exact_values.
  void refactor_clamped(const Cloth& cloth, bool& same);
  /// One step of dt by the time scheme (its stages solved here), then finish_step.
  void step(Cloth& cloth, const Vec3& gravity, double dt);
  /// The end of every step: whether the scheme's history is now valid (keyed to the cloth as
  /// it is, and to dt), and the step's counters.
  void finish_step(const Cloth& cloth, double dt, bool history_valid);
  /// adaptive: one output interval of dt in error-controlled steps of a scheme with an error
  /// estimate (adaptive_steps.cpp).
  void adaptive_interval(Cloth& cloth, const Vec3& gravity, double dt);

  // -- StageSolver: what the time scheme asks of Newton (time_scheme.hpp) --
  const std::vector<std::int32_t>& free_vertices() const override { return m_free_vertices; }
  Stage& stage() override { return m_stage; }
  const Stage& stage() const override { return m_stage; }
  const Positions& solution() const override { return m_iterate; }
  bool extrapolating() const override {
    return m_options.predictor == NewtonPredictor::extrapolated;
  }
  void pose_backward_euler(const Cloth& cloth, double dt) override;
  void finish_setup(const Cloth& cloth) override;
  void update_directions(const Cloth& cloth) override;
  /// The nonlinear solve of the stage posed: minimises its objective from the cloth's (driven)
  /// positions or the inertial guess, updates the counters, and leaves the solution in
  /// m_iterate; counts an unconverged solve.
  void solve(const Cloth& cloth) override;
  /// Writes m_iterate and (m_iterate − x̄)/h_v into the cloth's free vertices.
  void write(Cloth& cloth) override;
  void count_restart() override { ++m_statistics.history_restarts; }

  ImplicitOptions m_options;
  ImplicitStatistics m_statistics;
  std::unique_ptr<LinearSolver> m_solver;
  DivergenceMonitor m_monitor;

  // Structure, rebuilt per topology version.
  std::uint64_t m_topology = std::numeric_limits<std::uint64_t>::max();
  std::vector<std::int32_t> m_dof_of_vertex;  // n, first unknown of a free vertex or −1
  std::vector<std::int32_t> m_free_vertices;  // vertex of each block of unknowns
  SymmetricPattern m_pattern;
  std::vector<std::int64_t> m_spring_slots;  // s×3: slot of the (0,c) entry of the
                                             // off-diagonal block, or −1
  // per element pair of the membrane (for_each_membrane_pair), its block's rank among its
  // column block's neighbours, -1 for a constrained corner; pairs start per element
  std::vector<std::int64_t> m_membrane_pair_starts;
  std::vector<std::int32_t> m_membrane_pair_ranks;
  MembraneElementWork m_membrane_work;
  std::vector<std::int64_t> m_bending_slots;  // nnz(Q)×3: slot of quadratic bending's entry
                                              // (i, j), j >= i, coordinate c; or −1
  double m_mean_rest_length = 1.0;

  // Per-step data and work buffers (sized per topology; no allocation per step).
  std::unique_ptr<TimeScheme> m_scheme;
  // the scheme's history arrays, named (pointers into m_scheme), and their key
  std::vector<std::pair<std::string, Positions*>> m_history_arrays;
  HistoryKey m_history;
  Stage m_stage;                                     // the stage being solved
  int m_step_iterations = 0, m_step_backtracks = 0;  // this step's, over its stages
  // adaptive: the state, velocities and the scheme's history at a step's start, for a
  // rejection
  Positions m_step_positions, m_step_velocities;
  std::vector<Positions> m_step_history;
  /// The truncation test after an accepted step (`m_direction` × alpha) from the last
  /// iterate; `last_move` and `rate` carry the previous move and contraction rate within the
  /// step (0 and 1 at its start) and follow every accepted step; only a `trusted` one (a full
  /// Newton step) may stop. True: stop.
  bool truncation_test(const Cloth& cloth, double alpha, bool trusted, double& last_move,
                       double& rate) const;
  Vec3 m_gravity = Vec3::Zero();
  Positions m_directions;  // s×3, d̂ of the inertial prediction x̂
  Positions m_trial;       // n×3
  Positions m_iterate;     // n×3
  Eigen::VectorXd m_gradient, m_direction, m_rhs;
  std::vector<double> m_values;
  double m_energy_magnitude = 0.0;  // Σ |terms| of the last evaluate(): its round-off scale
  bool m_factor_valid = false;      // the solver holds a factor of this topology (lagged mode)
  // lagged mode: Newton iterations still to refactor without trying the kept factor after a
  // failed CG on it, and the next such back-off
  int m_lag_skip = 0, m_lag_backoff = 1;
  /// lagged mode: whether this iteration may try CG on the kept factor (counts a skip down)
  bool try_kept_factor();
  /// lagged mode: a CG on the kept factor succeeded (true) or missed its bound (false)
  void kept_factor_result(bool solved);
  // projection exact: steps still to take projected after a rejection, and the next back-off
  int m_exact_skip = 0, m_exact_backoff = 1;
  double m_shift = 0.0;   // projection shifted: μ, in units of the inertia M/h̃²
  double m_radius = 0.0;  // projection steihaug: trust radius in the clamped factor's norm
  std::vector<double> m_exact_values;  // projection steihaug: the exact Hessian's values
  // mixed: per spring, the force λ (N) the Newton matrices' transverse terms use
  std::vector<double> m_tension;
  /// mixed: λ ← the springs' forces at positions x
  void reset_tension(const Cloth& cloth, const Positions& x);
  /// mixed: λ after a step alpha·m_direction from m_iterate (before m_iterate moves)
  void update_tension(const Cloth& cloth, double alpha);
  CgWorkspace m_cg;
  Positions m_checkpoint_positions, m_checkpoint_velocities;

  // lbfgs: the scalar matrix Q, its factor and the correction pairs (sized per topology).
  ScalarSpringPattern m_scalar;
  std::vector<double> m_scalar_values;
  std::unique_ptr<SparseCholesky> m_scalar_solver;
  std::uint64_t m_scalar_topology = std::numeric_limits<std::uint64_t>::max();
  double m_scalar_h = 0.0;
  double m_scalar_checksum = std::numeric_limits<double>::quiet_NaN();
  bool m_scalar_factored = false;
  Eigen::MatrixXd m_pairs_s, m_pairs_y;  // dofs × lbfgs_history, circular
  Eigen::VectorXd m_pairs_rho, m_pairs_alpha, m_previous_gradient;
  Eigen::Matrix<double, Eigen::Dynamic, 3> m_scalar_rhs, m_scalar_solution;

  // What an advance() call gives back when it is interrupted or fails: the history and the
  // decisions kept across steps as they were at its start (the cloth goes back with them), so
  // the simulation is exactly as it was before the call.
  struct Memory {
    std::vector<Positions> history;  // the scheme's arrays, in m_history_arrays' order
    HistoryKey key;
    int exact_skip = 0, exact_backoff = 1, lag_skip = 0, lag_backoff = 1;
    double shift = 0.0, radius = 0.0;
  };
  Memory m_memory;
  void keep_memory();
  void restore_memory();
};

}  // namespace yore
