#include <limits>

#include "bindings.hpp"
#include "convert.hpp"
#include "options.hpp"
#include "yore/integrators/explicit.hpp"

namespace yore::bindings {

void bind_explicit(py::module_& m) {
  py::class_<ExplicitIntegrator> integrator_class(
      m, "ExplicitIntegrator", "Symplectic Euler with optional Provot strain limiting.");
  def_advance(integrator_class);
  def_history(integrator_class);
  static const OptionTable<ExplicitOptions> table = {
      // 0 = off here; Python's None (yore.options keeps that rule)
      in_range(plain_option("strain_limit", &ExplicitOptions::strain_limit), 0.0,
               std::numeric_limits<double>::infinity(), false),
      plain_option("strain_limit_passes", &ExplicitOptions::strain_limit_passes),
      plain_option("divergence_energy_factor", &ExplicitOptions::divergence_energy_factor),
      in_range(plain_option("energy_growth_tolerance", &ExplicitOptions::energy_growth_tolerance),
               0.0, 1e6, false),
  };
  integrator_class.attr("defaults") = option_values(table, ExplicitOptions{});
  bind_options_class(m, "ExplicitOptions", table);
  integrator_class.def_property_readonly(
      "options", [](const ExplicitIntegrator& integrator) { return integrator.options(); },
      "The options this integrator runs with (ExplicitOptions, read-only).");
  integrator_class.attr("option_rules") = option_rules(table);
  integrator_class
      .def(py::init([](const py::kwargs& kwargs) {
             return ExplicitIntegrator(options_from_kwargs(table, kwargs));
           }),
           "Keyword options as in `defaults` (strain_limit 0 = off).")
      .def_property_readonly("statistics",
                             [](const ExplicitIntegrator& integrator) {
                               check_idle(&integrator, "the integrator");
                               const ExplicitStatistics& s = integrator.statistics();
                               Statistics out;
                               out.steps = s.steps;
                               out.count("energy_gain", integrator.monitor().largest_gain());
                               out.phase("forces_seconds", s.forces_seconds);
                               out.phase("update_seconds", s.update_seconds);
                               out.phase("constraints_seconds", s.constraints_seconds);
                               out.phase("checks_seconds", s.checks_seconds);
                               out.count("strain_corrections", s.strain_corrections);
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
