#include "bindings.hpp"
#include "convert.hpp"
#include "yore/mesh.hpp"

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
}

}  // namespace yore::bindings
