#include <pybind11/stl.h>

#include <string>

#include "bindings.hpp"
#include "convert.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/stroke/growth.hpp"

namespace yore::bindings {
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
        for (int k = 0; k < kGrowthModeCount; ++k) {
          names.append(growth_rule(static_cast<GrowthMode>(k)).name);
        }
        return names;
      },
      "Names of the growth modes, in the table's order.");
}

}  // namespace yore::bindings
