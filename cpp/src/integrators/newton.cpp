// Newton's method on the incremental potential, in its parts: the direction (exact, shifted,
// projected, or by CG on a lagged factor), the projection decisions kept between iterations
// and steps, and the loop that joins them with the line search and the stopping verdict that
// quasi-Newton shares (implicit.cpp). Part of NewtonSolver.

#include <algorithm>
#include <cmath>

#include "implicit_detail.hpp"
#include "yore/integrators/newton_solver.hpp"
#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/platform/timer.hpp"

namespace yore {
using namespace implicit_detail;

NewtonSolver::ProjectionChoice NewtonSolver::begin_projection() {
  // Projection exact: after a rejection the step stays projected, and the next steps skip the
  // exact attempt with a doubling back-off (1, 2, 4, … up to 32 steps), so an indefinite phase
  // costs at most one thrown-away factorization per back-off period.
  ProjectionChoice choice;
  choice.try_exact = m_options.projection == HessianProjection::exact;
  if (choice.try_exact && m_exact_skip > 0) {
    --m_exact_skip;
    choice.try_exact = false;
  }
  return choice;
}

void NewtonSolver::end_projection(const ProjectionChoice& choice, int iterations) {
  if (m_options.projection != HessianProjection::exact) return;
  if (choice.rejected) {
    m_exact_skip = m_exact_backoff;
    m_exact_backoff = std::min(2 * m_exact_backoff, kMaxExactBackoff);
  } else if (m_exact_skip == 0 && iterations > 0 && choice.try_exact) {
    m_exact_backoff = 1;
  }
}

double NewtonSolver::newton_direction(const Cloth& cloth, ProjectionChoice& choice,
                                      double residual) {
  // Within a step, the exact Hessian is tried again once the projected iterations have cut the
  // residual tenfold since it was rejected: near a stable minimum it is positive definite
  // again, and the clamp alone converges only linearly.
  if (choice.rejected && !choice.try_exact && residual < 0.1 * choice.residual_at_rejection) {
    choice.try_exact = true;
  }
  double energy = 0.0;
  bool factored = false;
  if (m_options.projection == HessianProjection::shifted) {
    energy = evaluate(cloth, m_iterate, true, true, HessianProjection::shifted);
    ScopedTimer timer(m_statistics.factorize_seconds);
    factorize_shifted(cloth);
    factored = true;
  } else if (choice.try_exact) {
    energy = evaluate(cloth, m_iterate, true, true, HessianProjection::exact);
    ScopedTimer timer(m_statistics.factorize_seconds);
    try {
      m_solver->factorize(m_values.data());
      factored = true;
      ++m_statistics.exact_hessian_accepted;
    } catch (const NotPositiveDefinite&) {
      ++m_statistics.exact_hessian_rejected;
      choice.try_exact = false;
      choice.rejected = true;
      choice.residual_at_rejection = residual;
    }
  }
  bool solved = false;
  if (!factored) {
    const HessianProjection projection =
        choice.use_abs || m_options.projection == HessianProjection::abs ? HessianProjection::abs
                                                                         : HessianProjection::clamp;
    if (projection == HessianProjection::abs &&
        m_options.projection == HessianProjection::trust_region) {
      ++m_statistics.abs_projections;
    }
    energy = evaluate(cloth, m_iterate, true, true, projection);
    if (try_kept_factor()) solved = lagged_cg_solve();
    if (!solved) {
      ScopedTimer timer(m_statistics.factorize_seconds);
      m_solver->factorize(m_values.data());
      m_factor_valid = true;
    }
  }
  if (!solved) {
    ScopedTimer timer(m_statistics.solve_seconds);
    m_rhs = -m_gradient;
    m_solver->solve(m_rhs.data(), m_direction.data());
  }
  return energy;
}

bool NewtonSolver::lagged_cg_solve() {
  // CG on the current matrix, preconditioned by the lagged factor; a failed CG is followed by
  // a factorization (the caller's).
  ScopedTimer timer(m_statistics.solve_seconds);
  m_rhs = -m_gradient;
  m_direction.setZero();
  bool solved = false;
  m_statistics.lagged_cg_iterations += preconditioned_cg(
      m_pattern, m_values.data(), m_rhs, m_direction,
      [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { m_solver->solve(r.data(), z.data()); },
      m_options.lag_cg_tol, m_options.lag_max_cg_iterations, m_cg, solved);
  kept_factor_result(solved);
  if (solved) ++m_statistics.lagged_solves;
  return solved;
}

bool NewtonSolver::try_kept_factor() {
  // A failed CG on the kept factor costs lag_max_cg_iterations solves, about two factorizations
  // at the default bound (one factorization costs 8–12 solves at 32²–128²), and where the stiff
  // springs turn within a step every try fails: after the k-th failure in a row the next
  // min(2^(k−1), 32) iterations refactor without trying (on the stiff sheets, where every try
  // fails, 13–24 % more CPU than no lagging instead of 2.4–2.8 times), while a factor that
  // keeps serving is tried every iteration.
  if (!m_options.lagged_factorization || !m_factor_valid) return false;
  if (m_lag_skip > 0) {
    --m_lag_skip;
    return false;
  }
  return true;
}

void NewtonSolver::kept_factor_result(bool solved) {
  if (solved) {
    m_lag_backoff = 1;
  } else {
    ++m_statistics.lagged_failures;
    m_lag_skip = m_lag_backoff;
    m_lag_backoff = std::min(2 * m_lag_backoff, kMaxLagBackoff);
  }
}

void NewtonSolver::adapt_projection(const Cloth& cloth, ProjectionChoice& choice, double energy,
                                    double trial_energy, double slope, double alpha,
                                    double magnitude) {
  if (m_options.projection == HessianProjection::trust_region) {
    // Chen et al. 2024: the fit ρ of the quadratic model −(g·d + ½ dᵀHd) = −½ g·d (H d = −g)
    // to the actual decrease at the full step picks the next filter: a poor fit (ρ < 0.01,
    // here: the full step was not accepted) calls for |λ|, a good one for the clamp.
    const double predicted = -0.5 * slope;
    const double actual = energy - trial_energy;
    choice.use_abs = alpha < 1.0 || !(predicted > 0.0) || actual < 0.01 * predicted;
  }
  if (m_options.projection == HessianProjection::shifted) {
    // The trust-region ratio of the unshifted model, −(g·d + ½ dᵀHd) = −½ g·d + ½ μ dᵀ(M/h̃²)d
    // (since (H + μ M/h̃²) d = −g), to the actual decrease at the full step steers μ.
    double inertia_norm = 0.0;  // dᵀ(M/h̃²)d
    const Eigen::VectorXd& masses = cloth.masses();
    for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
      inertia_norm += masses[m_free_vertices[b]] / (m_stage.h * m_stage.h) *
                      m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).squaredNorm();
    }
    const double predicted = -0.5 * slope + 0.5 * m_shift * inertia_norm;
    const double actual = energy - trial_energy;
    const bool unresolved = -slope <= kRoundoff * magnitude;  // round-off: no fit to judge
    if (!unresolved && (alpha < 1.0 || !(actual >= 0.25 * predicted))) {
      m_shift = std::max(kShiftGrowth * m_shift, kMinShift);
    } else if (unresolved || actual >= 0.75 * predicted) {
      m_shift /= kShiftShrink;
      if (m_shift < kMinShift) m_shift = 0.0;
    }
  }
}

