#pragma once
// Conversions between numpy arrays and the core's Eigen types, with checks that name the
// offending argument, shape or value (std::invalid_argument → ValueError in Python).

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <vector>

#include "yore/cloth/cloth.hpp"
#include "yore/cloth/mesh.hpp"
#include "yore/integrators/integrator.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/solvers/linear_solver.hpp"

namespace yore::bindings {

namespace py = pybind11;

/// Text "(a, b, ...)" of an array's shape.
std::string shape_text(const py::array& array);

/// A float64 array from anything numpy can convert; ValueError naming `name` when it cannot.
py::array_t<double, py::array::c_style | py::array::forcecast> as_float_array(
    const py::handle& object, const char* name);

/// n×3 float64 rows (metres or m/s); rows == -1 accepts any n.
Positions to_rows3(const py::handle& object, const char* name, Eigen::Index rows = -1);

/// f×3 int32 faces; rejects non-integer dtypes and values outside int32.
Faces to_faces(const py::handle& object, const char* name = "faces");

/// s×2 int32 vertex pairs.
Edges to_edges(const py::handle& object, const char* name = "edges");

/// 1-D float64 vector; size == -1 accepts any size.
Eigen::VectorXd to_vector(const py::handle& object, const char* name, Eigen::Index size = -1);

/// A 3-vector from a length-3 sequence.
Eigen::Vector3d to_vec3(const py::handle& object, const char* name);

/// 1-D list of vertex indices (any integer dtype); range is checked by the core.
std::vector<std::int32_t> to_indices(const py::handle& object, const char* name);

/// `value` as int32; ValueError naming `name` outside the 32-bit range (counts, sizes).
std::int32_t to_int32(std::int64_t value, const char* name);

/// A read-only numpy copy (the core's storage may move when the topology changes).
template <typename Matrix>
py::array read_only_copy(const Matrix& matrix) {
  using Scalar = typename Matrix::Scalar;
  py::array_t<Scalar> out;
  if constexpr (Matrix::ColsAtCompileTime == 1) {
    out = py::array_t<Scalar>(static_cast<py::ssize_t>(matrix.size()));
  } else {
    out = py::array_t<Scalar>(
        {static_cast<py::ssize_t>(matrix.rows()), static_cast<py::ssize_t>(matrix.cols())});
  }
  // Row-major Eigen storage matches numpy's C order element for element.
  std::copy(matrix.data(), matrix.data() + matrix.size(), out.mutable_data());
  out.attr("flags").attr("writeable") = false;
  return std::move(out);
}

/// A read-only numpy copy of a std::vector.
template <typename T>
py::array read_only_copy(const std::vector<T>& values) {
  py::array_t<T> out(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), out.mutable_data());
  out.attr("flags").attr("writeable") = false;
  return std::move(out);
}

/// Marks an object (a Cloth, an integrator) as in use while a binding works on it with the GIL
/// released, so that another Python thread cannot read or change it meanwhile (a stroke would
/// reallocate the arrays an integrator is writing). Every binding that touches a Cloth or an
/// integrator calls check_idle() first, holding the GIL. Exception-safe (RAII); the mark is set
/// and cleared while the GIL is held.
class BusyGuard {
 public:
  /// Marks `object` busy; throws std::runtime_error (RuntimeError) naming `what` if it already is.
  BusyGuard(const void* object, const char* what, const char* call);
  ~BusyGuard();
  BusyGuard(const BusyGuard&) = delete;
  BusyGuard& operator=(const BusyGuard&) = delete;

 private:
  const void* m_object;
};

/// Throws std::runtime_error (RuntimeError) "<what> is in use by another thread (<call>)" if a
/// BusyGuard holds `object`. One relaxed atomic load when nothing is busy.
void check_idle(const void* object, const char* what);

/// Whether a BusyGuard holds `object`.
bool is_busy(const void* object);

