#include "yore/integrators/implicit.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "implicit_detail.hpp"
#include "yore/cloth/springs.hpp"
#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/platform/timer.hpp"

namespace yore {
using namespace implicit_detail;

namespace {

// The options' values one by one (tolerances, counts), in the order their errors are reported.
void check_option_values(const ImplicitOptions& options) {
  if (!std::isfinite(options.newton_tol) || options.newton_tol <= 0.0) {
    std::ostringstream msg;
    msg << "newton_tol must be finite and > 0, got " << options.newton_tol;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(options.truncation_fraction) || options.truncation_fraction < 0.0 ||
      options.truncation_fraction > 1.0) {
    std::ostringstream msg;
    msg << "truncation_fraction must be finite and in [0, 1], got " << options.truncation_fraction;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(options.step_tol) || options.step_tol < 0.0) {
    std::ostringstream msg;
    msg << "step_tol must be finite and >= 0, got " << options.step_tol;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(options.rho_infinity) || options.rho_infinity < 0.0 ||
      options.rho_infinity > 1.0) {
    std::ostringstream msg;
    msg << "rho_infinity must be finite and in [0, 1], got " << options.rho_infinity;
    throw std::invalid_argument(msg.str());
  }
  if (options.max_newton < 1) {
    std::ostringstream msg;
    msg << "max_newton must be >= 1, got " << options.max_newton;
    throw std::invalid_argument(msg.str());
  }
}

// Options that exclude one another (solvers, projections, adaptivity); `estimate`: the scheme
// estimates its error (error control needs it).
void check_option_combinations(const ImplicitOptions& options, bool estimate) {
  if (options.lagged_factorization &&
      (options.linear_solver.solver == "pcg" || options.adaptive_projection)) {
    throw std::invalid_argument(
        "lagged factorization needs a Cholesky backend and the projected Hessian "
        "(adaptive_projection off)");
  }
  if (options.lag_max_cg_iterations < 1 || !(options.lag_cg_tol > 0.0)) {
    throw std::invalid_argument("lag_max_cg_iterations must be >= 1 and lag_cg_tol > 0");
  }
  if (options.adaptive && (!estimate || options.minimizer != ImplicitMinimizer::newton)) {
    throw std::invalid_argument(
        "error-controlled steps (adaptive, dt = \"auto\") need a "
        "local error estimate: method tr-bdf2 or bdf2, with Newton");
  }
  if (!(options.rtol > 0.0) || !(options.rtol < 1.0) || !(options.atol > 0.0) ||
      !std::isfinite(options.atol) || options.max_steps < 1) {
    throw std::invalid_argument("rtol must be in (0, 1), atol finite and > 0, max_steps >= 1");
  }
  if (options.adaptive_projection && options.linear_solver.solver == "pcg") {
    throw std::invalid_argument(
        "adaptive projection needs a Cholesky backend (cholmod or eigen-ldlt) to detect an "
        "indefinite Hessian; pcg cannot");
  }
  if (options.projection == HessianProjection::steihaug &&
      (options.linear_solver.solver == "pcg" || options.linearized)) {
    throw std::invalid_argument(
        "the steihaug projection needs a Cholesky backend (cholmod or eigen-ldlt) for its "
        "preconditioner, and is not linearized");
  }
  if (options.projection == HessianProjection::shifted &&
      (options.linear_solver.solver == "pcg" || options.lagged_factorization)) {
    throw std::invalid_argument(
        "the shifted projection needs a Cholesky backend (cholmod or eigen-ldlt) to detect an "
        "indefinite Hessian, and no lagged factorization");
  }
}

// Quasi-Newton's own options.
void check_lbfgs_options(const ImplicitOptions& options) {
  if (options.linearized || options.lagged_factorization) {
    throw std::invalid_argument(
        "quasi-Newton (lbfgs) takes neither linearized nor lagged_factorization");
  }
  if (options.method != ImplicitMethod::backward_euler && options.method != ImplicitMethod::bdf2) {
    throw std::invalid_argument("quasi-Newton (lbfgs) takes method backward-euler or bdf2");
  }
  if (options.lbfgs_history < 1 || options.lbfgs_history > 1000) {
    std::ostringstream msg;
    msg << "lbfgs_history must be in [1, 1000], got " << options.lbfgs_history;
    throw std::invalid_argument(msg.str());
  }
}

}  // namespace

namespace {

/// A projection by its name in the option tables (yore.options, scene and state files).
const char* projection_name(HessianProjection projection) {
  switch (projection) {
    case HessianProjection::clamp:
      return "clamp";
    case HessianProjection::abs:
      return "abs";
    case HessianProjection::exact:
      return "exact";
    case HessianProjection::trust_region:
      return "trust-region";
    case HessianProjection::shifted:
      return "shifted";
    case HessianProjection::steihaug:
      return "steihaug";
  }
  return "clamp";
}

}  // namespace

ImplicitOptions resolve_choices(ImplicitOptions options, const ImplicitChoices& choices) {
  options.predictor = choices.predictor.value_or(options.linearized ? NewtonPredictor::start
                                                                    : NewtonPredictor::inertial);
  if (options.minimizer != ImplicitMinimizer::newton) return options;
  HessianProjection projection = HessianProjection::clamp;
  if (choices.projection) {
    projection = *choices.projection;
  } else if (choices.adaptive_projection) {
    projection = *choices.adaptive_projection ? HessianProjection::exact : HessianProjection::clamp;
  }
  if (choices.adaptive_projection && choices.projection &&
      *choices.adaptive_projection != (projection == HessianProjection::exact)) {
    throw std::invalid_argument(
        std::string("adaptive_projection=") + (*choices.adaptive_projection ? "True" : "False") +
        " contradicts projection='" + projection_name(projection) + "'; give one of them");
  }
  options.projection = projection;
  options.adaptive_projection = false;  // mapped into projection
  // the one linearized step is the same either way (to round-off)
  options.mixed =
      choices.mixed.value_or(projection == HessianProjection::clamp && !options.linearized);
  return options;
}

ImplicitIntegrator::ImplicitIntegrator(const ImplicitOptions& given)
    : m_options(given), m_monitor(given.divergence_energy_factor, given.energy_growth_tolerance) {
  if (m_options.adaptive_projection) m_options.projection = HessianProjection::exact;
  m_options.adaptive_projection = m_options.projection == HessianProjection::exact;
  const ImplicitOptions& options = m_options;
  check_option_values(options);
  m_scheme = time_scheme(options.method).make(options);
  m_history_arrays = m_scheme->history();
  check_option_combinations(options, m_scheme->error_estimate());
  if (options.minimizer == ImplicitMinimizer::lbfgs) {
    check_lbfgs_options(options);
    // the projection never applies (no Hessian is factored); clamp keeps the exact
    // projection's memory untouched
    m_options.projection = HessianProjection::clamp;
    m_options.adaptive_projection = false;
    m_scalar_solver = std::make_unique<SparseCholesky>(options.linear_solver.factorization,
                                                       options.linear_solver.ordering,
                                                       options.linear_solver.supernode_relaxation);
  }
  m_solver = make_linear_solver(options.linear_solver);
}

ImplicitIntegrator::~ImplicitIntegrator() = default;

const SolverStatistics& ImplicitIntegrator::solver_statistics() const {
  if (m_scalar_solver) return m_scalar_solver->statistics();  // lbfgs: Q's factor
  return m_solver->statistics();
}

namespace {

// The lower triangle of the block pattern: each 3×3 column block's diagonal block (its lower
// triangle), then 3 rows per coupled row block, in the order of `coupled` (sorted by column
// block; first_neighbour[b] is where column block b's entries start).
void fill_block_pattern(std::int32_t blocks,
                        const std::vector<std::pair<std::int32_t, std::int32_t>>& coupled,
                        const std::vector<std::int32_t>& first_neighbour,
                        SymmetricPattern& pattern) {
  pattern.size = 3 * blocks;
  pattern.block_size = 3;
  pattern.column_starts.assign(static_cast<std::size_t>(pattern.size) + 1, 0);
  pattern.row_indices.clear();
  pattern.row_indices.reserve(static_cast<std::size_t>(blocks) * 6 + coupled.size() * 9);
  for (std::int32_t b = 0; b < blocks; ++b) {
    for (int c = 0; c < 3; ++c) {
      const auto column = static_cast<std::size_t>(3 * b + c);
      pattern.column_starts[column] = static_cast<std::int32_t>(pattern.row_indices.size());
      for (int r = c; r < 3; ++r) pattern.row_indices.push_back(3 * b + r);
      for (std::int32_t k = first_neighbour[static_cast<std::size_t>(b)];
           k < first_neighbour[static_cast<std::size_t>(b) + 1]; ++k) {
        const std::int32_t row_block = coupled[static_cast<std::size_t>(k)].second;
        for (int r = 0; r < 3; ++r) pattern.row_indices.push_back(3 * row_block + r);
      }
    }
  }
  pattern.column_starts.back() = static_cast<std::int32_t>(pattern.row_indices.size());
}

// Where each free entry of quadratic bending's Q ⊗ I₃ goes in the pattern's values: slots
// (nnz(Q)×3) gets one index per entry and coordinate, -1 for entries of constrained vertices.
void bending_slots(const QuadraticBendingMatrix& bending,
                   const std::vector<std::int32_t>& dof_of_vertex,
                   const std::vector<std::pair<std::int32_t, std::int32_t>>& coupled,
                   const std::vector<std::int32_t>& first_neighbour,
                   const SymmetricPattern& pattern, std::vector<std::int64_t>& slots) {
  slots.assign(3 * bending.columns.size(), -1);
  // the lower triangle holds each pair once
  for_each_free_entry(
      bending, dof_of_vertex,
      [&](std::int32_t k, std::int32_t i, std::int32_t j, std::int32_t a, std::int32_t b) {
        const std::int32_t column_block = a / 3;
        std::int64_t base = -1;
        if (j > i) {
          const std::int32_t row_block = b / 3;
          const auto begin =
              coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block)];
          const auto end =
              coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block) + 1];
          base =
              3 * (std::lower_bound(begin, end, std::make_pair(column_block, row_block)) - begin);
        }
        for (int c = 0; c < 3; ++c) {
          // Q ⊗ I₃: only the (c, c) entry of the block; a column's diagonal comes first, then
          // the rest of its diagonal block (3 − c entries in all), then 3 rows per neighbour.
          const std::int64_t column_start =
              pattern.column_starts[static_cast<std::size_t>(3 * column_block + c)];
          slots[3 * static_cast<std::size_t>(k) + static_cast<std::size_t>(c)] =
              j == i ? column_start : column_start + (3 - c) + base + c;
        }
      });
}

