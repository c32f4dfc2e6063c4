/// @file assembly.cpp
/// The incremental potential of NewtonSolver: the sparsity pattern of its Hessian (built
/// and analysed once per topology), the work arrays, and the assembly of the energy, gradient
/// and Hessian values that every Newton iteration, line-search trial, quasi-Newton iteration
/// and SUNDIALS iteration matrix uses. The time schemes pose what it is assembled for
/// (time_scheme.hpp); Newton's iterations are in newton.cpp, its driver in implicit.cpp.

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "implicit_detail.hpp"
#include "yore/integrators/newton_solver.hpp"
#include "yore/platform/errors.hpp"
#include "yore/platform/timer.hpp"

namespace yore {
using namespace implicit_detail;

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

// Where each spring's off-diagonal block starts in the pattern's values, per column (−1 for a
// spring with a constrained end): the block (max, min) of its unknowns, ranked among its
// column block's coupled blocks.
void spring_slots(const SpringSet& springs, const std::vector<std::int32_t>& dof_of_vertex,
                  const std::vector<std::pair<std::int32_t, std::int32_t>>& coupled,
                  const std::vector<std::int32_t>& first_neighbour, const SymmetricPattern& pattern,
                  std::vector<std::int64_t>& slots) {
  slots.assign(3 * springs.size(), -1);
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const std::int32_t a = dof_of_vertex[static_cast<std::size_t>(springs.first[k])];
    const std::int32_t b = dof_of_vertex[static_cast<std::size_t>(springs.second[k])];
    if (a < 0 || b < 0) continue;
    const std::int32_t column_block = std::min(a, b) / 3, row_block = std::max(a, b) / 3;
    const auto begin = coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block)];
    const auto end = coupled.begin() + first_neighbour[static_cast<std::size_t>(column_block) + 1];
    const auto rank = std::lower_bound(begin, end, std::make_pair(column_block, row_block)) - begin;
    for (int c = 0; c < 3; ++c) {
      slots[3 * k + static_cast<std::size_t>(c)] =
          pattern.column_starts[static_cast<std::size_t>(3 * column_block + c)] + (3 - c) +
          3 * rank;
    }
  }
}

}  // namespace

bool NewtonSolver::ensure_structure(const Cloth& cloth) {
  if (cloth.topology_version() == m_topology) return false;
  const Stopwatch start;
  const Eigen::Index n = cloth.vertex_count();
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

  spring_slots(cloth.springs(), m_dof_of_vertex, coupled, first_neighbour, pattern, m_spring_slots);
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
  return true;
}

void NewtonSolver::membrane_ranks(const MembraneElements* elements,
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

void NewtonSolver::size_workspace(const Cloth& cloth, Eigen::Index dofs) {
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
  m_factor_valid = false;
  m_cg.resize(dofs);
}

void NewtonSolver::update_directions(const Cloth& cloth) {
  const SpringSet& springs = cloth.springs();
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const Vec3 d = m_stage.target.row(springs.first[k]) - m_stage.target.row(springs.second[k]);
    const double length = d.norm();
    m_directions.row(static_cast<Eigen::Index>(k)) = length > 0.0 ? Vec3(d / length) : Vec3::Zero();
  }
}

void NewtonSolver::reset_tension(const Cloth& cloth, const Positions& x) {
  const SpringSet& springs = cloth.springs();
  m_tension.resize(springs.size());
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const double length = (x.row(springs.first[k]) - x.row(springs.second[k])).norm();
    m_tension[k] = springs.stiffness[k] * (length - springs.rest_length[k]);
  }
}

