"""yore — cloth simulation with stroke-driven partial area expansion.

A mass-spring cloth (Shi & Saito, "Partially Area Expansion by Mesh Subdivision to Make Wrinkled
Cloth") with an explicit reference integrator; see README.md for the whole picture.
"""

from __future__ import annotations

from . import metrics, scenes, springs, stroke
from ._core import Cloth, NotPositiveDefinite, SimulationDiverged
from .io import load_mesh, save_mesh
from .meshes import cylinder_mesh, grid_mesh
from .simulation import INTEGRATORS, Simulation
from .state import load_state, save_state
from .scene_file import SceneError, load_scene
from .runner import RunError, resume_run, run_scene
from . import render, scene_file
from .stroke import Camera, StrokeMissed, StrokeReport

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
    "render",
    "load_state",
    "springs",
    "build_info",
    "set_num_threads",
]


def build_info() -> dict:
    """Versions of the libraries yore was built and linked with, and its thread count."""
    from . import _core

    info = dict(_core.build_info())
    info["threads"] = _core.max_threads()
    info["yore"] = __version__
    return info


def set_num_threads(threads: int) -> None:
    """Sets the number of threads of the core's parallel loops (>= 1)."""
    from . import _core

    _core.set_max_threads(int(threads))
