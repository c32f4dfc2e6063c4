#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/stroke/subdivision.hpp"

namespace yore::bindings {
namespace {

void put_subdivision(py::dict& out, const Subdivision& mesh) {
  out["vertices"] = read_only_copy(mesh.positions);
  out["faces"] = read_only_copy(mesh.faces);
  out["parents"] = read_only_copy(mesh.parents);
  out["new_vertex_corners"] = read_only_copy(mesh.new_vertex_corners);
  out["new_vertex_weights"] = read_only_copy(mesh.new_vertex_weights);
}

Edges to_edge_rows(const std::vector<VertexPair>& pairs) {
  Edges edges(static_cast<Eigen::Index>(pairs.size()), 2);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    edges.row(static_cast<Eigen::Index>(k)) << pairs[k][0], pairs[k][1];
  }
  return edges;
}

}  // namespace

void bind_subdivision(py::module_& m) {
  m.def(
      "split_faces_1to3",
      [](const py::handle& vertices, const py::handle& faces, const py::handle& split,
         const py::handle& barycentric, double min_barycentric, double min_angle_degrees) {
        const Positions v = to_rows3(vertices, "vertices");
        const Faces f = to_faces(faces);
        validate_mesh(v, f);
        const std::vector<std::int32_t> ids = to_indices(split, "split");
        const Positions weights =
            to_rows3(barycentric, "barycentric", static_cast<Eigen::Index>(ids.size()));
        std::vector<FaceSplit> splits(ids.size());
        for (std::size_t k = 0; k < ids.size(); ++k) {
          splits[k].face = ids[k];
          splits[k].barycentric = weights.row(static_cast<Eigen::Index>(k)).transpose();
        }
        const Split1to3 result = split_faces_1to3(v, f, splits, min_barycentric, min_angle_degrees);
        py::dict out;
        put_subdivision(out, result.mesh);
        out["split_faces"] = read_only_copy(result.split_faces);
        out["faces_skipped"] = read_only_copy(result.faces_skipped);
        out["moved_inward"] = result.moved_inward;
        return typed_result("FaceSplit", out);
      },
      py::arg("vertices"), py::arg("faces"), py::arg("split"), py::arg("barycentric"),
      py::kw_only(), py::arg("min_barycentric") = 0.1, py::arg("min_angle_degrees") = 5.0,
      "The paper's 1→3 split of a mesh (n×3 m, f×3), no springs, as a yore.results.FaceSplit: "
      "vertices, faces, parents, the new vertices' corners and weights, split_faces, "
      "faces_skipped, moved_inward.");
  m.def(
      "refine_faces_1to4",
      [](const py::handle& vertices, const py::handle& faces, const py::handle& refine) {
        const Positions v = to_rows3(vertices, "vertices");
        const Faces f = to_faces(faces);
        validate_mesh(v, f);
        const Refinement result = refine_faces_1to4(v, f, to_indices(refine, "refine"));
        py::dict out;
        put_subdivision(out, result.mesh);
        out["refined_faces"] = read_only_copy(result.refined_faces);
        out["bisected_faces"] = read_only_copy(result.bisected_faces);
        out["split_edges"] = read_only_copy(to_edge_rows(result.split_edges));
        return typed_result("FaceRefinement", out);
      },
      py::arg("vertices"), py::arg("faces"), py::arg("refine"),
      "1→4 midpoint refinement of faces with a conforming closure, no springs, as a "
      "yore.results.FaceRefinement: vertices, faces, parents, the new vertices' corners and "
      "weights, refined_faces, bisected_faces, split_edges.");
}

}  // namespace yore::bindings
