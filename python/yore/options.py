"""yore.options: the one registry of the options that cross a boundary — between Python and the
C++ core, and between scene files, state files, `yore.Simulation`, the viewer and the command
line, which all read their names, defaults and checks from here.

- Integrators: `INTEGRATOR_SPECS`, one `IntegratorSpec` per integrator (its core class and how
  to make it, its options table, its dt policy, the fields of its history in a state file), and
  the views of it `INTEGRATORS` (the names) and `INTEGRATOR_OPTIONS` (integrator → {option:
  default}). No other module names an integrator (tests/test_architecture.py checks): adding
  one is a C++ file, its binding and one row here. Names and defaults come
  from the C++ option structs (``_core.*Integrator.defaults``, a table in the bindings); written
  here are only the options that exist on the Python side alone and the defaults that differ by
  integrator. A default of None means "decided from the other options": the core decides
  (C++ ``resolve_choices``, its choices ``std::optional``), `resolve_options` asks it, and
  `defaults` gives an integrator's defaults so resolved.
  `check_option` checks a value (type and range, with an error naming the option); the C++
  constructors check again.
- Strokes: `STROKE_DEFAULTS` (the paper's expansion and mass scale come from the C++
  ``SplitOptions`` struct, bound as ``_core.split_defaults``).
- Pictures and the scene: `GRAVITY`, `IMAGE_WIDTH`, `IMAGE_HEIGHT`, `FOV_DEGREES`.

Written apart and read here: the C++ option tables (`yore.core_tables`), the modes some options
serve (`yore.option_modes`), and the stroke, scene and picture defaults (`yore.defaults`).
"""

from __future__ import annotations

from . import _core, rules
from .core_tables import (  # noqa: F401  (re-exported: the registry reads from them)
    ACCELERATIONS,
    ADAPTIVE_ONLY,
    CORE_CHOSEN_BY_NAME,
    CORE_ERROR_CONTROLLED,
    CORE_EXPLICIT,
    CORE_IMPLICIT,
    CORE_LOCAL_GLOBAL,
    CORE_RULES,
    MAX_SOLVER_ITERATIONS,
    MAX_STEP_ITERATIONS,
    NEWTON_ONLY,
)
from .defaults import (  # noqa: F401  (re-exported: one place to read every default from)
    ANIMATION_FORMATS,
    FOV_DEGREES,
    FOV_RULE,
    FRAMES_PER_SECOND,
    GRAVITY,
    GROWTH_MODES,
    IMAGE_HEIGHT,
    IMAGE_WIDTH,
    MASS,
    MAX_SMOOTHING_ITERATIONS,
    POISSON_RATIO,
    RENDER_ANIMATION,
    RUN_ANIMATION,
    SCENE_MATERIAL,
    SMOOTHING_DEFAULTS,
    SMOOTHING_RULES,
    STIFFNESS,
    STROKE_DEFAULTS,
)
from .integrator_spec import (  # noqa: F401  (IntegratorSpec re-exported with the registry)
    IntegratorSpec,
    error_controlled_factory,
    make_explicit,
    make_local_global,
)
from .option_modes import MODE_ONLY, Mode  # noqa: F401  (re-exported with check_modes)
from .rules import Invalid, show

__all__ = [
    "INTEGRATORS",
    "INTEGRATOR_OPTIONS",
    "INTEGRATOR_SPECS",
    "IntegratorSpec",
    "DEFAULT_INTEGRATOR",
    "REFERENCE_INTEGRATOR",
    "FIXED_DT",
    "OptionError",
    "check_option",
    "option_expected",
    "MODE_ONLY",
    "InactiveOptionError",
    "check_modes",
    "options_in_force",
    "resolve_options",
    "defaults",
    "STROKE_DEFAULTS",
    "GROWTH_MODES",
    "GRAVITY",
    "SCENE_MATERIAL",
    "IMAGE_WIDTH",
    "IMAGE_HEIGHT",
    "FOV_DEGREES",
    "FOV_RULE",
    "MAX_STEP_ITERATIONS",
    "MAX_SOLVER_ITERATIONS",
    "MAX_SMOOTHING_ITERATIONS",
    "SMOOTHING_DEFAULTS",
    "SMOOTHING_RULES",
]


