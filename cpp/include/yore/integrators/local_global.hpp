#pragma once
/// @file local_global.hpp
/// Prefactored implicit stepping (Liu et al. 2013, "Fast Simulation of Mass-Spring Systems"):
/// backward Euler by alternating a local step (each spring's ideal vector) and a global step (one
/// solve with a constant, prefactored matrix).

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/integrators/divergence.hpp"
#include "yore/integrators/integrator.hpp"
#include "yore/solvers/sparse_cholesky.hpp"
#include "yore/solvers/spring_matrix.hpp"

namespace yore {

/// How the prefactored matrix is rebuilt after a change of topology (a stroke).
enum class RebuildStrategy {
  fresh,           ///< new symbolic analysis (the ordering method's own) and factorization
  reuse_ordering,  ///< the previous ordering, new vertices placed beside their neighbours
                   ///< (cholmod_analyze_p), then a factorization
  stale_pcg,       ///< keep stepping with CG preconditioned by the stale factor; rebuild as
                   ///< reuse_ordering once CG needs more than stale_pcg_max_iterations
};

/// Settings of the local-global integrator.
struct LocalGlobalOptions {
  /// Cap on the local/global iterations (global solves) of one step; a step that reaches it
  /// before the tolerance is counted in unconverged_steps.
  int iterations = 300;
  /// A step's iterations stop once the estimated distance to the step's solution,
  /// ρ/(1 − ρ) ‖x_k − x_{k−1}‖∞ (ρ the observed contraction), is at most tolerance × the mean
  /// rest length; 0 turns the test off (always run `iterations`, never counted unconverged).
  double tolerance = 1e-3;
  /// Chebyshev semi-iterative acceleration (Wang 2015) with this spectral-radius estimate, or 0
  /// for none. 0.997: the plain iteration's contraction measured on a stiff hanging sheet (32²,
  /// k = 2e4 N/m, dt 1/60 s), with which 300 iterations fall within 0.3 % of explicit; an
  /// overestimate only slows Chebyshev, an underestimate can make it diverge.
  double chebyshev_rho = 0.997;
  Ordering ordering = Ordering::amd;
  FactorKind factorization = FactorKind::supernodal;
  RebuildStrategy rebuild = RebuildStrategy::fresh;
  int stale_pcg_max_iterations = 30;  ///< per solve, before the stale factor is replaced
  double stale_pcg_tol = 1e-12;       ///< relative residual of the stale-factor PCG
  bool record_objective = false;      ///< keep the objective after every iteration (tests)
  double divergence_energy_factor = 10.0;
  /// Largest rise of the energy above its lowest since the last change, in energy scales
  /// (DivergenceMonitor); 0 = no growth check.
  double energy_growth_tolerance = 0.1;
};

/// Counters and wall time per phase, cumulative.
struct LocalGlobalStatistics {
  std::int64_t steps = 0;
  std::int64_t iterations = 0;         ///< global solves, over all steps
  std::int64_t unconverged_steps = 0;  ///< steps that reached the iteration cap (tolerance > 0)
  std::int64_t last_iterations = 0;    ///< global solves of the last step
  /// Steps redone without Chebyshev acceleration because their energy rose past the growth
  /// check's allowance.
  std::int64_t energy_retries = 0;
  /// ‖h² M⁻¹ ∇E‖∞ / mean rest length at the end of the last step (dimensionless; the
  /// objective's gradient in displacement units, the Newton integrator's measure).
  double last_residual = std::numeric_limits<double>::quiet_NaN();
  /// The convergence test's error estimate / mean rest length at the end of the last step.
  double last_error_estimate = std::numeric_limits<double>::quiet_NaN();
  std::int64_t rebuilds = 0;        ///< changes of topology handled
  std::int64_t analyses = 0;        ///< symbolic analyses, over the integrator's life
  std::int64_t factorizations = 0;  ///< numeric factorizations, over the integrator's life
  std::int64_t stale_solves = 0;    ///< global solves done by stale-factor PCG
  std::int64_t pcg_iterations = 0;  ///< their CG iterations
  double assemble_seconds = 0.0;    ///< local steps and right-hand sides
  double analyze_seconds = 0.0;     ///< pattern and symbolic analysis
  double factorize_seconds = 0.0;
  double solve_seconds = 0.0;
  double rebuild_seconds = 0.0;  ///< analysis + factorization done because of a topology change
  std::int64_t last_dofs = 0;
};

/// The local-global method for the backward-Euler objective
///   E(x) = ½‖x − x̂‖²_M / h² + Σ ½ k (|xᵢ − xⱼ| − L)² + D(x) − Σ m g·x,
/// written with auxiliary spring vectors d (|d| = L) as a quadratic in x, so the global matrix
/// Q = M/h² + Σ (k + c/h) AᵀA + drag·M/h is constant: it is analysed per topology and factored
/// per (topology, dt, stiffness), never per step. Q damps each spring's whole relative motion;
/// the local step hands back the part across the spring's damping direction d̂ (normalised
/// x̃ᵢ − x̃ⱼ of the predictor x̃ = xₙ + h vₙ, an O(h²) extrapolation of the direction that keeps
/// the damping quadratic), so at convergence the damping is c/(2h)((Δxᵢ − Δxⱼ)·d̂)² — the
/// Newton integrator's objective exactly. Iterations stop at `tolerance` or the `iterations`
/// cap. Fixed and driven vertices are eliminated; Q is scalar (n_free × n_free), solved for
/// x, y and z.
class LocalGlobalIntegrator : public Integrator {
 public:
  /// Throws std::invalid_argument on bad options.
  explicit LocalGlobalIntegrator(const LocalGlobalOptions& options = {});
  ~LocalGlobalIntegrator();

