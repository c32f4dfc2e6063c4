#pragma once
/// @file springs.hpp
/// Springs of a mass-spring cloth, stored as a structure of arrays, and the pure per-spring kernels
/// (energy, gradient, Hessian, damping force) that every integrator uses.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace yore {

/// Kind of a spring, as the paper's Fig. 1 wires a triangle mesh.
enum class SpringKind : std::int8_t {
  structural = 0,  ///< on a mesh edge
  bending = 1,     ///< across an interior edge, between the two vertices opposite it
};

/// All springs of a cloth, one array per quantity (structure of arrays).
/// Spring s joins vertices first[s] and second[s] (first < second is not required).
struct SpringSet {
  std::vector<std::int32_t> first;   ///< s, vertex index of one end
  std::vector<std::int32_t> second;  ///< s, vertex index of the other end
  std::vector<double> rest_length;   ///< s, metres
  std::vector<double> stiffness;     ///< s, N/m
  std::vector<double> damping;       ///< s, N·s/m, along the spring
  std::vector<SpringKind> kind;      ///< s
  /// s, metres: the length the rest length is measured against — the rest length itself for a
  /// spring wired from the input mesh, the length at creation for one a stroke added. The ratio
  /// rest / reference is the field that rest-length smoothing smooths.
  std::vector<double> reference_length;

  /// Number of springs.
  std::size_t size() const { return first.size(); }
  /// Reserves room for n springs in every array.
  void reserve(std::size_t n);
  /// Appends one spring.
  void add(std::int32_t i, std::int32_t j, double rest_length_m, double stiffness_n_per_m,
           double damping_ns_per_m, SpringKind spring_kind);
  /// Appends one spring whose reference length differs from its rest length.
  void add(std::int32_t i, std::int32_t j, double rest_length_m, double stiffness_n_per_m,
           double damping_ns_per_m, SpringKind spring_kind, double reference_length_m);
  /// Keeps only the springs whose flag is set, in order.
  void keep(const std::vector<char>& flags);
  /// Removes every spring.
  void clear();
};

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

/// Energy ½ k (|xi − xj| − L)² of one spring, joules.
double spring_energy(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness);

/// Gradient of spring_energy with respect to xi, newtons (the gradient with respect to xj is its
/// negative; the elastic force on xi is minus this). Zero when |xi − xj| is zero, where the
/// direction is undefined.
Vec3 spring_gradient(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness);

/// 3×3 block K = ∂²E/∂xi² of one spring, N/m; the full 6×6 Hessian is [K −K; −K K].
/// K = k (d̂d̂ᵀ + (1 − L/ℓ)(I − d̂d̂ᵀ)). With project_psd the transverse factor (1 − L/ℓ) is clamped at
/// zero, which makes K (and the 6×6 Hessian) positive semidefinite even for a compressed spring.
/// At zero length the direction is undefined and k·I is returned.
Mat3 spring_hessian(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness,
                    bool project_psd);

/// How spring_hessian treats a negative transverse factor 1 − L/ℓ (a compressed spring).
enum class TransverseFilter {
  exact,  ///< keep it (the true Hessian, indefinite when compressed)
  clamp,  ///< clamp it at 0 (eigenvalue clamping)
  abs,    ///< take its absolute value (|λ| eigenvalue filtering)
};

/// spring_hessian with the transverse eigenvalue k(1 − L/ℓ) filtered as `filter` says, N/m.
Mat3 spring_hessian(const Vec3& xi, const Vec3& xj, double rest_length, double stiffness,
                    TransverseFilter filter);

/// The block with the transverse term of a given spring force f (N) instead of the actual
/// k(ℓ − L): k d̂d̂ᵀ + (f/ℓ)(I − d̂d̂ᵀ), the transverse factor filtered as `filter` says (Newton's
/// matrices on the mixed formulation, ImplicitOptions::mixed). k·I at zero length.
Mat3 spring_hessian_with_force(const Vec3& xi, const Vec3& xj, double stiffness, double force,
                               TransverseFilter filter);

/// Damping force on xi, −c ((vi − vj)·d̂) d̂, newtons (the force on xj is its negative).
Vec3 spring_damping_force(const Vec3& xi, const Vec3& xj, const Vec3& vi, const Vec3& vj,
                          double damping);

}  // namespace yore
