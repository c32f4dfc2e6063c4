#include <pybind11/stl.h>

#include <stdexcept>

#include "bindings.hpp"
#include "convert.hpp"
#include "options.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/stroke/stroke.hpp"

namespace yore::bindings {

void bind_stroke(py::module_& m) {
  m.def(
      "pick_rays",
      [](const Cloth& cloth, const py::handle& pixels, const py::handle& eye,
         const py::handle& base, const py::handle& per_x, const py::handle& per_y) {
        const Positions points = to_rows3(pixels, "pixels");
        const Vec3 origin = to_vec3(eye, "eye"), d0 = to_vec3(base, "base_direction"),
                   dx = to_vec3(per_x, "direction_per_pixel_x"),
                   dy = to_vec3(per_y, "direction_per_pixel_y");
        const BusyGuard busy(&cloth, "the Cloth", "a stroke is being traced on it");
        const auto hits = run_without_gil([&] {
          return pick_rays(cloth.positions(), cloth.faces(), points, origin, d0, dx, dy);
        });
        const auto count = static_cast<Eigen::Index>(hits.size());
        Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1> faces(count);
        Positions barycentric = Positions::Zero(count, 3);
        for (Eigen::Index k = 0; k < count; ++k) {
          const auto& hit = hits[static_cast<std::size_t>(k)];
          faces[k] = hit ? hit->face : -1;
          if (hit) barycentric.row(k) = hit->barycentric.transpose();
        }
        py::dict out;
        out["faces"] = read_only_copy(faces);
        out["barycentric"] = read_only_copy(barycentric);
        return typed_result("RayHits", out);
      },
      py::arg("cloth"), py::arg("pixels"), py::arg("eye"), py::arg("base_direction"),
      py::arg("direction_per_pixel_x"), py::arg("direction_per_pixel_y"),
      "Each pixel's (k×3, z = 0) first hit on the cloth's current surface, by the rays "
      "trace_rays casts, as a yore.results.RayHits: faces (k, -1 where the ray misses), "
      "barycentric (k×3).");
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
}

}  // namespace yore::bindings
