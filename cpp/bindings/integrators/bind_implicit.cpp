#include <pybind11/stl.h>

#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "convert.hpp"
#include "options.hpp"
#include "yore/integrators/implicit.hpp"

namespace yore::bindings {
namespace {

py::array csc_array(const std::vector<std::int32_t>& values) { return read_only_copy(values); }

// The `method` option's choices: the time schemes' registry (time_scheme.hpp).
std::vector<std::pair<std::string, ImplicitMethod>> scheme_choices() {
  std::vector<std::pair<std::string, ImplicitMethod>> choices;
  for (const TimeSchemeRow& row : time_schemes()) choices.emplace_back(row.name, row.method);
  return choices;
}

// The option table (names, defaults, rules) of ImplicitOptions; the method's choices are the
// time schemes' registry.
const OptionTable<ImplicitOptions>& implicit_table() {
  using O = ImplicitOptions;
  static const OptionTable<O> table = {
      choice_option<O, ImplicitMethod>(
          "method", [](O& o) -> ImplicitMethod& { return o.method; }, scheme_choices()),
      choice_option<O, ImplicitMinimizer>(
          "minimizer", [](O& o) -> ImplicitMinimizer& { return o.minimizer; },
          {{"newton", ImplicitMinimizer::newton}, {"lbfgs", ImplicitMinimizer::lbfgs}}),
      in_range(plain_option("lbfgs_history", &O::lbfgs_history), 1.0, kMaxLbfgsHistory),
      plain_option("linearized", &O::linearized),
      plain_option("adaptive_projection", &O::adaptive_projection),
      choice_option<O, HessianProjection>("projection",
                                          [](O& o) -> HessianProjection& { return o.projection; },
                                          {{"clamp", HessianProjection::clamp},
                                           {"abs", HessianProjection::abs},
                                           {"exact", HessianProjection::exact},
                                           {"trust-region", HessianProjection::trust_region},
                                           {"shifted", HessianProjection::shifted},
                                           {"steihaug", HessianProjection::steihaug}}),
      choice_option<O, NewtonPredictor>("predictor",
                                        [](O& o) -> NewtonPredictor& { return o.predictor; },
                                        {{"start", NewtonPredictor::start},
                                         {"inertial", NewtonPredictor::inertial},
                                         {"extrapolated", NewtonPredictor::extrapolated}}),
      plain_option("lagged_factorization", &O::lagged_factorization),
      plain_option("lag_max_cg_iterations", &O::lag_max_cg_iterations),
      in_range(plain_option("lag_cg_tol", &O::lag_cg_tol), 0.0, 1.0, true, true),
      plain_option("newton_tol", &O::newton_tol),
      in_range(plain_option("step_tol", &O::step_tol), 0.0, 1.0, false, true),
      in_range(plain_option("truncation_fraction", &O::truncation_fraction), 0.0, 1.0, false,
               false),
      plain_option("mixed", &O::mixed),
      plain_option("max_newton", &O::max_newton),
      in_range(plain_option("rho_infinity", &O::rho_infinity), 0.0, 1.0, false, false),
      plain_option("adaptive", &O::adaptive),
      in_range(plain_option("rtol", &O::rtol), kMinRelativeTolerance, 1.0, false, true),
      plain_option("atol", &O::atol),
      in_range(plain_option("max_steps", &O::max_steps), 1.0, 10'000'000.0),
      one_of(plain_option("solver", &O::linear_solver, &LinearSolverOptions::solver),
             {"cholmod", "eigen-ldlt", "pcg"}),
      choice_option<O, Ordering>(
          "ordering", [](O& o) -> Ordering& { return o.linear_solver.ordering; },
          ordering_choices()),
      choice_option<O, FactorKind>(
          "factorization", [](O& o) -> FactorKind& { return o.linear_solver.factorization; },
          factor_kind_choices()),
      in_range(plain_option("supernode_relaxation", &O::linear_solver,
                            &LinearSolverOptions::supernode_relaxation),
               0.0, 16.0, false, false),
      in_range(plain_option("pcg_tol", &O::linear_solver, &LinearSolverOptions::pcg_tol), 0.0, 1.0,
               true, true),
      in_range(plain_option("pcg_max_iterations", &O::linear_solver,
                            &LinearSolverOptions::pcg_max_iterations),
               1.0, kMaxSolverIterations),
      plain_option("divergence_energy_factor", &O::divergence_energy_factor),
      in_range(plain_option("energy_growth_tolerance", &O::energy_growth_tolerance), 0.0, 1e6,
               false),
  };
  return table;
}

// Simulation's resolve_choices: the choices `given` leaves open, decided as yore runs them.
py::dict resolve_choices_dict(const py::dict& given) {
  // None (or absent) leaves a choice open; the rest are options as the constructor takes
  static const char* const kChoices[] = {"adaptive_projection", "projection", "predictor", "mixed"};
  py::kwargs rest;
  for (const auto& [key, value] : given) {
    if (!value.is_none()) rest[key] = value;
  }
  const ImplicitOptions options = options_from_kwargs(implicit_table(), rest);
  ImplicitChoices choices;
  const auto is_given = [&](const char* name) { return rest.contains(name); };
  if (is_given(kChoices[0])) choices.adaptive_projection = options.adaptive_projection;
  if (is_given(kChoices[1])) choices.projection = options.projection;
  if (is_given(kChoices[2])) choices.predictor = options.predictor;
  if (is_given(kChoices[3])) choices.mixed = options.mixed;
  const py::dict all = option_values(implicit_table(), resolve_choices(options, choices));
  py::dict out;
  for (const char* name : {"projection", "predictor", "mixed"}) out[name] = all[name];
  return out;
}

// ImplicitIntegrator.newton_system: the incremental potential at `positions`, as a
// yore.results.NewtonSystem.
py::object newton_system_result(ImplicitIntegrator& integrator, const Cloth& cloth,
                                const py::handle& gravity, double dt, const py::handle& positions,
                                const std::string& projection) {
  check_idle(&integrator, "the integrator");
  idle(cloth);
  if (projection != "clamp" && projection != "abs" && projection != "exact") {
    throw std::invalid_argument("projection must be \"clamp\", \"abs\" or \"exact\", got \"" +
                                projection + "\"");
  }
  const HessianProjection chosen = projection == "exact" ? HessianProjection::exact
                                   : projection == "abs" ? HessianProjection::abs
                                                         : HessianProjection::clamp;
  const NewtonSystem system =
      integrator.newton_system(cloth, to_vec3(gravity, "gravity"), dt,
                               to_rows3(positions, "positions", cloth.vertex_count()), chosen);
  py::dict out;
  out["energy"] = system.energy;
  out["gradient"] = read_only_copy(system.gradient);
  out["hessian_data"] = read_only_copy(system.hessian);
  out["hessian_indices"] = csc_array(system.pattern.row_indices);
  out["hessian_indptr"] = csc_array(system.pattern.column_starts);
  out["size"] = system.pattern.size;
  out["direction"] = read_only_copy(system.direction);
  out["free_vertices"] = read_only_copy(system.free_vertices);
  return typed_result("NewtonSystem", out);
}

// The integrator's counters and phases, and its solver's.
Statistics implicit_statistics(const ImplicitIntegrator& integrator) {
  check_idle(&integrator, "the integrator");
  const ImplicitStatistics& s = integrator.statistics();
  const SolverStatistics& solver = integrator.solver_statistics();
  Statistics out;
  out.steps = s.steps;
  out.count("energy_gain", integrator.monitor().largest_gain());
  add_solver_phases(out, s);
  out.count("newton_iterations", s.newton_iterations);
  out.count("line_search_backtracks", s.line_search_backtracks);
  out.count("unconverged_steps", s.unconverged_steps);
  out.count("exact_hessian_rejected", s.exact_hessian_rejected);
  out.count("exact_hessian_accepted", s.exact_hessian_accepted);
  // every indefinite matrix caught (exact and shifted projections) was a factorization
  // thrown away; a lagged solve reused a factor of an earlier matrix
  out.count("factorizations_thrown_away", s.exact_hessian_rejected);
  out.count("factor_reuses", s.lagged_solves);
  out.count("step_test_stops", s.step_test_stops);
  out.count("truncation_stops", s.truncation_stops);
  out.count("abs_projections", s.abs_projections);
  out.count("shifted_factorizations", s.shifted_factorizations);
  out.count("last_scaled_residual", s.last_scaled_residual);
  out.count("last_truncation_error", s.last_truncation_error);
  out.count("lagged_solves", s.lagged_solves);
  out.count("lagged_cg_iterations", s.lagged_cg_iterations);
  out.count("lagged_failures", s.lagged_failures);
  out.count("lbfgs_skipped_updates", s.lbfgs_skipped_updates);
  out.count("trust_region_cg_iterations", s.trust_region_cg_iterations);
  out.count("trust_region_rejections", s.trust_region_rejections);
  out.count("negative_curvature_steps", s.negative_curvature_steps);
  out.count("stages", s.stages);
  out.count("trapezoid_newton_iterations", s.trapezoid_newton_iterations);
  out.count("extrapolated_stages", s.extrapolated_stages);
  out.count("history_restarts", s.history_restarts);
  out.count("energy_retries", s.energy_retries);
  out.count("rejected_steps", s.rejected_steps);
  out.count("intervals", s.intervals);
  out.count("last_newton_iterations", s.last_newton_iterations);
  out.count("last_line_search_backtracks", s.last_line_search_backtracks);
  out.count("last_residual", s.last_residual);
  out.count("dofs", s.last_dofs);
  out.count("analyses", solver.analyses);
  out.count("factorizations", solver.factorizations);
  out.count("solves", solver.solves);
  add_factor_statistics(out.counters, solver);
  out.count("pcg_iterations", solver.iterations);
  out.count("pcg_unconverged", solver.unconverged);
  return out;
}

/// projection_memory() and set_projection_memory(): what a state file keeps of Newton's
/// projections.
void def_projection_memory(py::class_<ImplicitIntegrator>& integrator_class) {
  integrator_class
      .def(
          "projection_memory",
          [](const ImplicitIntegrator& integrator) {
            check_idle(&integrator, "the integrator");
            const ImplicitIntegrator::ProjectionMemory memory = integrator.projection_memory();
            py::dict out;
            out["exact_skip"] = memory.exact_skip;
            out["exact_backoff"] = memory.exact_backoff;
            out["shift"] = memory.shift;
            out["radius"] = memory.radius;
            return out;
          },
          "The projections' memory across steps: a dict with exact_skip (steps still to "
          "take projected), exact_backoff (the next wait after a rejection), shift (the "
          "shifted projection's μ, in units of M/h̃²) and radius (the steihaug projection's "
          "trust radius, √J; 0: none yet).")
      .def(
          "set_projection_memory",
          [](ImplicitIntegrator& integrator, std::int64_t exact_skip, std::int64_t exact_backoff,
             double shift, double radius) {
            check_idle(&integrator, "the integrator");
            integrator.set_projection_memory({to_int32(exact_skip, "exact_skip"),
                                              to_int32(exact_backoff, "exact_backoff"), shift,
                                              radius});
          },
          py::arg("exact_skip"), py::arg("exact_backoff"), py::arg("shift") = 0.0,
          py::arg("radius") = 0.0,
          "Restores a memory taken by projection_memory(); ValueError out of range.");
}

}  // namespace

void bind_implicit(py::module_& m) {
  m.def("integrator_names", &integrator_names,
        "The public names of the integrators this core implements (yore.options checks its "
        "registry against them).");
  py::class_<ImplicitIntegrator> integrator_class(
      m, "ImplicitIntegrator",
      "The implicit time schemes (backward Euler, BDF2, generalized-α, TR-BDF2, implicit "
      "midpoint) by Newton's method on a sparse solver.");
  def_advance(integrator_class);
  def_history(integrator_class);
  const OptionTable<ImplicitOptions>& table = implicit_table();
  integrator_class.attr("defaults") = option_values(table, ImplicitOptions{});
  bind_options_class(m, "ImplicitOptions", table);
  integrator_class.def_property_readonly(
      "options", [](const ImplicitIntegrator& integrator) { return integrator.options(); },
      "The options this integrator runs with (ImplicitOptions, read-only).");
  integrator_class.attr("option_rules") = option_rules(table);
  integrator_class.def_static(
      "resolve_choices", &resolve_choices_dict, py::arg("options"),
      "The choices `options` leaves open (None or absent: adaptive_projection, projection, "
      "predictor, mixed) decided from the others, as yore runs them: {projection, predictor, "
      "mixed}. ValueError when adaptive_projection and projection disagree.");
  integrator_class
      .def(py::init([](const py::kwargs& kwargs) {
             return std::make_unique<ImplicitIntegrator>(
                 options_from_kwargs(implicit_table(), kwargs));
           }),
           "Keyword options as in `defaults`.")
      .def("newton_system", &newton_system_result, py::arg("cloth"), py::arg("gravity"),
           py::arg("dt"), py::arg("positions"), py::arg("projection") = "clamp",
           R"doc(The backward-Euler incremental potential of the next step from the cloth's state,
at `positions` (n×3; only free vertices are unknowns), as a yore.results.NewtonSystem: energy
(J), gradient (N), the Hessian's
lower triangle in CSC (hessian_data, hessian_indices, hessian_indptr, size) and the solver's
Newton direction. projection: "clamp" (default) or "abs" filter the compressed springs' and
faces' negative terms; "exact" keeps them and raises NotPositiveDefinite when the solver
rejects the matrix.)doc")
      .def_property_readonly("statistics", &implicit_statistics);
  def_projection_memory(integrator_class);
}

}  // namespace yore::bindings
