// The module yore._cpu: what the CPU and the OS run, read before anything loads a BLAS. A module
// of its own because yore._core links CHOLMOD, whose BLAS chooses its kernels the moment it
// loads (python/yore/blas.py decides them from this). Links nothing but pybind11.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "yore/platform/cpu_features.hpp"

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
}
