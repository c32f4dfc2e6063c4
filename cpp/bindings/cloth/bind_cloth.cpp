#include <pybind11/stl.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "bindings.hpp"
#include "cloth/cloth_state.hpp"
#include "convert.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/platform/errors.hpp"

namespace yore::bindings {
namespace {

// A bare Cloth's material when the arguments leave it out: the core's ClothMaterial{} (and
// kDefaultVertexMass, kDefaultPoissonRatio), bound as `Cloth.defaults`.
const ClothMaterial kDefaults{};

/// A number given as one (an int or a float, numpy's too): bools, strings and anything
/// pybind11 cannot make a double of are std::invalid_argument naming `name`.
double plain_number(const py::object& value, const char* name, const char* unit) {
  const bool flag = PyBool_Check(value.ptr()) ||
                    std::string(Py_TYPE(value.ptr())->tp_name) == "numpy.bool_" ||
                    std::string(Py_TYPE(value.ptr())->tp_name) == "numpy.bool";
  if (!flag && !py::isinstance<py::str>(value) && !py::isinstance<py::bytes>(value)) {
    try {
      return value.cast<double>();
    } catch (const py::cast_error&) {
    }
  }
  std::ostringstream msg;
  msg << name << " must be a number (" << unit << "), got "
      << std::string(py::str(py::repr(value))).substr(0, 60);
  throw std::invalid_argument(msg.str());
}

/// Per-vertex masses from a scalar (uniform) or an (n,) array, or from an areal density.
Eigen::VectorXd vertex_masses(const py::object& mass, const py::object& density,
                              const Positions& positions, const Faces* faces) {
  const Eigen::Index n = positions.rows();
  if (!density.is_none()) {
    if (!mass.is_none()) {
      throw std::invalid_argument(
          "give either masses (kg per vertex) or density (kg/m²), not both");
    }
    if (faces == nullptr) throw std::invalid_argument("density needs faces; give masses instead");
    return lumped_masses(positions, *faces, plain_number(density, "density", "kg/m²"));
  }
  if (mass.is_none()) return Eigen::VectorXd::Constant(n, kDefaultVertexMass);
  if (PyBool_Check(mass.ptr())) plain_number(mass, "masses", "kg per vertex");  // refuses it
  const auto array = as_float_array(mass, "masses");
  if (array.ndim() == 0) return Eigen::VectorXd::Constant(n, *array.data());
  return to_vector(mass, "masses", n);
}

/// The per-vertex masses argument: `masses`, or the former name `mass` (kg per vertex as well,
/// but spelled like the scene files' and yore.scenes' total mass), accepted for one version
/// with a DeprecationWarning.
py::object masses_argument(const py::object& masses, const py::object& mass) {
  if (mass.is_none()) return masses;
  if (!masses.is_none()) {
    throw std::invalid_argument("give masses (kg per vertex), not also its former name mass");
  }
  if (PyErr_WarnEx(PyExc_DeprecationWarning,
                   "Cloth(mass=...) is deprecated: the per-vertex masses are now given as "
                   "masses=... (mass means the total in scene files and yore.scenes)",
                   1) != 0) {
    throw py::error_already_set();
  }
  return mass;
}

py::dict energy_dict(const EnergyTerms& terms) {
  py::dict out;
  out["kinetic"] = terms.kinetic;
  out["spring"] = terms.spring;
  out["gravity"] = terms.gravity;
  out["bending"] = terms.bending;
  out["membrane"] = terms.membrane;
  out["total"] = terms.total();
  return out;
}

std::vector<std::int32_t> vertices_in_state(const Cloth& cloth, VertexState state) {
  std::vector<std::int32_t> out;
  for (std::size_t i = 0; i < cloth.vertex_states().size(); ++i) {
    if (cloth.vertex_states()[i] == state) out.push_back(static_cast<std::int32_t>(i));
  }
  return out;
}

// A number given as a Python object (None allowed by the caller): a real number, not a bool or
// a string; std::invalid_argument (ValueError) naming the argument otherwise.
double real_argument(const py::object& value, const char* name) {
  const py::object real = py::module_::import("numbers").attr("Real");
  const py::object numpy_bool = py::module_::import("numpy").attr("bool_");
  if (py::isinstance<py::bool_>(value) || py::isinstance(value, numpy_bool) ||
      !py::isinstance(value, real)) {
    throw InvalidArgument(std::string(name) + ": got " +
                              py::str(py::repr(value)).cast<std::string>() + "; expected a number",
                          name);
  }
  return value.cast<double>();
}

// A string argument (bending, stretch): a Python str, or std::invalid_argument (ValueError)
// naming the argument and what it takes (a None or a number used to be pybind11's TypeError).
std::string text_argument(const py::object& value, const char* name, const char* expected) {
  if (!py::isinstance<py::str>(value)) {
    throw InvalidArgument(std::string(name) + " must be " + expected + ", got " +
                              py::str(py::repr(value)).cast<std::string>(),
                          name);
  }
  return value.cast<std::string>();
}

// The membrane of stretch="membrane" (young_modulus required, poisson_ratio defaulted), or
// none with stretch="springs" (which takes neither); std::invalid_argument otherwise.
MembraneMaterial membrane_argument(const std::string& stretch, const py::object& young_modulus,
                                   const py::object& poisson_ratio) {
  if (stretch != "springs" && stretch != "membrane") {
    throw std::invalid_argument("stretch must be \"springs\" or \"membrane\", got \"" + stretch +
                                "\"");
  }
  MembraneMaterial membrane;
  if (stretch == "springs") {
    if (!young_modulus.is_none() || !poisson_ratio.is_none()) {
      throw InvalidArgument(
          "young_modulus and poisson_ratio are for stretch=\"membrane\"; springs take "
          "stretch_stiffness (N/m)",
          "young_modulus");
    }
    return membrane;
  }
  if (young_modulus.is_none()) {
    throw std::invalid_argument("stretch=\"membrane\" needs young_modulus (N/m, > 0)");
  }
  membrane.young_modulus = real_argument(young_modulus, "young_modulus");
  if (!(membrane.young_modulus > 0.0)) {
    throw InvalidArgument("young_modulus must be > 0 (N/m), got " +
                              py::str(py::repr(young_modulus)).cast<std::string>(),
                          "young_modulus");
  }
  membrane.poisson_ratio = poisson_ratio.is_none() ? kDefaultPoissonRatio
                                                   : real_argument(poisson_ratio, "poisson_ratio");
  return membrane;
}

// The bend stiffness argument, N/m: the default with bending springs, 0 (and only 0) with
// quadratic or hinge bending, which create none.
double bend_stiffness_argument(const py::object& bend_stiffness, BendingModel model,
                               const std::string& bending) {
  double stiffness = kDefaults.bend_stiffness;
  if (!bend_stiffness.is_none()) {
    stiffness = real_argument(bend_stiffness, "bend_stiffness");
  }
  if (is_quadratic(model)) {
    if (!bend_stiffness.is_none() && stiffness != 0.0) {
      throw std::invalid_argument("bending=\"" + bending +
                                  "\" creates no bending springs: leave "
                                  "bend_stiffness out (or 0), got " +
                                  std::to_string(stiffness));
    }
    stiffness = 0.0;
  }
  return stiffness;
}

// The structural springs' stiffness: the default, the argument, or 0 under a membrane (which
// takes no stiffness but 0).
double stretch_stiffness_argument(const py::object& stretch_stiffness,
                                  const MembraneMaterial& membrane) {
  double stretch_value = kDefaults.stretch_stiffness;
  if (!stretch_stiffness.is_none()) {
    stretch_value = real_argument(stretch_stiffness, "stretch_stiffness");
  }
  if (membrane.young_modulus > 0.0) {
    if (!stretch_stiffness.is_none() && stretch_value != 0.0) {
      throw std::invalid_argument(
          "stretch=\"membrane\" resists stretching instead of springs: leave "
          "stretch_stiffness out (or 0), got " +
          std::to_string(stretch_value));
    }
    stretch_value = 0.0;
  }
  return stretch_value;
}

// bending_modulus given exactly with the models that take it.
void check_bending_modulus_given(const py::object& bending_modulus, BendingModel model,
                                 const std::string& bending) {
  if (model == BendingModel::springs && !bending_modulus.is_none()) {
    throw InvalidArgument(
        "bending_modulus is for bending=\"quadratic\"; bending springs take "
        "bend_stiffness (N/m)",
        "bending_modulus");
  }
  if (is_quadratic(model) && bending_modulus.is_none()) {
    throw std::invalid_argument("bending=\"" + bending + "\" needs bending_modulus (N·m, >= 0)");
  }
}

// The membrane's strain, "smoothed" or "faces", set on the new cloth.
void set_membrane_strain(Cloth& cloth, const py::object& membrane_strain) {
  const std::string strain =
      text_argument(membrane_strain, "membrane_strain", "\"smoothed\" or \"faces\"");
  if (strain != "smoothed" && strain != "faces") {
    throw InvalidArgument(
        "membrane_strain must be \"smoothed\" or \"faces\", got \"" + strain + "\"",
        "membrane_strain");
  }
  try {
    cloth.set_membrane_smoothed(strain == "smoothed");
  } catch (const std::invalid_argument& error) {
    throw InvalidArgument(error.what(), "membrane_strain");
  }
}

// Cloth(...)'s arguments, checked one by one, into the core's constructor.
Cloth make_cloth(const py::handle& vertices, const py::handle& faces, const py::object& masses,
                 const py::object& stretch_stiffness, const py::object& bend_stiffness,
                 const py::object& damping_given, const py::object& drag_given,
                 const py::object& density, const py::object& bending_given,
                 const py::object& bending_modulus, const py::object& mass,
                 const py::object& stretch_given, const py::object& young_modulus,
                 const py::object& poisson_ratio, const py::object& membrane_strain) {
  const double damping = real_argument(damping_given, "damping");
  const double drag = real_argument(drag_given, "drag");
  const std::string bending =
      text_argument(bending_given, "bending", "\"springs\", \"quadratic\" or \"hinge\"");
  const std::string stretch =
      text_argument(stretch_given, "stretch", "\"springs\" or \"membrane\"");
  const py::object given = masses_argument(masses, mass);
  const MembraneMaterial membrane = membrane_argument(stretch, young_modulus, poisson_ratio);
  const double stretch_value = stretch_stiffness_argument(stretch_stiffness, membrane);
  const BendingModel model = bending_model(bending);
  check_bending_modulus_given(bending_modulus, model, bending);
  const double stiffness = bend_stiffness_argument(bend_stiffness, model, bending);
  const double modulus =
      bending_modulus.is_none() ? 0.0 : real_argument(bending_modulus, "bending_modulus");
  const Positions v = to_rows3(vertices, "vertices");
  const Faces f = to_faces(faces);
  const Eigen::VectorXd vertex_mass = vertex_masses(given, density, v, &f);
  ClothMaterial material;
  material.stretch_stiffness = stretch_value;
  material.bend_stiffness = stiffness;
  material.damping = damping;
  material.drag = drag;
  material.bending = model;
  material.bending_modulus = modulus;
  material.membrane = membrane;
  Cloth cloth(v, f, vertex_mass, material);
  if (!membrane_strain.is_none()) set_membrane_strain(cloth, membrane_strain);
  return cloth;
}

// Cloth's constructors: the mesh with its material, and plain spring networks.
void def_construction(py::class_<Cloth>& cloth_class) {
  cloth_class
      .def(py::init(&make_cloth), py::arg("vertices"), py::arg("faces"), py::kw_only(),
           py::arg("masses") = py::none(), py::arg("stretch_stiffness") = py::none(),
           py::arg("bend_stiffness") = py::none(), py::arg("damping") = kDefaults.damping,
           py::arg("drag") = kDefaults.drag, py::arg("density") = py::none(),
           py::arg("bending") = "springs", py::arg("bending_modulus") = py::none(),
           py::arg("mass") = py::none(), py::arg("stretch") = "springs",
           py::arg("young_modulus") = py::none(), py::arg("poisson_ratio") = py::none(),
           py::arg("membrane_strain") = py::none())
      .def_static(
          "from_springs",
          [](const py::handle& vertices, const py::handle& edges, const py::object& rest_lengths,
             const py::object& masses, double stiffness, double damping, double drag,
             const py::object& mass) {
            const Positions v = to_rows3(vertices, "vertices");
            const Edges e = to_edges(edges);
            const Eigen::VectorXd rest = rest_lengths.is_none()
                                             ? Eigen::VectorXd()
                                             : to_vector(rest_lengths, "rest_lengths", e.rows());
            const Eigen::VectorXd vertex_mass =
                vertex_masses(masses_argument(masses, mass), py::none(), v, nullptr);
            return Cloth::from_springs(v, e, rest, vertex_mass, stiffness, damping, drag);
          },
          py::arg("vertices"), py::arg("edges"), py::kw_only(),
          py::arg("rest_lengths") = py::none(), py::arg("masses") = py::none(),
          py::arg("stiffness") = kDefaults.stretch_stiffness,
          py::arg("damping") = kDefaults.damping, py::arg("drag") = kDefaults.drag,
          py::arg("mass") = py::none(),
          R"doc(A plain spring network with no faces (chains, single springs).
vertices n×3 (m); edges s×2 vertex indices; rest_lengths (s,) metres, default the distances in
vertices; masses kg per vertex (scalar or (n,); `mass`, its former name, still works for one
version with a DeprecationWarning); stiffness N/m; damping N·s/m; drag 1/s.)doc");
}

// Cloth's positions, velocities, masses, faces, springs, material coordinates.
void def_state_arrays(py::class_<Cloth>& cloth_class) {
  cloth_class
      .def_property(
          "positions", [](const Cloth& cloth) { return read_only_copy(idle(cloth).positions()); },
          [](Cloth& cloth, const py::handle& value) {
            idle(cloth);
            cloth.set_positions(to_rows3(value, "positions", cloth.vertex_count()));
          },
          "n×3 positions, metres (a read-only copy; assign a whole array to change them).")
      .def_property(
          "velocities", [](const Cloth& cloth) { return read_only_copy(idle(cloth).velocities()); },
          [](Cloth& cloth, const py::handle& value) {
            idle(cloth);
            cloth.set_velocities(to_rows3(value, "velocities", cloth.vertex_count()));
          },
          "n×3 velocities, m/s (assignable; fixed and driven vertices keep theirs).")
      .def_property_readonly(
          "masses", [](const Cloth& cloth) { return read_only_copy(idle(cloth).masses()); },
          "(n,) masses, kg.")
      .def_property_readonly(
          "faces", [](const Cloth& cloth) { return read_only_copy(idle(cloth).faces()); },
          "f×3 int32 faces (empty for a spring network).")
      .def_property_readonly(
          "springs",
          py::cpp_function([](Cloth& cloth) { return SpringsView{&idle(cloth)}; },
                           py::keep_alive<0, 1>()),
          "The springs (ends, rest, kind, ...); a view that keeps its cloth alive.")
      .def_property(
          "material_coordinates",
          [](const Cloth& cloth) -> py::object {
            idle(cloth);
            if (cloth.material_coordinates().rows() == 0) return py::none();
            return read_only_copy(cloth.material_coordinates());
          },
          [](Cloth& cloth, const py::handle& value) {
            idle(cloth);
            const auto array = as_float_array(value, "material_coordinates");
            if (array.ndim() != 2 || array.shape(1) != 2 ||
                array.shape(0) != cloth.vertex_count()) {
              throw std::invalid_argument("material_coordinates must have shape (" +
                                          std::to_string(cloth.vertex_count()) + ", 2), got " +
                                          shape_text(array));
            }
            Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> uv(array.shape(0), 2);
            std::copy(array.data(), array.data() + array.size(), uv.data());
            cloth.set_material_coordinates(uv);
          },
          "n×2 rest-pattern coordinates (m) or None; interpolated into split faces.");
}

// Cloth's counts and the stretching material.
void def_material(py::class_<Cloth>& cloth_class) {
  cloth_class
      .def_property_readonly("vertex_count",
                             [](const Cloth& cloth) { return idle(cloth).vertex_count(); })
      .def_property_readonly("face_count",
                             [](const Cloth& cloth) { return idle(cloth).face_count(); })
      .def_property_readonly("spring_count",
                             [](const Cloth& cloth) { return idle(cloth).springs().size(); })
      .def_property_readonly(
          "drag", [](const Cloth& cloth) { return idle(cloth).drag(); },
          "Air drag coefficient, 1/s.")
      .def_property_readonly(
          "bending", [](const Cloth& cloth) { return bending_name(idle(cloth).bending_model()); },
          "The bending model: \"springs\", \"quadratic\" or \"hinge\".")
      .def_property_readonly(
          "stretch",
          [](const Cloth& cloth) { return idle(cloth).has_membrane() ? "membrane" : "springs"; },
          "What resists stretching: \"springs\" or \"membrane\".")
      .def_property_readonly(
          "young_modulus", [](const Cloth& cloth) { return idle(cloth).membrane().young_modulus; },
          "The membrane's 2-D Young's modulus, N/m (0 with springs).")
      .def_property_readonly(
          "poisson_ratio", [](const Cloth& cloth) { return idle(cloth).membrane().poisson_ratio; },
          "The membrane's Poisson's ratio (0 with springs).")
      .def_property_readonly(
          "membrane_strain",
          [](const Cloth& cloth) -> py::object {
            const Cloth& c = idle(cloth);
            if (!c.has_membrane()) return py::none();
            return py::str(c.has_smoothed_membrane() ? "smoothed" : "faces");
          },
          R"doc(How the membrane reads strain: "faces" (constant-strain triangles, the
default: exact along a lattice's rows, an artificial bending ~0.02 h² × tension across them and
on irregular meshes), "smoothed" (Cloth(..., membrane_strain="smoothed"), with bending
"quadratic" or "hinge": at each vertex the area-weighted mean of its faces' deformation
gradients, with a penalty on each face's deviating from it; no interpolation bending on
point-symmetric stars in any direction, a low-pass of ~0.25 (kh)² on short waves), None
without a membrane.)doc");
}

// Cloth's the membrane's status and the bending model.
void def_bending(py::class_<Cloth>& cloth_class) {
  cloth_class
      .def(
          "membrane_status",
          [](const Cloth& cloth) {
            const MembraneStatus status = idle(cloth).membrane_status();
            py::dict out;
            out["clamped_rest_faces"] = status.clamped_rest_faces;
            out["collapsed_faces"] = status.collapsed_faces;
            out["rest_area"] = status.rest_area;
            out["current_area"] = status.current_area;
            return typed_result("MembraneStatus", out);
          },
          R"doc(The membrane's faces now, as a yore.results.MembraneStatus: clamped_rest_faces (rest triangles whose edge lengths
nearly or no longer close a triangle, laid out with a height of 1 % of their longest side),
collapsed_faces (current area below 1e-3 of the rest area), rest_area and current_area (m²).
All zero with springs.)doc")
      .def_property_readonly(
          "bending_modulus", [](const Cloth& cloth) { return idle(cloth).bending_modulus(); },
          "Modulus of quadratic bending, N·m (0 with bending springs).")
      .def_property_readonly(
          "bending_hinges",
          [](const Cloth& cloth) -> std::int64_t {
            idle(cloth);
            if (!is_quadratic(cloth.bending_model())) return 0;
            return cloth.quadratic_bending().hinge_count;
          },
          "Interior edges (hinges) of quadratic or hinge bending's matrix; 0 with bending "
          "springs.")
      .def_property_readonly(
          "quadratic_bending",
          [](const Cloth& cloth) -> py::object {
            idle(cloth);
            if (!is_quadratic(cloth.bending_model())) return py::none();
            const QuadraticBendingMatrix& q = cloth.quadratic_bending();
            py::dict out;
            out["size"] = q.size;
            out["hinges"] = q.hinge_count;
            out["indptr"] = read_only_copy(q.row_starts);
            out["indices"] = read_only_copy(q.columns);
            out["data"] = read_only_copy(q.values);
            out["rest_positions"] = read_only_copy(cloth.bending_rest_positions());
            return typed_result("QuadraticBending", out);
          },
          R"doc(Quadratic bending's matrix Q for the current faces (None with bending springs):
a yore.results.QuadraticBending with the symmetric n×n scalar matrix in CSR (indptr, indices, data; both triangles; per
unit modulus, the energy is ½ κ Σ_c x_cᵀ Q x_c), size n, hinges (interior edges) and
rest_positions (n×3, m, the rest state Q is built from).)doc");
}

