#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "yore/geometry/geometry.hpp"
#include "yore/integrators/explicit.hpp"
#include "yore/platform/build_info.hpp"
#include "yore/platform/errors.hpp"
#include "yore/solvers/bandwidth.hpp"

namespace py = pybind11;

namespace {

/// yore's exceptions: SimulationDiverged and ArgumentError carry what they name.
void bind_exceptions(py::module_& m) {
  // SimulationDiverged is a RuntimeError that carries where the run failed and a stable dt.
  // The type lives in the module (no static Python object to outlive the interpreter).
  py::exception<yore::SimulationDiverged>(m, "SimulationDiverged", PyExc_RuntimeError);
  py::register_exception<yore::NotPositiveDefinite>(m, "NotPositiveDefinite", PyExc_RuntimeError);
  // Bad input that names its argument: a ValueError whose `argument` is that name.
  py::exception<yore::InvalidArgument>(m, "ArgumentError", PyExc_ValueError).attr("__doc__") =
      "Bad input (a ValueError); `argument` names the argument at fault.";
  py::register_exception_translator([](std::exception_ptr pointer) {
    try {
      if (pointer) std::rethrow_exception(pointer);
    } catch (const yore::SimulationDiverged& error) {
      py::object type = py::module_::import("yore._native").attr("SimulationDiverged");
      py::object instance = type(error.what());
      instance.attr("step") = error.step();
      instance.attr("time") = error.time();
      instance.attr("dt") = error.dt();
      instance.attr("stable_dt") = error.stable_dt();
      PyErr_SetObject(type.ptr(), instance.ptr());
    } catch (const yore::InvalidArgument& error) {
      py::object type = py::module_::import("yore._native").attr("ArgumentError");
      py::object instance = type(error.what());
      instance.attr("argument") = error.argument();
      PyErr_SetObject(type.ptr(), instance.ptr());
    }
  });
}

}  // namespace

PYBIND11_MODULE(_native, m) {
  m.doc() =
      "yore's C++ core, loaded through yore._core once the BLAS kernels are chosen (use the "
      "`yore` package, not this module)";
  bind_exceptions(m);
  m.def(
      "build_info",
      [] {
        auto info = yore::build_info();
        info["cgal"] = yore::cgal_version();
        return info;
      },
      "Versions of the libraries the core was built and linked against.");
  m.def("max_threads", &yore::max_threads,
        "Threads the core's parallel loops may use (set_max_threads, else OpenMP's default).");
  m.def("set_blas_threads", &yore::set_blas_threads, py::arg("threads"),
        "Sets the threads of the loaded OpenBLAS alone (>= 1); False when it is not OpenBLAS.");
  m.def("blas_threads", &yore::blas_threads,
        "Threads of the loaded OpenBLAS that CHOLMOD calls (0 when the BLAS is not OpenBLAS).");
  m.def("stream_triad_bandwidth", &yore::stream_triad_bandwidth, py::arg("elements"),
        py::arg("repeats"),
        "Memory bandwidth (bytes/s) of a[i] = b[i] + s·c[i] with the core's threads, best of "
        "repeats (STREAM triad).");
  m.def("set_max_threads", &yore::set_max_threads, py::arg("threads"),
        "Sets the threads of the core's parallel loops and of OpenBLAS (>= 1); raises "
        "ValueError for fewer than 1.");

  yore::bindings::bind_statistics(m);
  yore::bindings::bind_springs(m);
  yore::bindings::bind_mesh(m);
  yore::bindings::bind_cloth_springs(m);
  yore::bindings::bind_cloth(m);
  yore::bindings::bind_explicit(m);
  yore::bindings::bind_implicit(m);
  yore::bindings::bind_stroke(m);
  yore::bindings::bind_stroke_pipeline(m);
  yore::bindings::bind_local_global(m);
  yore::bindings::bind_error_controlled(m);
  yore::bindings::bind_subdivision(m);
  yore::bindings::bind_growth(m);
}
