#include "bindings.hpp"
#include "convert.hpp"
#include "yore/explicit.hpp"

namespace yore::bindings {

void bind_explicit(py::module_& m) {
  py::class_<ExplicitIntegrator> integrator_class(
      m, "ExplicitIntegrator", "Symplectic Euler with optional Provot strain limiting.");
  def_advance(integrator_class);
  integrator_class.def(py::init([](double strain_limit, std::int64_t strain_limit_passes,
                       double divergence_energy_factor) {
             ExplicitOptions options;
             options.strain_limit = strain_limit;
             options.strain_limit_passes = to_int32(strain_limit_passes, "strain_limit_passes");
             options.divergence_energy_factor = divergence_energy_factor;
             return ExplicitIntegrator(options);
           }),
           py::kw_only(), py::arg("strain_limit") = 0.0, py::arg("strain_limit_passes") = 4,
           py::arg("divergence_energy_factor") = 10.0)
      .def_property_readonly("statistics", [](const ExplicitIntegrator& integrator) {
        check_idle(&integrator, "the integrator");
        const ExplicitStatistics& s = integrator.statistics();
        py::dict out;
        out["steps"] = s.steps;
        out["forces_seconds"] = s.forces_seconds;
        out["update_seconds"] = s.update_seconds;
        out["constraints_seconds"] = s.constraints_seconds;
        out["checks_seconds"] = s.checks_seconds;
        out["strain_corrections"] = s.strain_corrections;
        return out;
      })
      .def_property_readonly(
          "thread_usage",
          [](const ExplicitIntegrator& integrator) {
            check_idle(&integrator, "the integrator");
            const ExplicitStatistics& s = integrator.statistics();
            py::dict out;
            out["last_step"] = s.last_step_threads;
            out["parallel_steps"] = s.parallel_steps;
            out["serial_steps"] = s.steps - s.parallel_steps;
            out["probes"] = s.thread_probes;
            return out;
          },
          "Threads the last step's loops ran on (0 before any step), steps run on more than one "
          "thread and on one, and blocks run to re-time the other choice.");
}

}  // namespace yore::bindings
