#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "options.hpp"
#include "yore/integrators/error_controlled.hpp"

namespace yore::bindings {

namespace {

// The option table (names, defaults, rules) of ErrorControlledOptions.
const OptionTable<ErrorControlledOptions>& error_controlled_table() {
  using O = ErrorControlledOptions;
  static const OptionTable<O> table = {
      choice_option<O, ErrorControlledMethod>(
          "method", [](O& o) -> ErrorControlledMethod& { return o.method; },
          {{integrator_name::kCvode, ErrorControlledMethod::cvode},
           {integrator_name::kArkode, ErrorControlledMethod::arkode}}),
      in_range(plain_option("rtol", &O::rtol), kMinRelativeTolerance, 1.0, false, true),
      plain_option("atol", &O::atol),
      in_range(plain_option("atol_velocity", &O::atol_velocity), 0.0,
               std::numeric_limits<double>::infinity(), false, false),
      in_range(plain_option("max_order", &O::max_order), 1.0, 5.0),
      in_range(plain_option("order", &O::order), 2.0, 4.0),
      in_range(plain_option("max_dt", &O::max_dt), 0.0, std::numeric_limits<double>::infinity(),
               false, false),
      in_range(plain_option("max_steps", &O::max_steps), 1.0, 10'000'000.0),
      in_range(plain_option("max_nonlinear_iterations", &O::max_nonlinear_iterations), 1.0, 100.0),
      choice_option<O, Ordering>(
          "ordering", [](O& o) -> Ordering& { return o.linear_solver.ordering; },
          ordering_choices()),
      choice_option<O, FactorKind>(
          "factorization", [](O& o) -> FactorKind& { return o.linear_solver.factorization; },
          factor_kind_choices()),
      in_range(plain_option("supernode_relaxation", &O::linear_solver,
                            &LinearSolverOptions::supernode_relaxation),
               0.0, 16.0, false, false),
      plain_option("divergence_energy_factor", &O::divergence_energy_factor),
      in_range(plain_option("energy_growth_tolerance", &O::energy_growth_tolerance), 0.0, 1e6,
               false),
  };
  return table;
}

// The integrator's counters and phases, and its solver's and assembly's.
Statistics error_controlled_statistics(const ErrorControlledIntegrator& integrator) {
  check_idle(&integrator, "the integrator");
  const ErrorControlledStatistics& s = integrator.statistics();
  const SolverStatistics& solver = integrator.solver_statistics();
  const ImplicitStatistics& inner = integrator.assembly_statistics();
  Statistics out;
  out.steps = s.steps;
  out.count("energy_gain", integrator.monitor().largest_gain());
  out.phase("rhs_seconds", s.rhs_seconds);
  out.phase("setup_seconds", s.setup_seconds);
  out.phase("solve_seconds", s.solve_seconds);
  out.phase("assemble_seconds", inner.assemble_seconds);
  out.phase("analyze_seconds", inner.analyze_seconds);
  out.phase("factorize_seconds", inner.factorize_seconds);
  out.count("internal_steps", s.internal_steps);
  out.count("error_test_failures", s.error_test_failures);
  out.count("nonlinear_iterations", s.nonlinear_iterations);
  out.count("nonlinear_failures", s.nonlinear_failures);
  out.count("linear_setups", s.linear_setups);
  out.count("linear_solves", s.linear_solves);
  out.count("rhs_evaluations", s.rhs_evaluations);
  out.count("jacobian_evaluations", s.jacobian_evaluations);
  out.count("restarts", s.restarts);
  out.count("current_order", s.current_order);
  out.count("current_internal_dt", s.current_internal_dt);
  out.count("last_internal_dt", s.last_internal_dt);
  out.count("analyses", solver.analyses);
  out.count("factorizations", solver.factorizations);
  out.count("solves", solver.solves);
  add_factor_statistics(out.counters, solver);
  return out;
}

}  // namespace

void bind_error_controlled(py::module_& m) {
  py::class_<ErrorControlledIntegrator> integrator_class(
      m, "ErrorControlledIntegrator",
      "CVODE (BDF) or ARKODE (ESDIRK) on y = (x, v) with error control, their Newton systems "
      "solved on yore's CHOLMOD factor, refactored only when SUNDIALS asks.");
  def_advance(integrator_class);
  def_history(integrator_class);
  const OptionTable<ErrorControlledOptions>& table = error_controlled_table();
  integrator_class.attr("defaults") = option_values(table, ErrorControlledOptions{});
  bind_options_class(m, "ErrorControlledOptions", table);
  integrator_class.def_property_readonly(
      "options", [](const ErrorControlledIntegrator& integrator) { return integrator.options(); },
      "The options this integrator runs with (ErrorControlledOptions, read-only).");
  integrator_class.attr("option_rules") = option_rules(table);
  integrator_class
      .def(py::init([](const py::kwargs& kwargs) {
             return std::make_unique<ErrorControlledIntegrator>(
                 options_from_kwargs(error_controlled_table(), kwargs));
           }),
           "Keyword options as in `defaults`.")
      .def(
          "request_restart",
          [](ErrorControlledIntegrator& integrator) {
            check_idle(&integrator, "the integrator");
            integrator.request_restart();
          },
          "The next interval starts SUNDIALS afresh at the cloth's state, as a resumed run does.")
      .def_property_readonly("statistics", &error_controlled_statistics);
}

}  // namespace yore::bindings