// The lower triangle's off-diagonal blocks (column block, row block), sorted, once each: one per
// spring between two free vertices, quadratic bending's pairs and the membrane elements'.
std::vector<std::pair<std::int32_t, std::int32_t>> coupled_blocks(
    const Cloth& cloth, const std::vector<std::int32_t>& dof_of_vertex) {
  const SpringSet& springs = cloth.springs();
  // Off-diagonal blocks of the lower triangle: (row block > column block), one per spring
  // between two free vertices.
  std::vector<std::pair<std::int32_t, std::int32_t>> coupled;  // (column block, row block)
  coupled.reserve(springs.size());
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const std::int32_t a = dof_of_vertex[static_cast<std::size_t>(springs.first[k])];
    const std::int32_t b = dof_of_vertex[static_cast<std::size_t>(springs.second[k])];
    if (a < 0 || b < 0) continue;
    coupled.emplace_back(std::min(a, b) / 3, std::max(a, b) / 3);
  }
  // Quadratic bending couples every pair of a hinge's four vertices (more than the springs).
  const QuadraticBendingMatrix* bending =
      cloth.has_quadratic_bending() ? &cloth.quadratic_bending() : nullptr;
  if (bending != nullptr) {
    for_each_free_entry(
        *bending, dof_of_vertex,
        [&](std::int32_t, std::int32_t i, std::int32_t j, std::int32_t a, std::int32_t b) {
          if (j > i) coupled.emplace_back(a / 3, b / 3);
        });
  }
  // The membrane's elements couple every pair of their corners (a smoothed vertex its 1-ring).
  const MembraneElements* elements = cloth.has_membrane() ? &cloth.membrane_elements() : nullptr;
  if (elements != nullptr) {
    for_each_membrane_pair(*elements, [&](std::size_t, std::int32_t i, std::int32_t j) {
      const std::int32_t a = dof_of_vertex[static_cast<std::size_t>(i)];
      const std::int32_t b = dof_of_vertex[static_cast<std::size_t>(j)];
      if (a >= 0 && b >= 0) coupled.emplace_back(std::min(a, b) / 3, std::max(a, b) / 3);
    });
  }
  std::sort(coupled.begin(), coupled.end());
  coupled.erase(std::unique(coupled.begin(), coupled.end()), coupled.end());
  return coupled;
}

}  // namespace