void NewtonSolver::update_tension(const Cloth& cloth, double alpha) {
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

namespace {
// What the assembly does to a compressed spring's transverse Hessian, by projection.
TransverseFilter filter_of(HessianProjection projection) {
  if (projection == HessianProjection::exact || projection == HessianProjection::shifted) {
    return TransverseFilter::exact;
  }
  return projection == HessianProjection::abs ? TransverseFilter::abs : TransverseFilter::clamp;
}
}  // namespace

// The incremental potential at x: its energy, and (as asked) its gradient into m_gradient and
// its Hessian's values into m_values. The terms add to one running sum in a fixed order
// (inertia, springs, quadratic bending, membrane), which fixes the round-off.
double NewtonSolver::evaluate(const Cloth& cloth, const Positions& x, bool with_gradient,
                              bool with_hessian, HessianProjection projection) {
  const TransverseFilter filter = filter_of(projection);
  const Stopwatch start;
  double energy = 0.0, magnitude = 0.0;  // the sum and the sum of the terms' magnitudes
  if (with_gradient) m_gradient.setZero();
  if (with_hessian) std::fill(m_values.begin(), m_values.end(), 0.0);
  evaluate_inertia(cloth, x, with_gradient, with_hessian, energy, magnitude);
  evaluate_springs(cloth, x, with_gradient, with_hessian, filter, energy, magnitude);
  if (cloth.has_quadratic_bending())
    evaluate_bending(cloth, x, with_gradient, with_hessian, energy, magnitude);
  if (cloth.has_membrane())
    evaluate_membrane(cloth, x, with_gradient, with_hessian, filter, energy, magnitude);
  m_energy_magnitude = magnitude;
  m_statistics.assemble_seconds += start.seconds();
  return energy;
}

void NewtonSolver::evaluate_inertia(const Cloth& cloth, const Positions& x, bool with_gradient,
                                    bool with_hessian, double& energy, double& magnitude) {
  // Inertia, air drag and gravity of the free vertices.
  const double h = m_stage.h,
               hv = m_stage.hv;  // inertia's h̃ and the velocity scale (equal but for GA)
  const double drag = cloth.drag();
  const Eigen::VectorXd& masses = cloth.masses();
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
}

void NewtonSolver::evaluate_springs(const Cloth& cloth, const Positions& x, bool with_gradient,
                                    bool with_hessian, TransverseFilter filter, double& energy,
                                    double& magnitude) {
  // Springs: elasticity (Hessian filtered as asked) and damping along the predicted directions.
  const double hv = m_stage.hv;
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
      add_spring_block(k, a, b, block);
    }
  }
}

void NewtonSolver::add_spring_block(std::size_t k, std::int32_t a, std::int32_t b,
                                    const Mat3& block) {
  // +block in both unknowns' diagonal blocks (their lower triangles), −block in the pair's
  // off-diagonal block (ensure_structure's m_spring_slots) when both ends are free.
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
  if (a < 0 || b < 0) return;
  for (int col = 0; col < 3; ++col) {
    const std::int64_t slot = m_spring_slots[3 * k + static_cast<std::size_t>(col)];
    for (int row = 0; row < 3; ++row) {
      m_values[static_cast<std::size_t>(slot + row)] -= block(row, col);
    }
  }
}

void NewtonSolver::evaluate_bending(const Cloth& cloth, const Positions& x, bool with_gradient,
                                    bool with_hessian, double& energy, double& magnitude) {
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
  if (!with_hessian) return;
  for (std::size_t k = 0; k < bending.columns.size(); ++k) {
    const double value = modulus * bending.values[k];
    for (std::size_t c = 0; c < 3; ++c) {
      const std::int64_t slot = m_bending_slots[3 * k + c];
      if (slot >= 0) m_values[static_cast<std::size_t>(slot)] += value;
    }
  }
}

void NewtonSolver::evaluate_membrane(const Cloth& cloth, const Positions& x, bool with_gradient,
                                     bool with_hessian, TransverseFilter filter, double& energy,
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

double NewtonSolver::scaled_residual(const Cloth& cloth) const {
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

NewtonSystem NewtonSolver::newton_system(const Cloth& cloth, const Vec3& gravity, double dt,
                                         const Positions& positions, HessianProjection projection) {
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

const std::vector<std::int32_t>& NewtonSolver::prepare_structure(const Cloth& cloth) {
  ensure_structure(cloth);
  return m_free_vertices;
}

void NewtonSolver::factor_iteration_matrix(const Cloth& cloth, const Positions& x, double gamma,
                                           std::vector<double>& stiffness) {
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

void NewtonSolver::solve_iteration_matrix(const double* rhs, double* solution) {
  if (m_pattern.size == 0) return;
  const Stopwatch start;
  m_solver->solve(rhs, solution);
  m_statistics.solve_seconds += start.seconds();
}

}  // namespace yore
