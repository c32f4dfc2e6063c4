#pragma once
/// @file membrane.hpp
/// A continuum membrane of constant-strain triangles: St. Venant–Kirchhoff in plane stress,
///   W = μ E:E + ½ λ (tr E)²,   E = ½ (FᵀF − I),   energy = Σ_faces A W,
/// F the 3×2 deformation gradient of a face against its flat rest triangle, A its rest area,
/// μ = Y / (2(1 + ν)) and λ = Y ν / (1 − ν²) from the 2-D Young's modulus Y (N/m: the 3-D
/// modulus times the thickness) and Poisson's ratio ν, so that small strains follow Hooke's law
/// of a plane-stress sheet, σ = Y/(1 − ν²) [(1 − ν) ε + ν tr(ε) I].
///
/// A face's rest triangle is laid out from the rest lengths of the structural springs on its
/// three edges. With the membrane those springs carry no stiffness (Cloth makes them 0 N/m):
/// they carry the rest metric, which strokes (eq. (1)'s 1.1 × current length), growth modes,
/// refinement and rest-length smoothing already edit, and their damping. So a stroke's area
/// expansion is the membrane's too, with no second copy of the rest state to keep in step.
/// Pure functions; Cloth keeps the face→spring map.

#include "yore/mesh.hpp"
#include "yore/springs.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

namespace yore {

/// The membrane's material: 2-D Young's modulus and Poisson's ratio. young_modulus 0 means no
/// membrane.
struct MembraneMaterial {
  double young_modulus = 0.0;  ///< Y, N/m (Pa × thickness)
  double poisson_ratio = 0.0;  ///< ν, in (−1, 1): the 2-D plane-stress range
  /// Lamé's shear modulus μ = Y / (2(1 + ν)), N/m.
  double mu() const { return young_modulus / (2.0 * (1.0 + poisson_ratio)); }
  /// Plane-stress λ = Y ν / (1 − ν²), N/m.
  double lambda() const {
    return young_modulus * poisson_ratio / ((1.0 - poisson_ratio) * (1.0 + poisson_ratio));
  }
};

/// A rest triangle whose height is below this fraction of its longest side (its edge lengths
/// nearly break the triangle inequality, or do break it after a stroke or growth lengthened
/// one side) is laid out with this height instead and counted: a sliver of 0.57° at most.
constexpr double kMembraneMinRestHeight = 1e-2;

/// A face's rest triangle laid flat: vertex 0 at the origin, vertex 1 on the first axis.
struct MembraneRest {
  Eigen::Matrix2d inverse;  ///< Dm⁻¹, Dm = [p1 − p0, p2 − p0] (columns), 1/m
  double area = 0.0;        ///< m²
  bool clamped = false;     ///< the height was raised to kMembraneMinRestHeight × longest side
};

/// The rest triangle of a face from its rest edge lengths (m): l01 = |p1 − p0|, l12, l20.
/// Lengths must be positive and finite (springs' rest lengths are).
MembraneRest membrane_rest(double l01, double l12, double l20);

/// d_k = ∂F/∂x_k (per coordinate) of a face with rest triangle `rest`, F = Σ_k x_k d_kᵀ: the
/// gradients of its linear shape functions in the rest plane (1/m), the rows of Dm⁻¹ for
/// corners 1 and 2 and minus their sum for corner 0.
std::array<Eigen::Vector2d, 3> membrane_shape_gradients(const MembraneRest& rest);

using Vec9 = Eigen::Matrix<double, 9, 1>;
using Mat9 = Eigen::Matrix<double, 9, 9>;

/// Energy (J) of one face at corners x0, x1, x2 (m) for Lamé constants mu, lambda (N/m). With
/// `gradient` its derivative (N) in (x0, x1, x2) order; with `hessian` its second derivative
/// (N/m), the stress term S ⊗ I₃ filtered as `filter` says (S = 2μE + λ tr(E) I, the second
/// Piola–Kirchhoff stress: the analogue of a spring's transverse term; clamp keeps S's
/// non-negative eigenvalues, abs takes their magnitudes), so clamp and abs give a positive
/// semidefinite matrix whenever μ > 0 and μ + λ > 0 (ν in (−1, 1)). A collapsed face (F of rank
/// < 2) gives finite values.
double membrane_face(const Vec3& x0, const Vec3& x1, const Vec3& x2, const MembraneRest& rest,
                     double mu, double lambda, Vec9* gradient, Mat9* hessian,
                     TransverseFilter filter);

/// Per face, the structural spring on each of its edges: edges (v0, v1), (v1, v2), (v2, v0).
struct MembraneFaces {
  std::vector<std::array<std::int32_t, 3>> edge_springs;  ///< f
};

/// The map from faces to their edges' structural springs. Throws std::invalid_argument when an
/// edge has no structural spring.
MembraneFaces membrane_faces(const Faces& faces, const SpringSet& springs);

/// The rest triangle of face f from its springs' rest lengths.
MembraneRest membrane_face_rest(const MembraneFaces& map, const SpringSet& springs,
                                std::size_t face);

/// Σ_faces energy (J) at positions x (n×3, m).
double membrane_energy(const Faces& faces, const MembraneFaces& map, const SpringSet& springs,
                       const MembraneMaterial& material, const Positions& x);

/// Adds the membrane's gradient at x (N) to `gradient` (n×3, sized by the caller); returns the
/// energy (J).
double membrane_add_gradient(const Faces& faces, const MembraneFaces& map,
                             const SpringSet& springs, const MembraneMaterial& material,
                             const Positions& x, Positions& gradient);

/// What the membrane's faces look like at positions x.
struct MembraneStatus {
  std::int64_t clamped_rest_faces = 0;  ///< rest triangles laid out with the minimum height
  /// faces whose current area is below 1e-3 of their rest area (crushed flat or collapsed to a
  /// line: the Hessian stays finite and, filtered, semidefinite; forces push them back open)
  std::int64_t collapsed_faces = 0;
  double rest_area = 0.0;     ///< m², Σ of the faces' rest areas
  double current_area = 0.0;  ///< m², Σ of their areas at x
};

/// The status at positions x.
MembraneStatus membrane_status(const Faces& faces, const MembraneFaces& map,
                               const SpringSet& springs, const Positions& x);

}  // namespace yore