void ImplicitIntegrator::ensure_structure(const Cloth& cloth) {
  if (cloth.topology_version() == m_topology) return;
  const Stopwatch start;
  const Eigen::Index n = cloth.vertex_count();
  const SpringSet& springs = cloth.springs();
  const std::size_t s = springs.size();

  m_dof_of_vertex.assign(static_cast<std::size_t>(n), -1);
  m_free_vertices.clear();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (cloth.inverse_masses()[i] == 0.0) continue;
    m_dof_of_vertex[static_cast<std::size_t>(i)] =
        static_cast<std::int32_t>(3 * m_free_vertices.size());
    m_free_vertices.push_back(static_cast<std::int32_t>(i));
  }
  const auto blocks = static_cast<std::int32_t>(m_free_vertices.size());

  const std::vector<std::pair<std::int32_t, std::int32_t>> coupled =
      coupled_blocks(cloth, m_dof_of_vertex);
  const QuadraticBendingMatrix* bending =
      cloth.has_quadratic_bending() ? &cloth.quadratic_bending() : nullptr;
  const MembraneElements* elements = cloth.has_membrane() ? &cloth.membrane_elements() : nullptr;
  std::vector<std::int32_t> first_neighbour(static_cast<std::size_t>(blocks) + 1, 0);
  for (const auto& pair : coupled) ++first_neighbour[static_cast<std::size_t>(pair.first) + 1];
  for (std::int32_t b = 0; b < blocks; ++b) {
    first_neighbour[static_cast<std::size_t>(b) + 1] +=
        first_neighbour[static_cast<std::size_t>(b)];
  }

  SymmetricPattern& pattern = m_pattern;
  fill_block_pattern(blocks, coupled, first_neighbour, pattern);

  m_spring_slots.assign(3 * s, -1);
  for (std::size_t k = 0; k < s; ++k) {
    const std::int32_t a = m_dof_of_vertex[static_cast<std::size_t>(springs.first[k])];
    const std::int32_t b = m_dof_of_vertex[static_cast<std::size_t>(springs.second[k])];
    if (a < 0 || b < 0) continue;
    const std::int32_t column_block = std::min(a, b) / 3, row_block = std::max(a, b) / 3;
    const auto begin = coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block)];
    const auto end = coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block) + 1];
    const auto rank = std::lower_bound(begin, end, std::make_pair(column_block, row_block)) - begin;
    for (int c = 0; c < 3; ++c) {
      m_spring_slots[3 * k + static_cast<std::size_t>(c)] =
          pattern.column_starts[static_cast<std::size_t>(3 * column_block + c)] + (3 - c) +
          3 * rank;
    }
  }
  m_bending_slots.clear();
  if (bending != nullptr) {
    bending_slots(*bending, m_dof_of_vertex, coupled, first_neighbour, pattern, m_bending_slots);
  }
  membrane_ranks(elements, coupled, first_neighbour);

  const auto dofs = static_cast<Eigen::Index>(pattern.size);
  size_workspace(cloth, dofs);
  const bool newton = m_options.minimizer == ImplicitMinimizer::newton;

  if (pattern.size > 0 && newton) m_solver->analyze(pattern);
  m_topology = cloth.topology_version();
  m_statistics.analyze_seconds += start.seconds();
}

void ImplicitIntegrator::membrane_ranks(
    const MembraneElements* elements,
    const std::vector<std::pair<std::int32_t, std::int32_t>>& coupled,
    const std::vector<std::int32_t>& first_neighbour) {
  m_membrane_pair_starts.clear();
  m_membrane_pair_ranks.clear();
  if (elements == nullptr) return;
  m_membrane_pair_starts.push_back(0);
  for (std::size_t e = 0; e < elements->size(); ++e) {
    const std::int64_t m = elements->starts[e + 1] - elements->starts[e];
    m_membrane_pair_starts.push_back(m_membrane_pair_starts.back() + m * (m - 1) / 2);
  }
  m_membrane_pair_ranks.assign(static_cast<std::size_t>(m_membrane_pair_starts.back()), -1);
  for_each_membrane_pair(*elements, [&](std::size_t slot, std::int32_t i, std::int32_t j) {
    const std::int32_t a = m_dof_of_vertex[static_cast<std::size_t>(i)];
    const std::int32_t b = m_dof_of_vertex[static_cast<std::size_t>(j)];
    if (a < 0 || b < 0) return;
    const std::int32_t column_block = std::min(a, b) / 3, row_block = std::max(a, b) / 3;
    const auto begin = coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block)];
    const auto end = coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block) + 1];
    m_membrane_pair_ranks[slot] = static_cast<std::int32_t>(
        std::lower_bound(begin, end, std::make_pair(column_block, row_block)) - begin);
  });
}

