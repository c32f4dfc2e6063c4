#include "bindings.hpp"
#include "convert.hpp"
#include "yore/cloth.hpp"
#include "yore/growth.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <string>

namespace yore::bindings {
namespace {

StrokeBand band_of(const Cloth& cloth, const py::handle& path, const py::handle& path_part,
                   const py::handle& crossed, double width) {
  const Positions points = to_rows3(path, "path");
  return stroke_band(cloth.positions(), cloth.faces(), points, to_indices(path_part, "path_part"),
                     to_indices(crossed, "crossed_faces"), width);
}

void put_band(py::dict& out, const StrokeBand& band) {
  out["vertex_distance"] = read_only_copy(band.vertex_distance);
  out["vertex_weight"] = read_only_copy(band.vertex_weight);
  out["vertex_tangent"] = read_only_copy(band.vertex_tangent);
  out["faces"] = read_only_copy(band.faces);
}

}  // namespace

void bind_growth(py::module_& m) {
  m.def(
      "falloff_weight",
      [](const py::handle& distance, double half_width) {
        const Eigen::VectorXd d = to_vector(distance, "distance");
        Eigen::VectorXd w(d.size());
        for (Eigen::Index k = 0; k < d.size(); ++k) w[k] = falloff_weight(d[k], half_width);
        return read_only_copy(w);
      },
      py::arg("distance"), py::arg("half_width"),
      "Falloff weights 1 − smoothstep(distance / half_width) of a 1-D array of distances (m).");
  m.def(
      "growth_modes",
      [] {
        py::list names;
        for (int k = 0; k < 4; ++k) names.append(growth_rule(static_cast<GrowthMode>(k)).name);
        return names;
      },
      "Names of the growth modes, in the table's order.");
  m.def(
      "stroke_band",
      [](const Cloth& cloth, const py::handle& path, const py::handle& path_part,
         const py::handle& crossed, double width) {
        idle(cloth);
        py::dict out;
        put_band(out, band_of(cloth, path, path_part, crossed, width));
        return out;
      },
      py::arg("cloth"), py::arg("path"), py::arg("path_part"), py::arg("crossed_faces"),
      py::arg("width"),
      "The band of a stroke whose surface path (m×3, m) crosses crossed_faces; width 0 = the "
      "crossed faces only.");
  m.def(
      "grown_rest_lengths",
      [](const Cloth& cloth, const py::handle& path, const py::handle& path_part,
         const py::handle& crossed, double width, const std::string& growth, double expansion) {
        idle(cloth);
        const GrowthMode mode = growth_mode(growth);
        const StrokeBand band = band_of(cloth, path, path_part, crossed, width);
        const Growth grown = grow_rest_lengths(cloth.positions(), cloth.springs(), band, mode,
                                               expansion);
        py::dict out;
        put_band(out, band);
        out["rest_lengths"] = read_only_copy(grown.rest_lengths);
        out["spring_weights"] = read_only_copy(grown.weights);
        out["springs_grown"] = grown.springs_grown;
        out["rest_added"] = grown.rest_added;
        return out;
      },
      py::arg("cloth"), py::arg("path"), py::arg("path_part"), py::arg("crossed_faces"),
      py::arg("width"), py::arg("growth"), py::arg("expansion"),
      "Rest lengths (s, m) of the cloth's springs after a growth rule over a stroke's band; the "
      "cloth is not changed.");
}

}  // namespace yore::bindings
