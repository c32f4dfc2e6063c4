#include "bindings.hpp"
#include "convert.hpp"
#include "yore/linear_solver.hpp"

#include <pybind11/stl.h>

#include <stdexcept>
#include <string>

namespace yore::bindings {

void bind_linear_solver(py::module_& m) {
  m.def(
      "solve_spd",
      [](std::int64_t requested_size, const py::handle& indptr, const py::handle& indices,
         const py::handle& data, const py::handle& rhs, const std::string& solver,
         const std::string& ordering, const std::string& factorization) {
        LinearSolverOptions options;
        options.solver = solver;
        options.ordering = parse_ordering(ordering);
        options.factorization = parse_factor_kind(factorization);
        const std::int32_t size = to_int32(requested_size, "size");
        if (size < 0) throw std::invalid_argument("size must be >= 0, got " + std::to_string(size));
        SymmetricPattern pattern;
        pattern.size = size;
        pattern.column_starts = to_indices(indptr, "indptr");
        if (static_cast<std::int64_t>(pattern.column_starts.size()) != std::int64_t{size} + 1) {
          throw std::invalid_argument("indptr must have size + 1 = " + std::to_string(size + 1) +
                                      " entries, got " +
                                      std::to_string(pattern.column_starts.size()));
        }
        pattern.row_indices = to_indices(indices, "indices");
        const auto nonzeros = static_cast<std::int64_t>(pattern.row_indices.size());
        if (pattern.column_starts.front() != 0 || pattern.column_starts.back() != nonzeros) {
          throw std::invalid_argument("indptr must start at 0 and end at len(indices)");
        }
        for (std::int32_t c = 0; c < size; ++c) {
          if (pattern.column_starts[c + 1] < pattern.column_starts[c]) {
            throw std::invalid_argument("indptr must be non-decreasing");
          }
        }
        for (std::int32_t c = 0; c < size; ++c) {
          for (std::int32_t p = pattern.column_starts[c]; p < pattern.column_starts[c + 1]; ++p) {
            const std::int32_t r = pattern.row_indices[static_cast<std::size_t>(p)];
            const bool sorted = p == pattern.column_starts[c] ||
                                r > pattern.row_indices[static_cast<std::size_t>(p) - 1];
            if (r < c || r >= size || !sorted) {
              throw std::invalid_argument(
                  "indices must hold sorted rows of the lower triangle (row >= column)");
            }
          }
        }
        const Eigen::VectorXd values = to_vector(data, "data", nonzeros);
        const Eigen::VectorXd b = to_vector(rhs, "rhs", size);
        auto linear_solver = make_linear_solver(options);
        linear_solver->analyze(pattern);
        linear_solver->factorize(values.data());
        Eigen::VectorXd x(size);
        linear_solver->solve(b.data(), x.data());
        return read_only_copy(x);
      },
      py::arg("size"), py::arg("indptr"), py::arg("indices"), py::arg("data"), py::arg("rhs"),
      py::kw_only(), py::arg("solver") = "cholmod", py::arg("ordering") = "amd",
      py::arg("factorization") = "supernodal",
      R"doc(Solves H x = rhs for a symmetric H given by its lower triangle in CSC (sorted rows)
with one of the backends; raises NotPositiveDefinite when H is not positive definite.)doc");
}

}  // namespace yore::bindings
