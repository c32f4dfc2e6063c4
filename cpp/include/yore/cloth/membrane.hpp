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

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "yore/cloth/mesh.hpp"
#include "yore/cloth/springs.hpp"

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

/// The smoothed strain (issue 52). A face's constant strain sees the piecewise-linear
/// interpolant's gradient, which on a triangle not aligned with a wrinkle has a spurious slope
/// across it (of order h k² times the amplitude); the membrane's tension charges that slope
/// like bending, an artificial modulus ∝ h² S that set the wavelength on CGAL's meshes. When
/// asked (Cloth::set_membrane_smoothed; it needs the rest state Cloth keeps for its bending
/// model; the faces' strain is the default, exact along a lattice's rows) the membrane reads, at
/// each vertex p, the area-weighted mean of its faces' gradients (nodal strain smoothing:
/// the faces' spurious slopes, of alternating sign around p, largely cancel), and charges
///   E = (1 − s) Σ_p A_p W(F_p) + s Σ_faces A_f W(F_f),      s = kMembraneFaceShare (0),
/// A_p a third of p's faces' rest areas. The mean is over exactly the face thirds that make up
/// A_p, so Σ_p A_p F_p = Σ_f A_f F_f: a homogeneous stress is in balance at every interior
/// vertex (the patch test; a least-squares fitted gradient per vertex, tried first, is not:
/// 9 N of spurious force per vertex against 12 N of edge traction). The mean cannot see the
/// mesh-scale patterns whose face gradients cancel around each vertex (hourglass modes), so
/// each vertex element also charges, per subcell c (a third of one of its faces),
///   β (A_f/3) W(E_c − E_p),   E_c the face's strain read in p's rest frame,
/// a penalty on the face's strain deviating from the vertex's mean: zero for homogeneous
/// deformations (the patch test holds), second order in an in-plane hourglass mode (which
/// changes E linearly), fourth order in a smooth wrinkle (its spurious slope g changes E_c by
/// ½ g g, already second order) — so it resists the modes without bringing back the
/// interpolation's bending, which the faces' own energy would (a share s of the faces' energy
/// brings back s of their B_art). β = 1: the deviation costs what that strain would. Measured
/// (21² hanging cloth, implicit, 1 s; 13² explicit after a stroke; the faces' energy at the
/// run's positions over the membrane's): with s = 1 % and no penalty 16× and 49× (mesh-scale
/// strain let through), s = 50 % 1.02× and 0.73× at 52 % of the faces' B_art; with β = 1 and
/// no faces' share 0.88× and 1.17× at 3.5 %, and the explicit stable step is the faces' (6.8e-4
/// s there; β = 2 halves it). The gradients are averaged in p's tangent axes u of the rest
/// state, and p's rest metric there is the area-weighted mean over its faces of
/// C_f = D⁻ᵀ G_f D⁻¹ (D the face's reference edges in those axes, G_f the Gram matrix of its
/// rest triangle from the springs' rest lengths), so strokes and growth act on it as on the
/// faces; with C = L Lᵀ, F_p = G_p L⁻ᵀ for G_p the mean ∂x/∂u.
constexpr double kMembraneFaceShare = 0.0;

/// β of the strain-difference penalty of the vertex elements (above).
constexpr double kMembraneStabilisation = 1.0;