void NewtonSolver::newton_iterate(const Cloth& cloth, double& energy, double& residual,
                                  int& iterations, int& backtracks, bool& converged) {
  ProjectionChoice choice = begin_projection();
  double last_move = 0.0, rate = 1.0;  // the truncation test's memory within the step
  while (true) {
    poll_interrupt();  // max_newton is user-typed
    const IterationVerdict now = verdict(energy, residual, iterations);
    if (now == IterationVerdict::diverged) break;  // the state is checked after the step
    if (!m_options.linearized && now == IterationVerdict::converged) {
      converged = true;
      break;
    }
    if (now == IterationVerdict::at_cap) break;
    energy = newton_direction(cloth, choice, residual);
    ++iterations;

    const double slope = m_gradient.dot(m_direction);
    if (m_options.linearized) {
      for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
        m_iterate.row(m_free_vertices[b]) +=
            m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).transpose();
      }
      break;  // Baraff–Witkin: one step, by definition
    }
    double trial_energy = energy;
    const double magnitude = m_energy_magnitude;  // of the objective at the iterate
    const double alpha = line_search(cloth, energy, slope, backtracks, trial_energy);
    adapt_projection(cloth, choice, energy, trial_energy, slope, alpha, magnitude);
    if (m_options.mixed) update_tension(cloth, alpha);
    for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
      m_iterate.row(m_free_vertices[b]) +=
          alpha * m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).transpose();
    }
    energy = evaluate(cloth, m_iterate, true, false);
    residual = scaled_residual(cloth);
    if (truncation_test(cloth, alpha,
                        alpha == 1.0 && std::isfinite(energy) && std::isfinite(residual), last_move,
                        rate)) {
      ++m_statistics.truncation_stops;
      converged = true;
      break;
    }
    if (m_early_stops && m_options.step_tol > 0.0 && alpha == 1.0 && std::isfinite(energy) &&
        std::isfinite(residual) &&
        m_direction.lpNorm<Eigen::Infinity>() <= m_options.step_tol * m_mean_rest_length) {
      ++m_statistics.step_test_stops;
      converged = true;
      break;
    }
  }
  if (m_options.linearized) converged = true;
  end_projection(choice, iterations);
}