/// `values` as the typed result `type_name` of yore.results (a dict whose declared fields are
/// also attributes: ``cloth.state().positions`` and ``cloth.state()["positions"]`` both read).
/// The module is looked up when the call returns, so the extension loads without it.
inline py::object typed_result(const char* type_name, const py::dict& values) {
  return py::module_::import("yore.results").attr(type_name)(values);
}

/// `cloth` after check_idle (for bindings that read or change it).
inline const Cloth& idle(const Cloth& cloth) {
  check_idle(&cloth, "the Cloth");
  return cloth;
}
inline Cloth& idle(Cloth& cloth) {
  check_idle(&cloth, "the Cloth");
  return cloth;
}

/// A Python error taken out of the interpreter by an InterruptScope check, put back later.
class PendingPythonError {
 public:
  PendingPythonError() = default;
  ~PendingPythonError();
  PendingPythonError(const PendingPythonError&) = delete;
  PendingPythonError& operator=(const PendingPythonError&) = delete;
  /// Runs the interpreter's signal handlers (GIL held); true (error kept) if one raised.
  bool check_signals();
  /// Raises the kept error (KeyboardInterrupt if none) as py::error_already_set; GIL held.
  [[noreturn]] void raise();

 private:
  PyObject* m_type = nullptr;
  PyObject* m_value = nullptr;
  PyObject* m_traceback = nullptr;
};

/// Runs f() with the GIL released, answering Ctrl-C: about every 50 ms the core's interrupt
/// polls briefly take the GIL and run the signal handlers; when one raises (KeyboardInterrupt),
/// the core unwinds (integrators undo the interrupted advance() call) and the handler's
/// exception is raised here.
template <typename Function>
auto run_without_gil(Function&& function) {
  PendingPythonError pending;
  try {
    py::gil_scoped_release release;
    const InterruptScope scope([&pending] {
      py::gil_scoped_acquire acquire;
      return pending.check_signals();
    });
    return function();
  } catch (const Interrupted&) {
    pending.raise();
  }
}

/// Adds advance(cloth, gravity, dt, steps) and busy to an integrator class; the GIL is
/// released while advance runs, and the cloth and the integrator are marked busy meanwhile.
template <typename Integrator>
void def_advance(py::class_<Integrator>& integrator_class) {
  integrator_class.def(
      "advance",
      [](Integrator& integrator, Cloth& cloth, const py::handle& gravity, double dt,
         std::int64_t steps) {
        const Eigen::Vector3d g = to_vec3(gravity, "gravity");
        const BusyGuard cloth_busy(&cloth, "the Cloth", "an integrator's advance is running");
        const BusyGuard integrator_busy(&integrator, "the integrator", "its advance is running");
        run_without_gil([&] { integrator.advance(cloth, g, dt, steps); });
      },
      py::arg("cloth"), py::arg("gravity"), py::arg("dt"), py::arg("steps"),
      R"doc(Runs `steps` steps of dt seconds; raises SimulationDiverged (cloth restored) on blow-up.
Answers Ctrl-C: KeyboardInterrupt, the cloth back at its state before this call. Raises
RuntimeError if the cloth or the integrator is in use by another thread.)doc");
  integrator_class.def_property_readonly(
      "busy", [](const Integrator& integrator) { return is_busy(&integrator); },
      "Whether an advance call (possibly on another thread) is running on this integrator.");
}