#: Each integrator's options (name → default, None where `Simulation` resolves it from the
#: others); `check_option` checks a value. Names and defaults come from the C++ option structs
#: (`yore.core_tables`); written here are only the options that exist on the Python side alone
#: (None = decide from the others, ``acceleration``) and the defaults that differ by integrator.
INTEGRATOR_OPTIONS = {
    # strain_limit: Provot strain limiting, largest length / rest length of a structural spring
    # (e.g. 1.1); None turns it off (the core's 0). divergence_energy_factor: the divergence
    # bound in multiples of the cloth's energy scale (see ExplicitIntegrator).
    # energy_growth_tolerance (every integrator): the largest rise of the energy above the lowest
    # it reached since the last change, in energy scales (DivergenceMonitor); 0 = off.
    "explicit": {**CORE_EXPLICIT, "strain_limit": None},
    "implicit": {
        # linearized: one Newton step, no line search (Baraff & Witkin 1998). Newton stops when
        # the residual max |∇ᵢE|·h̃²/mᵢ (the gradient as a displacement) is at most newton_tol ×
        # the mean rest length; a step that reaches max_newton is counted in stats
        # (unconverged_steps) and warned about. solver: "cholmod" | "eigen-ldlt" | "pcg";
        # ordering: "auto" | "amd" | "metis" | "nesdis" | "natural"; factorization:
        # "supernodal" | "simplicial"; supernode_relaxation: CHOLMOD's amalgamation, scaled.
        # lagged_factorization: keep the factor across Newton iterations and steps, CG
        # preconditioned by it on the current matrix (steihaug: the exact Hessian), refactor
        # when CG needs more than lag_max_cg_iterations (and, after the k-th such failure in
        # a row, for the next min(2^(k-1), 32) iterations). truncation_fraction: Newton also
        # stops once its estimated distance to the solution is at most this fraction of the
        # step's estimated truncation error (0 = off; ImplicitOptions says how both are
        # estimated).
        **{
            name: value
            for name, value in CORE_IMPLICIT.items()
            if name not in CORE_CHOSEN_BY_NAME + ADAPTIVE_ONLY
        },
        # mixed: Newton's matrices take the springs' forces from the step's linearization (the
        # mixed formulation, Trusty et al. 2022). None: on with the clamp (it saves ~40 % of
        # its iterations on stiff sheets), off with the other projections (measured mixed with
        # steihaug, far worse with its lagged factors; docs/integrators.md).
        "mixed": None,
        # Try the exact Hessian first, fall back to the PSD projection when the factorization
        # finds it indefinite. None: on for the Cholesky backends, off for pcg (which cannot
        # tell). False: always project (linear convergence when many springs are compressed).
        "adaptive_projection": None,
        # How compressed springs' Hessians are made PSD: "clamp" | "abs" | "exact" (exact Hessian,
        # the clamp where the factorization finds it indefinite, decision kept across iterations
        # and steps) | "trust-region" (Chen et al. 2024: abs after a poor model fit, else clamp)
        # | "shifted" (Levenberg–Marquardt: exact Hessian + μ M/h², μ raised when indefinite or
        # on a poor model fit, lowered on a good one, carried across steps) | "steihaug"
        # (trust-region Newton–CG: CG on the exact Hessian preconditioned by the clamped one's
        # factor; no factorization thrown away). None: adaptive_projection decides if given,
        # else "clamp".
        "projection": None,
        # Where Newton starts: "start" (xₙ) | "inertial" (xₙ + h vₙ) | "extrapolated" (the
        # inertial guess plus h̃² times the latest acceleration the method holds; exact in free
        # fall, more iterations on hanging sheets). None: "start" for linearized
        # (Baraff–Witkin's step), "inertial" otherwise.
        "predictor": None,
    },
}
# With dt="auto" (and only then) the steps of bdf2 and tr-bdf2 are chosen by their local error
# estimates (BDF2: variable-step BDF2's, from the divided difference of the velocities;
# TR-BDF2: its embedded pair): a step is accepted when its estimate is at most atol (m) +
# rtol × the largest |x| of a free vertex; dt becomes the output interval; more than max_steps
# steps in one interval is SimulationDiverged. `adaptive` is what dt="auto" sets (state files
# keep it).
_ADAPTIVE_OPTIONS = {name: CORE_IMPLICIT[name] for name in ADAPTIVE_ONLY}
INTEGRATOR_OPTIONS["bdf2"] = {**INTEGRATOR_OPTIONS["implicit"], **_ADAPTIVE_OPTIONS}
INTEGRATOR_OPTIONS["generalized-alpha"] = {
    **INTEGRATOR_OPTIONS["implicit"],
    # ρ∞, the spectral radius of a step at infinite frequency: 1 keeps every frequency (the
    # trapezoidal rule), 0 removes the highest in one step; low frequencies keep their energy
    # to third order in ωh whatever ρ∞ (Chung & Hulbert 1993).
    "rho_infinity": CORE_IMPLICIT["rho_infinity"],
    # Newton's truncation test at a tenth of the default's fraction: ρ∞ > 0 keeps the stiff
    # modes' oscillation in the step's error estimate, so the default's 0.1 stops Newton too
    # early (at ρ∞ 0.5 the stiff 32² sheet, 2e5 N/m at 1/32 s, gained energy without bound; at
    # ρ∞ 0.2 its kinetic-energy history is 22 % off with 0.1 against 9.5 % with 0.01).
    "truncation_fraction": 0.01,
}
INTEGRATOR_OPTIONS["tr-bdf2"] = {
    **INTEGRATOR_OPTIONS["implicit"],
    **_ADAPTIVE_OPTIONS,
    # A tighter truncation test than implicit's, as generalized-α's: the trapezoidal stage keeps
    # the stiff modes' oscillation (|R(∞)| = 1), which inflates both stages' error estimates, so
    # Newton stopped at 0.1 of them leaves residual forces that feed the oscillation that loosens
    # the next stop. On the 64² sheet at 2e6 N/m and 1/64 s (scene damping and drag) it gained
    # energy without bound at 0.1 (+1.9e5 J by 2 s), none at 0.03 or 0.01 (docs/integrators.md).
    # benchmarks/truncation_fraction.py: at 1/64 s 0.03 is as accurate as 0.01 for about half
    # the cost; at 1/32 s 0.60–0.71 of it, up to 0.8 points further off; a step whose energy
    # rises past the growth check is redone to the residual test (energy_retries).
    "truncation_fraction": 0.03,
}
INTEGRATOR_OPTIONS["implicit-midpoint"] = {
    **INTEGRATOR_OPTIONS["implicit"],
    # generalized-α's tighter truncation test: the midpoint rule damps nothing (|R| = 1 on the
    # imaginary axis), so the stiff modes' oscillation stays in its error estimate, as in
    # TR-BDF2's trapezoidal stage, and Newton stopped at 0.1 of it would feed that oscillation.
    "truncation_fraction": 0.01,
}
INTEGRATOR_OPTIONS["local-global"] = {
    # Iterations of a step stop once the estimated distance to the step's solution is at most
    # tolerance × the mean rest length (0: no test, always `iterations`), or at the cap
    # `iterations` (counted in unconverged_steps). chebyshev_rho: the spectral-radius estimate
    # of Chebyshev acceleration (LocalGlobalOptions says how it was measured). rebuild, after
    # a stroke: "fresh" analysis + factorization, "reuse-ordering" (cholmod_analyze_p with the
    # old ordering extended) or "stale-pcg" (CG preconditioned by the stale factor until it
    # needs more than stale_pcg_max_iterations, then reuse-ordering). record_objective: keep
    # the objective after every iteration (diagnostics).
    **CORE_LOCAL_GLOBAL,
    "acceleration": "chebyshev",  # "none" | "chebyshev" (Wang 2015); "none" passes rho 0
}
INTEGRATOR_OPTIONS["quasi-newton"] = {
    # The potential minimised: backward Euler's or BDF2's, as "implicit" and "bdf2" do.
    "method": "backward-euler",  # "backward-euler" | "bdf2"
    # lbfgs_history: L-BFGS correction pairs kept within a step (the initial Hessian is the
    # constant local-global matrix, factored once per topology, step size and material);
    # Newton's residual test (newton_tol) and cap (max_newton), predictor, ordering,
    # factorization, divergence bound.
    **{
        name: value
        for name, value in CORE_IMPLICIT.items()
        if name not in NEWTON_ONLY + ADAPTIVE_ONLY + ("minimizer", "method", "rho_infinity")
    },
    # Quasi-Newton iterations are cheap (one scalar solve with three right-hand sides) but
    # many: its cap is twenty times Newton's.
    "max_newton": 1000,
    "predictor": "inertial",  # "start" | "inertial" | "extrapolated", as for Newton
    # Q is factored once and solved every iteration: the simplicial factor solves faster
    # (0.41 against 0.63 ms per iteration at 64², one thread, three right-hand sides).
    "factorization": "simplicial",
}
# The error-controlled integrators (SUNDIALS): a tolerance in, steps out. dt is their output
# interval (frames and advance() land on its multiples); inside one, SUNDIALS takes the internal
# steps its local error test asks for. rtol: relative tolerance; atol: absolute tolerance of the
# positions (m) and, unless atol_velocity (m/s) is given, of the velocities (the same number);
# SUNDIALS weighs component i's error by 1/(rtol |yᵢ| + atolᵢ) in a root-mean-square norm.
# max_dt: largest internal step (0: no limit); max_steps: internal steps allowed in one output
# interval before the run stops with SimulationDiverged. cvode: max_order, the highest BDF
# order (1..5); arkode: order, the stiffly accurate ESDIRK table's (2: TR-BDF2, 3, 4).
_ERROR_CONTROLLED_COMMON = {
    name: value
    for name, value in CORE_ERROR_CONTROLLED.items()
    if name not in ("method", "max_order", "order")
}
_ERROR_CONTROLLED_COMMON["atol_velocity"] = None  # None: the same number as atol
INTEGRATOR_OPTIONS["cvode"] = {
    **_ERROR_CONTROLLED_COMMON,
    "max_order": CORE_ERROR_CONTROLLED["max_order"],
}
INTEGRATOR_OPTIONS["arkode"] = {**_ERROR_CONTROLLED_COMMON, "order": CORE_ERROR_CONTROLLED["order"]}
#: The quasi-Newton potentials (`INTEGRATOR_OPTIONS["quasi-newton"]["method"]`): the one-step
#: ones whose iteration matrix is the scalar local-global matrix.
QUASI_NEWTON_METHODS = ("backward-euler", "bdf2")


