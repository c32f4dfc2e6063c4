#pragma once
/// @file newton_solver.hpp
/// Newton's method on the incremental potential of one implicit stage: the structure and
/// assembly of its Hessian (assembly.cpp), the Hessian projections, the line search and the
/// trust region, the stopping tests, the linear-solver and factor policy (newton.cpp,
/// newton_solver.cpp), quasi-Newton (quasi_newton.cpp) and the counters. The time schemes pose
/// the stages it solves (time_scheme.hpp: it is their StageSolver); ImplicitIntegrator joins the
/// two with the history, error control and the divergence checks (implicit.hpp); the SUNDIALS
/// integrators factor its iteration matrix (error_controlled.hpp).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/cloth/membrane.hpp"
#include "yore/cloth/springs.hpp"
#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/time_scheme.hpp"
#include "yore/solvers/linear_solver.hpp"
#include "yore/solvers/sparse_cholesky.hpp"
#include "yore/solvers/spring_matrix.hpp"

namespace yore {

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
class NewtonSolver final : public StageSolver {
 public:
  /// Checks the options Newton reads (tolerances, counts, solver and projection combinations,
  /// quasi-Newton's) and makes the linear solver; throws std::invalid_argument on bad ones.
  /// adaptive_projection is mapped into projection (exact), and quasi-Newton's to the clamp.
  explicit NewtonSolver(const ImplicitOptions& options);
  ~NewtonSolver();
  NewtonSolver(const NewtonSolver&) = delete;
  NewtonSolver& operator=(const NewtonSolver&) = delete;

  /// The scheme whose truncation error the truncation test and the statistics read (none:
  /// the test never stops Newton).
  void set_scheme(const TimeScheme* scheme) { m_scheme = scheme; }
  /// Builds the pattern, its symbolic analysis and the work arrays when `cloth`'s topology
  /// changed since the last call; returns whether it did.
  bool ensure_structure(const Cloth& cloth);
  /// The start of a step under `gravity`: the stopping tests' length scale (the mean rest
  /// length, which a growth stroke changes without a new topology) and the step's counters.
  void begin_step(const Cloth& cloth, const Vec3& gravity);
  /// This step's Newton iterations and line-search halvings, over its stages.
  int step_iterations() const { return m_step_iterations; }
  int step_backtracks() const { return m_step_backtracks; }
  /// Whether Newton may stop before the residual test (the truncation test or the step test
  /// is on), and switching them off and on again (a step redone to the residual test).
  bool has_early_stops() const {
    return !m_options.linearized &&
           (m_options.truncation_fraction > 0.0 || m_options.step_tol > 0.0);
  }
  void set_early_stops(bool on) { m_early_stops = on; }

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

  /// The backward-Euler incremental potential of a step of dt from the cloth's state at
  /// `positions` (see ImplicitIntegrator::newton_system).
  NewtonSystem newton_system(const Cloth& cloth, const Vec3& gravity, double dt,
                             const Positions& positions, HessianProjection projection);

  // -- The iteration matrix of the first-order (x, v) integrators (error_controlled.cpp) ---
  /// Builds the pattern and its symbolic analysis when `cloth`'s topology changed; returns the
  /// vertex of each block of 3 unknowns (the free vertices, in order).
  const std::vector<std::int32_t>& prepare_structure(const Cloth& cloth);
  /// Assembles at positions x (n×3) and factors V = M/γ² + (C + drag M)/γ + H, the matrix
  /// Newton factors for a stage of h̃ = γ: C the springs' damping along x's spring
  /// directions, H the stiffness Hessian of springs and bending at x projected as the options
  /// say. γ² V = M + γ(C + drag M) + γ² H is M(I − γJ)'s velocity block for y = (x, v),
  /// J = ∂(v, M⁻¹f)/∂(x, v). Writes H alone (pattern order) into `stiffness`.
  void factor_iteration_matrix(const Cloth& cloth, const Positions& x, double gamma,
                               std::vector<double>& stiffness);
  /// Solves V z = rhs with the last factor_iteration_matrix (both of its pattern's size).
  void solve_iteration_matrix(const double* rhs, double* solution);
  /// The lower-triangle pattern of the 3n_free system (after prepare_structure).
  const SymmetricPattern& pattern() const { return m_pattern; }

  ProjectionMemory projection_memory() const {
    return {m_exact_skip, m_exact_backoff, m_shift, m_radius};
  }
  /// Restores a memory taken by projection_memory(); throws std::invalid_argument out of range.
  void set_projection_memory(const ProjectionMemory& memory);
  /// Every decision kept across steps (the projection memory and the lagged factor's
  /// back-off), for an interrupted call to give back.
  struct Decisions {
    ProjectionMemory projection;
    int lag_skip = 0, lag_backoff = 1;
  };
  Decisions decisions() const { return {projection_memory(), m_lag_skip, m_lag_backoff}; }
  /// Restores decisions() (unchecked: they were this solver's) and forgets the kept factor.
  void restore_decisions(const Decisions& decisions);

  const ImplicitOptions& options() const { return m_options; }
  const ImplicitStatistics& statistics() const { return m_statistics; }
  /// The counters, for the integrator's step-level ones (steps, rejections, intervals).
  ImplicitStatistics& statistics() { return m_statistics; }
  /// The linear solver's counters (analyses, factorizations, nnz(L), flops, ordering).
  const SolverStatistics& solver_statistics() const;