void ImplicitIntegrator::size_workspace(const Cloth& cloth, Eigen::Index dofs) {
  const Eigen::Index n = cloth.vertex_count();
  const std::size_t s = cloth.springs().size();
  m_gradient.resize(dofs);
  m_direction.resize(dofs);
  m_rhs.resize(dofs);
  const bool newton = m_options.minimizer == ImplicitMinimizer::newton;
  // quasi-Newton never assembles the 3n×3n Hessian: no values, no analysis of it
  m_values.assign(newton ? static_cast<std::size_t>(m_pattern.nonzeros()) : 0, 0.0);
  m_exact_values.assign(m_options.projection == HessianProjection::steihaug ? m_values.size() : 0,
                        0.0);
  m_stage.anchor.setZero(n, 3);
  m_stage.target.setZero(n, 3);
  m_trial.setZero(n, 3);
  m_iterate.setZero(n, 3);
  m_directions.resize(static_cast<Eigen::Index>(s), 3);
  m_stage.acceleration.setZero(n, 3);
  m_stage.extrapolated = false;
  // A history restored by set_history for this very topology survives the first step's setup.
  const bool clear = m_history.topology != cloth.topology_version();
  m_scheme->resize(n, clear);
  if (clear) m_history.valid = false;
  m_factor_valid = false;
  m_cg.resize(dofs);
}

void ImplicitIntegrator::pose_backward_euler(const Cloth& cloth, double dt) {
  const Positions& x = cloth.positions();
  const Positions& v = cloth.velocities();
  m_stage.h = dt;
  m_stage.anchor = x;
  m_stage.target = x + dt * v;
  m_stage.hv = m_stage.h;
  // Damping directions of the inertial prediction x̂ (constrained vertices included: x̂ − x̄ is
  // their velocity times h̃ too), an O(h̃²) extrapolation of the end-of-step directions: frozen at
  // xₙ they would be O(h) off, which costs BDF2 its order and damps a rigid rotation.
  update_directions(cloth);
}

void ImplicitIntegrator::update_directions(const Cloth& cloth) {
  const SpringSet& springs = cloth.springs();
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const Vec3 d = m_stage.target.row(springs.first[k]) - m_stage.target.row(springs.second[k]);
    const double length = d.norm();
    m_directions.row(static_cast<Eigen::Index>(k)) = length > 0.0 ? Vec3(d / length) : Vec3::Zero();
  }
}

void ImplicitIntegrator::reset_tension(const Cloth& cloth, const Positions& x) {
  const SpringSet& springs = cloth.springs();
  m_tension.resize(springs.size());
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const double length = (x.row(springs.first[k]) - x.row(springs.second[k])).norm();
    m_tension[k] = springs.stiffness[k] * (length - springs.rest_length[k]);
  }
}

void ImplicitIntegrator::update_tension(const Cloth& cloth, double alpha) {
  const SpringSet& springs = cloth.springs();
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const std::int32_t i = springs.first[k], j = springs.second[k];
    const Vec3 d = m_iterate.row(i) - m_iterate.row(j);
    const double length = d.norm();
    if (length == 0.0) continue;
    Vec3 moved = Vec3::Zero();
    const std::int32_t a = m_dof_of_vertex[static_cast<std::size_t>(i)];
    const std::int32_t b = m_dof_of_vertex[static_cast<std::size_t>(j)];
    if (a >= 0) moved += m_direction.segment<3>(a);
    if (b >= 0) moved -= m_direction.segment<3>(b);
    const double predicted =
        springs.stiffness[k] * (length + d.dot(moved) / length - springs.rest_length[k]);
    m_tension[k] += alpha * (predicted - m_tension[k]);
  }
}

