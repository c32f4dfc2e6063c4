#include "bindings.hpp"
#include "convert.hpp"
#include "options.hpp"
#include "yore/cloth.hpp"
#include "yore/stroke.hpp"

#include <pybind11/stl.h>

#include <stdexcept>

namespace yore::bindings {
namespace {

py::dict trace_dict(const StrokeTrace& trace) {
  const auto count = static_cast<Eigen::Index>(trace.crossings.size());
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1> faces(count);
  Positions barycentric(count, 3);
  for (Eigen::Index k = 0; k < count; ++k) {
    faces[k] = trace.crossings[static_cast<std::size_t>(k)].face;
    barycentric.row(k) = trace.crossings[static_cast<std::size_t>(k)].barycentric.transpose();
  }
  const auto points = static_cast<Eigen::Index>(trace.path.size());
  Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1> path_faces(points), path_part(points);
  Positions path_barycentric(points, 3);
  for (Eigen::Index k = 0; k < points; ++k) {
    const StrokePoint& point = trace.path[static_cast<std::size_t>(k)];
    path_faces[k] = point.face;
    path_part[k] = point.part;
    path_barycentric.row(k) = point.barycentric.transpose();
  }
  py::dict out;
  out["path_faces"] = read_only_copy(path_faces);
  out["path_barycentric"] = read_only_copy(path_barycentric);
  out["path_part"] = read_only_copy(path_part);
  out["faces"] = read_only_copy(faces);
  out["barycentric"] = read_only_copy(barycentric);
  out["samples"] = trace.samples;
  out["missed_samples"] = trace.missed_samples;
  return out;
}

template <typename Vector>
std::vector<std::int32_t> to_std(const Vector& v) {
  return std::vector<std::int32_t>(v.begin(), v.end());
}

}  // namespace

void bind_stroke(py::module_& m) {
  m.def(
      "trace_closest",
      [](const Cloth& cloth, const py::handle& points, double max_distance, double spacing) {
        const Positions stroke = to_rows3(points, "points");
        const BusyGuard busy(&cloth, "the Cloth", "a stroke is being traced on it");
        return trace_dict(run_without_gil([&] {
          return trace_closest(cloth.positions(), cloth.faces(), stroke, max_distance, spacing);
        }));
      },
      py::arg("cloth"), py::arg("points"), py::arg("max_distance"), py::arg("spacing"),
      "Faces a 3-D polyline (k×3, m) crosses on the cloth's current surface, closest-point.");
  m.def(
      "trace_material",
      [](const Cloth& cloth, const py::handle& points, double tolerance, double spacing) {
        idle(cloth);
        if (cloth.material_coordinates().rows() == 0) {
          throw std::invalid_argument(
              "the cloth has no material coordinates; set cloth.material_coordinates (n×2)");
        }
        Positions flat = Positions::Zero(cloth.vertex_count(), 3);
        flat.leftCols<2>() = cloth.material_coordinates();
        const Positions stroke = to_rows3(points, "points");
        const BusyGuard busy(&cloth, "the Cloth", "a stroke is being traced on it");
        return trace_dict(run_without_gil(
            [&] { return trace_closest(flat, cloth.faces(), stroke, tolerance, spacing); }));
      },
      py::arg("cloth"), py::arg("points"), py::arg("tolerance"), py::arg("spacing"),
      "Faces a polyline in rest-pattern coordinates (k×3 with z = 0) crosses.");
  m.def(
      "trace_rays",
      [](const Cloth& cloth, const py::handle& pixels, const py::handle& eye,
         const py::handle& base, const py::handle& per_x, const py::handle& per_y,
         double spacing) {
        const Positions stroke = to_rows3(pixels, "pixels");
        const Vec3 origin = to_vec3(eye, "eye"), d0 = to_vec3(base, "base_direction"),
                   dx = to_vec3(per_x, "direction_per_pixel_x"),
                   dy = to_vec3(per_y, "direction_per_pixel_y");
        const BusyGuard busy(&cloth, "the Cloth", "a stroke is being traced on it");
        return trace_dict(run_without_gil([&] {
          return trace_rays(cloth.positions(), cloth.faces(), stroke, origin, d0, dx, dy, spacing);
        }));
      },
      py::arg("cloth"), py::arg("pixels"), py::arg("eye"), py::arg("base_direction"),
      py::arg("direction_per_pixel_x"), py::arg("direction_per_pixel_y"), py::arg("spacing"),
      "Faces a pixel polyline crosses, by rays from a pinhole camera; nearest hits.");
  // The split's options by their Python names, read from a default SplitOptions: the one
  // source of the stroke defaults (yore.options.STROKE_DEFAULTS reads `split_defaults`).
  using S = SplitOptions;
  static const OptionTable<S> split_table = {
      plain_option("expansion", &S::expansion),
      plain_option("mass_scale", &S::mass_scale),
      plain_option("conserve_mass", &S::conserve_mass),
      plain_option("min_barycentric", &S::min_barycentric),
      plain_option("min_angle_degrees", &S::min_angle_degrees),
  };
  const SplitOptions split_defaults;
  m.attr("split_defaults") = option_values(split_table, split_defaults);
  m.def(
      "split_faces",
      [](Cloth& cloth, const py::handle& faces, const py::handle& barycentric, double expansion,
         double mass_scale, double min_barycentric, double min_angle_degrees,
         bool conserve_mass) {
        idle(cloth);
        const std::vector<std::int32_t> ids = to_indices(faces, "faces");
        const Positions weights =
            to_rows3(barycentric, "barycentric", static_cast<Eigen::Index>(ids.size()));
        std::vector<FaceSplit> splits(ids.size());
        for (std::size_t k = 0; k < ids.size(); ++k) {
          splits[k].face = ids[k];
          splits[k].barycentric = weights.row(static_cast<Eigen::Index>(k)).transpose();
        }
        SplitOptions options;
        options.expansion = expansion;
        options.mass_scale = mass_scale;
        options.min_barycentric = min_barycentric;
        options.min_angle_degrees = min_angle_degrees;
        options.conserve_mass = conserve_mass;
        const SplitReport report = cloth.split_faces(splits, options);
        py::dict out;
        out["split_faces"] = read_only_copy(report.split_faces);
        out["skipped_faces"] = read_only_copy(report.skipped_faces);
        out["new_vertices"] = read_only_copy(report.new_vertices);
        out["region_faces"] = read_only_copy(report.region_faces);
        out["springs_added"] = report.springs_added;
        out["springs_removed"] = report.springs_removed;
        out["rest_area_before"] = report.rest_area_before;
        out["rest_area_after"] = report.rest_area_after;
        out["moved_inward"] = report.moved_inward;
        out["mass_added"] = report.mass_added;
        return out;
      },
      py::arg("cloth"), py::arg("faces"), py::arg("barycentric"), py::kw_only(),
      py::arg("expansion") = split_defaults.expansion,
      py::arg("mass_scale") = split_defaults.mass_scale,
      py::arg("min_barycentric") = split_defaults.min_barycentric,
      py::arg("min_angle_degrees") = split_defaults.min_angle_degrees,
      py::arg("conserve_mass") = split_defaults.conserve_mass,
      "Splits faces 1→3 at barycentric points (the paper's subdivision); returns a report. "
      "conserve_mass: the new vertices take their mass from the corners (mass_scale unused).");
}

}  // namespace yore::bindings