  /// Runs `steps` steps of dt (s) under gravity (m/s²); SimulationDiverged (cloth restored) on
  /// blow-up; std::invalid_argument on bad arguments.
  void advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) override;

  const LocalGlobalOptions& options() const { return m_options; }
  const LocalGlobalStatistics& statistics() const { return m_statistics; }
  /// The energy checks (their largest gain is reported as the energy_gain counter).
  const DivergenceMonitor& monitor() const { return m_monitor; }
  /// The factorization's counters (analyses, factorizations, nnz(L), flops, ordering).
  const SolverStatistics& solver_statistics() const;
  /// The objective E after each iteration of the last step (record_objective only), J.
  const std::vector<double>& objective_history() const { return m_objective_history; }

 private:
  void ensure_matrix(const Cloth& cloth, double dt);
  void build_pattern(const Cloth& cloth);
  void fill_values(const Cloth& cloth, double dt);
  void factor_fresh(bool keep_ordering);
  void global_solve();
  double objective(const Cloth& cloth, const Positions& x) const;
  // One step, in its parts.
  double begin_step(Cloth& cloth, const Vec3& gravity, double dt);
  double local_step(const Cloth& cloth, bool with_gradient);
  double global_step(int iteration, double& omega, double rho);
  /// The convergence test's estimate of the error left after an iteration, from the plain
  /// global step and the contraction of the iteration (see local_global.cpp).
  struct ErrorEstimate {
    double ratios[3] = {0.0, 0.0, 0.0};  // of successive plain steps, the latest three
    double previous_change = 0.0;
    double error = std::numeric_limits<double>::infinity();
    double update(double change, int iteration, double rho);
  };
  void step(Cloth& cloth, const Vec3& gravity, double dt);
  /// One attempt at the step with Chebyshev's spectral radius rho (0: the plain iteration);
  /// whether the tolerance was met.
  bool solve_step(Cloth& cloth, const Vec3& gravity, double dt, double rho);

  LocalGlobalOptions m_options;
  LocalGlobalStatistics m_statistics;
  DivergenceMonitor m_monitor;
  std::unique_ptr<SparseCholesky> m_solver;

  // Structure, per topology.
  std::uint64_t m_topology = std::numeric_limits<std::uint64_t>::max();
  ScalarSpringPattern m_scalar;  // unknowns, pattern and spring slots of Q
  const std::vector<std::int32_t>& m_free_of_vertex = m_scalar.free_of_vertex;
  const std::vector<std::int32_t>& m_free_vertices = m_scalar.free_vertices;
  const SymmetricPattern& m_pattern = m_scalar.pattern;
  const std::vector<std::int64_t>& m_spring_slot = m_scalar.spring_slot;
  std::vector<double> m_values;
  // Matrix key besides the topology.
  double m_dt = 0.0;
  double m_material_checksum = std::numeric_limits<double>::quiet_NaN();
  bool m_factor_current = false;

  // A stale factor kept by the stale_pcg strategy, for the first m_stale_size unknowns.
  std::unique_ptr<SparseCholesky> m_stale_solver;
  std::int32_t m_stale_size = 0;
  std::vector<std::int32_t> m_previous_permutation;
  std::int32_t m_previous_size = 0;

  // Per-step data and work buffers (no allocation per step).
  double m_h = 0.0;
  Vec3 m_gravity = Vec3::Zero();
  Positions m_start, m_target, m_iterate, m_previous_iterate, m_solution;
  Positions m_directions;  // s×3, damping directions, from the predictor xₙ + h vₙ
  // Per-unknown accumulators are row-major (a spring touches two rows); the solver's right-hand
  // side and solution are column-major (x, y, z columns in one pass over the factor).
  Positions m_base_rhs, m_rhs_rows, m_gradient;
  Eigen::Matrix<double, Eigen::Dynamic, 3> m_rhs, m_unknowns;
  Eigen::VectorXd m_work_rhs, m_work_x, m_diagonal;
  CgWorkspace m_cg;
  std::vector<double> m_objective_history;
  Positions m_checkpoint_positions, m_checkpoint_velocities;
  Positions m_step_positions, m_step_velocities;  // the step's start, for a redo
};

}  // namespace yore
