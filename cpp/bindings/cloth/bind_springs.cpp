#include <sstream>
#include <stdexcept>

#include "bindings.hpp"
#include "convert.hpp"
#include "yore/cloth/springs.hpp"

namespace yore::bindings {
namespace {

struct SpringBatch {
  Positions first, second;
  Eigen::VectorXd rest_length, stiffness;
};

SpringBatch to_batch(const py::handle& xi, const py::handle& xj, const py::handle& rest,
                     const py::handle& stiffness) {
  SpringBatch batch;
  batch.first = to_rows3(xi, "xi");
  batch.second = to_rows3(xj, "xj", batch.first.rows());
  batch.rest_length = to_vector(rest, "rest_length", batch.first.rows());
  batch.stiffness = to_vector(stiffness, "stiffness", batch.first.rows());
  return batch;
}

// The spring primitives over a batch of springs (one row each), for tests and tools.
py::array spring_energies(const py::handle& xi, const py::handle& xj, const py::handle& rest,
                          const py::handle& stiffness) {
  const SpringBatch b = to_batch(xi, xj, rest, stiffness);
  Eigen::VectorXd out(b.first.rows());
  for (Eigen::Index s = 0; s < out.size(); ++s) {
    out[s] = spring_energy(b.first.row(s), b.second.row(s), b.rest_length[s], b.stiffness[s]);
  }
  return read_only_copy(out);
}

py::array spring_gradients(const py::handle& xi, const py::handle& xj, const py::handle& rest,
                           const py::handle& stiffness) {
  const SpringBatch b = to_batch(xi, xj, rest, stiffness);
  Positions out(b.first.rows(), 3);
  for (Eigen::Index s = 0; s < out.rows(); ++s) {
    out.row(s) = spring_gradient(b.first.row(s), b.second.row(s), b.rest_length[s], b.stiffness[s]);
  }
  return read_only_copy(out);
}

py::array spring_hessians(const py::handle& xi, const py::handle& xj, const py::handle& rest,
                          const py::handle& stiffness, bool project_psd) {
  const SpringBatch b = to_batch(xi, xj, rest, stiffness);
  py::array_t<double> out({b.first.rows(), Eigen::Index(3), Eigen::Index(3)});
  double* data = out.mutable_data();
  for (Eigen::Index s = 0; s < b.first.rows(); ++s) {
    const Mat3 block = spring_hessian(b.first.row(s), b.second.row(s), b.rest_length[s],
                                      b.stiffness[s], project_psd);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) data[9 * s + 3 * r + c] = block(r, c);
  }
  return out;
}

py::array spring_damping_forces(const py::handle& xi, const py::handle& xj, const py::handle& vi,
                                const py::handle& vj, const py::handle& damping) {
  const Positions first = to_rows3(xi, "xi");
  const Positions second = to_rows3(xj, "xj", first.rows());
  const Positions first_velocity = to_rows3(vi, "vi", first.rows());
  const Positions second_velocity = to_rows3(vj, "vj", first.rows());
  const Eigen::VectorXd c = to_vector(damping, "damping", first.rows());
  Positions out(first.rows(), 3);
  for (Eigen::Index s = 0; s < out.rows(); ++s) {
    out.row(s) = spring_damping_force(first.row(s), second.row(s), first_velocity.row(s),
                                      second_velocity.row(s), c[s]);
  }
  return read_only_copy(out);
}

}  // namespace

void bind_springs(py::module_& m) {
  m.def("spring_energy", &spring_energies, py::arg("xi"), py::arg("xj"), py::arg("rest_length"),
        py::arg("stiffness"));
  m.def("spring_gradient", &spring_gradients, py::arg("xi"), py::arg("xj"), py::arg("rest_length"),
        py::arg("stiffness"));
  m.def("spring_hessian", &spring_hessians, py::arg("xi"), py::arg("xj"), py::arg("rest_length"),
        py::arg("stiffness"), py::arg("project_psd"));
  m.def("spring_damping_force", &spring_damping_forces, py::arg("xi"), py::arg("xj"), py::arg("vi"),
        py::arg("vj"), py::arg("damping"));
}

}  // namespace yore::bindings