// over 80 lines: the assembly pass (inertia, springs, quadratic bending into one energy sum,
// gradient and Hessian values) runs in every Newton iteration and line-search trial; its
// stages share the running sums whose order fixes the round-off, so it stays one pass.
double ImplicitIntegrator::evaluate(const Cloth& cloth, const Positions& x, bool with_gradient,
                                    bool with_hessian, HessianProjection projection) {
  const TransverseFilter filter =
      projection == HessianProjection::exact || projection == HessianProjection::shifted
          ? TransverseFilter::exact
      : projection == HessianProjection::abs ? TransverseFilter::abs
                                             : TransverseFilter::clamp;
  const Stopwatch start;
  const double h = m_stage.h,
               hv = m_stage.hv;  // inertia's h̃ and the velocity scale (equal but for GA)
  const double drag = cloth.drag();
  const Eigen::VectorXd& masses = cloth.masses();
  double energy = 0.0, magnitude = 0.0;  // the sum and the sum of the terms' magnitudes
  if (with_gradient) m_gradient.setZero();
  if (with_hessian) std::fill(m_values.begin(), m_values.end(), 0.0);

  // Inertia, air drag and gravity of the free vertices.
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    const std::int32_t i = m_free_vertices[b];
    const double m = masses[i];
    const Vec3 inertial = x.row(i) - m_stage.target.row(i);
    const Vec3 moved = x.row(i) - m_stage.anchor.row(i);
    const double inertia_weight = m / (h * h), drag_weight = drag * m / hv;
    const double gravity_energy = m * x.row(i).dot(m_gravity);
    const double positive =
        0.5 * inertia_weight * inertial.squaredNorm() + 0.5 * drag_weight * moved.squaredNorm();
    energy += positive - gravity_energy;
    magnitude += positive + std::abs(gravity_energy);
    if (with_gradient) {
      m_gradient.segment<3>(static_cast<Eigen::Index>(3 * b)) =
          inertia_weight * inertial + drag_weight * moved - m * m_gravity;
    }
    if (with_hessian) {
      // each column of a diagonal block starts with its diagonal entry
      for (int c = 0; c < 3; ++c) {
        m_values[static_cast<std::size_t>(m_pattern.column_starts[3 * b + c])] +=
            inertia_weight + drag_weight;
      }
    }
  }

  // Springs: elasticity (Hessian filtered as asked) and damping along the predicted directions.
  const SpringSet& springs = cloth.springs();
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const std::int32_t i = springs.first[k], j = springs.second[k];
    const Vec3 xi = x.row(i), xj = x.row(j);
    const double rest = springs.rest_length[k], stiffness = springs.stiffness[k];
    const double elastic = spring_energy(xi, xj, rest, stiffness);
    energy += elastic;
    magnitude += elastic;
    const double c = springs.damping[k];
    const Vec3 n0 = m_directions.row(static_cast<Eigen::Index>(k));
    double relative = 0.0;
    if (c > 0.0) {
      relative =
          (xi - m_stage.anchor.row(i).transpose() - xj + m_stage.anchor.row(j).transpose()).dot(n0);
      energy += 0.5 * c / hv * relative * relative;
      magnitude += 0.5 * c / hv * relative * relative;
    }
    const std::int32_t a = m_dof_of_vertex[static_cast<std::size_t>(i)];
    const std::int32_t b = m_dof_of_vertex[static_cast<std::size_t>(j)];
    if (with_gradient) {
      Vec3 gradient = spring_gradient(xi, xj, rest, stiffness);
      if (c > 0.0) gradient += (c / hv * relative) * n0;
      if (a >= 0) m_gradient.segment<3>(a) += gradient;
      if (b >= 0) m_gradient.segment<3>(b) -= gradient;
    }
    if (with_hessian) {
      Mat3 block = m_options.mixed
                       ? spring_hessian_with_force(xi, xj, stiffness, m_tension[k], filter)
                       : spring_hessian(xi, xj, rest, stiffness, filter);
      if (c > 0.0) block += (c / hv) * n0 * n0.transpose();
      const auto& starts = m_pattern.column_starts;
      for (const std::int32_t dof : {a, b}) {
        if (dof < 0) continue;
        for (int col = 0; col < 3; ++col) {
          for (int row = col; row < 3; ++row) {
            m_values[static_cast<std::size_t>(starts[static_cast<std::size_t>(dof + col)] +
                                              (row - col))] += block(row, col);
          }
        }
      }
      if (a >= 0 && b >= 0) {
        for (int col = 0; col < 3; ++col) {
          const std::int64_t slot = m_spring_slots[3 * k + static_cast<std::size_t>(col)];
          for (int row = 0; row < 3; ++row) {
            m_values[static_cast<std::size_t>(slot + row)] -= block(row, col);
          }
        }
      }
    }
  }
  if (cloth.has_quadratic_bending()) {
    // Quadratic bending: ½ κ xᵀ Q x per coordinate, gradient κ Q x, constant Hessian κ Q ⊗ I₃.
    const QuadraticBendingMatrix& bending = cloth.quadratic_bending();
    const double modulus = cloth.bending_modulus();
    double twice_bending = 0.0;
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      Vec3 product = Vec3::Zero();
      for (std::int32_t k = bending.row_starts[static_cast<std::size_t>(i)];
           k < bending.row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
        product += bending.values[static_cast<std::size_t>(k)] *
                   x.row(bending.columns[static_cast<std::size_t>(k)]).transpose();
      }
      product *= modulus;
      twice_bending += x.row(i).dot(product);
      const std::int32_t a = m_dof_of_vertex[static_cast<std::size_t>(i)];
      if (with_gradient && a >= 0) m_gradient.segment<3>(a) += product;
    }
    energy += 0.5 * twice_bending;
    magnitude += std::abs(0.5 * twice_bending);
    if (with_hessian) {
      for (std::size_t k = 0; k < bending.columns.size(); ++k) {
        const double value = modulus * bending.values[k];
        for (std::size_t c = 0; c < 3; ++c) {
          const std::int64_t slot = m_bending_slots[3 * k + c];
          if (slot >= 0) m_values[static_cast<std::size_t>(slot)] += value;
        }
      }
    }
  }
  if (cloth.has_membrane())
    evaluate_membrane(cloth, x, with_gradient, with_hessian, filter, energy, magnitude);
  m_energy_magnitude = magnitude;
  m_statistics.assemble_seconds += start.seconds();
  return energy;
}

void ImplicitIntegrator::evaluate_membrane(const Cloth& cloth, const Positions& x,
                                           bool with_gradient, bool with_hessian,
                                           TransverseFilter filter, double& energy,
                                           double& magnitude) {
  // Each element's corner blocks: the diagonal ones in their unknowns' diagonal blocks, each
  // pair's in the block ensure_structure ranked for it (m_membrane_pair_ranks).
  const MembraneElements& elements = cloth.membrane_elements();
  const double mu = cloth.membrane().mu(), lambda = cloth.membrane().lambda();
  const auto& starts = m_pattern.column_starts;
  MembraneElementWork& work = m_membrane_work;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const double element_energy =
        membrane_element(elements, e, x, mu, lambda, filter, work, with_gradient, with_hessian);
    energy += element_energy;
    magnitude += element_energy;
    const auto begin = static_cast<std::size_t>(elements.starts[e]);
    const std::size_t m = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
    auto dof = [&](std::size_t k) {
      return m_dof_of_vertex[static_cast<std::size_t>(elements.corners[begin + k])];
    };
    if (with_gradient) {
      for (std::size_t k = 0; k < m; ++k) {
        if (dof(k) >= 0) m_gradient.segment<3>(dof(k)) += work.gradient[k];
      }
    }
    if (!with_hessian) continue;
    const auto pairs = static_cast<std::size_t>(m_membrane_pair_starts[e]);
    for (std::size_t p = 0; p < m; ++p) {
      const std::int32_t a = dof(p);
      if (a < 0) continue;
      const Mat3& diagonal = work.blocks[p * (p + 1) / 2 + p];
      for (int col = 0; col < 3; ++col) {
        for (int row = col; row < 3; ++row) {
          m_values[static_cast<std::size_t>(starts[static_cast<std::size_t>(a + col)] +
                                            (row - col))] += diagonal(row, col);
        }
      }
      for (std::size_t q = 0; q < p; ++q) {
        const std::int32_t rank = m_membrane_pair_ranks[pairs + p * (p - 1) / 2 + q];
        if (rank < 0) continue;
        const std::int32_t b = dof(q);
        const Mat3& block = work.blocks[p * (p + 1) / 2 + q];  // ∂gradient_p/∂x_q
        // the lower triangle: the column block is the smaller unknown
        const bool p_below = a > b;
        const std::int32_t column = p_below ? b : a;
        for (int col = 0; col < 3; ++col) {
          const std::int64_t slot = starts[static_cast<std::size_t>(column + col)] + (3 - col) +
                                    3 * static_cast<std::int64_t>(rank);
          for (int row = 0; row < 3; ++row) {
            m_values[static_cast<std::size_t>(slot + row)] +=
                p_below ? block(row, col) : block(col, row);
          }
        }
      }
    }
  }
}

