// Quasi-Newton minimisation of the incremental potential (Liu, Bouaziz & Kavan 2017): L-BFGS
// whose initial inverse Hessian is a solve with the constant scalar matrix Q of the
// local-global method. Part of NewtonSolver: it shares the objective (evaluate), the
// predictor, the line search, the residual test and the BDF2 bookkeeping with Newton.

#include <algorithm>
#include <cmath>

#include "yore/integrators/newton_solver.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/platform/timer.hpp"

namespace yore {
namespace {

// A pair (s, y) is stored only when its curvature sᵀy is positive beyond round-off relative to
// |s||y|: otherwise the update would make the inverse-Hessian estimate indefinite.
constexpr double kCurvatureFloor = 1e-12;

}  // namespace

void NewtonSolver::ensure_scalar_matrix(const Cloth& cloth) {
  const double checksum = spring_material_checksum(cloth);
  if (m_scalar_topology != cloth.topology_version()) {
    ScopedTimer timer(m_statistics.analyze_seconds);
    build_scalar_spring_pattern(cloth, m_scalar);
    const Eigen::Index unknowns = m_scalar.pattern.size;
    const Eigen::Index dofs = 3 * unknowns;
    const int history = m_options.lbfgs_history;
    m_pairs_s.resize(dofs, history);
    m_pairs_y.resize(dofs, history);
    m_pairs_rho.resize(history);
    m_pairs_alpha.resize(history);
    m_previous_gradient.resize(dofs);
    m_scalar_rhs.resize(unknowns, 3);
    m_scalar_solution.resize(unknowns, 3);
    if (unknowns > 0) m_scalar_solver->analyze(m_scalar.pattern);
    m_scalar_topology = cloth.topology_version();
    m_scalar_factored = false;
  }
  if (m_scalar_factored && m_scalar_h == m_stage.h && m_scalar_checksum == checksum) return;
  ScopedTimer timer(m_statistics.factorize_seconds);
  fill_scalar_spring_matrix(cloth, m_stage.h, m_scalar, m_scalar_values);
  if (m_scalar.pattern.size > 0) m_scalar_solver->factorize(m_scalar_values.data());
  m_scalar_h = m_stage.h;
  m_scalar_checksum = checksum;
  m_scalar_factored = true;
}

void NewtonSolver::lbfgs_direction(int stored, int newest) {
  // Two-loop recursion: d = −H g with H the L-BFGS inverse Hessian built on Q⁻¹ (the newest
  // of the `stored` pairs in slot `newest`). Q's unknowns are the free vertices in increasing
  // order, as the blocks of the gradient.
  ScopedTimer timer(m_statistics.solve_seconds);
  const auto unknowns = static_cast<Eigen::Index>(m_free_vertices.size());
  const int capacity = m_options.lbfgs_history;
  m_rhs = m_gradient;
  for (int k = 0; k < stored; ++k) {
    const int slot = (newest - k + capacity) % capacity;
    const double a = m_pairs_rho[slot] * m_pairs_s.col(slot).dot(m_rhs);
    m_pairs_alpha[slot] = a;
    m_rhs -= a * m_pairs_y.col(slot);
  }
  for (Eigen::Index b = 0; b < unknowns; ++b) {
    for (int c = 0; c < 3; ++c) m_scalar_rhs(b, c) = m_rhs[3 * b + c];
  }
  if (unknowns > 0) {
    m_scalar_solver->solve_columns(m_scalar_rhs.data(), m_scalar_solution.data(), 3);
  }
  for (Eigen::Index b = 0; b < unknowns; ++b) {
    for (int c = 0; c < 3; ++c) m_direction[3 * b + c] = m_scalar_solution(b, c);
  }
  for (int k = stored - 1; k >= 0; --k) {
    const int slot = (newest - k + capacity) % capacity;
    const double beta = m_pairs_rho[slot] * m_pairs_y.col(slot).dot(m_direction);
    m_direction += (m_pairs_alpha[slot] - beta) * m_pairs_s.col(slot);
  }
  m_direction = -m_direction;
}

void NewtonSolver::quasi_newton_iterate(const Cloth& cloth, double& energy, double& residual,
                                        int& iterations, int& backtracks, bool& converged) {
  ensure_scalar_matrix(cloth);
  const int capacity = m_options.lbfgs_history;
  int stored = 0, newest = -1;  // the history starts empty every step
  while (true) {
    poll_interrupt();  // max_newton is user-typed
    const IterationVerdict now = verdict(energy, residual, iterations);
    if (now == IterationVerdict::converged) converged = true;
    if (now != IterationVerdict::go_on) return;  // diverged: the state is checked after the step
    lbfgs_direction(stored, newest);
    ++iterations;
    const double slope = m_gradient.dot(m_direction);
    m_previous_gradient = m_gradient;  // (the line search may overwrite m_gradient)
    double trial_energy = energy;
    // the trials carry their gradient: the accepted one is the next iterate's (one pass over the
    // springs per iteration when the full step is taken, as it mostly is)
    const double alpha = line_search(cloth, energy, slope, backtracks, trial_energy, true);
    m_iterate = m_trial;  // same size: no allocation
    energy = trial_energy;
    residual = scaled_residual(cloth);
    // The new pair: s = α d, y = ∇E(new) − ∇E(old), kept if its curvature is positive.
    const int slot = (newest + 1) % capacity;
    m_pairs_s.col(slot) = alpha * m_direction;
    m_pairs_y.col(slot) = m_gradient - m_previous_gradient;
    const double curvature = m_pairs_s.col(slot).dot(m_pairs_y.col(slot));
    if (std::isfinite(curvature) &&
        curvature > kCurvatureFloor * m_pairs_s.col(slot).norm() * m_pairs_y.col(slot).norm()) {
      m_pairs_rho[slot] = 1.0 / curvature;
      newest = slot;
      stored = std::min(stored + 1, capacity);
    } else {
      ++m_statistics.lbfgs_skipped_updates;
    }
  }
}

}  // namespace yore