class OptionError(ValueError):
    """An integrator option of the wrong type or out of range: ``option`` its name, ``got`` a
    description of the value, ``expected`` what would be accepted."""

    def __init__(self, option, got, expected):
        self.option, self.got, self.expected = option, got, expected
        super().__init__(f"option {option}: got {got}; expected {expected}")


def show_value(value):
    """A value as option errors quote it (`yore.rules.show`)."""
    return show(value)


#: How each option is checked (one rule per name, whichever integrator takes it), built from the
#: C++ option tables' rules (`CORE_RULES`); the defaults are in `INTEGRATOR_OPTIONS`.
#: `check_option` applies them; the C++ constructors check again.
_RULES = {name: rules.from_core(spec) for name, spec in CORE_RULES.items()}
# The Python side's own: None for "decide from the others", and strain_limit's None for off
# (the core's 0), so a limit is at least 1.
_RULES.update(
    strain_limit=rules.real(1.0, low_open=False).or_none(),
    adaptive_projection=_RULES["adaptive_projection"].or_none(),
    projection=_RULES["projection"].or_none(),
    predictor=_RULES["predictor"].or_none(),
    mixed=_RULES["mixed"].or_none(),
    atol_velocity=rules.real(0.0).or_none(),
    acceleration=rules.choice(*ACCELERATIONS),
    method=rules.choice(*QUASI_NEWTON_METHODS),
)
assert all(set(table) <= set(_RULES) for table in INTEGRATOR_OPTIONS.values())