/// Binds Integrator::history / set_history (and history_fields) on an integrator class: a
/// history is a dict of its named n×3 arrays plus "dt", or None.
template <class Integrator>
void def_history(py::class_<Integrator>& integrator_class) {
  integrator_class.def_property_readonly(
      "history_fields",
      [](const Integrator& integrator) {
        check_idle(&integrator, "the integrator");
        py::tuple names(integrator.history_fields().size());
        std::size_t k = 0;
        for (const std::string& name : integrator.history_fields()) names[k++] = name;
        return names;
      },
      "Names of the arrays the integrator's history holds (empty: it keeps none).");
  integrator_class.def(
      "history",
      [](const Integrator& integrator, const Cloth& cloth) -> py::object {
        check_idle(&integrator, "the integrator");
        idle(cloth);
        const IntegratorHistory history = integrator.history(cloth);
        if (!history.valid) return py::none();
        py::dict out;
        for (const auto& [name, values] : history.arrays) {
          out[name.c_str()] = read_only_copy(values);
        }
        out["dt"] = history.dt;
        if (history.next_dt > 0.0) out["next_dt"] = history.next_dt;
        return out;
      },
      py::arg("cloth"),
      R"doc(What the next step of `cloth` carries over besides the cloth's state: a dict of the
named n×3 arrays in `history_fields` (BDF2: positions, m, and velocities, m/s, one step back;
generalized-α: accelerations and force_accelerations, m/s²; TR-BDF2: accelerations, m/s²) and
dt (s, the last step's), and with BDF2's error control next_dt (s, the step proposed for the
next output interval); None when the next step starts afresh or the method keeps none.)doc");
  integrator_class.def(
      "set_history",
      [](Integrator& integrator, const Cloth& cloth, const py::object& history) {
        check_idle(&integrator, "the integrator");
        idle(cloth);
        IntegratorHistory restored;
        if (!history.is_none()) {
          if (!py::isinstance<py::dict>(history)) {
            throw std::invalid_argument("history must be a dict or None");
          }
          const py::dict values = history.cast<py::dict>();
          restored.valid = true;
          for (const std::string& name : integrator.history_fields()) {
            if (!values.contains(name)) {
              throw std::invalid_argument("history has no array '" + name + "'");
            }
            const std::string what = "history " + name;
            restored.arrays.emplace_back(name, to_rows3(values[name.c_str()], what.c_str()));
          }
          if (!values.contains("dt")) throw std::invalid_argument("history has no dt");
          restored.dt = values["dt"].cast<double>();
          if (values.contains("next_dt")) restored.next_dt = values["next_dt"].cast<double>();
        }
        integrator.set_history(cloth, restored);
      },
      py::arg("cloth"), py::arg("history"),
      "Restores a history taken by history() (None forgets it) for `cloth` as it is now; "
      "ValueError on missing arrays, wrong shapes or non-finite values.");
}

/// Adds the factor's size, flops and ordering (as every integrator's statistics report them).
/// An integrator's statistics as Python sees them (bound as yore._core.Statistics): the steps
/// taken, the wall time per phase (s) and the counters, each by one name. A phase is set with
/// phase(), a counter with count(); their dicts keep the order they were set in.
struct Statistics {
  std::int64_t steps = 0;
  py::dict phases;
  py::dict counters;
  void phase(const char* name, double seconds) { phases[name] = seconds; }
  template <typename T>
  void count(const char* name, T value) {
    counters[name] = value;
  }
};

/// The phases of an integrator built on a linear solver, in the order its statistics list
/// them: assemble, analyze, factorize, solve.
template <typename S>
void add_solver_phases(Statistics& out, const S& s) {
  out.phase("assemble_seconds", s.assemble_seconds);
  out.phase("analyze_seconds", s.analyze_seconds);
  out.phase("factorize_seconds", s.factorize_seconds);
  out.phase("solve_seconds", s.solve_seconds);
}

/// Binds Statistics (module.cpp, once).
void bind_statistics(py::module_& m);

inline void add_factor_statistics(py::dict& out, const SolverStatistics& solver) {
  out["factor_nonzeros"] = solver.factor_nonzeros;
  out["factor_flops"] = solver.factor_flops;
  out["supernode_median_columns"] = solver.supernode_median_columns;
  out["supernode_median_rows"] = solver.supernode_median_rows;
  out["ordering"] = solver.ordering;
  out["openmp_regions_inlined"] = solver.openmp_regions_inlined;
}

}  // namespace yore::bindings
