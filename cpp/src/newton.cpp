// Newton's method on the incremental potential, in its parts: the direction (exact, shifted,
// projected, or by CG on a lagged factor), the projection decisions kept between iterations
// and steps, and the loop that joins them with the line search and the stopping verdict that
// quasi-Newton shares (implicit.cpp). Part of ImplicitIntegrator.

#include "yore/errors.hpp"
#include "yore/implicit.hpp"
#include "yore/interrupt.hpp"
#include "yore/timer.hpp"

#include "implicit_detail.hpp"

#include <algorithm>
#include <cmath>

namespace yore {
using namespace implicit_detail;

ImplicitIntegrator::ProjectionChoice ImplicitIntegrator::begin_projection() {
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

void ImplicitIntegrator::end_projection(const ProjectionChoice& choice, int iterations) {
  if (m_options.projection != HessianProjection::exact) return;
  if (choice.rejected) {
    m_exact_skip = m_exact_backoff;
    m_exact_backoff = std::min(2 * m_exact_backoff, kMaxExactBackoff);
  } else if (m_exact_skip == 0 && iterations > 0 && choice.try_exact) {
    m_exact_backoff = 1;
  }
}

double ImplicitIntegrator::newton_direction(const Cloth& cloth, ProjectionChoice& choice,
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
    if (m_options.lagged_factorization && m_factor_valid) {
      // CG on the current matrix, preconditioned by the lagged factor.
      ScopedTimer timer(m_statistics.solve_seconds);
      m_rhs = -m_gradient;
      m_direction.setZero();
      m_statistics.lagged_cg_iterations += preconditioned_cg(
          m_pattern, m_values.data(), m_rhs, m_direction,
          [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { m_solver->solve(r.data(), z.data()); },
          m_options.lag_cg_tolerance, m_options.lag_max_cg_iterations, m_cg, solved);
      if (solved) ++m_statistics.lagged_solves;  // a failed CG is followed by a factorization
    }
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

void ImplicitIntegrator::adapt_projection(const Cloth& cloth, ProjectionChoice& choice,
                                          double energy, double trial_energy, double slope,
                                          double alpha, double magnitude) {
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
      inertia_norm += masses[m_free_vertices[b]] / (m_h * m_h) *
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

void ImplicitIntegrator::newton_iterate(const Cloth& cloth, double& energy, double& residual,
                                        int& iterations, int& backtracks, bool& converged) {
  ProjectionChoice choice = begin_projection();
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
    for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
      m_iterate.row(m_free_vertices[b]) +=
          alpha * m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).transpose();
    }
    energy = evaluate(cloth, m_iterate, true, false);
    residual = scaled_residual(cloth);
    if (m_options.step_tol > 0.0 && alpha == 1.0 && std::isfinite(energy) &&
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

bool ImplicitIntegrator::factorize_shifted(const Cloth& cloth) {
  // m_values holds the exact Hessian; add μ M/h̃² to its diagonal, raising μ until the
  // factorization succeeds. Each failure is one thrown-away factorization.
  const Eigen::VectorXd& masses = cloth.masses();
  double applied = 0.0;
  for (;;) {
    const double extra = m_shift - applied;
    if (extra != 0.0) {
      for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
        const double weight = extra * masses[m_free_vertices[b]] / (m_h * m_h);
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

}  // namespace yore