def check_option(integrator, name, value):
    """``value`` of option ``name`` of ``integrator`` as stored (int, float, bool, str or None);
    ValueError naming the option, the value and what is expected (an unknown name lists the
    valid ones). Types are checked, not coerced: ``linearized="no"``, ``max_newton=2.9`` and
    ``lag_cg_tol=inf`` are errors."""
    valid = INTEGRATOR_OPTIONS[integrator]
    if name not in valid:
        raise ValueError(
            f"unknown option {name!r} for integrator {integrator!r}; valid: "
            f"{', '.join(sorted(valid)) or 'none'}"
        )
    try:
        return _RULES[name](value)
    except Invalid as error:
        raise OptionError(name, show(value), error.expected) from None


def option_expected(name) -> str:
    """What option ``name`` accepts, in words (for error messages elsewhere)."""
    return _RULES[name].expected


class InactiveOptionError(OptionError):
    """An option given for a mode its integrator is not in, which would be ignored: ``option``
    its name, ``needs`` how to select the mode it acts in, ``off`` the mode in use."""

    def __init__(self, option, mode, value):
        ValueError.__init__(
            self,
            f"{option} acts only with {mode.needs}; {mode.off(value)} it "
            f"would be ignored: drop it or {mode.remedy}",
        )
        self.needs, self.off = mode.needs, mode.off(value)
        self.option, self.got, self.expected = (
            option,
            f"given {self.off}",
            f"no {option}, or {mode.needs}",
        )


