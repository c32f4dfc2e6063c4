// The stable time steps of Cloth: Gershgorin bounds, Lanczos estimates (at the current state
// or for every state) and the step limit of symplectic Euler on one damped mode.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "yore/cloth/cloth.hpp"

namespace yore {
namespace {

// A membrane element's stiffness is bounded by c (L ⊗ I₃), L_kl = A d_k·d_l (its rest
// "Laplacian", d_k the gradients of the shape functions): at rest the St. Venant–Kirchhoff
// Hessian in F is at most max(2(μ + λ), 2μ) (pure dilation or pure shear), and the map from the
// corners to F has Gram matrix L ⊗ I₃. StVK stiffens as it stretches: along a stretch s its
// tangent modulus is Y (3s² − 1)/2, 1.315 Y at 10 %, the allowance taken here, so the bound
// covers faces stretched by up to 10 %.
constexpr double kMembraneStretchAllowance = 1.315;

double membrane_bound_constant(const MembraneMaterial& material) {
  const double mu = material.mu(), lambda = material.lambda();
  return kMembraneStretchAllowance * std::max(2.0 * (mu + lambda), 2.0 * mu);
}

// Calls visit(a, Δd) per subcell of element e: its area a (with β) and per corner of the element
// Δd_k = d_ck − d_k (the face's gradient, 0 off the face, minus the mean's).
template <class Visit>
void for_each_subcell_difference(const MembraneElements& elements, std::size_t e, Visit&& visit) {
  if (elements.subcell_starts.empty()) return;
  const auto begin = static_cast<std::size_t>(elements.starts[e]);
  const std::size_t m = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
  std::vector<Eigen::Vector2d> delta(m);
  for (auto c = static_cast<std::size_t>(elements.subcell_starts[e]);
       c < static_cast<std::size_t>(elements.subcell_starts[e + 1]); ++c) {
    for (std::size_t k = 0; k < m; ++k) {
      delta[k] = -Eigen::Vector2d(elements.gradient_u[begin + k], elements.gradient_v[begin + k]);
    }
    for (std::size_t j = 0; j < 3; ++j) {
      delta[static_cast<std::size_t>(elements.subcell_corner[3 * c + j])] += Eigen::Vector2d(
          elements.subcell_gradient_u[3 * c + j], elements.subcell_gradient_v[3 * c + j]);
    }
    visit(elements.subcell_area[c], delta);
  }
}

// y += S K S x for the membrane's elements, S = diag(scale) per vertex: every_state
// K_e = c (L ⊗ I₃), L_kl = A d_k·d_l (membrane_bound_constant); otherwise its Hessian at
// `positions`, the stress term clamped (PSD), applied per element in O(corners): with
// X = Σ_q x_q d_qᵀ, Σ_q H_pq x_q = A [X S̃ d_p + μ F Xᵀ F d_p + μ F Fᵀ X d_p + λ tr(F Xᵀ) F d_p]
// (membrane_element's blocks summed).
// y += diag(scale) H diag(scale) x for one element's Hessian blocks (lower triangle in
// work.blocks, corners begin..end of the element).
void apply_blocks(const MembraneElements& elements, std::size_t begin, std::size_t end,
                  const MembraneElementWork& work, const Eigen::VectorXd& scale,
                  const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  for (std::size_t p = begin; p < end; ++p) {
    for (std::size_t q = begin; q <= p; ++q) {
      const Mat3& block = work.blocks[(p - begin) * (p - begin + 1) / 2 + (q - begin)];
      const std::int32_t i = elements.corners[p], j = elements.corners[q];
      y.segment<3>(3 * i) += scale[i] * (block * (scale[j] * x.segment<3>(3 * j)));
      if (p != q) {
        y.segment<3>(3 * j) += scale[j] * (block.transpose() * (scale[i] * x.segment<3>(3 * i)));
      }
    }
  }
}

void add_membrane_product(const MembraneElements& elements, const MembraneMaterial& material,
                          const Positions& positions, bool every_state,
                          const Eigen::VectorXd& scale, const Eigen::VectorXd& x,
                          Eigen::VectorXd& y) {
  using Mat32 = Eigen::Matrix<double, 3, 2>;
  const double mu = material.mu(), lambda = material.lambda();
  const double c = membrane_bound_constant(material);
  MembraneElementWork work;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const auto begin = static_cast<std::size_t>(elements.starts[e]);
    const auto end = static_cast<std::size_t>(elements.starts[e + 1]);
    const bool subcells = !elements.subcell_starts.empty() &&
                          elements.subcell_starts[e + 1] > elements.subcell_starts[e];
    if (subcells && !every_state) {  // its clamped blocks, applied
      membrane_element(elements, e, positions, mu, lambda, TransverseFilter::clamp, work, false,
                       true);
      apply_blocks(elements, begin, end, work, scale, x, y);
      continue;
    }
    if (subcells) {
      for_each_subcell_difference(
          elements, e, [&](double a, const std::vector<Eigen::Vector2d>& delta) {
            Mat32 Xc = Mat32::Zero();
            for (std::size_t k = begin; k < end; ++k) {
              const std::int32_t i = elements.corners[k];
              Xc += scale[i] * x.segment<3>(3 * i) * delta[k - begin].transpose();
            }
            for (std::size_t k = begin; k < end; ++k) {
              const std::int32_t i = elements.corners[k];
              y.segment<3>(3 * i) += scale[i] * (c * a * (Xc * delta[k - begin]));
            }
          });
    }
    Mat32 X = Mat32::Zero(), F = Mat32::Zero();
    for (std::size_t k = begin; k < end; ++k) {
      const std::int32_t i = elements.corners[k];
      const Eigen::RowVector2d d(elements.gradient_u[k], elements.gradient_v[k]);
      X += scale[i] * x.segment<3>(3 * i) * d;
      if (!every_state) F += positions.row(i).transpose() * d;
    }
    Mat32 Y;  // Σ_q H_pq x_q = Y d_p
    if (every_state) {
      Y = c * elements.area[e] * X;
    } else {
      const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
      Eigen::Matrix2d S = 2.0 * mu * E + lambda * E.trace() * Eigen::Matrix2d::Identity();
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(S);
      S = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
          eigen.eigenvectors().transpose();
      Y = elements.area[e] * (X * S + mu * F * X.transpose() * F + mu * F * F.transpose() * X +
                              lambda * (F.cwiseProduct(X)).sum() * F);
    }
    for (std::size_t k = begin; k < end; ++k) {
      const std::int32_t i = elements.corners[k];
      y.segment<3>(3 * i) +=
          scale[i] * (Y * Eigen::Vector2d(elements.gradient_u[k], elements.gradient_v[k]));
    }
  }
}

// Per-spring 3×3 stiffness and damping blocks (each vector has one per spring). every_state:
// k·I and c·I, which bound the spring's Hessian k[d̂d̂ᵀ + (1 − L/ℓ)(I − d̂d̂ᵀ)] (ℓ >= 0) and its
// damping c d̂d̂ᵀ whatever the cloth's shape. Otherwise the Hessian at the current positions,
// projected to PSD (the transverse factor clamped to [0, 1]), and the damping along the current
// directions.
void spring_blocks(const SpringSet& springs, const Positions& positions, bool every_state,
                   std::vector<Mat3>& stiffness_blocks, std::vector<Mat3>& damping_blocks) {
  const std::size_t spring_count = springs.size();
  for (std::size_t s = 0; s < spring_count; ++s) {
    const double k = springs.stiffness[s], c = springs.damping[s];
    const Vec3 d = positions.row(springs.first[s]) - positions.row(springs.second[s]);
    const double length = d.norm();
    if (every_state || !(length > 0.0) || !std::isfinite(length)) {
      stiffness_blocks[s] = k * Mat3::Identity();
      damping_blocks[s] = c * Mat3::Identity();
      continue;
    }
    const Vec3 direction = d / length;
    const Mat3 along = direction * direction.transpose();
    const double transverse = std::clamp(1.0 - springs.rest_length[s] / length, 0.0, 1.0);
    stiffness_blocks[s] = k * (along + transverse * (Mat3::Identity() - along));
    damping_blocks[s] = c * along;
  }
}

// Gershgorin's membrane rows: Σ_elements c |L_kl| √(wₖ wₗ) per vertex, with the subcells'
// differences (see membrane_bound_constant); w the inverse masses.
Eigen::VectorXd membrane_gershgorin_rows(const MembraneElements& elements,
                                         const MembraneMaterial& material,
                                         const Eigen::VectorXd& inverse_masses) {
  Eigen::VectorXd rows = Eigen::VectorXd::Zero(inverse_masses.size());
  const double c = membrane_bound_constant(material);
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const auto begin = static_cast<std::size_t>(elements.starts[e]);
    const auto end = static_cast<std::size_t>(elements.starts[e + 1]);
    for (std::size_t k = begin; k < end; ++k) {
      for (std::size_t l = begin; l < end; ++l) {
        const double laplacian =
            elements.area[e] * (elements.gradient_u[k] * elements.gradient_u[l] +
                                elements.gradient_v[k] * elements.gradient_v[l]);
        const std::int32_t i = elements.corners[k], j = elements.corners[l];
        rows[i] += c * std::abs(laplacian) * std::sqrt(inverse_masses[i] * inverse_masses[j]);
      }
    }
    for_each_subcell_difference(
        elements, e, [&](double a, const std::vector<Eigen::Vector2d>& delta) {
          for (std::size_t k = begin; k < end; ++k) {
            for (std::size_t l = begin; l < end; ++l) {
              const std::int32_t i = elements.corners[k], j = elements.corners[l];
              rows[i] += c * a * std::abs(delta[k - begin].dot(delta[l - begin])) *
                         std::sqrt(inverse_masses[i] * inverse_masses[j]);
            }
          }
        });
  }
  return rows;
}

}  // namespace

