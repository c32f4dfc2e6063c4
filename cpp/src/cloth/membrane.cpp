/// @file membrane.cpp
/// The membrane's energy, gradient and Hessian blocks per element (St. Venant–Kirchhoff, with the
/// smoothed strain's subcell penalty), its rest state per face, and its status checks.

#include "yore/cloth/membrane.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace yore {

namespace {

using Mat32 = Eigen::Matrix<double, 3, 2>;

// A face's current area below this fraction of its rest area counts as collapsed.
constexpr double kCollapsedArea = 1e-3;

// S filtered: its eigenvalues kept (exact), clamped at 0 or replaced by their magnitudes.
Eigen::Matrix2d filtered_stress(const Eigen::Matrix2d& stress, TransverseFilter filter) {
  if (filter == TransverseFilter::exact) return stress;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(stress);
  Eigen::Vector2d values = eigen.eigenvalues();
  if (values.minCoeff() >= 0.0) return stress;
  for (int i = 0; i < 2; ++i) {
    values[i] = filter == TransverseFilter::clamp ? std::max(values[i], 0.0) : std::abs(values[i]);
  }
  return eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
}

}  // namespace

std::array<Eigen::Vector2d, 3> membrane_shape_gradients(const MembraneRest& rest) {
  const Eigen::Vector2d d1 = rest.inverse.row(0).transpose();
  const Eigen::Vector2d d2 = rest.inverse.row(1).transpose();
  return {-(d1 + d2), d1, d2};
}

MembraneRest membrane_rest(double l01, double l12, double l20) {
  MembraneRest rest;
  // p0 = 0, p1 = (l01, 0), p2 = (cx, cy) with |p2| = l20 and |p2 − p1| = l12.
  const double cx = (l01 * l01 + l20 * l20 - l12 * l12) / (2.0 * l01);
  const double longest = std::max({l01, l12, l20});
  const double min_height = kMembraneMinRestHeight * longest;
  const double height_squared = l20 * l20 - cx * cx;
  double cy = height_squared > 0.0 ? std::sqrt(height_squared) : 0.0;
  if (!(cy >= min_height)) {
    cy = min_height;
    rest.clamped = true;
  }
  rest.area = 0.5 * l01 * cy;
  rest.inverse << 1.0 / l01, -cx / (l01 * cy), 0.0, 1.0 / cy;
  return rest;
}

double membrane_face(const Vec3& x0, const Vec3& x1, const Vec3& x2, const MembraneRest& rest,
                     double mu, double lambda, Vec9* gradient, Mat9* hessian,
                     TransverseFilter filter) {
  Mat32 edges;
  edges.col(0) = x1 - x0;
  edges.col(1) = x2 - x0;
  const Mat32 F = edges * rest.inverse;
  const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
  const double trace = E.trace();
  const double energy = rest.area * (mu * E.squaredNorm() + 0.5 * lambda * trace * trace);
  if (gradient == nullptr && hessian == nullptr) return energy;
  const Eigen::Matrix2d S = 2.0 * mu * E + lambda * trace * Eigen::Matrix2d::Identity();
  const std::array<Eigen::Vector2d, 3> d = membrane_shape_gradients(rest);
  if (gradient != nullptr) {
    const Mat32 P = rest.area * F * S;
    for (int k = 0; k < 3; ++k) gradient->segment<3>(3 * k) = P * d[static_cast<std::size_t>(k)];
  }
  if (hessian != nullptr) {
    const Eigen::Matrix2d stress = filtered_stress(S, filter);
    for (int l = 0; l < 3; ++l) {
      const Eigen::Vector2d& dl = d[static_cast<std::size_t>(l)];
      for (int c = 0; c < 3; ++c) {
        // dF = e_c dlᵀ; dE = ½ (dl F_c + F_cᵀ dlᵀ), F_c the row c of F.
        const Eigen::RowVector2d row = F.row(c);
        const Eigen::Matrix2d dE = 0.5 * (dl * row + row.transpose() * dl.transpose());
        Mat32 dP = F * (2.0 * mu * dE + lambda * dE.trace() * Eigen::Matrix2d::Identity());
        dP.row(c) += dl.transpose() * stress;
        for (int k = 0; k < 3; ++k) {
          hessian->block<3, 1>(3 * k, 3 * l + c) =
              rest.area * (dP * d[static_cast<std::size_t>(k)]);
        }
      }
    }
  }
  return energy;
}

