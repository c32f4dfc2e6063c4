#pragma once
/// @file spring_matrix.hpp
/// The constant scalar matrix of the prefactored methods (local-global and quasi-Newton):
///   Q = M/h² + drag·M/h + Σ_springs (k + c/h) AᵀA (+ κ Q_bending, quadratic bending's constant
///   Hessian per coordinate, entering exactly as the springs' elastic Hessian k AᵀA does)
/// over the free vertices (fixed and driven ones eliminated), one unknown per vertex and shared
/// by x, y and z: a ninth of the nonzeros of the 3n×3n Newton Hessian. Its pattern depends on
/// the topology only; its values on h, masses, stiffness, damping and drag.

#include <cstdint>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/solvers/linear_solver.hpp"

namespace yore {

/// Unknowns and lower-triangle pattern of Q for one topology.
struct ScalarSpringPattern {
  std::vector<std::int32_t> free_of_vertex;  ///< per vertex: its unknown, or −1 if constrained
  std::vector<std::int32_t> free_vertices;   ///< per unknown: its vertex (increasing)
  SymmetricPattern pattern;                  ///< each column starts with its diagonal entry
  std::vector<std::int64_t> spring_slot;     ///< per spring: its off-diagonal entry, or −1
  /// per entry (i, j) of the cloth's quadratic bending matrix: Q's entry it adds to (the
  /// diagonal for i = j; j > i once per pair), or −1; empty without quadratic bending
  std::vector<std::int64_t> bending_slot;
};

/// Builds the unknowns and the pattern of Q for the cloth's current topology.
void build_scalar_spring_pattern(const Cloth& cloth, ScalarSpringPattern& out);

/// Writes Q's values for step size h (s) into `values` (one per pattern entry; resized).
void fill_scalar_spring_matrix(const Cloth& cloth, double h, const ScalarSpringPattern& structure,
                               std::vector<double>& values);

/// A number that changes when any spring's stiffness or damping, the drag or the bending
/// modulus changes: with
/// the topology and h it decides when Q must be refactored.
double spring_material_checksum(const Cloth& cloth);

}  // namespace yore
