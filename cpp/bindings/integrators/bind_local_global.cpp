#include <pybind11/stl.h>

#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "convert.hpp"
#include "options.hpp"
#include "yore/integrators/local_global.hpp"

namespace yore::bindings {
namespace {

/// The integrator's counters and phases as a Statistics.
Statistics local_global_statistics(const LocalGlobalIntegrator& integrator) {
  check_idle(&integrator, "the integrator");
  const LocalGlobalStatistics& s = integrator.statistics();
  const SolverStatistics& solver = integrator.solver_statistics();
  Statistics out;
  out.steps = s.steps;
  out.count("energy_gain", integrator.monitor().largest_gain());
  add_solver_phases(out, s);
  out.phase("rebuild_seconds", s.rebuild_seconds);
  out.count("iterations", s.iterations);
  out.count("unconverged_steps", s.unconverged_steps);
  out.count("energy_retries", s.energy_retries);
  out.count("last_iterations", s.last_iterations);
  out.count("last_residual", s.last_residual);
  out.count("last_error_estimate", s.last_error_estimate);
  out.count("rebuilds", s.rebuilds);
  out.count("stale_solves", s.stale_solves);
  out.count("pcg_iterations", s.pcg_iterations);
  out.count("dofs", s.last_dofs);
  out.count("analyses", s.analyses);
  out.count("factorizations", s.factorizations);
  add_factor_statistics(out.counters, solver);
  return out;
}

}  // namespace

void bind_local_global(py::module_& m) {
  py::class_<LocalGlobalIntegrator> integrator_class(
      m, "LocalGlobalIntegrator", "Prefactored local/global backward Euler (Liu et al. 2013).");
  def_advance(integrator_class);
  def_history(integrator_class);
  using O = LocalGlobalOptions;
  static const OptionTable<O> table = {
      plain_option("iterations", &O::iterations),
      in_range(plain_option("tolerance", &O::tolerance), 0.0, 1.0, false, true),
      in_range(plain_option("chebyshev_rho", &O::chebyshev_rho), 0.0, 1.0, false, true),
      choice_option<O, Ordering>(
          "ordering", [](O& o) -> Ordering& { return o.ordering; }, ordering_choices()),
      choice_option<O, FactorKind>(
          "factorization", [](O& o) -> FactorKind& { return o.factorization; },
          factor_kind_choices()),
      choice_option<O, RebuildStrategy>("rebuild",
                                        [](O& o) -> RebuildStrategy& { return o.rebuild; },
                                        {{"fresh", RebuildStrategy::fresh},
                                         {"reuse-ordering", RebuildStrategy::reuse_ordering},
                                         {"stale-pcg", RebuildStrategy::stale_pcg}}),
      plain_option("stale_pcg_max_iterations", &O::stale_pcg_max_iterations),
      in_range(plain_option("stale_pcg_tol", &O::stale_pcg_tol), 0.0, 1.0, true, true),
      plain_option("record_objective", &O::record_objective),
      plain_option("divergence_energy_factor", &O::divergence_energy_factor),
      in_range(plain_option("energy_growth_tolerance", &O::energy_growth_tolerance), 0.0, 1e6,
               false),
  };
  integrator_class.attr("defaults") = option_values(table, O{});
  bind_options_class(m, "LocalGlobalOptions", table);
  integrator_class.def_property_readonly(
      "options", [](const LocalGlobalIntegrator& integrator) { return integrator.options(); },
      "The options this integrator runs with (LocalGlobalOptions, read-only).");
  integrator_class.attr("option_rules") = option_rules(table);
  integrator_class
      .def(py::init([](const py::kwargs& kwargs) {
             return std::make_unique<LocalGlobalIntegrator>(options_from_kwargs(table, kwargs));
           }),
           "Keyword options as in `defaults` (chebyshev_rho 0 = no acceleration).")
      .def_property_readonly(
          "objective_history",
          [](const LocalGlobalIntegrator& integrator) {
            check_idle(&integrator, "the integrator");
            return read_only_copy(integrator.objective_history());
          },
          "The objective (J) after each iteration of the last step (record_objective only).")
      .def_property_readonly("statistics", &local_global_statistics);
}

}  // namespace yore::bindings