void ImplicitIntegrator::step(Cloth& cloth, const Vec3& gravity, double dt) {
  ensure_structure(cloth);
  // The stopping tests' length scale follows the rest lengths every step: a growth stroke
  // changes them without changing the topology, and a scale kept from before it made a run
  // resumed after the stroke stop Newton elsewhere than the straight run (issue 53, R05).
  const SpringSet& springs = cloth.springs();
  double rest_sum = 0.0;
  for (const double rest : springs.rest_length) rest_sum += rest;
  m_mean_rest_length = springs.size() ? rest_sum / static_cast<double>(springs.size()) : 1.0;
  m_gravity = gravity;
  m_step_iterations = m_step_backtracks = 0;
  const bool history_valid = m_scheme->step(*this, cloth, dt, m_history);
  finish_step(cloth, dt, history_valid);
}

void ImplicitIntegrator::finish_step(const Cloth& cloth, double dt, bool history_valid) {
  m_history.valid = history_valid;
  m_history.topology = cloth.topology_version();
  m_history.edits = cloth.edit_count();
  m_history.dt = dt;
  ++m_statistics.steps;
  m_statistics.last_newton_iterations = m_step_iterations;
  m_statistics.last_line_search_backtracks = m_step_backtracks;
}

void ImplicitIntegrator::solve(const Cloth& cloth) {
  if (m_options.mixed) reset_tension(cloth, cloth.positions());
  m_iterate = cloth.positions();
  if (m_options.predictor != NewtonPredictor::start) {
    // The stage solves M (x − x̂)/h̃² = f: its solution is x̂ + h̃² a⁺, so the start x̂ + h̃² ã
    // is off by h̃² (a⁺ − ã), the error of ã's extrapolation, where x̂ alone is off by h̃² a⁺.
    const bool extrapolate = m_stage.extrapolated;
    const double scale = m_stage.h * m_stage.h;
    for (const std::int32_t i : m_free_vertices) {
      m_iterate.row(i) = m_stage.target.row(i);
      if (extrapolate) m_iterate.row(i) += scale * m_stage.acceleration.row(i);
    }
    if (extrapolate) ++m_statistics.extrapolated_stages;
  }
  m_stage.extrapolated = false;  // each stage's setup provides its own
  int stage_iterations = 0, stage_backtracks = 0;
  bool converged = m_pattern.size == 0;
  double energy = 0.0, residual = 0.0;
  if (!converged) {
    energy = evaluate(cloth, m_iterate, true, false);
    residual = scaled_residual(cloth);
    if (m_options.minimizer == ImplicitMinimizer::lbfgs) {
      quasi_newton_iterate(cloth, energy, residual, stage_iterations, stage_backtracks, converged);
    } else if (m_options.projection == HessianProjection::steihaug && !m_options.linearized) {
      steihaug_iterate(cloth, energy, residual, stage_iterations, stage_backtracks, converged);
    } else {
      newton_iterate(cloth, energy, residual, stage_iterations, stage_backtracks, converged);
    }
  }
  if (!converged) ++m_statistics.unconverged_steps;
  if (m_pattern.size > 0) {
    evaluate(cloth, m_iterate, true, false);
    m_statistics.last_residual = m_gradient.lpNorm<Eigen::Infinity>();
    m_statistics.last_scaled_residual = scaled_residual(cloth) / m_mean_rest_length;
    m_statistics.last_truncation_error = m_scheme->truncation_error(*this, cloth);
  } else {
    m_statistics.last_residual = 0.0;
    m_statistics.last_scaled_residual = 0.0;
    m_statistics.last_truncation_error = 0.0;
  }
  ++m_statistics.stages;
  m_statistics.newton_iterations += stage_iterations;
  if (m_stage.trapezoid) m_statistics.trapezoid_newton_iterations += stage_iterations;
  m_stage.trapezoid = false;  // each stage's setup says
  m_statistics.line_search_backtracks += stage_backtracks;
  m_statistics.last_dofs = m_pattern.size;
  m_step_iterations += stage_iterations;
  m_step_backtracks += stage_backtracks;
}

void ImplicitIntegrator::write(Cloth& cloth) {
  Positions& x = cloth.integrator_positions();
  Positions& v = cloth.integrator_velocities();
  for (const std::int32_t i : m_free_vertices) {
    x.row(i) = m_iterate.row(i);
    v.row(i) = (m_iterate.row(i) - m_stage.anchor.row(i)) / m_stage.hv;
  }
}

void ImplicitIntegrator::finish_setup(const Cloth& cloth) {
  // Constrained vertices are where the drivers put them at the stage's end, moving at their
  // prescribed velocity: their rows make the damping of springs to them see that velocity.
  const Positions& x = cloth.positions();
  const Positions& v = cloth.velocities();
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    if (m_dof_of_vertex[static_cast<std::size_t>(i)] >= 0) continue;
    m_stage.anchor.row(i) = x.row(i) - m_stage.hv * v.row(i);
    m_stage.target.row(i) = x.row(i);
  }
  update_directions(cloth);
}

