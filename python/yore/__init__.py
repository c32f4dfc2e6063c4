"""yore — cloth simulation with stroke-driven partial area expansion.

A mass-spring cloth (Shi & Saito, "Partially Area Expansion by Mesh Subdivision to Make Wrinkled
Cloth") with an explicit reference integrator; see README.md and the documentation in docs/.

Importing yore changes nothing in the process: no signal handler, no thread count, no
environment variable. Its names load on first use (the C++ core through `yore._core`, after
the BLAS kernels are chosen). The `yore` command sets its own Ctrl-C handling and thread
defaults; a program sets threads with `set_num_threads` or `use_thread_defaults`. (The one
exception is the command's own import of this package: its script's or ``python -m yore``'s,
which makes a Ctrl-C one line from here on, `yore._start_guard`.)
"""

from __future__ import annotations

from . import _start_guard

if _start_guard.is_command_import():
    _start_guard.guard()

import importlib as _importlib  # noqa: E402

from .runtime import VERSION as __version__  # noqa: E402,F401  (the package's version)

#: Where each public name lives: {name: module}, loaded on first use.
_WHERE = {
    "ArgumentError": "._core",
    "Cloth": "._core",
    "NotPositiveDefinite": "._core",
    "SimulationDiverged": "._core",
    "load_mesh": ".io",
    "save_mesh": ".io",
    "cylinder_mesh": ".meshes",
    "grid_mesh": ".meshes",
    "pattern_mesh": ".meshes",
    "INTEGRATORS": ".simulation",
    "Simulation": ".simulation",
    "load_state": ".state",
    "save_state": ".state",
    "RunError": ".runs",
    "SceneError": ".runs",
    "load_scene": ".runs",
    "resume_run": ".runs",
    "run_scene": ".runs",
    "Camera": ".camera",
    "RefinementTooLarge": ".stroke",
    "StrokeMissed": ".stroke",
    "StrokeOptions": ".stroke",
    "StrokePath": ".stroke",
    "StrokeReport": ".stroke",
    "build_info": ".runtime",
    "set_num_threads": ".runtime",
    "use_thread_defaults": ".runtime",
}

#: The public submodules (any submodule is imported on first use; ``yore.sweep`` brings Dask
#: and xarray).
_SUBMODULES = (
    "blas",
    "camera",
    "checks",
    "metrics",
    "runs",
    "scenes",
    "springs",
    "stroke",
    "subdivision",
    "sweep",
    "viz",
)

__all__ = [
    "Cloth",
    "Simulation",
    "SimulationDiverged",
    "NotPositiveDefinite",
    "ArgumentError",
    "RefinementTooLarge",
    "StrokeMissed",
    "StrokeOptions",
    "StrokePath",
    "StrokeReport",
    "Camera",
    "metrics",
    "INTEGRATORS",
    "grid_mesh",
    "cylinder_mesh",
    "pattern_mesh",
    "load_mesh",
    "save_mesh",
    "scenes",
    "save_state",
    "load_scene",
    "SceneError",
    "run_scene",
    "resume_run",
    "RunError",
    "viz",
    "camera",
    "checks",
    "runs",
    "load_state",
    "springs",
    "stroke",
    "subdivision",
    "build_info",
    "set_num_threads",
    "use_thread_defaults",
]


def __getattr__(name):
    if name in _WHERE:
        value = getattr(_importlib.import_module(_WHERE[name], __name__), name)
    elif not name.startswith("__"):  # a submodule (yore.io, yore._core, ...)
        try:
            value = _importlib.import_module(f".{name}", __name__)
        except ModuleNotFoundError as error:
            if error.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module 'yore' has no attribute {name!r}") from None
    else:
        raise AttributeError(f"module 'yore' has no attribute {name!r}")
    globals()[name] = value  # the next lookup is an ordinary attribute
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__) | set(_SUBMODULES))
