"""yore — cloth simulation with stroke-driven partial area expansion.

A mass-spring cloth (Shi & Saito, "Partially Area Expansion by Mesh Subdivision to Make Wrinkled
Cloth") with an explicit reference integrator; see README.md for the whole picture.
"""

from __future__ import annotations

import numbers
import os as _os
import signal as _signal
import sys as _sys
import threading as _threading


def _interrupted_while_starting(number, frame):  # pragma: no cover - exits the process
    print("yore: interrupted", file=_sys.stderr, flush=True)
    _os._exit(130)


# The `yore` command imports all of yore before its main() can catch Ctrl-C: while it starts, a
# Ctrl-C is one line and exit 130 (a traceback of the imports otherwise). Only for the command:
# a program importing yore keeps its own handling.
_STARTING = (_os.path.basename(_sys.argv[0] if _sys.argv else "") == "yore"
             and _threading.current_thread() is _threading.main_thread()
             and _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler)
if _STARTING:
    _signal.signal(_signal.SIGINT, _interrupted_while_starting)

from . import metrics, scenes, springs, stroke, subdivision  # noqa: E402  (after the handler)
from ._core import Cloth, NotPositiveDefinite, SimulationDiverged
from .io import load_mesh, save_mesh
from .meshes import cylinder_mesh, grid_mesh
from .simulation import INTEGRATORS, Simulation
from .state import load_state, save_state
from .runs import RunError, SceneError, load_scene, resume_run, run_scene
from . import camera, checks, runs, viz
from .camera import Camera
from .stroke import StrokeMissed, StrokeReport
from . import _core as _threads_core

# OpenBLAS's threads (CHOLMOD's factorization) wait for each other like OpenMP's, and no step
# re-times them: one thread unless the user asked (README, "Threads": on a busy machine two
# made a linearized implicit step 3× slower). set_num_threads(n) sets n here too.
if not any(name in _os.environ for name in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS",
                                            "OMP_NUM_THREADS")):
    _threads_core.set_blas_threads(1)

__version__ = "0.1.0"

__all__ = [
    "Cloth",
    "Simulation",
    "SimulationDiverged",
    "NotPositiveDefinite",
    "StrokeMissed",
    "StrokeReport",
    "Camera",
    "metrics",
    "INTEGRATORS",
    "grid_mesh",
    "cylinder_mesh",
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


def build_info() -> dict:
    """Versions of the libraries yore was built and linked with, and its thread count."""
    from . import _core

    info = dict(_core.build_info())
    info["threads"] = _core.max_threads()
    info["yore"] = __version__
    return info


from .checks import MAX_THREADS  # noqa: E402  (most threads set_num_threads accepts)


def set_num_threads(threads: int) -> None:
    """Sets the threads of yore's parallel loops and of the BLAS that CHOLMOD calls (OpenBLAS),
    for the whole process: the one place the thread count is set (``yore --threads N`` and a
    scene's ``[simulation] threads`` call it). Raises ValueError unless `threads` is an int >= 1
    (bool is refused).

    The explicit step still runs a block of steps on one thread when that is faster (small
    cloths, or a machine busy with other processes); ``Simulation.stats["threads"]`` says what
    its loops used.
    """
    from . import _core

    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or \
            not 1 <= threads <= MAX_THREADS:
        raise ValueError(f"the number of threads must be an int in [1, {MAX_THREADS}], got "
                         f"{threads!r}")
    _core.set_max_threads(int(threads))
