"""The C++ core's option tables as Python reads them (`yore.options`, the integrators'
registry, builds each integrator's options from them): each integrator class's options with
their defaults (``_core.*Integrator.defaults``), the rules of every core option
(``_core.*Integrator.option_rules``), and the groups of options one mode serves."""

from __future__ import annotations

from . import _core

#: The C++ option structs' names and defaults, per integrator class.
CORE_EXPLICIT = dict(_core.ExplicitIntegrator.defaults)
CORE_IMPLICIT = dict(_core.ImplicitIntegrator.defaults)
CORE_LOCAL_GLOBAL = dict(_core.LocalGlobalIntegrator.defaults)
CORE_ERROR_CONTROLLED = dict(_core.ErrorControlledIntegrator.defaults)
#: Core options no integrator takes as such: the method and minimizer are the integrator's
#: name, rho_infinity is generalized-α's alone.
CORE_CHOSEN_BY_NAME = ("method", "minimizer", "lbfgs_history", "rho_infinity")
#: Error control of bdf2 and tr-bdf2 (dt="auto"): adaptive is set by dt="auto", the rest are its own.
ADAPTIVE_ONLY = ("adaptive", "rtol", "atol", "max_steps")
#: Options of Newton's method that quasi-Newton does not take.
NEWTON_ONLY = (
    "linearized",
    "step_tol",
    "truncation_fraction",
    "mixed",
    "adaptive_projection",
    "projection",
    "lagged_factorization",
    "lag_max_cg_iterations",
    "lag_cg_tol",
    "solver",
    "pcg_tol",
    "pcg_max_iterations",
)

ACCELERATIONS = ("none", "chebyshev")
#: What values each core option takes, by name, from the C++ option tables
#: (``_core.*Integrator.option_rules``: kind "flag", "count", "real" or "choice", bounds and
#: choices); an option several integrators take has one rule.
CORE_RULES = {}
for _integrator in (
    _core.ExplicitIntegrator,
    _core.ImplicitIntegrator,
    _core.LocalGlobalIntegrator,
    _core.ErrorControlledIntegrator,
):
    for _name, _spec in _integrator.option_rules.items():
        CORE_RULES.setdefault(_name, dict(_spec))

#: Largest iteration counts an option may ask for (the core's). One step runs its iterations
#: inside the C++ core, out of reach of Ctrl-C, so a typo such as ``iterations = 10**9`` must be
#: refused rather than run for days.
MAX_STEP_ITERATIONS = int(CORE_RULES["max_newton"]["high"])  # newton, CG, passes per step
MAX_SOLVER_ITERATIONS = int(CORE_RULES["pcg_max_iterations"]["high"])  # per linear solve