double ImplicitIntegrator::line_search(const Cloth& cloth, double energy, double slope,
                                       int& backtracks, double& trial_energy, bool trial_gradient) {
  double alpha = 1.0;
  const double magnitude = m_energy_magnitude;  // of the objective at the iterate
  for (int halvings = 0;; ++halvings) {
    m_trial = m_iterate;
    for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
      m_trial.row(m_free_vertices[b]) +=
          alpha * m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).transpose();
    }
    if (-alpha * slope <= kRoundoff * magnitude) {
      // Close to the minimum the energy cannot resolve the decrease the model predicts (an
      // Armijo test on it accepts noise or halves forever). The trapezoid rule on the
      // directional derivatives, ΔE ≈ α/2 (∇E(x)·d + ∇E(x + αd)·d), measures the change without
      // cancellation; Armijo is tested on it. (m_gradient is the trial's afterwards.)
      trial_energy = evaluate(cloth, m_trial, true, false);
      const double change = 0.5 * alpha * (slope + m_gradient.dot(m_direction));
      if (std::isfinite(trial_energy) && std::isfinite(change) &&
          change <= kArmijo * alpha * slope) {
        break;
      }
    } else {
      trial_energy = evaluate(cloth, m_trial, trial_gradient, false);
      if (trial_energy <= energy + kArmijo * alpha * slope) break;  // sufficient decrease
    }
    if (halvings == kMaxBacktracks) break;  // take the tiny step; the residual decides
    alpha *= 0.5;
    ++backtracks;
  }
  return alpha;
}

ImplicitIntegrator::IterationVerdict ImplicitIntegrator::verdict(double energy, double residual,
                                                                 int iterations) const {
  // A non-finite objective or gradient is divergence (advance_checked restores the state and
  // reports it), never convergence; the residual test comes before the cap, so a step that
  // converges on its last allowed iteration counts as converged.
  if (!std::isfinite(energy) || !std::isfinite(residual)) return IterationVerdict::diverged;
  // The scaled residual of the start is h̃²|a|, a the acceleration the forces would give, so at
  // small steps the length test alone passes a start that ignores every force (at h = 1/3840 s
  // h̃²g is below 1e-5 × a 9 cm rest length: the cloth would not even fall). The start passes
  // only if it also leaves no vertex a net force above newton_tol × its weight; after a Newton
  // step the length test alone decides.
  double tolerance = m_options.newton_tol * m_mean_rest_length;
  if (iterations == 0) {
    tolerance =
        std::min(tolerance, m_options.newton_tol * m_stage.h * m_stage.h * m_gravity.norm());
  }
  if (residual <= tolerance) return IterationVerdict::converged;
  if (iterations >= m_options.max_newton) return IterationVerdict::at_cap;
  return IterationVerdict::go_on;
}

bool ImplicitIntegrator::truncation_test(const Cloth& cloth, double alpha, bool trusted,
                                         double& last_move, double& rate) const {
  if (!(m_options.truncation_fraction > 0.0)) return false;
  double move = 0.0;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    move = std::max(move, m_direction.segment<3>(static_cast<Eigen::Index>(3 * b)).norm());
  }
  move *= alpha;
  if (last_move > 0.0) rate = std::max(0.3 * rate, move / last_move);
  last_move = move;
  return trusted && move * std::min(1.0, rate) <=
                        m_options.truncation_fraction * m_scheme->truncation_error(*this, cloth);
}

double ImplicitIntegrator::scaled_residual(const Cloth& cloth) const {
  // The gradient as a displacement: h̃²/m ∇E is how far the inertia term alone would move a
  // vertex to balance it, so the test scales with h̃ and the mass like the positions do.
  const Eigen::VectorXd& masses = cloth.masses();
  double largest = 0.0;
  for (std::size_t b = 0; b < m_free_vertices.size(); ++b) {
    const double scale = m_stage.h * m_stage.h / masses[m_free_vertices[b]];
    const double value =
        scale * m_gradient.segment<3>(static_cast<Eigen::Index>(3 * b)).lpNorm<Eigen::Infinity>();
    if (std::isnan(value)) return value;  // a non-finite gradient is divergence, not convergence
    largest = std::max(largest, value);
  }
  return largest;
}

std::vector<std::string> ImplicitIntegrator::history_fields() const {
  std::vector<std::string> names;
  for (const auto& entry : m_history_arrays) names.push_back(entry.first);
  return names;
}

IntegratorHistory ImplicitIntegrator::history(const Cloth& cloth) const {
  IntegratorHistory out;
  out.valid = !m_history_arrays.empty() && m_history.matches(cloth);
  if (!out.valid) return out;
  out.dt = m_history.dt;
  for (const auto& [name, array] : m_history_arrays) out.arrays.emplace_back(name, *array);
  if (m_options.adaptive && m_scheme->multistep()) out.next_dt = m_history.proposal;
  return out;
}

void ImplicitIntegrator::set_projection_memory(const ProjectionMemory& memory) {
  if (memory.exact_skip < 0 || memory.exact_skip > kMaxExactBackoff || memory.exact_backoff < 1 ||
      memory.exact_backoff > kMaxExactBackoff) {
    std::ostringstream msg;
    msg << "projection memory must have exact_skip in [0, " << kMaxExactBackoff
        << "] and exact_backoff in [1, " << kMaxExactBackoff << "], got " << memory.exact_skip
        << " and " << memory.exact_backoff;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(memory.shift) || memory.shift < 0.0 || memory.shift > kMaxShift) {
    std::ostringstream msg;
    msg << "projection memory must have shift in [0, " << kMaxShift << "], got " << memory.shift;
    throw std::invalid_argument(msg.str());
  }
  m_exact_skip = memory.exact_skip;
  m_exact_backoff = memory.exact_backoff;
  m_shift = memory.shift;
  if (!std::isfinite(memory.radius) || memory.radius < 0.0) {
    std::ostringstream msg;
    msg << "projection memory must have a finite radius >= 0, got " << memory.radius;
    throw std::invalid_argument(msg.str());
  }
  m_radius = memory.radius;
}

