#include "bindings.hpp"
#include "convert.hpp"
#include "yore/local_global.hpp"

#include <pybind11/stl.h>

#include <stdexcept>
#include <string>

namespace yore::bindings {

void bind_local_global(py::module_& m) {
  py::class_<LocalGlobalIntegrator> integrator_class(
      m, "LocalGlobalIntegrator", "Prefactored local/global backward Euler (Liu et al. 2013).");
  def_advance(integrator_class);
  integrator_class
      .def(py::init([](std::int64_t iterations, double tolerance, double chebyshev_rho, const std::string& ordering,
                       const std::string& factorization, const std::string& rebuild,
                       std::int64_t stale_pcg_max_iterations, double stale_pcg_tol, bool record_objective,
                       double divergence_energy_factor) {
             LocalGlobalOptions options;
             options.iterations = to_int32(iterations, "iterations");
             options.tolerance = tolerance;
             options.chebyshev_rho = chebyshev_rho;
             options.ordering = parse_ordering(ordering);
             options.factor = parse_factor_kind(factorization);
             if (rebuild == "fresh") options.rebuild = RebuildStrategy::fresh;
             else if (rebuild == "reuse-ordering") options.rebuild = RebuildStrategy::reuse_ordering;
             else if (rebuild == "stale-pcg") options.rebuild = RebuildStrategy::stale_pcg;
             else throw std::invalid_argument("unknown rebuild '" + rebuild +
                                              "'; valid: fresh, reuse-ordering, stale-pcg");
             options.stale_pcg_max_iterations =
                 to_int32(stale_pcg_max_iterations, "stale_pcg_max_iterations");
             options.stale_pcg_tolerance = stale_pcg_tol;
             options.record_objective = record_objective;
             options.divergence_energy_factor = divergence_energy_factor;
             return std::make_unique<LocalGlobalIntegrator>(options);
           }),
           py::kw_only(), py::arg("iterations") = LocalGlobalOptions{}.iterations,
           py::arg("tolerance") = LocalGlobalOptions{}.tolerance, py::arg("chebyshev_rho") = 0.0,
           py::arg("ordering") = "amd", py::arg("factorization") = "supernodal",
           py::arg("rebuild") = "fresh", py::arg("stale_pcg_max_iterations") = 30,
           py::arg("stale_pcg_tol") = 1e-12, py::arg("record_objective") = false,
           py::arg("divergence_energy_factor") = 10.0)
      .def_property_readonly(
          "objective_history",
          [](const LocalGlobalIntegrator& integrator) {
            check_idle(&integrator, "the integrator");
            return read_only_copy(integrator.objective_history());
          },
          "The objective (J) after each iteration of the last step (record_objective only).")
      .def_property_readonly("statistics", [](const LocalGlobalIntegrator& integrator) {
        check_idle(&integrator, "the integrator");
        const LocalGlobalStatistics& s = integrator.statistics();
        const SolverStatistics& solver = integrator.solver_statistics();
        py::dict out;
        out["steps"] = s.steps;
        out["assemble_seconds"] = s.assemble_seconds;
        out["analyze_seconds"] = s.analyze_seconds;
        out["factorize_seconds"] = s.factorize_seconds;
        out["solve_seconds"] = s.solve_seconds;
        out["rebuild_seconds"] = s.rebuild_seconds;
        out["iterations"] = s.iterations;
        out["unconverged_steps"] = s.unconverged_steps;
        out["last_iterations"] = s.last_iterations;
        out["last_residual"] = s.last_residual;
        out["last_error_estimate"] = s.last_error_estimate;
        out["rebuilds"] = s.rebuilds;
        out["stale_solves"] = s.stale_solves;
        out["pcg_iterations"] = s.pcg_iterations;
        out["dofs"] = s.last_dofs;
        out["analyses"] = s.analyses;
        out["factorizations"] = s.factorizations;
        add_factor_statistics(out, solver);
        return out;
      });
}

}  // namespace yore::bindings
