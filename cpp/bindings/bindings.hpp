#pragma once
// One bind_<topic> function per topic, all called from the single PYBIND11_MODULE in module.cpp.

#include <pybind11/pybind11.h>

namespace yore::bindings {

void bind_springs(pybind11::module_& m);
void bind_mesh(pybind11::module_& m);
void bind_cloth_springs(pybind11::module_& m);  // Cloth.springs, before bind_cloth
void bind_cloth(pybind11::module_& m);
void bind_explicit(pybind11::module_& m);
void bind_implicit(pybind11::module_& m);
void bind_stroke(pybind11::module_& m);
void bind_stroke_pipeline(pybind11::module_& m);
void bind_local_global(pybind11::module_& m);
void bind_error_controlled(pybind11::module_& m);
void bind_subdivision(pybind11::module_& m);
void bind_growth(pybind11::module_& m);

}  // namespace yore::bindings
