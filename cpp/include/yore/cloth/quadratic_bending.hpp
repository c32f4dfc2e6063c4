#pragma once
/// @file quadratic_bending.hpp
/// The isometric quadratic bending energy of Bergou, Wardetzky, Harmon, Zorin & Grinspun 2006
/// ("A Quadratic Bending Model for Inextensible Surfaces"): per interior edge (a hinge) a 4-vector
/// of cotangent weights K_e from the rest geometry, and the constant n×n matrix
///   Q = Σ_e 1 / (A₀ + A₁) K_e K_eᵀ
/// (A₀, A₁ the rest areas of the hinge's two faces; the paper's weight is 3/(A₀ + A₁), which
/// makes the energy three times ½ κ ∫ (2H)² dA; with 1 it tends to that, so κ is the plate's
/// bending rigidity), so that the bending energy of positions x is
///   E(x) = ½ κ Σ_{c ∈ x,y,z} x_cᵀ Q x_c,   gradient κ Q x (per coordinate),   Hessian κ Q ⊗ I₃,
/// κ the bending modulus (N·m). |K_e x| = 2 |e| sin(θ/2) for a hinge bent by the dihedral angle θ
/// (0 when flat), so E vanishes on every flat state, is invariant under rigid motion, and is
/// exact for isometric bending from a flat rest state. Pure functions; Cloth stores the matrix.
///
/// The hinge energy depends on the directions of the mesh's edges: a cylinder stores 1.5× its
/// continuum energy on a grid whose lines cross the rulings at 45° and 1.12–1.16× on CGAL's
/// isotropic meshes at every h (it does not converge there). fitted_bending_matrix is the
/// consistent one (issue 52) and the default: per vertex p, the least-squares quadratic through
/// its 1-ring (in its rest tangent plane) gives the Hessian H_p x of each coordinate, a linear
/// map of the positions that is exact for quadratic fields on any mesh, and
///   E(x) = ½ κ Σ_p A_p Σ_c |H_p x_c|²_F      (A_p a third of p's faces' rest area),
/// ½ κ ∫ |∇∇x|² dA, which for isometric bending of a flat sheet is ½ κ ∫ (κ₁² + κ₂²) dA =
/// ½ κ ∫ (2H)² dA, the hinge model's limit; plus, per patch, β/(m ρ⁴) times the squared
/// residual of its fit (zero for quadratic fields, O(h²) relative on smooth ones), so that no
/// mesh-scale shape the fit cannot see is free. Same form, Q = Σ_p A_p K_p; a wider stencil
/// (pairs within two rings, ~20 entries a row against the hinge's ~12). Fits run in
/// coordinates whitened by each patch's spread, so a stretched mesh is fitted like the
/// regular one it is an affine image of.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "yore/cloth/mesh.hpp"

namespace yore {

/// Q of one topology, a symmetric n×n scalar matrix as full CSR (both triangles; the diagonal
/// first in every row, then the other columns in increasing order), structure of arrays.
struct QuadraticBendingMatrix {
  std::int64_t size = 0;                 ///< n, the vertices
  std::vector<std::int32_t> row_starts;  ///< n + 1
  std::vector<std::int32_t> columns;     ///< nnz
  std::vector<double> values;            ///< nnz, 1/m² · m² = dimensionless per unit modulus
  std::int64_t hinge_count = 0;          ///< interior edges, each one term of Q
  /// Σ_e 2 |e|² / (A₀ + A₁): the energy per unit modulus (J per N·m) with every hinge folded
  /// flat (θ = π), a scale for the divergence check.
  double fold_energy = 0.0;
};

/// Builds Q from rest positions (n×3, m; only the shape of each face matters) and faces (f×3, a
/// mesh that passed validate_mesh). Throws std::invalid_argument on a face whose rest area is
/// zero or not finite, or a shape mismatch.
QuadraticBendingMatrix quadratic_bending_matrix(const Positions& rest_positions,
                                                const Faces& faces);

/// Q of the fitted model (above) from rest positions and faces: the same checks as
/// quadratic_bending_matrix, whose fold_energy and hinge_count it keeps as scales. A vertex's
/// patch is its 1-ring and itself, grown by the nearest vertices of the next ring until 6 or
/// more points pose a fit whose design matrix keeps its smallest singular value above 1e-2 of
/// its largest. Throws std::invalid_argument when a mesh component cannot (under 6 vertices,
/// or all near one conic).
QuadraticBendingMatrix fitted_bending_matrix(const Positions& rest_positions, const Faces& faces);

/// ½ κ Σ_c x_cᵀ Q x_c, joules, for positions x (n×3, m) and modulus κ (N·m).
double quadratic_bending_energy(const QuadraticBendingMatrix& matrix, double modulus,
                                const Positions& positions);

/// κ Q x into gradient (n×3, N; resized), the gradient of quadratic_bending_energy; returns the
/// energy (J) computed in the same pass.
double quadratic_bending_gradient(const QuadraticBendingMatrix& matrix, double modulus,
                                  const Positions& positions, Positions& gradient);

/// Calls visit(k, i, j, a, b) for every stored entry k = (i, j) of Q with j ≥ i (the lower
/// triangle's pairs once, the diagonal included) whose vertices are both unknowns: a =
/// index_of_vertex[i] ≥ 0 and b = index_of_vertex[j] ≥ 0 (n entries, −1 for a constrained
/// vertex). The shared walk of the solvers' pattern and slot builders.
template <class Visit>
void for_each_free_entry(const QuadraticBendingMatrix& matrix,
                         const std::vector<std::int32_t>& index_of_vertex, Visit&& visit) {
  for (std::int64_t i = 0; i < matrix.size; ++i) {
    const std::int32_t a = index_of_vertex[static_cast<std::size_t>(i)];
    if (a < 0) continue;
    for (std::int32_t k = matrix.row_starts[static_cast<std::size_t>(i)];
         k < matrix.row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
      const std::int32_t j = matrix.columns[static_cast<std::size_t>(k)];
      const std::int32_t b = index_of_vertex[static_cast<std::size_t>(j)];
      if (j >= i && b >= 0) visit(k, static_cast<std::int32_t>(i), j, a, b);
    }
  }
}

}  // namespace yore