MembraneFaces membrane_faces(const Faces& faces, const SpringSet& springs) {
  // (low vertex, high vertex, spring) of every structural spring, sorted for lookup.
  std::vector<std::array<std::int32_t, 3>> edges;
  edges.reserve(springs.size());
  for (std::size_t k = 0; k < springs.size(); ++k) {
    if (springs.kind[k] != SpringKind::structural) continue;
    const std::int32_t i = springs.first[k], j = springs.second[k];
    edges.push_back({std::min(i, j), std::max(i, j), static_cast<std::int32_t>(k)});
  }
  std::sort(edges.begin(), edges.end());
  MembraneFaces map;
  map.edge_springs.resize(static_cast<std::size_t>(faces.rows()));
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    for (int e = 0; e < 3; ++e) {
      const std::int32_t a = faces(f, e), b = faces(f, (e + 1) % 3);
      const std::array<std::int32_t, 3> key{std::min(a, b), std::max(a, b), -1};
      const auto found = std::lower_bound(edges.begin(), edges.end(), key);
      if (found == edges.end() || (*found)[0] != key[0] || (*found)[1] != key[1]) {
        std::ostringstream msg;
        msg << "membrane: edge (" << a << ", " << b << ") of face " << f
            << " has no structural spring to carry its rest length";
        throw std::invalid_argument(msg.str());
      }
      map.edge_springs[static_cast<std::size_t>(f)][static_cast<std::size_t>(e)] = (*found)[2];
    }
  }
  return map;
}

MembraneRest membrane_face_rest(const MembraneFaces& map, const SpringSet& springs,
                                std::size_t face) {
  const std::array<std::int32_t, 3>& s = map.edge_springs[face];
  return membrane_rest(springs.rest_length[static_cast<std::size_t>(s[0])],
                       springs.rest_length[static_cast<std::size_t>(s[1])],
                       springs.rest_length[static_cast<std::size_t>(s[2])]);
}