bool NewtonSolver::factorize_shifted(const Cloth& cloth) {
  // m_values holds the exact Hessian; add μ M/h̃² to its diagonal, raising μ until the
  // factorization succeeds. Each failure is one thrown-away factorization.
  const Eigen::VectorXd& masses = cloth.masses();
  double applied = 0.0;
  for (;;) {
    const double extra = m_shift - applied;
    if (extra != 0.0) {
      for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
        const double weight = extra * masses[m_free_vertices[b]] / (m_stage.h * m_stage.h);
        for (int c = 0; c < 3; ++c) {
          m_values[static_cast<std::size_t>(m_pattern.column_starts[3 * b + c])] += weight;
        }
      }
      applied = m_shift;
    }
    try {
      m_solver->factorize(m_values.data());
      if (m_shift > 0.0) {
        ++m_statistics.shifted_factorizations;
      } else {
        ++m_statistics.exact_hessian_accepted;
      }
      return true;
    } catch (const NotPositiveDefinite&) {
      ++m_statistics.exact_hessian_rejected;
      if (m_shift >= kMaxShift) throw;
      m_shift = std::max(kShiftGrowth * m_shift, kMinShift);
    }
  }
}

// Preconditioned CG on H d = −g from d = 0, P the clamped Hessian (Steihaug–Toint; Nocedal &
// Wright, Alg. 7.2), inside ‖d‖_P ≤ Δ. It stops at the relative residual `forcing` in the P⁻¹
// norm, where ‖d‖_P reaches Δ (then along p to the edge), or on curvature pᵀHp ≤ 0: on the
// first iteration (p the clamped Newton step) it goes to the edge along p, later it keeps d.
// Unlike Steihaug's it never follows negative curvature past the clamped step: a compressed
// spring's negative transverse stiffness k(1 − L/ℓ) holds only within ~√(2ℓ(L − ℓ)) of its
// line, a stiff spring's quartic term takes over beyond it, and steps along it were refused
// by the ratio test at ρ ≈ −10…−10⁶ (measured on the 32² stiff sheet). ‖d‖_P and dᵀPp are
// carried by recurrences (no product with P). `exhausted`: CG stopped at max_iterations.
double NewtonSolver::steihaug_direction(double forcing, bool first, bool same, int max_iterations,
                                        bool& boundary, double& length, bool& exhausted,
                                        bool& negative) {
  CgWorkspace& w = m_cg;
  exhausted = negative = false;
  m_direction.setZero();
  w.residual = -m_gradient;
  precondition_residual();
  double rz = w.residual.dot(w.preconditioned);
  // A step starts from at least the clamped Newton step's length (the radius a step ends with
  // is that of its last, tiny corrections).
  if (first || !(m_radius > 0.0)) m_radius = std::max(m_radius, std::sqrt(rz));
  const double radius2 = m_radius * m_radius;
  if (same) return newton_step_in_region(rz, boundary, length);
  w.direction = w.preconditioned;
  const double target = forcing * std::sqrt(rz);
  double dpd = 0.0, dpp = 0.0, ppp = rz;  // ‖d‖²_P, dᵀPp, ‖p‖²_P
  boundary = false;
  for (int j = 0;; ++j) {
    if (j == max_iterations) {
      exhausted = true;
      break;
    }
    poll_interrupt();
    symmetric_multiply(m_pattern, m_exact_values.data(), w.direction, w.product);
    const double curvature = w.direction.dot(w.product);
    if (!(curvature > 0.0)) {
      ++m_statistics.negative_curvature_steps;
      negative = true;
      if (j > 0) break;
    }
    const double alpha = rz / curvature;
    const double next_dpd = dpd + 2.0 * alpha * dpp + alpha * alpha * ppp;
    if (!(curvature > 0.0) || next_dpd >= radius2) {
      // τ ≥ 0 with ‖d + τp‖²_P = Δ²
      const double tau = (-dpp + std::sqrt(std::max(0.0, dpp * dpp + ppp * (radius2 - dpd)))) / ppp;
      m_direction += tau * w.direction;
      boundary = true;
      break;
    }
    m_direction += alpha * w.direction;
    dpd = next_dpd;
    w.residual -= alpha * w.product;
    precondition_residual();
    ++m_statistics.trust_region_cg_iterations;
    const double next = w.residual.dot(w.preconditioned);
    if (!(next > target * target)) break;
    const double beta = next / rz;
    dpp = beta * (dpp + alpha * ppp);
    ppp = next + beta * beta * ppp;
    w.direction = w.preconditioned + beta * w.direction;
    rz = next;
  }
  length = boundary ? m_radius : std::sqrt(std::max(0.0, dpd));
  symmetric_multiply(m_pattern, m_exact_values.data(), m_direction, w.product);
  return -(m_gradient.dot(m_direction) + 0.5 * m_direction.dot(w.product));
}