double Cloth::gershgorin_time_step() const {
  // Row sums of |M^{-1/2} A M^{-1/2}| over free vertices bound the largest eigenvalue of the
  // mass-scaled stiffness (A = K, each spring block has norm <= k while the spring is not
  // compressed) and damping (A = C) matrices.
  double omega_squared = 0.0;
  double gamma = 0.0;
  const QuadraticBendingMatrix* bending = has_quadratic_bending() ? &quadratic_bending() : nullptr;
  // The membrane's rows: Σ_elements c |L_kl| √(wₖ wₗ) (see membrane_bound_constant).
  const Eigen::VectorXd membrane_rows =
      has_membrane() ? membrane_gershgorin_rows(membrane_elements(), m_membrane, m_inverse_masses)
                     : Eigen::VectorXd();
  for (Eigen::Index i = 0; i < vertex_count(); ++i) {
    if (m_inverse_masses[i] == 0.0) continue;
    double stiffness_row = membrane_rows.size() > 0 ? membrane_rows[i] : 0.0, damping_row = 0.0;
    for (std::int32_t slot = m_incidence_offsets[static_cast<std::size_t>(i)];
         slot < m_incidence_offsets[static_cast<std::size_t>(i) + 1]; ++slot) {
      const auto s = static_cast<std::size_t>(m_incident_springs[static_cast<std::size_t>(slot)]);
      const std::int32_t other = m_springs.first[s] == i ? m_springs.second[s] : m_springs.first[s];
      const double coupling =
          m_inverse_masses[i] + std::sqrt(m_inverse_masses[i] * m_inverse_masses[other]);
      stiffness_row += m_springs.stiffness[s] * coupling;
      damping_row += m_springs.damping[s] * coupling;
    }
    if (bending != nullptr) {
      // κ Q ⊗ I₃ adds κ Σ_j |Q_ij| √(wᵢ wⱼ) to the row (constrained j have w = 0).
      for (std::int32_t k = bending->row_starts[static_cast<std::size_t>(i)];
           k < bending->row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
        const std::int32_t j = bending->columns[static_cast<std::size_t>(k)];
        stiffness_row += m_bending_modulus *
                         std::abs(bending->values[static_cast<std::size_t>(k)]) *
                         std::sqrt(m_inverse_masses[i] * m_inverse_masses[j]);
      }
    }
    omega_squared = std::max(omega_squared, stiffness_row);
    gamma = std::max(gamma, damping_row);
  }
  gamma += m_drag;
  return symplectic_euler_step_limit(omega_squared, gamma);
}