 private:
  // ensure_structure's last stage: every work array sized for the topology (dofs unknowns).
  void size_workspace(const Cloth& cloth, Eigen::Index dofs);
  double evaluate(const Cloth& cloth, const Positions& x, bool with_gradient, bool with_hessian,
                  HessianProjection projection = HessianProjection::clamp);
  // The membrane's pair ranks in the pattern (ensure_structure's coupled blocks).
  void membrane_ranks(const MembraneElements* elements,
                      const std::vector<std::pair<std::int32_t, std::int32_t>>& coupled,
                      const std::vector<std::int32_t>& first_neighbour);
  // evaluate's terms, each adding to energy, magnitude, m_gradient and m_values in turn:
  // inertia, drag and gravity of the free vertices; the springs (elastic and damping); the
  // quadratic bending matrix.
  void evaluate_inertia(const Cloth& cloth, const Positions& x, bool with_gradient,
                        bool with_hessian, double& energy, double& magnitude);
  void evaluate_springs(const Cloth& cloth, const Positions& x, bool with_gradient,
                        bool with_hessian, TransverseFilter filter, double& energy,
                        double& magnitude);
  void add_spring_block(std::size_t k, std::int32_t a, std::int32_t b, const Mat3& block);
  void evaluate_bending(const Cloth& cloth, const Positions& x, bool with_gradient,
                        bool with_hessian, double& energy, double& magnitude);
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
  /// lbfgs: m_direction ← −H ∇E by the two-loop recursion over the stored pairs.
  void lbfgs_direction(int stored, int newest);
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
  /// What one trust-region Newton–CG step keeps across its iterations.
  struct SteihaugLoop {
    bool assembled = false;  // m_exact_values (and the gradient) are of m_iterate
    bool current = false;    // the factor is of m_iterate's clamped Hessian
    bool same = false;       // and that equals the exact one
    double first_residual = -1.0;
    double last_move = 0.0, rate = 1.0;  // the truncation test's memory within the step
  };
  /// One subproblem's solution (steihaug_direction's results).
  struct SteihaugStep {
    double predicted = 0.0, length = 0.0;
    bool boundary = false, exhausted = false, negative = false;
    /// CG ended inside the region, converged, on positive curvature: a Newton step, which
    /// the step and truncation tests may trust.
    bool newton() const { return !boundary && !negative && !exhausted; }
  };
  /// Assembles (once per iterate) and solves the subproblem at m_iterate, refactoring when
  /// the kept factor no longer preconditions; energy becomes the iterate's when assembled.
  SteihaugStep steihaug_subproblem(const Cloth& cloth, SteihaugLoop& loop, double& energy,
                                   double residual, int iterations);
  /// Evaluates m_trial = m_iterate + m_direction; returns its energy and the actual decrease.
  double steihaug_trial(const Cloth& cloth, double predicted, double energy, double& actual);
  /// Moves to the accepted trial; true when the truncation or the step test stops Newton.
  bool steihaug_accept(const Cloth& cloth, SteihaugLoop& loop, const SteihaugStep& step,
                       double& energy, double& residual);
  /// steihaug_direction's parts: m_cg.preconditioned ← P⁻¹ m_cg.residual (the clamped
  /// factor); the subproblem when both Hessians are equal (Newton's step, within the region).
  void precondition_residual();
  double newton_step_in_region(double rz, bool& boundary, double& length);
  /// projection steihaug: assembles the clamped Hessian at m_iterate into m_values and factors
  /// it; `same` tells whether it equals the exact one in m_exact_values.
  void refactor_clamped(const Cloth& cloth, bool& same);
  /// The scheme's truncation error of the stage at the current iterate (NaN without one).
  double truncation_error(const Cloth& cloth) const;

  ImplicitOptions m_options;
  ImplicitStatistics m_statistics;
  std::unique_ptr<LinearSolver> m_solver;

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
  const TimeScheme* m_scheme = nullptr;  // whose truncation error the stopping test reads
  Stage m_stage;                         // the stage being solved
  int m_step_iterations = 0, m_step_backtracks = 0;  // this step's, over its stages
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
  /// The Newton system solved by CG preconditioned by the kept factor (lagged_factorization);
  /// whether CG converged.
  bool lagged_cg_solve();
  /// lagged mode: a CG on the kept factor succeeded (true) or missed its bound (false)
  void kept_factor_result(bool solved);
  // projection exact: steps still to take projected after a rejection, and the next back-off
  int m_exact_skip = 0, m_exact_backoff = 1;
  double m_shift = 0.0;       // projection shifted: μ, in units of the inertia M/h̃²
  bool m_early_stops = true;  // the truncation and step tests may stop Newton
  double m_radius = 0.0;      // projection steihaug: trust radius in the clamped factor's norm
  std::vector<double> m_exact_values;  // projection steihaug: the exact Hessian's values
  // mixed: per spring, the force λ (N) the Newton matrices' transverse terms use
  std::vector<double> m_tension;
  /// mixed: λ ← the springs' forces at positions x
  void reset_tension(const Cloth& cloth, const Positions& x);
  /// mixed: λ after a step alpha·m_direction from m_iterate (before m_iterate moves)
  void update_tension(const Cloth& cloth, double alpha);
  CgWorkspace m_cg;

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
};

}  // namespace yore