// Cloth's the clock, constraints and drivers, the energy.
void def_time_and_constraints(py::class_<Cloth>& cloth_class) {
  cloth_class
      .def_property(
          "time", [](const Cloth& cloth) { return idle(cloth).time(); },
          [](Cloth& cloth, double time) {
            idle(cloth);
            if (!std::isfinite(time)) {
              throw std::invalid_argument("time must be finite, got " + std::to_string(time));
            }
            cloth.set_time(time);
            cloth.apply_drivers(time);  // driven vertices are where their drivers say at `time`
          },
          "Simulated time, s; assigning it also moves driven vertices to that time.")
      .def_property_readonly(
          "topology_version", [](const Cloth& cloth) { return idle(cloth).topology_version(); },
          "Changes whenever vertices, springs or the constrained set change.")
      .def_property_readonly(
          "fixed_vertices",
          [](const Cloth& cloth) {
            idle(cloth);
            return read_only_copy(vertices_in_state(cloth, VertexState::fixed));
          },
          "Indices of fixed vertices.")
      .def_property_readonly(
          "driven_vertices",
          [](const Cloth& cloth) {
            idle(cloth);
            return read_only_copy(vertices_in_state(cloth, VertexState::driven));
          },
          "Indices of kinematic (driven) vertices.")
      .def(
          "fix",
          [](Cloth& cloth, const py::handle& indices) {
            idle(cloth);
            cloth.fix(to_indices(indices, "indices"));
          },
          py::arg("indices"), "Fixes vertices: they never move.")
      .def(
          "drive_rotation",
          [](Cloth& cloth, const py::handle& indices, const py::handle& center,
             const py::handle& axis, double omega) {
            idle(cloth);
            cloth.drive_rotation(to_indices(indices, "indices"), to_vec3(center, "center"),
                                 to_vec3(axis, "axis"), omega);
          },
          py::arg("indices"), py::arg("center"), py::arg("axis"), py::arg("omega"),
          R"doc(Makes vertices kinematic: from the current time on they rotate about the axis
through `center` (m) along `axis` at `omega` rad/s (right-handed), exactly.)doc")
      .def(
          "energy",
          [](const Cloth& cloth, const py::handle& gravity) {
            idle(cloth);
            return typed_result("Energy", energy_dict(cloth.energy(to_vec3(gravity, "gravity"))));
          },
          py::arg("gravity"),
          "Kinetic, spring, gravitational, bending and membrane energy and their total (J), "
          "as a yore.results.Energy.");
}

