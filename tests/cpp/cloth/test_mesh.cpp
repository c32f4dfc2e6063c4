// Tests of cpp/src/cloth/mesh.cpp (cpp/include/yore/cloth/mesh.hpp): mesh validation, the
// connectivity the springs are wired from (paper Fig. 1), lumped vertex areas and Heron's formula.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/cloth/mesh.hpp"

using yore::Faces;
using yore::Positions;

namespace {

// 3×3 vertices, alternating diagonals meeting at the centre (vertex 4).
yore_test::Mesh centred_grid() {
  yore_test::Mesh mesh;
  mesh.faces.resize(8, 3);
  mesh.faces << 0, 1, 4, 0, 4, 3, 1, 2, 4, 2, 5, 4, 3, 4, 6, 4, 7, 6, 4, 5, 8, 4, 8, 7;
  mesh.positions.resize(9, 3);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) mesh.positions.row(3 * j + i) << i, j, 0.0;
  return mesh;
}

yore_test::Mesh tetrahedron() {
  yore_test::Mesh mesh;
  mesh.positions.resize(4, 3);
  mesh.positions << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  mesh.faces.resize(4, 3);
  mesh.faces << 0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2;
  return mesh;
}

}  // namespace

TEST_CASE("3×3 grid: 16 structural springs, 8 bending springs, 8 boundary edges") {
  const yore_test::Mesh mesh = centred_grid();
  CHECK_NOTHROW(yore::validate_mesh(mesh.positions, mesh.faces));
  const yore::MeshConnectivity c = yore::mesh_connectivity(mesh.faces);
  CHECK(c.edges.size() == 16);
  CHECK(c.bending_pairs.size() == 8);
  CHECK(c.boundary_edge_count == 8);
  // edges unique, i < j and sorted; bending pairs i < j, none of them an edge
  CHECK(std::is_sorted(c.edges.begin(), c.edges.end()));
  CHECK(std::adjacent_find(c.edges.begin(), c.edges.end()) == c.edges.end());
  const std::set<yore::VertexPair> edges(c.edges.begin(), c.edges.end());
  for (const auto& e : c.edges) CHECK(e[0] < e[1]);
  for (const auto& p : c.bending_pairs) {
    CHECK(p[0] < p[1]);
    CHECK(edges.count(p) == 0);
  }
}

TEST_CASE("bending pairs join the two vertices opposite each interior edge") {
  // two triangles sharing edge (1, 2): one bending spring, between 0 and 3
  Faces faces(2, 3);
  faces << 0, 1, 2, 2, 1, 3;
  const yore::MeshConnectivity c = yore::mesh_connectivity(faces);
  CHECK(c.edges.size() == 5);
  CHECK(c.boundary_edge_count == 4);
  REQUIRE(c.bending_pairs.size() == 1);
  CHECK(c.bending_pairs[0] == yore::VertexPair{0, 3});
}

TEST_CASE("Euler's formula on a grid and a tube; a closed tetrahedron has no bending pairs") {
  for (const auto& [mesh, euler] : {std::pair{yore_test::grid_mesh(5, 4), 1},
                                    std::pair{yore_test::cylinder_mesh(0.3, 0.5, 4, 7), 0}}) {
    CHECK_NOTHROW(yore::validate_mesh(mesh.positions, mesh.faces));
    const auto c = yore::mesh_connectivity(mesh.faces);
    const auto v = mesh.positions.rows(), e = static_cast<Eigen::Index>(c.edges.size()),
               f = mesh.faces.rows();
    CHECK(v - e + f == euler);
    // every face has 3 sides: 3f = 2 (interior edges) + boundary edges
    CHECK(3 * f == 2 * e - static_cast<Eigen::Index>(c.boundary_edge_count));
  }
  // every vertex pair of a tetrahedron is an edge: the bending pairs all duplicate edges
  const auto tet = tetrahedron();
  CHECK_NOTHROW(yore::validate_mesh(tet.positions, tet.faces));
  const auto c = yore::mesh_connectivity(tet.faces);
  CHECK(c.edges.size() == 6);
  CHECK(c.boundary_edge_count == 0);
  CHECK(c.bending_pairs.empty());
}

