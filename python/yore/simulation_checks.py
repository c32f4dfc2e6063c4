"""`yore.Simulation`'s constructor arguments, checked: the cloth and the integrator's name and
options, gravity, and what dt="auto" asks of the integrator (each bad argument is one
TypeError or ValueError naming it); and the default explicit time step."""

from __future__ import annotations

import math

import numpy as np

from ._core import Cloth
from .checks import MAX_STEPS
from .options import FIXED_DT, INTEGRATOR_OPTIONS, INTEGRATOR_SPECS, INTEGRATORS

__all__ = [
    "EXPLICIT_DT_SAFETY",
    "check_integrator_and_options",
    "checked_gravity",
    "checked_step_count",
    "default_explicit_dt",
    "output_interval",
    "steps_to",
]


def check_integrator_and_options(cloth, integrator, options) -> None:
    """A `yore.Cloth`, a known integrator, and only that integrator's options."""
    if not isinstance(cloth, Cloth):
        raise TypeError(f"cloth must be a yore.Cloth, got {type(cloth).__name__}")
    if not isinstance(integrator, str) or integrator not in INTEGRATORS:
        raise ValueError(f"unknown integrator {integrator!r}; valid: {', '.join(INTEGRATORS)}")
    valid = INTEGRATOR_OPTIONS[integrator]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ValueError(
            f"unknown option(s) {', '.join(map(repr, unknown))} for integrator "
            f"{integrator!r}; valid: {', '.join(sorted(valid)) or 'none'}"
        )


def checked_gravity(gravity) -> np.ndarray:
    """Gravity as 3 finite numbers (m/s²)."""
    gravity = np.asarray(gravity, dtype=np.float64)
    if gravity.shape != (3,) or not np.all(np.isfinite(gravity)):
        raise ValueError(f"gravity must be 3 finite numbers (m/s²), got {gravity!r}")
    return gravity


def output_interval(dt, integrator, options):
    """dt as given, or for dt="auto" the output interval `FIXED_DT`, when the integrator has
    error control (or an `adaptive` option) to choose the steps within it."""
    if not isinstance(dt, str):
        return dt
    if dt != "auto":
        raise ValueError(f"dt must be a number of seconds or 'auto', got {dt!r}")
    if not (INTEGRATOR_SPECS[integrator].error_controlled or "adaptive" in options):
        adaptive = [
            name
            for name, spec in INTEGRATOR_SPECS.items()
            if spec.error_controlled or "adaptive" in spec.options
        ]
        raise ValueError(
            f"dt='auto' chooses the steps by error control, which "
            f"integrator {integrator!r} does not have; use one of "
            f"{', '.join(adaptive)}"
        )
    return FIXED_DT


#: Safety factor of the default explicit time step on ``Cloth.stable_time_step_bound()`` (the
#: state-independent Lanczos bound, which holds whatever shape the cloth takes; 0.98 covers the
#: Lanczos iteration's approach from below). The tighter current-state estimate
#: ``Cloth.stable_time_step()`` is not safe as a default: a heavy grid hung from two corners
#: stretches until its limit is 0.84× that estimate at its start (benchmarks/stable_dt.py and
#: tests/test_threads.py), while the bound stayed below every limit found by trying.
EXPLICIT_DT_SAFETY = 0.98


def default_explicit_dt(cloth: Cloth, safety: float = EXPLICIT_DT_SAFETY) -> float:
    """The default explicit time step (s): ``safety`` × ``cloth.stable_time_step_bound()`` (the
    state-independent estimate), rounded down to 1/N s; 1/60 s when nothing elastic limits the
    step. ``cloth.stable_time_step()`` is the tight estimate at the current state, and
    ``cloth.gershgorin_time_step()`` the cheapest, most conservative one."""
    stable = cloth.stable_time_step_bound()
    if not math.isfinite(stable):
        return 1.0 / 60.0
    if not safety * stable >= 1e-300:
        raise ValueError(
            f"no explicit time step is stable for this cloth (the bound is "
            f"{stable:.3g} s): its stiffnesses or masses are out of range"
        )
    return 1.0 / math.ceil(1.0 / (safety * stable))


def checked_step_count(n) -> int:
    """`Simulation.step`'s n: a non-negative integer up to `MAX_STEPS`."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ValueError(f"n must be a non-negative integer, got {n!r}")
    if n > MAX_STEPS:
        raise ValueError(
            f"n: {n} steps in one call is more than the limit of {MAX_STEPS}; "
            "call step repeatedly for longer runs"
        )
    return int(n)


def steps_to(target, now, dt, error_controlled, seconds) -> int:
    """`Simulation.advance`'s whole steps of dt from ``now`` towards ``target`` (asked as
    ``seconds``): the nearest count, or with error control the whole output intervals before
    it (the caller takes one shortened interval to the target itself); at most `MAX_STEPS`."""
    ratio = (target - now) / dt
    if not ratio <= MAX_STEPS + 1:  # (1e308 s overflowed the step count: OverflowError)
        raise ValueError(
            f"advance: {seconds:g} s at dt = {dt:.6g} s is {ratio:.4g} "
            f"steps, more than the limit of {MAX_STEPS} per call"
        )
    if error_controlled:
        # dt is an output interval: whole intervals, then one to the target itself
        steps = max(0, int(np.floor(ratio * (1 + 1e-12))))
    else:
        steps = max(0, int(round(ratio)))
    if steps > MAX_STEPS:
        raise ValueError(
            f"advance: {seconds:g} s at dt = {dt:.6g} s is {steps} steps, "
            f"more than the limit of {MAX_STEPS} per call"
        )
    return steps