// Cloth's the state dict, pickling, stable steps, busy, repr.
void def_state_and_steps(py::class_<Cloth>& cloth_class) {
  cloth_class
      .def(
          "state", [](const Cloth& cloth) { return typed_result("ClothState", state_dict(cloth)); },
          R"doc(Everything that defines the cloth, as a yore.results.ClothState (a dict of numbers
and numpy arrays whose fields are also attributes): state, springs in their order, masses,
constraints, drivers, material coordinates, bending, membrane and the clock.
Cloth.from_state(cloth.state()) is the same cloth, bit for bit (pickle uses this pair).)doc")
      .def_static("from_state", &cloth_from_state, py::arg("state"),
                  R"doc(Rebuilds a cloth from Cloth.state()'s dict. Raises ValueError naming an
unknown or missing key or the first inconsistent value.)doc")
      .def(py::pickle([](const Cloth& cloth) { return state_dict(cloth); },
                      [](const py::dict& values) { return cloth_from_state(values); }))
      .def(
          "stable_time_step", [](const Cloth& cloth) { return idle(cloth).stable_time_step(); },
          R"doc(Largest stable symplectic-Euler time step at the current state, s: Lanczos on the
mass-scaled PSD-projected spring Hessian (fixed and driven vertices eliminated), damping of the
top mode plus drag, h = (sqrt(g^2 + 4 lambda) - g) / lambda. Tight (an estimate from above at
this state: stretching or a stroke can lower the limit; the default explicit dt uses
stable_time_step_bound). 0 when k/m overflows; 2/g or inf when nothing elastic moves.)doc")
      .def(
          "stable_time_step_bound",
          [](const Cloth& cloth) { return idle(cloth).stable_time_step_bound(); },
          R"doc(State-independent stable time step, s: as stable_time_step on the spring graph
Laplacian (x I3) of stiffness and damping, which bounds the Hessian whatever the cloth's shape.
Lower than stable_time_step, and stays valid as the cloth stretches.)doc")
      .def(
          "gershgorin_time_step",
          [](const Cloth& cloth) { return idle(cloth).gershgorin_time_step(); },
          R"doc(Cheapest, most conservative stable time step, s: Gershgorin bounds on the
mass-scaled stiffness and damping Laplacians. Never above stable_time_step_bound; exact for one
spring, up to ~1.8x low on a cloth.)doc")
      .def_property_readonly(
          "busy", [](const Cloth& cloth) { return is_busy(&cloth); },
          "Whether a call that released the GIL (an integrator's advance, a stroke trace) is "
          "working on this cloth; meanwhile every other use raises RuntimeError.")
      .def("__repr__", [](const Cloth& cloth) {
        if (is_busy(&cloth)) return std::string("<yore.Cloth (in use by another thread)>");
        std::ostringstream text;
        text << "<yore.Cloth: " << cloth.vertex_count() << " vertices, " << cloth.face_count()
             << " faces, " << cloth.springs().size() << " springs, topology "
             << cloth.topology_version() << ">";
        return text.str();
      });
}

}  // namespace