namespace {

// The bilinear form of 𝒞 (2μ A:B + λ tr A tr B) between the strain changes of two gradients,
// F_a = Σ x d_aᵀ moved at corner k and F_b moved at corner l: the 3×3 block
// μ (d·e) F_a F_bᵀ + μ (F_a e)(F_b d)ᵀ + λ (F_a d)(F_b e)ᵀ, d = d_ak, e = d_bl.
Mat3 material_block(const Mat32& Fa, const Eigen::Vector2d& d, const Mat32& Fb,
                    const Eigen::Vector2d& e, double mu, double lambda) {
  return mu * d.dot(e) * Fa * Fb.transpose() + mu * (Fa * e) * (Fb * d).transpose() +
         lambda * (Fa * d) * (Fb * e).transpose();
}

double stvk_density(const Eigen::Matrix2d& E, double mu, double lambda) {
  const double trace = E.trace();
  return mu * E.squaredNorm() + 0.5 * lambda * trace * trace;
}

// One subcell's face: its area, its corners' slots in the element, their face gradients, and
// the deformation gradient F on the face.
struct SubcellFace {
  double area = 0.0;
  std::array<std::size_t, 3> at{};
  std::array<Eigen::Vector2d, 3> d;
  Mat32 F = Mat32::Zero();
};

SubcellFace subcell_face(const MembraneElements& elements, std::size_t begin, std::size_t c,
                         const Positions& x) {
  SubcellFace face;
  face.area = elements.subcell_area[c];
  for (std::size_t j = 0; j < 3; ++j) {
    face.at[j] = static_cast<std::size_t>(elements.subcell_corner[3 * c + j]);
    face.d[j] = Eigen::Vector2d(elements.subcell_gradient_u[3 * c + j],
                                elements.subcell_gradient_v[3 * c + j]);
    face.F += x.row(elements.corners[begin + face.at[j]]).transpose() * face.d[j].transpose();
  }
  return face;
}

// A subcell's 𝒞 between (face − mean) strain changes: face–face, minus the two cross terms
// (here), plus mean–mean (the caller); the stress term S on the face's gradients only for the
// exact Hessian (the filtered ones keep this penalty's Gauss–Newton part, which is positive
// semidefinite). d(l): the element's mean gradients of its m corners.
template <class MeanGradient>
void add_subcell_blocks(const SubcellFace& face, std::size_t m, MeanGradient&& d, const Mat32& F,
                        const Eigen::Matrix2d& S, double mu, double lambda, bool exact,
                        MembraneElementWork& work) {
  // the block (p, q), p ≥ q, of the lower triangle, given the full block (k, l)
  auto add = [&](std::size_t k, std::size_t l, const Mat3& block) {
    if (k >= l) {
      work.blocks[k * (k + 1) / 2 + l] += block;
    } else {
      work.blocks[l * (l + 1) / 2 + k] += block.transpose();
    }
  };
  const double a = face.area;
  const auto& at = face.at;
  for (std::size_t u = 0; u < 3; ++u) {
    for (std::size_t l = 0; l < m; ++l) {
      // −a M(c, mean) at the full block (at[u], l); M(mean, c) is its mirror, which the
      // symmetric storage implies — except on the diagonal block, which holds both
      const Mat3 cross = a * material_block(face.F, face.d[u], F, d(l), mu, lambda);
      if (l == at[u]) {
        work.blocks[l * (l + 1) / 2 + l] -= cross + cross.transpose();
      } else {
        add(at[u], l, -cross);
      }
    }
    for (std::size_t v = 0; v < 3; ++v) {
      if (at[v] > at[u]) continue;  // each lower pair once (the diagonal too)
      Mat3 block = material_block(face.F, face.d[u], face.F, face.d[v], mu, lambda);
      if (exact) block.diagonal().array() += face.d[u].dot(S * face.d[v]);
      work.blocks[at[u] * (at[u] + 1) / 2 + at[v]] += a * block;
    }
  }
}

// The subcells' share of membrane_element (see MembraneElements): adds their energy, and
// to the gradient and the blocks; F, E of the element's mean. The mean–mean part of each
// subcell's 𝒞 form is the same for every subcell up to its area, so the caller adds it once
// (mean_material, the subcells' total area, and mean_stress, −Σ a S for the exact Hessian);
// here only the pairs that touch a subcell's face.
double add_subcells(const MembraneElements& elements, std::size_t e, const Positions& x,
                    const Mat32& F, const Eigen::Matrix2d& E, double mu, double lambda,
                    TransverseFilter filter, MembraneElementWork& work, bool with_gradient,
                    bool with_hessian, double& mean_material, Eigen::Matrix2d& mean_stress) {
  const auto begin = static_cast<std::size_t>(elements.starts[e]);
  const std::size_t m = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
  auto d = [&](std::size_t k) {
    return Eigen::Vector2d(elements.gradient_u[begin + k], elements.gradient_v[begin + k]);
  };
  const bool exact = filter == TransverseFilter::exact;
  double energy = 0.0;
  mean_material = 0.0;
  mean_stress.setZero();
  for (auto c = static_cast<std::size_t>(elements.subcell_starts[e]);
       c < static_cast<std::size_t>(elements.subcell_starts[e + 1]); ++c) {
    const SubcellFace face = subcell_face(elements, begin, c, x);
    const double a = face.area;
    const Eigen::Matrix2d difference =
        0.5 * (face.F.transpose() * face.F - Eigen::Matrix2d::Identity()) - E;
    energy += a * stvk_density(difference, mu, lambda);
    if (!with_gradient && !with_hessian) continue;
    const Eigen::Matrix2d S =
        2.0 * mu * difference + lambda * difference.trace() * Eigen::Matrix2d::Identity();
    if (with_gradient) {
      const Mat32 mean = a * F * S, face_stress = a * face.F * S;
      for (std::size_t k = 0; k < m; ++k) work.gradient[k] -= mean * d(k);
      for (std::size_t j = 0; j < 3; ++j) work.gradient[face.at[j]] += face_stress * face.d[j];
    }
    if (!with_hessian) continue;
    mean_material += a;
    if (exact) mean_stress -= a * S;
    add_subcell_blocks(face, m, d, F, S, mu, lambda, exact, work);
  }
  return energy;
}

}  // namespace

namespace {

// The element's Hessian blocks (lower triangle, row-major) into work.blocks:
// ∂grad_p/∂x_q = A [(d_pᵀ S̃ d_q) I + μ f_q f_pᵀ + μ (d_p·d_q) F Fᵀ + λ f_p f_qᵀ], f_k = F d_k,
// S̃ the filtered stress (the derivative of A F S d_p with S = 2μE + λ tr(E) I).
void element_hessian(const MembraneElements& elements, std::size_t e, const Mat32& F,
                     const Eigen::Matrix2d& S, double mu, double lambda, TransverseFilter filter,
                     MembraneElementWork& work) {
  const auto begin = static_cast<std::size_t>(elements.starts[e]);
  const std::size_t m = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
  const double area = elements.area[e];
  auto d = [&](std::size_t k) {
    return Eigen::Vector2d(elements.gradient_u[begin + k], elements.gradient_v[begin + k]);
  };
  if (work.directions.size() < m) work.directions.resize(m);
  if (work.blocks.size() < m * (m + 1) / 2) work.blocks.resize(m * (m + 1) / 2);
  const Eigen::Matrix2d stress = filtered_stress(S, filter);
  const Mat3 outer = F * F.transpose();
  for (std::size_t k = 0; k < m; ++k) work.directions[k] = F * d(k);
  for (std::size_t p = 0; p < m; ++p) {
    const Eigen::Vector2d dp = d(p);
    const Vec3& fp = work.directions[p];
    for (std::size_t q = 0; q <= p; ++q) {
      const Eigen::Vector2d dq = d(q);
      const Vec3& fq = work.directions[q];
      Mat3& block = work.blocks[p * (p + 1) / 2 + q];
      block = (mu * dp.dot(dq)) * outer + mu * fq * fp.transpose() + lambda * fp * fq.transpose();
      block.diagonal().array() += dp.dot(stress * dq);
      block *= area;
    }
  }
}

}  // namespace