TEST_CASE("validate_mesh names the first offending face, edge or vertex") {
  const yore_test::Mesh good = centred_grid();
  SUBCASE("no faces") {
    CHECK_THROWS_WITH_AS(yore::validate_mesh(good.positions, Faces(0, 3)),
                         doctest::Contains("no faces"), std::invalid_argument);
  }
  SUBCASE("non-finite position") {
    Positions p = good.positions;
    p(5, 1) = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_WITH_AS(yore::validate_mesh(p, good.faces),
                         doctest::Contains("vertex 5 has a non-finite position"),
                         std::invalid_argument);
  }
  SUBCASE("index out of range") {
    Faces f = good.faces;
    f(3, 2) = 9;
    CHECK_THROWS_WITH_AS(yore::validate_mesh(good.positions, f),
                         doctest::Contains("face 3 has vertex index 9 out of range"),
                         std::invalid_argument);
  }
  SUBCASE("repeated vertex") {
    Faces f = good.faces;
    f(2, 1) = f(2, 0);
    CHECK_THROWS_WITH_AS(yore::validate_mesh(good.positions, f),
                         doctest::Contains("face 2 repeats a vertex"), std::invalid_argument);
  }
  SUBCASE("zero-area face, unless the shape check is off") {
    Positions p(3, 3);
    p << 0, 0, 0, 1, 0, 0, 2, 0, 0;  // collinear
    Faces f(1, 3);
    f << 0, 1, 2;
    CHECK_THROWS_WITH_AS(yore::validate_mesh(p, f), doctest::Contains("degenerate"),
                         std::invalid_argument);
    CHECK_NOTHROW(yore::validate_mesh(p, f, false));
  }
  SUBCASE("unused vertex") {
    Positions p(10, 3);
    p << good.positions, Eigen::RowVector3d(5, 5, 5);
    CHECK_THROWS_WITH_AS(yore::validate_mesh(p, good.faces),
                         doctest::Contains("vertex 9 belongs to no face"), std::invalid_argument);
  }
  SUBCASE("an edge with three faces") {
    Positions p(5, 3);
    p << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1;
    Faces f(3, 3);
    f << 0, 1, 2, 1, 0, 3, 0, 1, 4;
    CHECK_THROWS_WITH_AS(yore::validate_mesh(p, f),
                         doctest::Contains("edge (0, 1) is shared by 3 faces"),
                         std::invalid_argument);
  }
  SUBCASE("a duplicate face") {
    Positions p(3, 3);
    p << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    Faces f(2, 3);
    f << 0, 1, 2, 2, 1, 0;
    CHECK_THROWS_WITH_AS(yore::validate_mesh(p, f), doctest::Contains("same triangle"),
                         std::invalid_argument);
  }
}

TEST_CASE("lumped vertex areas: a third of each face per corner, summing to the area") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 3, 1.5, 0.8);
  const Eigen::VectorXd areas = yore::lumped_vertex_areas(mesh.positions, mesh.faces);
  REQUIRE(areas.size() == mesh.positions.rows());
  // 12 faces of 0.5 × 0.4 / 2 m²: sums of ~40 such terms agree to round-off (1e-15)
  CHECK(areas.sum() == doctest::Approx(1.5 * 0.8).epsilon(1e-14));
  const double face_area = 0.5 * 0.5 * 0.4;
  CHECK(areas[0] == doctest::Approx(face_area / 3 * 2).epsilon(1e-14));  // two faces at (0,0)
  for (Eigen::Index i = 0; i < areas.size(); ++i) CHECK(areas[i] > 0.0);
  // a tilted triangle: its area is the cross product's, whatever the orientation in space
  Positions p(3, 3);
  p << 0, 0, 0, 0, 3, 0, 0, 0, 4;
  Faces f(1, 3);
  f << 0, 1, 2;
  CHECK(yore::lumped_vertex_areas(p, f).isApprox(Eigen::Vector3d::Constant(2.0), 1e-15));
}

TEST_CASE("lumped masses: density times the lumped areas; the total is density × area") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(4, 3, 1.5, 0.8);
  const Eigen::VectorXd masses = yore::lumped_masses(mesh.positions, mesh.faces, 0.2);
  CHECK(masses.sum() == doctest::Approx(0.2 * 1.5 * 0.8).epsilon(1e-14));
  CHECK(masses.isApprox(0.2 * yore::lumped_vertex_areas(mesh.positions, mesh.faces), 1e-15));
  for (const double bad : {0.0, -1.0, std::numeric_limits<double>::infinity(),
                           std::numeric_limits<double>::quiet_NaN()}) {
    CHECK_THROWS_WITH_AS(yore::lumped_masses(mesh.positions, mesh.faces, bad),
                         doctest::Contains("density must be finite and > 0"),
                         std::invalid_argument);
  }
  Faces out_of_range = mesh.faces;
  out_of_range(0, 0) = 99;
  CHECK_THROWS_AS(yore::lumped_masses(mesh.positions, out_of_range, 0.2), std::invalid_argument);
}

TEST_CASE("Heron's formula, and 0 outside the triangle inequality") {
  CHECK(yore::area_from_sides(3.0, 4.0, 5.0) == doctest::Approx(6.0).epsilon(1e-15));
  CHECK(yore::area_from_sides(1.0, 1.0, 1.0) == doctest::Approx(std::sqrt(3.0) / 4).epsilon(1e-15));
  CHECK(yore::area_from_sides(1.0, 1.0, 2.0) == 0.0);  // flat
  CHECK(yore::area_from_sides(1.0, 1.0, 3.0) == 0.0);  // impossible
}
