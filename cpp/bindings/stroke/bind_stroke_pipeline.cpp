#include <pybind11/stl.h>

#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "convert.hpp"
#include "yore/stroke/stroke_pipeline.hpp"

namespace yore::bindings {
namespace {

/// The stroke as C++ traces it: "closest" (points k×3 m, max_distance m), "material" (points
/// k×3 rest-pattern m with z = 0, max_distance the tolerance m) or "rays" (pixels k×3 with z =
/// 0 and a camera's eye and pixel rays).
StrokeInput stroke_input(const std::string& trace, const py::handle& points, double max_distance,
                         const py::handle& eye, const py::handle& base_direction,
                         const py::handle& per_pixel_x, const py::handle& per_pixel_y,
                         double spacing_pixels) {
  StrokeInput input;
  input.points = to_rows3(points, "points");
  input.max_distance = max_distance;
  if (trace == "closest") {
    input.kind = StrokeInput::Kind::closest;
  } else if (trace == "material") {
    input.kind = StrokeInput::Kind::material;
  } else if (trace == "rays") {
    input.kind = StrokeInput::Kind::rays;
    input.eye = to_vec3(eye, "eye");
    input.base_direction = to_vec3(base_direction, "base_direction");
    input.per_pixel_x = to_vec3(per_pixel_x, "direction_per_pixel_x");
    input.per_pixel_y = to_vec3(per_pixel_y, "direction_per_pixel_y");
    input.spacing_pixels = spacing_pixels;
  } else {
    throw std::invalid_argument("trace: got '" + trace +
                                "'; expected 'closest', 'rays' or 'material'");
  }
  return input;
}

// What a stroke did: StrokeResult's fields by their C++ names, read-only (index lists and
// weights as read-only arrays). yore.stroke.StrokeReport shows them with the Python side's
// own (the options, the re-analysis time).
void bind_stroke_result(py::module_& m) {
  py::class_<StrokeResult>(m, "StrokeResult", "What one stroke did (see stroke_pipeline.hpp).")
      .def_readonly("faces_split", &StrokeResult::faces_split)
      .def_property_readonly("faces_skipped",
                             [](const StrokeResult& r) { return read_only_copy(r.faces_skipped); })
      .def_property_readonly(
          "vertices_added",
          [](const StrokeResult& r) { return static_cast<std::int64_t>(r.new_vertices.size()); })
      .def_readonly("springs_added", &StrokeResult::springs_added)
      .def_readonly("springs_removed", &StrokeResult::springs_removed)
      .def_property_readonly("region_faces",
                             [](const StrokeResult& r) { return read_only_copy(r.region_faces); })
      .def_property_readonly("new_vertices",
                             [](const StrokeResult& r) { return read_only_copy(r.new_vertices); })
      .def_readonly("area_before", &StrokeResult::area_before)
      .def_readonly("rest_area_before", &StrokeResult::rest_area_before)
      .def_readonly("rest_area_after", &StrokeResult::rest_area_after)
      .def_readonly("samples", &StrokeResult::samples)
      .def_readonly("missed_samples", &StrokeResult::missed_samples)
      .def_readonly("moved_inward", &StrokeResult::moved_inward)
      .def_readonly("locate_seconds", &StrokeResult::locate_seconds)
      .def_readonly("subdivide_seconds", &StrokeResult::subdivide_seconds)
      .def_readonly("faces_refined", &StrokeResult::faces_refined)
      .def_readonly("faces_bisected", &StrokeResult::faces_bisected)
      .def_readonly("springs_grown", &StrokeResult::springs_grown)
      .def_readonly("rest_length_added", &StrokeResult::rest_length_added)
      .def_readonly("mass_added", &StrokeResult::mass_added)
      .def_property_readonly("line_vertices",
                             [](const StrokeResult& r) { return read_only_copy(r.line_vertices); })
      .def_property_readonly("spring_weights",
                             [](const StrokeResult& r) { return read_only_copy(r.spring_weights); })
      .def_property_readonly(
          "vertex_weights", [](const StrokeResult& r) { return read_only_copy(r.vertex_weights); });
}

/// The stroke's exceptions, its result type and its options' defaults (by their Python names,
/// read from a default StrokeOptions: the one source of yore.options.STROKE_DEFAULTS).
void bind_stroke_basics(py::module_& m) {
  // A missed stroke and a refused refinement are ValueErrors of their own, defined here and
  // re-exported by yore.stroke (and yore).
  py::register_exception<StrokeMissed>(m, "StrokeMissed", PyExc_ValueError).attr("__doc__") =
      "The stroke touches the cloth nowhere.";
  py::register_exception<RefinementTooLarge>(m, "RefinementTooLarge", PyExc_ValueError)
      .attr("__doc__") =
      "A stroke's refinement could make the mesh larger than its vertex limit (the cloth is "
      "unchanged).";
  bind_stroke_result(m);
  const StrokeOptions stroke_defaults;
  py::dict defaults;
  defaults["growth"] = growth_rule(stroke_defaults.growth).name;
  defaults["width"] = stroke_defaults.width;
  defaults["refine"] = stroke_defaults.refine;
  defaults["max_vertices"] = stroke_defaults.max_vertices;
  defaults["spacing_pixels"] = StrokeInput{}.spacing_pixels;
  m.attr("stroke_defaults") = defaults;
}

}  // namespace

void bind_stroke_pipeline(py::module_& m) {
  bind_stroke_basics(m);
  const SplitOptions split_defaults;
  const StrokeOptions stroke_defaults;
  const std::string default_growth = growth_rule(stroke_defaults.growth).name;
  m.attr("refine_vertices_per_face") = kRefineVerticesPerFace;
  m.attr("refine_band_growth") = kRefineBandGrowth;
  m.def("predicted_refined_vertices", &predicted_refined_vertices, py::arg("vertices"),
        py::arg("band_faces"), py::arg("passes"),
        "An estimate from above of the vertex count after `passes` refinement passes of a band "
        "of `band_faces` faces on a mesh of `vertices`.");
  m.def(
      "apply_stroke",
      [](Cloth& cloth, const std::string& trace, const py::handle& points, double max_distance,
         const py::handle& eye, const py::handle& base_direction, const py::handle& per_pixel_x,
         const py::handle& per_pixel_y, double spacing_pixels, const std::string& growth,
         double width, int refine, double expansion, double mass_scale, bool conserve_mass,
         double min_barycentric, double min_angle_degrees, std::int64_t max_vertices) {
        idle(cloth);
        const StrokeInput input = stroke_input(trace, points, max_distance, eye, base_direction,
                                               per_pixel_x, per_pixel_y, spacing_pixels);
        StrokeOptions options;
        options.growth = growth_mode(growth);
        options.width = width;
        options.refine = refine;
        options.split.expansion = expansion;
        options.split.mass_scale = mass_scale;
        options.split.conserve_mass = conserve_mass;
        options.split.min_barycentric = min_barycentric;
        options.split.min_angle_degrees = min_angle_degrees;
        options.max_vertices = max_vertices;
        const BusyGuard busy(&cloth, "the Cloth", "a stroke is being applied to it");
        return run_without_gil([&] { return apply_stroke(cloth, input, options); });
      },
      py::arg("cloth"), py::arg("trace"), py::arg("points"), py::kw_only(),
      py::arg("max_distance") = 0.0, py::arg("eye") = py::none(),
      py::arg("base_direction") = py::none(), py::arg("direction_per_pixel_x") = py::none(),
      py::arg("direction_per_pixel_y") = py::none(),
      py::arg("spacing_pixels") = StrokeInput{}.spacing_pixels, py::arg("growth") = default_growth,
      py::arg("width") = stroke_defaults.width, py::arg("refine") = stroke_defaults.refine,
      py::arg("expansion") = split_defaults.expansion,
      py::arg("mass_scale") = split_defaults.mass_scale,
      py::arg("conserve_mass") = split_defaults.conserve_mass,
      py::arg("min_barycentric") = split_defaults.min_barycentric,
      py::arg("min_angle_degrees") = split_defaults.min_angle_degrees,
      py::arg("max_vertices") = stroke_defaults.max_vertices,
      R"doc(One stroke: trace → band → `refine` passes (traced again after each) → the paper's
1→3 split (growth "paper") or the growth rule over the band. trace: "closest" (points k×3 m,
max_distance m), "material" (points k×3 in rest-pattern m with z = 0, max_distance the
tolerance) or "rays" (pixels k×3 with z = 0, eye and the camera's pixel rays, spacing_pixels).
width m (0: the crossed faces). Returns a StrokeResult. Raises StrokeMissed
when a trace hits nothing, RefinementTooLarge (cloth unchanged) when the refinement
could pass max_vertices, ValueError on bad input.)doc");
}

}  // namespace yore::bindings
