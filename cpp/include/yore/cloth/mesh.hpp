#pragma once
/// @file mesh.hpp
/// Triangle-mesh checks and the connectivity a mass-spring cloth is wired from (paper Fig. 1).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace yore {

/// n×3 row-major positions, metres.
using Positions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// f×3 row-major vertex indices of triangles.
using Faces = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// s×2 row-major vertex index pairs.
using Edges = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 2, Eigen::RowMajor>;
using VertexPair = std::array<std::int32_t, 2>;

/// Checks that positions are finite and that every entry is a real triangle mesh a cloth can be
/// built from: at least one face, indices in range, three distinct vertices per face, no
/// zero-area face, no edge shared by more than two faces, no duplicate face, no unused vertex.
/// Throws std::invalid_argument naming the first offending face, edge or vertex.
/// check_shape false skips the zero-area test: a simulated cloth may crush a face flat (a
/// saved state is checked that way; a mesh a cloth is built from is checked whole).
void validate_mesh(const Positions& positions, const Faces& faces, bool check_shape = true);

/// Connectivity of a triangle mesh, as the paper's Fig. 1 wires springs on it.
struct MeshConnectivity {
  std::vector<VertexPair> edges;          ///< every unique edge (i < j), sorted
  std::vector<VertexPair> bending_pairs;  ///< per interior edge, its two opposite vertices (i < j),
                                          ///< without duplicates and without pairs that are edges
  std::size_t boundary_edge_count = 0;    ///< edges with exactly one face
};

/// Unique edges and bending pairs of a mesh whose faces passed validate_mesh.
MeshConnectivity mesh_connectivity(const Faces& faces);

/// Per-vertex lumped area: each vertex gets a third of the area of every face around it (m²).
Eigen::VectorXd lumped_vertex_areas(const Positions& positions, const Faces& faces);

/// Per-vertex masses of a sheet of areal density `density` (kg/m²), lumped by area: a third of
/// each face's mass to each of its corners (kg). Throws std::invalid_argument on a bad mesh or
/// a density that is not finite and > 0.
Eigen::VectorXd lumped_masses(const Positions& positions, const Faces& faces, double density);

/// Area (m²) of a triangle with these side lengths (m), Heron's formula; 0 if they violate the
/// triangle inequality. Rest areas of faces come from their structural springs' rest lengths.
double area_from_sides(double a, double b, double c);

}  // namespace yore
