#include "yore/cloth/springs.hpp"

#include <cmath>

namespace yore {

void SpringSet::reserve(std::size_t n) {
  first.reserve(n);
  second.reserve(n);
  rest_length.reserve(n);
  stiffness.reserve(n);
  damping.reserve(n);
  kind.reserve(n);
  reference_length.reserve(n);
}

void SpringSet::add(std::int32_t i, std::int32_t j, double rest_length_m, double stiffness_n_per_m,
                    double damping_ns_per_m, SpringKind spring_kind) {
  add(i, j, rest_length_m, stiffness_n_per_m, damping_ns_per_m, spring_kind, rest_length_m);
}

void SpringSet::add(std::int32_t i, std::int32_t j, double rest_length_m, double stiffness_n_per_m,
                    double damping_ns_per_m, SpringKind spring_kind, double reference_length_m) {
  first.push_back(i);
  second.push_back(j);
  rest_length.push_back(rest_length_m);
  stiffness.push_back(stiffness_n_per_m);
  damping.push_back(damping_ns_per_m);
  kind.push_back(spring_kind);
  reference_length.push_back(reference_length_m);
}

void SpringSet::keep(const std::vector<char>& flags) {
  std::size_t out = 0;
  for (std::size_t s = 0; s < size(); ++s) {
    if (!flags[s]) continue;
    first[out] = first[s];
    second[out] = second[s];
    rest_length[out] = rest_length[s];
    stiffness[out] = stiffness[s];
    damping[out] = damping[s];
    kind[out] = kind[s];
    reference_length[out] = reference_length[s];
    ++out;
  }
  first.resize(out);
  second.resize(out);
  rest_length.resize(out);
  stiffness.resize(out);
  damping.resize(out);
  kind.resize(out);
  reference_length.resize(out);
}

void SpringSet::clear() {
  first.clear();
  second.clear();
  rest_length.clear();
  stiffness.clear();
  damping.clear();
  kind.clear();
  reference_length.clear();
}

double spring_energy(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness) {
  const double stretch = (xi - xj).norm() - rest_length;
  return 0.5 * stiffness * stretch * stretch;
}

Vec3 spring_gradient(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness) {
  const Vec3 d = xi - xj;
  const double length = d.norm();
  if (length == 0.0) return Vec3::Zero();
  return (stiffness * (length - rest_length) / length) * d;
}

Mat3 spring_hessian(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness,
                    bool project_psd) {
  return spring_hessian(xi, xj, rest_length, stiffness,
                        project_psd ? TransverseFilter::clamp : TransverseFilter::exact);
}

namespace {

// k (d̂d̂ᵀ + t (I − d̂d̂ᵀ)) for d = xi − xj of length ℓ > 0, with the transverse factor t filtered.
Mat3 spring_block(const Vec3& d, double length, double stiffness, double transverse,
                  TransverseFilter filter) {
  const Vec3 n = d / length;
  const Mat3 nn = n * n.transpose();
  // A compressed spring (ℓ < L, or a negative force) has a negative transverse stiffness: it
  // buckles sideways. Clamping keeps the block PSD so an implicit system stays SPD.
  if (transverse < 0.0) {
    if (filter == TransverseFilter::clamp) transverse = 0.0;
    if (filter == TransverseFilter::abs) transverse = -transverse;
  }
  return stiffness * (nn + transverse * (Mat3::Identity() - nn));
}

}  // namespace

Mat3 spring_hessian(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness,
                    TransverseFilter filter) {
  const Vec3 d = xi - xj;
  const double length = d.norm();
  if (length == 0.0) return stiffness * Mat3::Identity();
  return spring_block(d, length, stiffness, 1.0 - rest_length / length, filter);
}

Mat3 spring_hessian_with_force(const Vec3& xi, const Vec3& xj, double stiffness, double force,
                               TransverseFilter filter) {
  const Vec3 d = xi - xj;
  const double length = d.norm();
  if (length == 0.0) return stiffness * Mat3::Identity();
  // f/ℓ = k t; a spring of stiffness 0 has no force and no transverse term
  const double transverse = stiffness > 0.0 ? force / (stiffness * length) : 0.0;
  return spring_block(d, length, stiffness, transverse, filter);
}

Vec3 spring_damping_force(const Vec3& xi, const Vec3& xj, const Vec3& vi, const Vec3& vj,
                          double damping) {
  const Vec3 d = xi - xj;
  const double length = d.norm();
  if (length == 0.0) return Vec3::Zero();
  const Vec3 n = d / length;
  return (-damping * (vi - vj).dot(n)) * n;
}

}  // namespace yore
