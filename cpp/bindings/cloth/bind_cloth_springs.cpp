// Cloth.springs: the view of a cloth's springs (structure of arrays).
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "cloth/cloth_state.hpp"
#include "convert.hpp"

namespace yore::bindings {

void bind_cloth_springs(py::module_& m) {
  py::class_<SpringsView>(m, "Springs", "The springs of a cloth (structure of arrays).")
      .def("__len__", [](const SpringsView& view) { return idle(*view.cloth).springs().size(); })
      .def_property_readonly(
          "ends",
          [](const SpringsView& view) {
            const SpringSet& springs = idle(*view.cloth).springs();
            Edges ends(static_cast<Eigen::Index>(springs.size()), 2);
            for (std::size_t s = 0; s < springs.size(); ++s) {
              ends(static_cast<Eigen::Index>(s), 0) = springs.first[s];
              ends(static_cast<Eigen::Index>(s), 1) = springs.second[s];
            }
            return read_only_copy(ends);
          },
          "s×2 int32 vertex indices of each spring's ends.")
      .def_property(
          "rest",
          [](const SpringsView& view) {
            return read_only_copy(idle(*view.cloth).springs().rest_length);
          },
          [](SpringsView& view, const py::handle& rest) {
            Cloth& cloth = idle(*view.cloth);
            cloth.set_rest_lengths(
                to_vector(rest, "rest", static_cast<Eigen::Index>(cloth.springs().size())));
          },
          "(s,) rest lengths, metres; assignable (finite, > 0).")
      .def_property_readonly(
          "kind",
          [](const SpringsView& view) {
            const auto& kinds = idle(*view.cloth).springs().kind;
            std::vector<std::int8_t> codes(kinds.size());
            for (std::size_t s = 0; s < kinds.size(); ++s) {
              codes[s] = static_cast<std::int8_t>(kinds[s]);
            }
            return read_only_copy(codes);
          },
          "(s,) int8 kind of each spring: 0 structural, 1 bending.")
      .def_property_readonly(
          "reference",
          [](const SpringsView& view) {
            return read_only_copy(idle(*view.cloth).springs().reference_length);
          },
          "(s,) reference lengths, metres: what rest lengths are measured against (the input "
          "length, or the length when a stroke created the spring).")
      .def_property_readonly(
          "stiffness",
          [](const SpringsView& view) {
            return read_only_copy(idle(*view.cloth).springs().stiffness);
          },
          "(s,) stiffness, N/m.")
      .def_property_readonly(
          "damping",
          [](const SpringsView& view) {
            return read_only_copy(idle(*view.cloth).springs().damping);
          },
          "(s,) damping along each spring, N·s/m.");
}

}  // namespace yore::bindings
