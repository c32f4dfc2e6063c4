#pragma once
// Small meshes and numerical checks shared by the C++ tests (not a unit of its own).
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <set>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/cloth/mesh.hpp"
#include "yore/solvers/linear_solver.hpp"

namespace yore_test {

using yore::Faces;
using yore::Positions;

struct Mesh {
  Positions positions;
  Faces faces;
};

/// A ClothMaterial from its values in the order of its fields (stretch and bend stiffness,
/// damping, drag, bending model, bending modulus, membrane): tests name materials compactly.
inline yore::ClothMaterial material(double stretch, double bend, double damping = 0.0,
                                    double drag = 0.0,
                                    yore::BendingModel bending = yore::BendingModel::springs,
                                    double modulus = 0.0,
                                    const yore::MembraneMaterial& membrane = {}) {
  yore::ClothMaterial out;
  out.stretch_stiffness = stretch;
  out.bend_stiffness = bend;
  out.damping = damping;
  out.drag = drag;
  out.bending = bending;
  out.bending_modulus = modulus;
  out.membrane = membrane;
  return out;
}

/// A flat nx × ny grid of vertices over [0, width] × [0, height] at z = 0, each cell cut along
/// a diagonal that alternates like a checkerboard; counter-clockwise faces seen from +z.
inline Mesh grid_mesh(int nx, int ny, double width = 1.0, double height = 1.0) {
  Mesh mesh;
  mesh.positions.resize(nx * ny, 3);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      mesh.positions.row(j * nx + i) << width * i / (nx - 1), height * j / (ny - 1), 0.0;
  mesh.faces.resize(2 * (nx - 1) * (ny - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      if ((i + j) % 2 == 0) {
        mesh.faces.row(f++) << a, b, d;
        mesh.faces.row(f++) << a, d, c;
      } else {
        mesh.faces.row(f++) << a, b, c;
        mesh.faces.row(f++) << b, d, c;
      }
    }
  }
  return mesh;
}

/// An open tube about the y axis: `rings` rings of `segments` vertices (Euler characteristic 0).
inline Mesh cylinder_mesh(double radius, double height, int rings, int segments) {
  Mesh mesh;
  mesh.positions.resize(rings * segments, 3);
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double angle = 2.0 * M_PI * s / segments;
      mesh.positions.row(r * segments + s) << radius * std::cos(angle), height * r / (rings - 1),
          -radius * std::sin(angle);
    }
  mesh.faces.resize(2 * (rings - 1) * segments, 3);
  int f = 0;
  for (int r = 0; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const int a = r * segments + s, b = r * segments + (s + 1) % segments;
      const int c = a + segments, d = b + segments;
      mesh.faces.row(f++) << a, b, d;
      mesh.faces.row(f++) << a, d, c;
    }
  return mesh;
}

/// A cloth on a grid: uniform masses summing to `total_mass`, bending springs, damping, drag.
inline yore::Cloth grid_cloth(int n, double stretch = 200.0, double bend = 20.0,
                              double damping = 0.0, double drag = 0.0, double total_mass = 0.1) {
  const Mesh mesh = grid_mesh(n, n);
  return yore::Cloth(mesh.positions, mesh.faces,
                     Eigen::VectorXd::Constant(mesh.positions.rows(), total_mass / (n * n)),
                     yore_test::material(stretch, bend, damping, drag));
}

/// The dense symmetric matrix of a lower-triangle CSC pattern and its values.
inline Eigen::MatrixXd dense(const yore::SymmetricPattern& pattern, const double* values) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(pattern.size, pattern.size);
  for (std::int32_t c = 0; c < pattern.size; ++c)
    for (std::int32_t k = pattern.column_starts[c]; k < pattern.column_starts[c + 1]; ++k) {
      const std::int32_t r = pattern.row_indices[static_cast<std::size_t>(k)];
      out(r, c) = values[k];
      out(c, r) = values[k];
    }
  return out;
}

/// The lower-triangle CSC pattern and values of a dense symmetric matrix (entries != 0).
inline yore::SymmetricPattern lower_pattern(const Eigen::MatrixXd& matrix,
                                            std::vector<double>& values) {
  yore::SymmetricPattern pattern;
  pattern.size = static_cast<std::int32_t>(matrix.rows());
  pattern.column_starts.push_back(0);
  values.clear();
  for (Eigen::Index c = 0; c < matrix.cols(); ++c) {
    for (Eigen::Index r = c; r < matrix.rows(); ++r) {
      if (matrix(r, c) == 0.0) continue;
      pattern.row_indices.push_back(static_cast<std::int32_t>(r));
      values.push_back(matrix(r, c));
    }
    pattern.column_starts.push_back(static_cast<std::int32_t>(pattern.row_indices.size()));
  }
  return pattern;
}

/// A random symmetric positive-definite n×n matrix, A Aᵀ + n I, from a fixed seed.
inline Eigen::MatrixXd random_spd(int n, unsigned seed) {
  std::srand(seed);
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  return a * a.transpose() + n * Eigen::MatrixXd::Identity(n, n);
}

/// The springs of one kind as sorted vertex pairs.
inline std::set<yore::VertexPair> pairs_of_kind(const yore::Cloth& cloth, yore::SpringKind kind) {
  std::set<yore::VertexPair> out;
  const auto& s = cloth.springs();
  for (std::size_t k = 0; k < s.size(); ++k)
    if (s.kind[k] == kind)
      out.insert({std::min(s.first[k], s.second[k]), std::max(s.first[k], s.second[k])});
  return out;
}

/// Checks that the springs are exactly the paper's Fig. 1 wiring of the cloth's current faces.
inline void check_wiring(const yore::Cloth& cloth) {
  const yore::MeshConnectivity c = yore::mesh_connectivity(cloth.faces());
  CHECK(pairs_of_kind(cloth, yore::SpringKind::structural) ==
        std::set<yore::VertexPair>(c.edges.begin(), c.edges.end()));
  CHECK(pairs_of_kind(cloth, yore::SpringKind::bending) ==
        std::set<yore::VertexPair>(c.bending_pairs.begin(), c.bending_pairs.end()));
  CHECK(cloth.springs().size() == c.edges.size() + c.bending_pairs.size());
}

/// A spring network of three vertices in a bent chain (two springs, 40 N/m).
inline yore::Cloth chain() {
  Positions positions(3, 3);
  positions << 0, 0, 0, 0.4, 0, 0, 0.8, 0.1, 0;
  yore::Edges edges(2, 2);
  edges << 0, 1, 1, 2;
  return yore::Cloth::from_springs(positions, edges, Eigen::VectorXd(),
                                   Eigen::VectorXd::Constant(3, 0.1), 40.0, 0.01, 0.1);
}

/// A mass on a spring of rest length 1 m hanging from a fixed point, pulled down by
/// `amplitude` (m): it moves on the spring's line, where the force −k(ℓ − L) is linear, so every
/// method is a linear recurrence and the exact motion is y(t) = −1 − A cos(ωt), ω² = k/m.
inline yore::Cloth oscillator(double mass, double stiffness, double amplitude) {
  yore::Positions positions(2, 3);
  positions << 0, 0, 0, 0, -(1.0 + amplitude), 0;
  yore::Edges edges(1, 2);
  edges << 0, 1;
  yore::Cloth cloth =
      yore::Cloth::from_springs(positions, edges, Eigen::VectorXd::Ones(1),
                                Eigen::VectorXd::Constant(2, mass), stiffness, 0.0, 0.0);
  cloth.fix({0});
  return cloth;
}

}  // namespace yore_test
