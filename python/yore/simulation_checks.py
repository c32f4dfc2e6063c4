"""`yore.Simulation`'s constructor arguments, checked: the cloth and the integrator's name and
options, gravity, and what dt="auto" asks of the integrator. Each bad argument is one
TypeError or ValueError naming it."""

from __future__ import annotations

import numpy as np

from ._core import Cloth
from .options import FIXED_DT, INTEGRATOR_OPTIONS, INTEGRATOR_SPECS, INTEGRATORS

__all__ = ["check_integrator_and_options", "checked_gravity", "output_interval"]


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
