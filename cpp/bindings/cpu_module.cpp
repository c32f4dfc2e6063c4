// The module yore._cpu: what the CPU and the OS run, read before anything loads a BLAS. A module
// of its own because yore._core links CHOLMOD, whose BLAS chooses its kernels the moment it
// loads (python/yore/blas.py decides them from this). Links nothing but pybind11. It also holds
// the input limits' table (yore/platform/limits.hpp), which yore.limits reads: the checks that
// run before the core loads (the thread count yore.blas sets) need it too.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>

#include "yore/platform/cpu_features.hpp"
#include "yore/platform/limits.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_cpu, m) {
  m.doc() = "The CPU's usable instruction-set extensions (use yore.blas, not this module)";
  py::class_<yore::CpuFeatures>(m, "CpuFeatures",
                                "What CPUID says, vector extensions filtered by what the OS "
                                "enables (XCR0).")
      .def_readonly("vendor", &yore::CpuFeatures::vendor)
      .def_readonly("family", &yore::CpuFeatures::family)
      .def_readonly("model", &yore::CpuFeatures::model)
      .def_readonly("extensions", &yore::CpuFeatures::extensions)
      .def_readonly("os_saves_ymm", &yore::CpuFeatures::os_saves_ymm)
      .def_readonly("os_saves_zmm", &yore::CpuFeatures::os_saves_zmm);
  m.def("cpu_features", &yore::cpu_features,
        "This CPU's vendor, family, model and usable extensions (empty off x86-64).");
  py::dict limits;
  for (const yore::Limit& limit : yore::kLimits) {
    limits[limit.name] = limit.integral
                             ? py::object(py::int_(static_cast<std::int64_t>(limit.value)))
                             : py::object(py::float_(limit.value));
  }
  m.attr("limits") = limits;
}