double Cloth::stable_time_step() const { return lanczos_time_step(false); }

double Cloth::stable_time_step_bound() const { return lanczos_time_step(true); }

namespace {

// x ↦ S A S x, S = M^{-1/2}, for per-spring 3×3 blocks A (stiffness or damping); with the
// stiffness, quadratic bending's constant κ Q ⊗ I₃ and the membrane's product are added.
struct ScaledOperator {
  const SpringSet& springs;
  const Eigen::VectorXd& scale;
  const QuadraticBendingMatrix* bending;  // null: no quadratic bending
  double bending_modulus;
  const MembraneElements* membrane;  // null: no membrane
  const MembraneMaterial& material;
  const Positions& positions;
  bool every_state;

  void apply(const std::vector<Mat3>& blocks, bool stiffness, const Eigen::VectorXd& x,
             Eigen::VectorXd& y) const {
    const Eigen::Index n = scale.size();
    y.setZero(3 * n);
    for (std::size_t s = 0; s < springs.size(); ++s) {
      const std::int32_t i = springs.first[s], j = springs.second[s];
      const Vec3 f = blocks[s] * (scale[i] * x.segment<3>(3 * i) - scale[j] * x.segment<3>(3 * j));
      y.segment<3>(3 * i) += scale[i] * f;
      y.segment<3>(3 * j) -= scale[j] * f;
    }
    if (!stiffness) return;
    if (bending != nullptr) add_bending(x, y);
    if (membrane != nullptr) {
      add_membrane_product(*membrane, material, positions, every_state, scale, x, y);
    }
  }

