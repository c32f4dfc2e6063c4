// Cloth.state() and Cloth.from_state(): a cloth as a dict of arrays and back (bind_cloth.cpp
// binds them; pickling uses them too).
#include "cloth/cloth_state.hpp"

#include <pybind11/stl.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "convert.hpp"

namespace yore::bindings {
namespace {

/// The keys of Cloth.state(), in order.
const char* const kStateKeys[] = {"positions",
                                  "velocities",
                                  "masses",
                                  "faces",
                                  "spring_ends",
                                  "spring_rest",
                                  "spring_reference",
                                  "spring_stiffness",
                                  "spring_damping",
                                  "spring_kind",
                                  "drag",
                                  "stretch_stiffness",
                                  "bend_stiffness",
                                  "damping",
                                  "material_coordinates",
                                  "vertex_states",
                                  "drivers",
                                  "clock_origin",
                                  "clock_steps",
                                  "clock_dt",
                                  "bending",
                                  "bending_modulus",
                                  "bending_rest",
                                  "young_modulus",
                                  "poisson_ratio",
                                  "bending_operator",
                                  "membrane_strain"};
/// Keys a state may lack: states saved before quadratic bending existed are bending springs,
/// before the membrane existed springs resist stretching, and before the fitted operator
/// (issue 52) "quadratic" meant the hinge energy: such a state loads as bending="hinge", so it
/// goes on with the physics it was saved with; likewise a membrane saved before the smoothed strain
/// (no "membrane_strain") keeps the faces' constant strain.
bool optional_state_key(const std::string& key) {
  return key == "bending" || key == "bending_modulus" || key == "bending_rest" ||
         key == "young_modulus" || key == "poisson_ratio" || key == "bending_operator" ||
         key == "membrane_strain";
}

std::vector<double> double_list(const py::handle& object, const char* name, Eigen::Index size) {
  const Eigen::VectorXd values = to_vector(object, name, size);
  return std::vector<double>(values.data(), values.data() + values.size());
}

// The rotation drivers as a list of dicts (vertices, reference, center, axis, omega,
// start_time).
py::list drivers_list(const std::vector<RotationDriver>& drivers) {
  py::list out;
  for (const RotationDriver& driver : drivers) {
    py::dict entry;
    entry["vertices"] = read_only_copy(driver.vertices);
    entry["reference"] = read_only_copy(driver.reference);
    entry["center"] = read_only_copy(driver.center);
    entry["axis"] = read_only_copy(driver.axis);
    entry["omega"] = driver.omega;
    entry["start_time"] = driver.start_time;
    out.append(entry);
  }
  return out;
}

}  // namespace

/// The bending model named in Python, or std::invalid_argument listing the valid names.
BendingModel bending_model(const std::string& name) {
  if (name == "springs") return BendingModel::springs;
  if (name == "quadratic") return BendingModel::quadratic;
  if (name == "hinge") return BendingModel::hinge;
  throw std::invalid_argument("bending must be \"springs\", \"quadratic\" or \"hinge\", got \"" +
                              name + "\"");
}

const char* bending_name(BendingModel model) {
  switch (model) {
    case BendingModel::quadratic:
      return "quadratic";
    case BendingModel::hinge:
      return "hinge";
    default:
      return "springs";
  }
}

py::dict state_dict(const Cloth& cloth) {
  const ClothState state = idle(cloth).state();
  const SpringSet& springs = state.springs;
  const std::size_t s = springs.size();
  Edges ends(static_cast<Eigen::Index>(s), 2);
  std::vector<std::int8_t> kinds(s);
  for (std::size_t k = 0; k < s; ++k) {
    ends(static_cast<Eigen::Index>(k), 0) = springs.first[k];
    ends(static_cast<Eigen::Index>(k), 1) = springs.second[k];
    kinds[k] = static_cast<std::int8_t>(springs.kind[k]);
  }
  std::vector<std::uint8_t> vertex_states(state.vertex_states.size());
  for (std::size_t i = 0; i < vertex_states.size(); ++i) {
    vertex_states[i] = static_cast<std::uint8_t>(state.vertex_states[i]);
  }
  py::dict out;
  out["positions"] = read_only_copy(state.positions);
  out["velocities"] = read_only_copy(state.velocities);
  out["masses"] = read_only_copy(state.masses);
  out["faces"] = read_only_copy(state.faces);
  out["spring_ends"] = read_only_copy(ends);
  out["spring_rest"] = read_only_copy(springs.rest_length);
  out["spring_reference"] = read_only_copy(springs.reference_length);
  out["spring_stiffness"] = read_only_copy(springs.stiffness);
  out["spring_damping"] = read_only_copy(springs.damping);
  out["spring_kind"] = read_only_copy(kinds);
  out["drag"] = state.drag;
  out["stretch_stiffness"] = state.stretch_stiffness;
  out["bend_stiffness"] = state.bend_stiffness;
  out["damping"] = state.spring_damping;
  out["material_coordinates"] =
      state.material.rows() ? py::object(read_only_copy(state.material)) : py::none();
  out["vertex_states"] = read_only_copy(vertex_states);
  out["drivers"] = drivers_list(state.drivers);
  out["clock_origin"] = state.clock.origin;
  out["clock_steps"] = state.clock.steps;
  out["clock_dt"] = state.clock.dt;
  out["bending"] = bending_name(state.bending);
  // Which Q "quadratic" means in this file (issue 52); a file without it holds the hinge Q.
  out["bending_operator"] = state.bending == BendingModel::quadratic ? py::object(py::str("fitted"))
                                                                     : py::object(py::none());
  out["bending_modulus"] = state.bending_modulus;
  out["bending_rest"] =
      state.bending_rest.rows() ? py::object(read_only_copy(state.bending_rest)) : py::none();
  out["young_modulus"] = state.membrane.young_modulus;
  out["poisson_ratio"] = state.membrane.poisson_ratio;
  out["membrane_strain"] =
      state.membrane_smoothed ? py::object(py::str("smoothed")) : py::object(py::none());
  return out;
}

py::dict state_fields() {
  py::list required, optional;
  for (const char* key : kStateKeys) (optional_state_key(key) ? optional : required).append(key);
  py::dict out;
  out["required"] = py::tuple(required);
  out["optional"] = py::tuple(optional);
  return out;
}

namespace {

// A state dict's keys: none unknown, none missing but the optional ones.
void check_state_keys(const py::dict& values) {
  std::string unknown;
  for (const auto& item : values) {
    const std::string key = py::str(item.first);
    if (std::find_if(std::begin(kStateKeys), std::end(kStateKeys),
                     [&](const char* name) { return key == name; }) == std::end(kStateKeys)) {
      unknown += (unknown.empty() ? "" : ", ") + key;
    }
  }
  std::string missing;
  for (const char* key : kStateKeys) {
    if (!values.contains(key) && !optional_state_key(key)) {
      missing += (missing.empty() ? "" : ", ") + std::string(key);
    }
  }
  if (!unknown.empty() || !missing.empty()) {
    throw std::invalid_argument(
        "not a cloth state: " + (unknown.empty() ? "" : "unknown key(s) " + unknown) +
        (unknown.empty() || missing.empty() ? "" : "; ") +
        (missing.empty() ? "" : "missing key(s) " + missing));
  }
}

// The springs: ends, lengths, stiffness, damping and kinds.
void read_springs(const py::dict& values, SpringSet& springs) {
  const Edges ends = to_edges(values["spring_ends"], "state spring_ends");
  const Eigen::Index s = ends.rows();
  springs.first.resize(static_cast<std::size_t>(s));
  springs.second.resize(static_cast<std::size_t>(s));
  for (Eigen::Index k = 0; k < s; ++k) {
    springs.first[static_cast<std::size_t>(k)] = ends(k, 0);
    springs.second[static_cast<std::size_t>(k)] = ends(k, 1);
  }
  springs.rest_length = double_list(values["spring_rest"], "state spring_rest", s);
  springs.reference_length = double_list(values["spring_reference"], "state spring_reference", s);
  springs.stiffness = double_list(values["spring_stiffness"], "state spring_stiffness", s);
  springs.damping = double_list(values["spring_damping"], "state spring_damping", s);
  for (const double code : double_list(values["spring_kind"], "state spring_kind", s)) {
    if (code != 0.0 && code != 1.0) {  // before the cast: NaN or 1e300 to int is undefined
      throw std::invalid_argument("state spring_kind must hold 0 (structural) or 1 (bending)");
    }
    springs.kind.push_back(static_cast<SpringKind>(static_cast<int>(code)));
  }
}

// Vertex states, rotation drivers and the clock.
void read_constraints(const py::dict& values, ClothState& state, Eigen::Index n) {
  for (const double code : double_list(values["vertex_states"], "state vertex_states", n)) {
    if (code != 0.0 && code != 1.0 && code != 2.0) {
      throw std::invalid_argument(
          "state vertex_states must hold 0 (free), 1 (fixed) or 2 (driven)");
    }
    state.vertex_states.push_back(static_cast<VertexState>(static_cast<int>(code)));
  }
  for (const py::handle entry : values["drivers"].cast<py::list>()) {
    const py::dict driver_values = entry.cast<py::dict>();
    RotationDriver driver;
    driver.vertices = to_indices(driver_values["vertices"], "state driver vertices");
    driver.reference = to_rows3(driver_values["reference"], "state driver reference",
                                static_cast<Eigen::Index>(driver.vertices.size()));
    driver.center = to_vec3(driver_values["center"], "state driver center");
    driver.axis = to_vec3(driver_values["axis"], "state driver axis");
    driver.omega = driver_values["omega"].cast<double>();
    driver.start_time = driver_values["start_time"].cast<double>();
    state.drivers.push_back(std::move(driver));
  }
  state.clock.origin = values["clock_origin"].cast<double>();
  state.clock.steps = values["clock_steps"].cast<std::int64_t>();
  state.clock.dt = values["clock_dt"].cast<double>();
}

// The bending model and its rest shape, and the membrane's material (optional keys: states
// from before them read as the model they were).
void read_bending_and_membrane(const py::dict& values, ClothState& state, Eigen::Index n) {
  if (values.contains("bending"))
    state.bending = bending_model(values["bending"].cast<std::string>());
  if (values.contains("bending_operator") && !values["bending_operator"].is_none()) {
    const py::object given = values["bending_operator"];
    if (!py::isinstance<py::str>(given) || given.cast<std::string>() != "fitted" ||
        state.bending != BendingModel::quadratic) {
      throw std::invalid_argument(
          "state bending_operator must be \"fitted\" with bending \"quadratic\", else None");
    }
  } else if (state.bending == BendingModel::quadratic) {
    state.bending = BendingModel::hinge;  // a state from before the fitted operator: hinges
  }
  if (values.contains("bending_modulus") && !values["bending_modulus"].is_none()) {
    state.bending_modulus = values["bending_modulus"].cast<double>();
  }
  if (values.contains("bending_rest") && !values["bending_rest"].is_none()) {
    state.bending_rest = to_rows3(values["bending_rest"], "state bending_rest", n);
  }
  if (values.contains("young_modulus")) {
    state.membrane.young_modulus = values["young_modulus"].cast<double>();
  }
  if (values.contains("poisson_ratio")) {
    state.membrane.poisson_ratio = values["poisson_ratio"].cast<double>();
  }
  if (values.contains("membrane_strain") && !values["membrane_strain"].is_none()) {
    const py::object given = values["membrane_strain"];
    if (!py::isinstance<py::str>(given) || given.cast<std::string>() != "smoothed") {
      throw std::invalid_argument("state membrane_strain must be \"smoothed\" or None");
    }
    state.membrane_smoothed = true;
  }
}

}  // namespace

Cloth cloth_from_state(const py::dict& values) {
  check_state_keys(values);
  ClothState state;
  state.positions = to_rows3(values["positions"], "state positions");
  const Eigen::Index n = state.positions.rows();
  state.velocities = to_rows3(values["velocities"], "state velocities", n);
  state.masses = to_vector(values["masses"], "state masses", n);
  const auto faces = as_float_array(values["faces"], "state faces");
  if (faces.size() > 0) state.faces = to_faces(values["faces"], "state faces");
  read_springs(values, state.springs);
  state.drag = values["drag"].cast<double>();
  state.stretch_stiffness = values["stretch_stiffness"].cast<double>();
  state.bend_stiffness = values["bend_stiffness"].cast<double>();
  state.spring_damping = values["damping"].cast<double>();
  if (!values["material_coordinates"].is_none()) {
    const auto uv = as_float_array(values["material_coordinates"], "state material_coordinates");
    if (uv.ndim() != 2 || uv.shape(1) != 2 || uv.shape(0) != n) {
      throw std::invalid_argument("state material_coordinates must have shape (" +
                                  std::to_string(n) + ", 2), got " + shape_text(uv));
    }
    state.material.resize(n, 2);
    std::copy(uv.data(), uv.data() + uv.size(), state.material.data());
  }
  read_constraints(values, state, n);
  read_bending_and_membrane(values, state, n);
  return Cloth::from_state(state);
}

}  // namespace yore::bindings