void NewtonSolver::precondition_residual() {
  ScopedTimer timer(m_statistics.solve_seconds);
  m_solver->solve(m_cg.residual.data(), m_cg.preconditioned.data());
}

double NewtonSolver::newton_step_in_region(double rz, bool& boundary, double& length) {
  // No spring is compressed: H = P, and the first CG step (P⁻¹(−g) in m_cg.preconditioned, rz
  // its P-norm squared) is Newton's step, cut back to the region's boundary.
  boundary = rz > m_radius * m_radius;
  const double scale = boundary ? m_radius / std::sqrt(rz) : 1.0;
  m_direction = scale * m_cg.preconditioned;
  length = scale * std::sqrt(rz);
  return scale * rz - 0.5 * scale * scale * rz;  // −(g·d + ½ dᵀHd) with Hz = −g
}

void NewtonSolver::refactor_clamped(const Cloth& cloth, bool& same) {
  // m_values ← the clamped Hessian at m_iterate (m_exact_values holds the exact one there)
  evaluate(cloth, m_iterate, false, true, HessianProjection::clamp);
  same = m_values == m_exact_values;
  ScopedTimer timer(m_statistics.factorize_seconds);
  m_solver->factorize(m_values.data());
  m_factor_valid = true;
}

void NewtonSolver::steihaug_iterate(const Cloth& cloth, double& energy, double& residual,
                                    int& iterations, int& backtracks, bool& converged) {
  // Trust-region Newton–CG: each accepted iterate assembles the exact and the clamped Hessian
  // and factors the clamped one (SPD: never refused); a step the ratio test refuses is solved
  // again, on the same factor, in a smaller region.
  SteihaugLoop loop;
  while (true) {
    poll_interrupt();  // max_newton is user-typed
    const IterationVerdict now = verdict(energy, residual, iterations);
    // diverged: the state is checked after the step; at the cap: the caller counts it
    if (now == IterationVerdict::converged) converged = true;
    if (now != IterationVerdict::go_on) break;
    const SteihaugStep step = steihaug_subproblem(cloth, loop, energy, residual, iterations);
    ++iterations;
    double actual = 0.0;
    const double trial_energy = steihaug_trial(cloth, step.predicted, energy, actual);
    const double ratio = step.predicted > 0.0 ? actual / step.predicted : -1.0;
    const bool finite = std::isfinite(trial_energy) && std::isfinite(actual);
    if (!finite || !(ratio >= kSteihaugShrinkBelow)) {
      m_radius = kSteihaugShrink * step.length;
    } else if (ratio > kSteihaugGrowAbove && step.boundary) {
      m_radius = kSteihaugGrowth * m_radius;
    }
    if (finite && ratio > kSteihaugAccept) {
      if (steihaug_accept(cloth, loop, step, energy, residual)) {
        converged = true;
        break;
      }
    } else {
      ++backtracks;
      ++m_statistics.trust_region_rejections;
      if (!(m_radius > 0.0)) break;  // nothing left to try; the verdict at the cap decides
      evaluate(cloth, m_iterate, true, false);  // the iterate's gradient again
    }
  }
}