double membrane_element(const MembraneElements& elements, std::size_t e, const Positions& x,
                        double mu, double lambda, TransverseFilter filter,
                        MembraneElementWork& work, bool with_gradient, bool with_hessian) {
  const auto begin = static_cast<std::size_t>(elements.starts[e]);
  const std::size_t m = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
  const double area = elements.area[e];
  Mat32 F = Mat32::Zero();
  for (std::size_t k = 0; k < m; ++k) {
    const Vec3 xk = x.row(elements.corners[begin + k]);
    F.col(0) += elements.gradient_u[begin + k] * xk;
    F.col(1) += elements.gradient_v[begin + k] * xk;
  }
  const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
  const double trace = E.trace();
  double energy = area * (mu * E.squaredNorm() + 0.5 * lambda * trace * trace);
  const bool subcells = !elements.subcell_starts.empty() &&
                        elements.subcell_starts[e + 1] > elements.subcell_starts[e];
  double mean_material = 0.0;  // the subcells' share of the mean–mean 𝒞 form (their area)
  Eigen::Matrix2d mean_stress = Eigen::Matrix2d::Zero();  // and of its stress term
  if (!with_gradient && !with_hessian) {
    if (subcells) {
      energy += add_subcells(elements, e, x, F, E, mu, lambda, filter, work, false, false,
                             mean_material, mean_stress);
    }
    return energy;
  }
  const Eigen::Matrix2d S = 2.0 * mu * E + lambda * trace * Eigen::Matrix2d::Identity();
  auto d = [&](std::size_t k) {
    return Eigen::Vector2d(elements.gradient_u[begin + k], elements.gradient_v[begin + k]);
  };
  if (with_gradient) {
    if (work.gradient.size() < m) work.gradient.resize(m);
    const Mat32 P = area * F * S;
    for (std::size_t k = 0; k < m; ++k) work.gradient[k] = P * d(k);
  }
  if (with_hessian) element_hessian(elements, e, F, S, mu, lambda, filter, work);
  if (subcells) {
    energy += add_subcells(elements, e, x, F, E, mu, lambda, filter, work, with_gradient,
                           with_hessian, mean_material, mean_stress);
    if (with_hessian) {  // the subcells' mean–mean part, once for all of them
      for (std::size_t p = 0; p < m; ++p) {
        for (std::size_t q = 0; q <= p; ++q) {
          Mat3 block = mean_material * material_block(F, d(p), F, d(q), mu, lambda);
          block.diagonal().array() += d(p).dot(mean_stress * d(q));
          work.blocks[p * (p + 1) / 2 + q] += block;
        }
      }
    }
  }
  return energy;
}

double membrane_energy(const MembraneElements& elements, const MembraneMaterial& material,
                       const Positions& x) {
  MembraneElementWork work;
  double energy = 0.0;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    energy += membrane_element(elements, e, x, material.mu(), material.lambda(),
                               TransverseFilter::exact, work, false, false);
  }
  return energy;
}

double membrane_add_gradient(const MembraneElements& elements, const MembraneMaterial& material,
                             const Positions& x, Positions& gradient, MembraneElementWork& work) {
  double energy = 0.0;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    energy += membrane_element(elements, e, x, material.mu(), material.lambda(),
                               TransverseFilter::exact, work, true, false);
    const auto begin = static_cast<std::size_t>(elements.starts[e]);
    const std::size_t m = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
    for (std::size_t k = 0; k < m; ++k) {
      gradient.row(elements.corners[begin + k]) += work.gradient[k].transpose();
    }
  }
  return energy;
}

MembraneStatus membrane_status(const Faces& faces, const MembraneFaces& map,
                               const SpringSet& springs, const Positions& x) {
  MembraneStatus status;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const MembraneRest rest = membrane_face_rest(map, springs, static_cast<std::size_t>(f));
    const Vec3 x0 = x.row(faces(f, 0));
    const double area =
        0.5 * (Vec3(x.row(faces(f, 1))) - x0).cross(Vec3(x.row(faces(f, 2))) - x0).norm();
    status.clamped_rest_faces += rest.clamped ? 1 : 0;
    status.collapsed_faces += area < kCollapsedArea * rest.area ? 1 : 0;
    status.rest_area += rest.area;
    status.current_area += area;
  }
  return status;
}

}  // namespace yore