void bind_cloth(py::module_& m) {
  py::class_<Cloth> cloth_class(m, "Cloth", R"doc(
A mass-spring cloth on a triangle mesh, wired as the paper's Fig. 1: structural springs on every
edge, bending springs across every interior edge between the two opposite vertices.

Cloth(vertices, faces, masses=None, stretch_stiffness=100.0, bend_stiffness=100.0, damping=0.0,
      drag=0.0, density=None, bending="springs", bending_modulus=None, stretch="springs",
      young_modulus=None, poisson_ratio=None, membrane_strain=None)
  vertices n×3 (m); faces f×3 integer indices; masses kg per vertex, a scalar (uniform, the
  paper's choice; 1e-3 when neither masses nor density is given) or an (n,) array (`mass`, its
  former name, still works for one version with a DeprecationWarning); density kg/m² instead of
  masses lumps mass by area (a third of each face to each corner); stiffnesses N/m per spring
  (bend_stiffness=0 creates no bending springs); damping N·s/m along each spring; drag 1/s, a force
  -drag·m·v on each vertex (still air).
  bending="springs" (the paper's bending springs, default), "quadratic" or "hinge": a bending
  energy ½ κ Σ_c x_cᵀ Q x_c with modulus κ = bending_modulus (N·m, required, >= 0; 0 adds no
  term) and Q from the rest shape of the faces in `vertices`. "quadratic" is ½ κ ∫ |∇∇x|² dA
  with each vertex's Hessian fitted (least squares) over its 1-ring: the same energy on any
  mesh (a cylinder within 0.5 % on grids at any angle and on pattern meshes); it needs every
  vertex's mesh part to hold 6 vertices not all near one conic. "hinge" is Bergou et al. 2006's
  hinge energy (cotangent weights per interior edge), which depends on the mesh's directions
  (1.5× on a grid at 45°, 1.12–1.16× on pattern meshes). Neither creates bending springs
  (bend_stiffness must then be left out or 0).
  stretch="springs" (the paper's structural springs, default) or "membrane": a continuum
  membrane of constant-strain triangles (St. Venant–Kirchhoff, plane stress) with 2-D Young's
  modulus young_modulus (N/m: Pa × thickness, required, > 0) and poisson_ratio (in (-1, 1),
  default 0.3) resists stretching; the structural springs stay on every edge with 0 N/m, as the
  carriers of the rest edge lengths the membrane's rest triangles are laid out from (strokes,
  growth and smoothing edit them) and of the damping (stretch_stiffness must be left out or 0).
  membrane_strain: "faces" (None, the default) or "smoothed" (needs bending "quadratic" or
  "hinge"; see the membrane_strain property).
  Raises ValueError on a bad mesh or value.)doc");
  {
    py::dict defaults;
    defaults["masses"] = kDefaultVertexMass;
    defaults["stretch_stiffness"] = kDefaults.stretch_stiffness;
    defaults["bend_stiffness"] = kDefaults.bend_stiffness;
    defaults["damping"] = kDefaults.damping;
    defaults["drag"] = kDefaults.drag;
    defaults["poisson_ratio"] = kDefaultPoissonRatio;
    cloth_class.attr("defaults") = defaults;
  }
  cloth_class.attr("state_fields") = state_fields();
  def_construction(cloth_class);
  def_state_arrays(cloth_class);
  def_material(cloth_class);
  def_bending(cloth_class);
  def_time_and_constraints(cloth_class);
  def_state_and_steps(cloth_class);
}

}  // namespace yore::bindings