NewtonSolver::SteihaugStep NewtonSolver::steihaug_subproblem(const Cloth& cloth, SteihaugLoop& loop,
                                                             double& energy, double residual,
                                                             int iterations) {
  bool fresh = false;          // this subproblem made the factor (else: a reuse)
  bool first_on_kept = false;  // the first subproblem at this iterate on a kept factor
  if (!loop.assembled) {
    energy = evaluate(cloth, m_iterate, true, true, HessianProjection::exact);
    std::copy(m_values.begin(), m_values.end(), m_exact_values.begin());
    loop.assembled = true;
    if (!try_kept_factor()) {
      refactor_clamped(cloth, loop.same);
      fresh = loop.current = true;
    } else {
      first_on_kept = true;
    }
  }
  if (loop.first_residual < 0.0) loop.first_residual = residual;
  // Loose far from the solution, tighter as the residual falls (superlinear convergence).
  const double forcing = std::min(kSteihaugForcing, std::sqrt(residual / loop.first_residual));
  const bool first = iterations == 0;  // this step's first subproblem
  SteihaugStep step;
  step.predicted =
      steihaug_direction(forcing, first, loop.same && loop.current,
                         loop.current ? kMaxSteihaugIterations : m_options.lag_max_cg_iterations,
                         step.boundary, step.length, step.exhausted, step.negative);
  if (first_on_kept) kept_factor_result(!step.exhausted);
  if (step.exhausted && !loop.current) {
    // the kept factor no longer preconditions well: factor this iterate's clamped Hessian
    // and solve the subproblem again
    refactor_clamped(cloth, loop.same);
    fresh = loop.current = true;
    step.predicted = steihaug_direction(forcing, first, loop.same, kMaxSteihaugIterations,
                                        step.boundary, step.length, step.exhausted, step.negative);
  }
  if (!fresh) ++m_statistics.lagged_solves;  // solved on a factor made at an earlier iterate
  return step;
}

double NewtonSolver::steihaug_trial(const Cloth& cloth, double predicted, double energy,
                                    double& actual) {
  const double slope = m_gradient.dot(m_direction);
  m_trial = m_iterate;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    m_trial.row(m_free_vertices[b]) +=
        m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).transpose();
  }
  if (predicted <= kRoundoff * m_energy_magnitude) {
    // below the energy's resolution: the trapezoid rule on the directional derivatives
    // (as in line_search)
    const double trial_energy = evaluate(cloth, m_trial, true, false);
    actual = -0.5 * (slope + m_gradient.dot(m_direction));
    return trial_energy;
  }
  const double trial_energy = evaluate(cloth, m_trial, false, false);
  actual = energy - trial_energy;
  return trial_energy;
}

bool NewtonSolver::steihaug_accept(const Cloth& cloth, SteihaugLoop& loop, const SteihaugStep& step,
                                   double& energy, double& residual) {
  if (m_options.mixed) update_tension(cloth, 1.0);
  std::swap(m_iterate, m_trial);
  energy = evaluate(cloth, m_iterate, true, false);
  residual = scaled_residual(cloth);
  loop.assembled = loop.current = loop.same = false;
  const bool trusted = step.newton() && std::isfinite(energy) && std::isfinite(residual);
  if (truncation_test(cloth, 1.0, trusted, loop.last_move, loop.rate)) {
    ++m_statistics.truncation_stops;
    return true;
  }
  if (m_early_stops && m_options.step_tol > 0.0 && trusted &&
      m_direction.lpNorm<Eigen::Infinity>() <= m_options.step_tol * m_mean_rest_length) {
    ++m_statistics.step_test_stops;
    return true;
  }
  return false;
}

}  // namespace yore