/// The membrane's quadrature as elements, each A W(F) with F = Σ_k x_k d_kᵀ over its corners:
/// the faces first (three corners, the constant-strain gradients; none with the smoothed strain
/// when kMembraneFaceShare is 0), then with the smoothed strain one per vertex on a face (its
/// 1-ring, with its subcells' penalty). Structure of arrays; the corners of every element
/// depend on the topology only, the gradients and areas on the rest lengths too.
struct MembraneElements {
  std::vector<std::int32_t> starts;   ///< elements + 1
  std::vector<std::int32_t> corners;  ///< vertices, per element in increasing order
  std::vector<double> gradient_u;     ///< d_k's first component, 1/m
  std::vector<double> gradient_v;     ///< d_k's second component, 1/m
  std::vector<double> area;        ///< per element: its share of the energy × its rest area, m²
  std::int64_t face_elements = 0;  ///< the first this many are the faces
  /// A vertex element's penalty (kMembraneStabilisation): per subcell (a third of one of its
  /// faces) β W(E_c − E) with E_c the face's strain in the vertex's rest frame; empty starts
  /// (or equal entries) for elements without.
  std::vector<std::int32_t> subcell_starts;  ///< elements + 1, or empty
  std::vector<double> subcell_area;          ///< β × a third of the face's rest area, m²
  std::vector<std::int32_t> subcell_corner;  ///< 3 per subcell: local corner indices
  std::vector<double> subcell_gradient_u;    ///< 3 per subcell, 1/m
  std::vector<double> subcell_gradient_v;    ///< 3 per subcell, 1/m
  std::size_t size() const { return area.size(); }
};

/// What the smoothed strain keeps per topology: per vertex and incident face, D⁻¹ of the face's
/// reference edges in the vertex's tangent axes (4 values, column-major; all 0 when the face
/// stands edge-on to that plane), and per vertex its element's corners (itself and its 1-ring).
struct MembraneReference {
  std::vector<std::int32_t> face_starts;     ///< n + 1
  std::vector<std::int32_t> incident_faces;  ///< per vertex, its faces
  std::vector<double> reference_inverse;     ///< 4 per incident face
  std::vector<std::int32_t> corner_starts;   ///< n + 1
  std::vector<std::int32_t> corners;         ///< per vertex, in increasing order
};

/// The reference of rest positions (n×3, m) and faces (indices already checked).
MembraneReference membrane_reference(const Positions& rest_positions, const Faces& faces);

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

/// Fills `out` with the elements at the springs' current rest lengths: the faces alone
/// (share 1) without a reference, with one the faces (share kMembraneFaceShare) and the
/// smoothed vertices. Reuses out's storage.
void build_membrane_elements(const Faces& faces, const MembraneFaces& map, const SpringSet& springs,
                             const MembraneReference* reference, MembraneElements& out);

/// Calls visit(slot, i, j) for every pair of distinct corners (p > q, vertices i and j) of every
/// element, slot counting the pairs in element order and, within one, at p(p − 1)/2 + q.
template <class Visit>
void for_each_membrane_pair(const MembraneElements& elements, Visit&& visit) {
  std::size_t slot = 0;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const auto begin = static_cast<std::size_t>(elements.starts[e]);
    const std::size_t m = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
    for (std::size_t p = 0; p < m; ++p) {
      for (std::size_t q = 0; q < p; ++q) {
        visit(slot++, elements.corners[begin + p], elements.corners[begin + q]);
      }
    }
  }
}

/// Scratch of membrane_element, grown to the largest element and reused.
struct MembraneElementWork {
  std::vector<Vec3> gradient;    ///< per corner, N
  std::vector<Vec3> directions;  ///< per corner, F d_k
  /// ∂gradient_p/∂x_q for q ≤ p at p(p+1)/2 + q (N/m), the stress term filtered (membrane_face)
  std::vector<Mat3> blocks;
};

/// Energy (J) of element e at positions x; with_gradient fills work.gradient, with_hessian
/// work.blocks (both per corner, in the element's corner order).
double membrane_element(const MembraneElements& elements, std::size_t e, const Positions& x,
                        double mu, double lambda, TransverseFilter filter,
                        MembraneElementWork& work, bool with_gradient, bool with_hessian);

/// Σ_elements energy (J) at positions x (n×3, m).
double membrane_energy(const MembraneElements& elements, const MembraneMaterial& material,
                       const Positions& x);

/// Adds the membrane's gradient at x (N) to `gradient` (n×3, sized by the caller); returns the
/// energy (J).
double membrane_add_gradient(const MembraneElements& elements, const MembraneMaterial& material,
                             const Positions& x, Positions& gradient, MembraneElementWork& work);

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
