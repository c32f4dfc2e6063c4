#pragma once
// The parts of the Cloth binding that live in their own files: the view of its springs
// (bind_cloth_springs.cpp) and the conversions of its state to and from a dict (cloth_state.cpp).

#include <pybind11/pybind11.h>

#include <string>

#include "yore/cloth/cloth.hpp"

namespace yore::bindings {

namespace py = pybind11;

/// The springs of a cloth, seen from Python (a view; keeps its cloth alive).
struct SpringsView {
  Cloth* cloth;
};

/// The bending model named in Python, or std::invalid_argument listing the valid names.
BendingModel bending_model(const std::string& name);
/// The Python name of a bending model.
const char* bending_name(BendingModel model);
/// Cloth.state(): every array and number that defines the cloth, keyed as kStateKeys.
py::dict state_dict(const Cloth& cloth);
/// Cloth.state_fields: {"required": the keys every state has, "optional": the keys older states
/// may lack}, both in kStateKeys' order — the one list the state files' schema reads.
py::dict state_fields();
/// Cloth.from_state(): the cloth a state dict describes; std::invalid_argument (ValueError)
/// naming unknown or missing keys and bad shapes or values.
Cloth cloth_from_state(const py::dict& values);

}  // namespace yore::bindings