def check_modes(integrator, given, options) -> None:
    """InactiveOptionError for the first option named in ``given`` (the options a user passed,
    not the defaults) that acts only in a mode ``options`` (all of ``integrator``'s, as they
    will run, ``adaptive`` set by dt="auto") does not select (`MODE_ONLY`)."""
    table = INTEGRATOR_OPTIONS[integrator]
    for name in given:
        mode = MODE_ONLY.get(name)
        if mode is not None and mode.setting in table and not mode.on(options[mode.setting]):
            raise InactiveOptionError(name, mode, options[mode.setting])


def options_in_force(integrator, given, dt=None) -> dict:
    """The options a simulation of ``integrator`` with time step ``dt`` (seconds, "auto" or
    None) runs with when ``given`` (name → checked value) are the user's: the defaults filled
    in, and dt="auto" selecting error control (``adaptive``) as `yore.Simulation` does; None
    left where the integrator decides (`resolve_options` decides)."""
    options = {**INTEGRATOR_OPTIONS[integrator], **given}
    if isinstance(dt, str) and dt == "auto" and "adaptive" in options:
        options["adaptive"] = True
    return options


def resolve_options(integrator, options) -> dict:
    """``options`` (all of ``integrator``'s, checked) with every None that stands for "decide from
    the others" decided — by the core (``_core.ImplicitIntegrator.resolve_choices``, the one
    place that decides: C++'s ``resolve_choices``, its choices ``std::optional``). ValueError
    where two options contradict."""
    options = dict(options)
    spec = INTEGRATOR_SPECS[integrator]
    if not spec.newton and "predictor" not in options:
        return options
    given = {name: value for name, value in options.items() if name in CORE_IMPLICIT}
    if not spec.newton:
        given["minimizer"] = "lbfgs"  # quasi-Newton: the predictor alone is decided
    decided = _core.ImplicitIntegrator.resolve_choices(given)
    if spec.newton:
        options.update(decided)
    elif options["predictor"] is None:
        options["predictor"] = decided["predictor"]
    return options


def defaults(integrator) -> dict:
    """``integrator``'s options at their defaults, as `yore.Simulation` runs them (None
    resolved; ``adaptive_projection`` stays None: it only maps into ``projection``)."""
    if integrator not in INTEGRATOR_OPTIONS:
        raise ValueError(f"unknown integrator {integrator!r}; valid: {', '.join(INTEGRATORS)}")
    return resolve_options(integrator, INTEGRATOR_OPTIONS[integrator])


# -- the integrators' registry -----------------------------------------------------------------
#: Default time step of the integrators that are not conditionally stable, s.
FIXED_DT = 1.0 / 60.0
#: The integrator a scene, a scene file and `yore.scenes` use unless told (the paper's), and the
#: one the run loader steps a probe with: it needs no factorization and no options.
DEFAULT_INTEGRATOR = REFERENCE_INTEGRATOR = "explicit"


