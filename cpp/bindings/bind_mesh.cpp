#include "bindings.hpp"
#include "convert.hpp"
#include "yore/mesh.hpp"
#include "yore/pattern_mesh.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

namespace yore::bindings {

void bind_mesh(py::module_& m) {
  m.def(
      "validate_mesh",
      [](const py::handle& vertices, const py::handle& faces) {
        validate_mesh(to_rows3(vertices, "vertices"), to_faces(faces));
      },
      py::arg("vertices"), py::arg("faces"),
      "Raises ValueError unless (vertices, faces) is a triangle mesh a cloth can be built on.");
  m.def(
      "mesh_connectivity",
      [](const py::handle& vertices, const py::handle& faces) {
        const Faces f = to_faces(faces);
        validate_mesh(to_rows3(vertices, "vertices"), f);
        const MeshConnectivity c = mesh_connectivity(f);
        auto pairs = [](const std::vector<VertexPair>& list) {
          Edges out(static_cast<Eigen::Index>(list.size()), 2);
          for (std::size_t k = 0; k < list.size(); ++k) {
            out(static_cast<Eigen::Index>(k), 0) = list[k][0];
            out(static_cast<Eigen::Index>(k), 1) = list[k][1];
          }
          return read_only_copy(out);
        };
        py::dict result;
        result["edges"] = pairs(c.edges);
        result["bending_pairs"] = pairs(c.bending_pairs);
        result["boundary_edge_count"] = c.boundary_edge_count;
        return result;
      },
      py::arg("vertices"), py::arg("faces"),
      "Unique edges, bending pairs and the number of boundary edges of a valid mesh.");
  m.def(
      "lumped_vertex_areas",
      [](const py::handle& vertices, const py::handle& faces) {
        const Positions v = to_rows3(vertices, "vertices");
        const Faces f = to_faces(faces);
        validate_mesh(v, f);
        return read_only_copy(lumped_vertex_areas(v, f));
      },
      py::arg("vertices"), py::arg("faces"), "Per-vertex third of the incident face areas, m².");
  m.attr("PATTERN_MAX_ANGLE_DEGREES") = kPatternMaxAngleDegrees;
  m.def(
      "pattern_mesh",
      [](const Polygon2& outline, const std::vector<Polygon2>& holes, double edge_length,
         double min_angle, std::int64_t max_vertices) {
        PatternMeshOptions options;
        options.edge_length = edge_length;
        options.min_angle_degrees = min_angle;
        options.max_vertices = max_vertices;
        const PatternMesh mesh = run_without_gil([&] { return pattern_mesh(outline, holes, options); });
        return py::make_tuple(read_only_copy(mesh.points), read_only_copy(mesh.faces),
                              mesh.outline_vertices);
      },
      py::arg("outline"), py::arg("holes"), py::arg("edge_length"), py::arg("min_angle"),
      py::arg("max_vertices"),
      "(points m×2, faces, outline vertex count) of a pattern meshed by CGAL; see "
      "yore.pattern_mesh.");
}

}  // namespace yore::bindings
