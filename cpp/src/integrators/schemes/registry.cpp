/// @file registry.cpp
/// The time schemes of the implicit integrator, one row each (time_scheme.hpp says how to add
/// one). Option tables list them in this order; each file under schemes/ defines its factory.

#include <stdexcept>

#include "yore/integrators/implicit_options.hpp"
#include "yore/integrators/time_scheme.hpp"

namespace yore {

std::unique_ptr<TimeScheme> make_backward_euler(const ImplicitOptions& options);
std::unique_ptr<TimeScheme> make_bdf2(const ImplicitOptions& options);
std::unique_ptr<TimeScheme> make_generalized_alpha(const ImplicitOptions& options);
std::unique_ptr<TimeScheme> make_tr_bdf2(const ImplicitOptions& options);
std::unique_ptr<TimeScheme> make_implicit_midpoint(const ImplicitOptions& options);

const std::vector<TimeSchemeRow>& time_schemes() {
  static const std::vector<TimeSchemeRow> rows = {
      {ImplicitMethod::backward_euler, "backward-euler", "implicit", make_backward_euler},
      {ImplicitMethod::bdf2, "bdf2", "bdf2", make_bdf2},
      {ImplicitMethod::generalized_alpha, "generalized-alpha", "generalized-alpha",
       make_generalized_alpha},
      {ImplicitMethod::tr_bdf2, "tr-bdf2", "tr-bdf2", make_tr_bdf2},
      {ImplicitMethod::implicit_midpoint, "implicit-midpoint", "implicit-midpoint",
       make_implicit_midpoint},
  };
  return rows;
}

const TimeSchemeRow& time_scheme(ImplicitMethod method) {
  for (const TimeSchemeRow& row : time_schemes()) {
    if (row.method == method) return row;
  }
  throw std::invalid_argument("unknown implicit method");
}

}  // namespace yore