def _newton_factory(integrator, method):
    def make(options):
        options = resolve_options(integrator, options)
        core = {name: options[name] for name in CORE_IMPLICIT if name in options}
        core.update(method=method, adaptive_projection=False)  # mapped into projection
        return _core.ImplicitIntegrator(**core)

    return make


def _make_quasi_newton(options):
    options = resolve_options("quasi-newton", options)  # predictor None: the inertial guess
    core = {name: options[name] for name in CORE_IMPLICIT if name in options}
    return _core.ImplicitIntegrator(minimizer="lbfgs", **core)


_BDF2_HISTORY = ("positions", "velocities")


def _newton_spec(name, method, summary, history=()):
    return IntegratorSpec(
        name,
        summary,
        INTEGRATOR_OPTIONS[name],
        _newton_factory(name, method),
        newton=True,
        history=lambda options: history,
    )


#: The integrators, in the order help texts list them.
INTEGRATOR_SPECS = {
    spec.name: spec
    for spec in (
        IntegratorSpec(
            "explicit",
            "symplectic Euler, the reference (stable below the explicit limit)",
            INTEGRATOR_OPTIONS["explicit"],
            make_explicit,
            conditionally_stable=True,
        ),
        _newton_spec(
            "implicit",
            "backward-euler",
            "backward Euler by Newton on a sparse Cholesky "
            "factorization (first order, damps the motion)",
        ),
        _newton_spec(
            "bdf2", "bdf2", "BDF2 on the same machinery (second order, damps less)", _BDF2_HISTORY
        ),
        _newton_spec(
            "generalized-alpha",
            "generalized-alpha",
            "generalized-α (Chung & Hulbert "
            "1993; second order, high frequencies damped as rho_infinity says)",
            ("accelerations", "force_accelerations"),
        ),
        _newton_spec(
            "tr-bdf2",
            "tr-bdf2",
            "TR-BDF2 (Bank et al. 1985; second order, L-stable, "
            "two Newton solves a step, an embedded error estimate)",
            ("accelerations",),
        ),
        _newton_spec(
            "implicit-midpoint",
            "implicit-midpoint",
            "the implicit midpoint rule (second order, symplectic, no numerical "
            "damping: energy-conserving on linear springs)",
            ("accelerations",),
        ),
        IntegratorSpec(
            "local-global",
            "prefactored local/global backward Euler (Liu et al. 2013)",
            INTEGRATOR_OPTIONS["local-global"],
            make_local_global,
            cap=("iterations", "tolerance"),
        ),
        IntegratorSpec(
            "quasi-newton",
            "L-BFGS on the backward-Euler or BDF2 potential (Liu, Bouaziz & Kavan 2017)",
            INTEGRATOR_OPTIONS["quasi-newton"],
            _make_quasi_newton,
            history=lambda options: _BDF2_HISTORY if options.get("method") == "bdf2" else (),
        ),
        IntegratorSpec(
            "cvode",
            "CVODE's variable-order BDF with error control (SUNDIALS; rtol/atol "
            "in, internal steps out; dt is the output interval)",
            INTEGRATOR_OPTIONS["cvode"],
            error_controlled_factory("cvode"),
            cap=("max_steps", "rtol"),
            error_controlled=True,
        ),
        IntegratorSpec(
            "arkode",
            "ARKODE's stiffly accurate ESDIRK with error control (SUNDIALS; "
            "order 2-4; dt is the output interval)",
            INTEGRATOR_OPTIONS["arkode"],
            error_controlled_factory("arkode"),
            cap=("max_steps", "rtol"),
            error_controlled=True,
        ),
    )
}
#: Integrator names of the public API.
INTEGRATORS = tuple(INTEGRATOR_SPECS)
assert set(INTEGRATORS) == set(INTEGRATOR_OPTIONS)
# the core names the integrators it implements (its messages use the same table)
assert set(INTEGRATORS) == set(_core.integrator_names()), "the registry and the core disagree"
