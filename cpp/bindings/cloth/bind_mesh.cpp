#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "yore/cloth/mesh.hpp"
#include "yore/geometry/pattern_mesh.hpp"

namespace yore::bindings {

void bind_mesh(py::module_& m) {
  m.def(
      "validate_mesh",
      [](const py::handle& vertices, const py::handle& faces) {
        validate_mesh(to_rows3(vertices, "vertices"), to_faces(faces));
      },
      py::arg("vertices"), py::arg("faces"),
      "Raises ValueError unless (vertices, faces) is a triangle mesh a cloth can be built on.");
  m.attr("PATTERN_MAX_ANGLE_DEGREES") = kPatternMaxAngleDegrees;
  m.def(
      "pattern_mesh",
      [](const Polygon2& outline, const std::vector<Polygon2>& holes, double edge_length,
         double min_angle, std::int64_t max_vertices) {
        PatternMeshOptions options;
        options.edge_length = edge_length;
        options.min_angle_degrees = min_angle;
        options.max_vertices = max_vertices;
        const PatternMesh mesh =
            run_without_gil([&] { return pattern_mesh(outline, holes, options); });
        return py::make_tuple(read_only_copy(mesh.points), read_only_copy(mesh.faces),
                              mesh.outline_vertices);
      },
      py::arg("outline"), py::arg("holes"), py::arg("edge_length"), py::arg("min_angle"),
      py::arg("max_vertices"),
      "(points m×2, faces, outline vertex count) of a pattern meshed by CGAL; see "
      "yore.pattern_mesh.");
}

}  // namespace yore::bindings
