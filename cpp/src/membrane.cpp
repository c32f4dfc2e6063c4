#include "yore/membrane.hpp"


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

double membrane_energy(const Faces& faces, const MembraneFaces& map, const SpringSet& springs,
                       const MembraneMaterial& material, const Positions& x) {
  const double mu = material.mu(), lambda = material.lambda();
  double energy = 0.0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const MembraneRest rest = membrane_face_rest(map, springs, static_cast<std::size_t>(f));
    energy += membrane_face(x.row(faces(f, 0)), x.row(faces(f, 1)), x.row(faces(f, 2)), rest,
                            mu, lambda, nullptr, nullptr, TransverseFilter::exact);
  }
  return energy;
}

double membrane_add_gradient(const Faces& faces, const MembraneFaces& map,
                             const SpringSet& springs, const MembraneMaterial& material,
                             const Positions& x, Positions& gradient) {
  const double mu = material.mu(), lambda = material.lambda();
  double energy = 0.0;
  Vec9 g;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const MembraneRest rest = membrane_face_rest(map, springs, static_cast<std::size_t>(f));
    energy += membrane_face(x.row(faces(f, 0)), x.row(faces(f, 1)), x.row(faces(f, 2)), rest,
                            mu, lambda, &g, nullptr, TransverseFilter::exact);
    for (int k = 0; k < 3; ++k) gradient.row(faces(f, k)) += g.segment<3>(3 * k).transpose();
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
