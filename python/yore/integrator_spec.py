"""The registry's row type, `IntegratorSpec` (`yore.options.INTEGRATOR_SPECS` holds one per
integrator), and the factories of the core integrators whose options need no resolving
(explicit, local-global, the SUNDIALS ones); Newton's factories resolve theirs and live
with the registry in `yore.options`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from . import _core
from .core_tables import CORE_ERROR_CONTROLLED, CORE_LOCAL_GLOBAL

__all__ = ["IntegratorSpec", "make_explicit", "make_local_global", "error_controlled_factory"]


@dataclass(frozen=True)
class IntegratorSpec:
    """Everything the Python side knows of one integrator; `INTEGRATOR_SPECS` holds them.

    name: the public name (``yore.Simulation(integrator=name)``, scene and state files).
    summary: one line for help texts. options: its options table (name → default, None where
    `resolve_options` decides). make: its core integrator from its options as given (the
    factory resolves them). conditionally_stable: dt defaults to the explicit stable-step bound
    and follows the cloth through strokes, and a diverged run's advice is that bound; otherwise
    dt defaults to `FIXED_DT`. newton: Newton's integrator, whose options `resolve_options`
    decides and whose projection memory a state file keeps. history: the fields (n×3 arrays)
    of the history a state file keeps besides its dt, given the options; () when none.
    cap: the options that name its iteration cap and its tolerance (the warning for steps
    that reach the cap quotes them). error_controlled: SUNDIALS chooses the internal steps by
    a tolerance; dt is the output interval, and since SUNDIALS' memory cannot be saved, a
    resumed state restarts the integrator at the saved time (the state says so).
    """

    name: str
    summary: str
    options: dict
    make: Callable[[dict], object]
    conditionally_stable: bool = False
    newton: bool = False
    history: Callable[[dict], tuple] = lambda options: ()
    cap: tuple = ("max_newton", "newton_tol")
    error_controlled: bool = False


def make_explicit(options):
    limit = options["strain_limit"]
    return _core.ExplicitIntegrator(
        strain_limit=0.0 if limit is None else float(limit),
        strain_limit_passes=int(options["strain_limit_passes"]),
        divergence_energy_factor=float(options["divergence_energy_factor"]),
        energy_growth_tolerance=float(options["energy_growth_tolerance"]),
    )


def make_local_global(options):
    core = {name: options[name] for name in CORE_LOCAL_GLOBAL}
    if options["acceleration"] == "none":
        core["chebyshev_rho"] = 0.0
    return _core.LocalGlobalIntegrator(**core)


def error_controlled_factory(method):
    def make(options):
        core = {name: options[name] for name in CORE_ERROR_CONTROLLED if name in options}
        if core.get("atol_velocity") is None:
            core["atol_velocity"] = 0.0  # the core's "same as atol"
        return _core.ErrorControlledIntegrator(method=method, **core)

    return make
