"""yore — cloth simulation with stroke-driven partial area expansion.

A mass-spring cloth (Shi & Saito, "Partially Area Expansion by Mesh Subdivision to Make Wrinkled
Cloth") with an explicit reference integrator; see README.md and the documentation in docs/.
"""

from __future__ import annotations

import os as _os

# First, before the heavy imports: a sweep worker ignores Ctrl-C, and the `yore` command's
# Ctrl-C while it starts is one line (yore.runtime).
from .runtime import guard_command_start as _guard_command_start
from .runtime import ignore_interrupts_in_sweep_workers as _ignore_interrupts_in_sweep_workers

_ignore_interrupts_in_sweep_workers()
_guard_command_start()

# Next, before anything loads the core (and with it CHOLMOD's BLAS, which picks its kernels as it
# loads): the BLAS kernels this CPU runs, unless the user chose (yore.blas).
from . import blas as _blas  # noqa: E402
from .runtime import is_command as _is_command  # noqa: E402

_blas.prepare(in_command=_is_command())
from . import _core as _loaded_core  # noqa: E402,F401  (the load the choice is for)

_blas.finish(in_command=_is_command())

from . import metrics, scenes, springs, stroke, subdivision  # noqa: E402  (after the guard)
from ._core import ArgumentError, Cloth, NotPositiveDefinite, SimulationDiverged
from .io import load_mesh, save_mesh
from .meshes import cylinder_mesh, grid_mesh, pattern_mesh
from .simulation import INTEGRATORS, Simulation
from .state import load_state, save_state
from .runs import RunError, SceneError, load_scene, resume_run, run_scene
from . import camera, checks, runs, viz
from .camera import Camera
from .stroke import RefinementTooLarge, StrokeMissed, StrokeOptions, StrokePath, StrokeReport
from . import _core as _threads_core

# OpenBLAS's threads (CHOLMOD's factorization) wait for each other like OpenMP's, and no step
# re-times them: one thread unless the user asked (docs/integrators.md, "Threads": on a busy
# machine two made a linearized implicit step 3× slower). set_num_threads(n) sets n here too.
if not any(
    name in _os.environ for name in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")
):
    _threads_core.set_blas_threads(1)
from .runtime import clamp_threads_to_the_address_space as _clamp_threads  # noqa: E402

_clamp_threads()

from .runtime import VERSION as __version__, build_info, set_num_threads  # noqa: E402,F401

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
]


def __getattr__(name):
    # yore.sweep (Dask, xarray) loads on first use: `import yore` stays light
    if name == "sweep":
        import importlib

        return importlib.import_module(".sweep", __name__)
    raise AttributeError(f"module 'yore' has no attribute {name!r}")