  void add_bending(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    for (Eigen::Index i = 0; i < scale.size(); ++i) {
      if (scale[i] == 0.0) continue;
      Vec3 sum = Vec3::Zero();
      for (std::int32_t k = bending->row_starts[static_cast<std::size_t>(i)];
           k < bending->row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
        const std::int32_t j = bending->columns[static_cast<std::size_t>(k)];
        sum += bending->values[static_cast<std::size_t>(k)] * scale[j] * x.segment<3>(3 * j);
      }
      y.segment<3>(3 * i) += bending_modulus * scale[i] * sum;
    }
  }
};

// Lanczos' deterministic start: xorshift64* values in [−1, 1) on the free vertices'
// coordinates (zero on constrained ones), normalized, so the estimate is reproducible.
Eigen::VectorXd lanczos_start(const Eigen::VectorXd& scale) {
  const Eigen::Index dim = 3 * scale.size();
  Eigen::VectorXd q(dim);
  std::uint64_t seed = 0x9E3779B97F4A7C15ULL;
  for (Eigen::Index r = 0; r < dim; ++r) {
    seed ^= seed >> 12;
    seed ^= seed << 25;
    seed ^= seed >> 27;  // xorshift64*
    const double u = static_cast<double>((seed * 0x2545F4914F6CDD1DULL) >> 11) * 0x1.0p-53;
    q[r] = scale[r / 3] > 0.0 ? 2.0 * u - 1.0 : 0.0;
  }
  q.normalize();
  return q;
}

// The top Ritz pair of Lanczos' tridiagonal matrix (α on the diagonal, β beside it) of the
// given size; false when the eigensolver fails.
bool top_ritz_pair(const std::vector<double>& alpha, const std::vector<double>& beta, int steps,
                   double& top, Eigen::VectorXd& coefficients) {
  Eigen::MatrixXd tridiagonal = Eigen::MatrixXd::Zero(steps, steps);
  for (int r = 0; r < steps; ++r) {
    tridiagonal(r, r) = alpha[static_cast<std::size_t>(r)];
    if (r + 1 < steps) {
      tridiagonal(r, r + 1) = tridiagonal(r + 1, r) = beta[static_cast<std::size_t>(r)];
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(tridiagonal);
  if (eigen.info() != Eigen::Success) return false;
  top = eigen.eigenvalues()[steps - 1];
  coefficients = eigen.eigenvectors().col(steps - 1);
  return true;
}

// Lanczos with full reorthogonalization on S K S: its top Ritz value, the mode's coefficients
// in basis' first `steps` columns. Ritz values approach λ_max from below; the top one usually
// converges in a few dozen iterations (the top of the spectrum is where Krylov methods are
// fastest). Its estimate is checked every 5 iterations, and stops changing by more than the
// relative tolerance. top is NaN when not finite.
struct LanczosTop {
  double top = 0.0;
  Eigen::VectorXd coefficients;
  int steps = 0;
};
LanczosTop lanczos_top(const ScaledOperator& op, const std::vector<Mat3>& stiffness_blocks,
                       double tolerance, Eigen::MatrixXd& basis) {
  const auto max_iterations = static_cast<int>(basis.cols());
  Eigen::VectorXd q = lanczos_start(op.scale), w(q.size());
  std::vector<double> alpha, beta;
  LanczosTop result;
  double previous_top = -1.0;
  for (int it = 0; it < max_iterations; ++it) {
    basis.col(it) = q;
    op.apply(stiffness_blocks, true, q, w);
    alpha.push_back(q.dot(w));
    // Two passes of classical Gram–Schmidt against the whole basis.
    for (int pass = 0; pass < 2; ++pass) {
      w -= basis.leftCols(it + 1) * (basis.leftCols(it + 1).transpose() * w);
    }
    result.steps = it + 1;
    const double b = w.norm();
    const bool last = it + 1 == max_iterations || !(b > 1e-12 * std::abs(alpha.front()) + 1e-300);
    if ((it + 1) % 5 == 0 || last) {
      if (!top_ritz_pair(alpha, beta, result.steps, result.top, result.coefficients)) break;
      if (!std::isfinite(result.top)) {
        result.top = std::numeric_limits<double>::quiet_NaN();
        return result;
      }
      if (last || std::abs(result.top - previous_top) <= tolerance * result.top) {
        break;
      }
      previous_top = result.top;
    }
    beta.push_back(b);
    q = w / b;
  }
  return result;
}

}  // namespace

double Cloth::lanczos_time_step(bool every_state) const {
  const double gershgorin = gershgorin_time_step();
  // Overflowing k / m (no step is stable) or nothing elastic moving (only damping limits the
  // step): the Gershgorin answer is exact, and Lanczos would only see zeros or non-finite values.
  if (!(gershgorin > 0.0) || !std::isfinite(gershgorin) || m_springs.size() == 0) return gershgorin;
  bool any_free = false;
  for (Eigen::Index i = 0; i < vertex_count(); ++i)
    any_free = any_free || m_inverse_masses[i] > 0.0;
  if (!any_free) return gershgorin;

  // Per-spring 3×3 stiffness and damping blocks (see spring_blocks).
  const std::size_t spring_count = m_springs.size();
  std::vector<Mat3> stiffness_blocks(spring_count), damping_blocks(spring_count);
  spring_blocks(m_springs, m_positions, every_state, stiffness_blocks, damping_blocks);
  // Constrained (fixed or driven) vertices have zero inverse mass, so S = M^{-1/2} eliminates
  // their rows and columns.
  const Eigen::VectorXd scale = m_inverse_masses.cwiseSqrt();
  const ScaledOperator op{m_springs,
                          scale,
                          has_quadratic_bending() ? &quadratic_bending() : nullptr,
                          m_bending_modulus,
                          has_membrane() ? &membrane_elements() : nullptr,
                          m_membrane,
                          m_positions,
                          every_state};
  const Eigen::Index dim = 3 * vertex_count();
  Eigen::MatrixXd basis(dim, std::min<Eigen::Index>(dim, kLanczosMaxIterations));
  const LanczosTop lanczos = lanczos_top(op, stiffness_blocks, kLanczosRelativeTolerance, basis);
  if (std::isnan(lanczos.top)) return 0.0;
  if (!(lanczos.top > 0.0) || lanczos.coefficients.size() != lanczos.steps) return gershgorin;
  // Damping of the top mode: the Rayleigh quotient of S C S at its Ritz vector (exact when the
  // damping is proportional to the stiffness, as with the scenes' uniform springs), plus drag.
  const Eigen::VectorXd mode = (basis.leftCols(lanczos.steps) * lanczos.coefficients).normalized();
  Eigen::VectorXd w;
  op.apply(damping_blocks, false, mode, w);
  const double gamma = std::max(0.0, mode.dot(w)) + m_drag;
  return symplectic_euler_step_limit(lanczos.top, gamma);
}

double symplectic_euler_step_limit(double omega_squared, double gamma) {
  // Masses are normal numbers, but k / m can still overflow: then no step is stable.
  if (!std::isfinite(omega_squared) || !std::isfinite(gamma)) return 0.0;
  if (omega_squared == 0.0) {
    // Nothing elastic moves: only damping limits the step (h γ < 2), if anything.
    return gamma > 0.0 ? 2.0 / gamma : std::numeric_limits<double>::infinity();
  }
  // The mode x'' = −ω² x − γ x' under v⁺ = v + h a(x, v), x⁺ = x + h v⁺ is stable while
  // h² ω² + 2 h γ < 4 (and h γ < 2, implied).
  return (std::sqrt(gamma * gamma + 4.0 * omega_squared) - gamma) / omega_squared;
}

}  // namespace yore
