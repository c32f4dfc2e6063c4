#pragma once
// Conversions between numpy arrays and the core's Eigen types, with checks that name the
// offending argument, shape or value (std::invalid_argument → ValueError in Python).

#include "yore/cloth.hpp"
#include "yore/linear_solver.hpp"
#include "yore/mesh.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <vector>

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
Faces to_faces(const py::handle& object);

/// s×2 int32 vertex pairs.
Edges to_edges(const py::handle& object);

/// 1-D float64 vector; size == -1 accepts any size.
Eigen::VectorXd to_vector(const py::handle& object, const char* name, Eigen::Index size = -1);

/// A 3-vector from a length-3 sequence.
Eigen::Vector3d to_vec3(const py::handle& object, const char* name);

/// 1-D list of vertex indices (any integer dtype); range is checked by the core.
std::vector<std::int32_t> to_indices(const py::handle& object, const char* name);

/// A read-only numpy copy (the core's storage may move when the topology changes).
template <typename Matrix>
py::array read_only_copy(const Matrix& matrix) {
  using Scalar = typename Matrix::Scalar;
  py::array_t<Scalar> out;
  if constexpr (Matrix::ColsAtCompileTime == 1) {
    out = py::array_t<Scalar>(static_cast<py::ssize_t>(matrix.size()));
  } else {
    out = py::array_t<Scalar>({static_cast<py::ssize_t>(matrix.rows()),
                               static_cast<py::ssize_t>(matrix.cols())});
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

/// Adds advance(cloth, gravity, dt, steps) to an integrator class; the GIL is released while
/// it runs (the cloth must not be touched from another Python thread meanwhile).
template <typename Integrator>
void def_advance(py::class_<Integrator>& integrator_class) {
  integrator_class.def(
      "advance",
      [](Integrator& integrator, Cloth& cloth, const py::handle& gravity, double dt,
         std::int64_t steps) {
        const Eigen::Vector3d g = to_vec3(gravity, "gravity");
        py::gil_scoped_release release;
        integrator.advance(cloth, g, dt, steps);
      },
      py::arg("cloth"), py::arg("gravity"), py::arg("dt"), py::arg("steps"),
      "Runs `steps` steps of dt seconds; raises SimulationDiverged (cloth restored) on blow-up.");
}

/// Adds the factor's size, flops and ordering (as every integrator's statistics report them).
inline void add_factor_statistics(py::dict& out, const SolverStatistics& solver) {
  out["factor_nonzeros"] = solver.factor_nonzeros;
  out["factor_flops"] = solver.factor_flops;
  out["ordering"] = solver.ordering;
}

}  // namespace yore::bindings