void ImplicitIntegrator::set_history(const Cloth& cloth, const IntegratorHistory& history) {
  check_history(cloth, history);
  if (!history.valid) {
    m_history.valid = false;
    return;
  }
  for (const auto& [name, array] : m_history_arrays) *array = history.array(name);
  if (m_scheme->multistep()) m_history.proposal = history.next_dt;
  m_history.dt = history.dt;
  m_history.topology = cloth.topology_version();
  m_history.edits = cloth.edit_count();
  m_history.valid = true;
}

void ImplicitIntegrator::advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) {
  const char* name = m_options.minimizer == ImplicitMinimizer::lbfgs
                         ? "quasi-newton"
                         : time_scheme(m_options.method).integrator;
  const Remedy remedy =
      m_options.minimizer == ImplicitMinimizer::lbfgs ? Remedy::quasi_newton : Remedy::newton;
  if (steps > 0) keep_memory();
  advance_checked(
      cloth, gravity, dt, steps, m_monitor, {name, remedy}, m_checkpoint_positions,
      m_checkpoint_velocities,
      [&] {
        if (m_options.adaptive) {
          adaptive_interval(cloth, gravity, dt);
        } else {
          step(cloth, gravity, dt);
        }
      },
      [&] { return m_statistics.steps - 1; }, [&] { restore_memory(); });
}

void ImplicitIntegrator::keep_memory() {
  Memory& k = m_memory;
  // the scheme's history arrays (assignment reuses their storage)
  k.history.resize(m_history_arrays.size());
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a)
    k.history[a] = *m_history_arrays[a].second;
  k.key = m_history;
  k.exact_skip = m_exact_skip;
  k.exact_backoff = m_exact_backoff;
  k.lag_skip = m_lag_skip;
  k.lag_backoff = m_lag_backoff;
  k.shift = m_shift;
  k.radius = m_radius;
}

void ImplicitIntegrator::restore_memory() {
  const Memory& k = m_memory;
  for (std::size_t a = 0; a < m_history_arrays.size(); ++a)
    *m_history_arrays[a].second = k.history[a];
  m_history = k.key;
  m_exact_skip = k.exact_skip;
  m_exact_backoff = k.exact_backoff;
  m_lag_skip = k.lag_skip;
  m_lag_backoff = k.lag_backoff;
  m_shift = k.shift;
  m_radius = k.radius;
  m_factor_valid = false;  // lagged mode: the kept factor is of a later matrix
}

NewtonSystem ImplicitIntegrator::newton_system(const Cloth& cloth, const Vec3& gravity, double dt,
                                               const Positions& positions,
                                               HessianProjection projection) {
  if (projection != HessianProjection::clamp && projection != HessianProjection::abs &&
      projection != HessianProjection::exact) {
    throw std::invalid_argument("newton_system: projection must be clamp, abs or exact");
  }
  if (positions.rows() != cloth.vertex_count()) {
    std::ostringstream msg;
    msg << "positions must have shape (" << cloth.vertex_count() << ", 3), got ("
        << positions.rows() << ", 3)";
    throw std::invalid_argument(msg.str());
  }
  if (m_options.minimizer != ImplicitMinimizer::newton) {
    throw std::invalid_argument("newton_system needs a Newton integrator (minimizer newton)");
  }
  ensure_structure(cloth);
  m_gravity = gravity;
  pose_backward_euler(cloth, dt);
  m_iterate = cloth.positions();
  for (const std::int32_t i : m_free_vertices) m_iterate.row(i) = positions.row(i);
  if (m_options.mixed) reset_tension(cloth, m_iterate);  // the true Hessian at the point
  NewtonSystem system;
  system.energy = evaluate(cloth, m_iterate, true, true, projection);
  system.gradient = m_gradient;
  system.pattern = m_pattern;
  system.hessian = m_values;
  system.free_vertices = m_free_vertices;
  system.direction = Eigen::VectorXd::Zero(m_pattern.size);
  if (m_pattern.size > 0) {
    m_solver->factorize(m_values.data());
    m_rhs = -m_gradient;
    m_solver->solve(m_rhs.data(), system.direction.data());
  }
  return system;
}

const std::vector<std::int32_t>& ImplicitIntegrator::prepare_structure(const Cloth& cloth) {
  ensure_structure(cloth);
  return m_free_vertices;
}

void ImplicitIntegrator::factor_iteration_matrix(const Cloth& cloth, const Positions& x,
                                                 double gamma, std::vector<double>& stiffness) {
  if (!(gamma > 0.0) || !std::isfinite(gamma)) {
    throw std::invalid_argument("factor_iteration_matrix: gamma must be finite and > 0");
  }
  ensure_structure(cloth);
  // The damping directions are x's own (the Jacobian of the explicit forces at x); the
  // anchor and target only enter the objective's value, which is not used here.
  m_stage.target = x;
  m_stage.anchor = x;
  update_directions(cloth);
  const HessianProjection projection = m_options.projection == HessianProjection::abs
                                           ? HessianProjection::abs
                                           : HessianProjection::clamp;
  // h̃ = ∞: the inertia, drag and damping weights vanish and the values are H alone.
  m_stage.h = m_stage.hv = std::numeric_limits<double>::infinity();
  evaluate(cloth, x, false, true, projection);
  stiffness = m_values;  // same size after the first call: no allocation
  m_stage.h = m_stage.hv = gamma;
  evaluate(cloth, x, false, true, projection);
  if (m_pattern.size == 0) return;
  const Stopwatch start;
  m_solver->factorize(m_values.data());
  m_statistics.factorize_seconds += start.seconds();
}

void ImplicitIntegrator::solve_iteration_matrix(const double* rhs, double* solution) {
  if (m_pattern.size == 0) return;
  const Stopwatch start;
  m_solver->solve(rhs, solution);
  m_statistics.solve_seconds += start.seconds();
}

}  // namespace yore
