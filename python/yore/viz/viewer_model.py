"""The viewer's model: a simulation, the stroke options, picking by the core's rays, strokes
with undo, stepping a frame at a time and the figures the panel shows — everything of the viewer
but the window, so tests (and scripts) drive it without polyscope. `yore.viz.viewer.Viewer` is
this model shown in a polyscope window (or headless, for pictures)."""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import numpy as np

from ..limits import LIMITS
from .. import _core, blas
from ..camera import Camera, fit_camera
from ..checks import check_integer
from ..options import IMAGE_HEIGHT, IMAGE_WIDTH, INTEGRATORS, SMOOTHING_RULES, STROKE_DEFAULTS
from ..simulation import Simulation
from ..stroke import StrokeMissed, StrokeOptions, StrokePath

__all__ = [
    "ViewerModel",
    "parse_pixels",
    "densify",
    "SAMPLE_SPACING_PX",
    "UNDO_DEPTH",
    "SUNDIALS_FIGURES",
]

#: Mouse or given pixels are densified so that consecutive samples are at most this far apart.
SAMPLE_SPACING_PX = 2.0
#: Most samples one stroke may have after densifying (a drag across a 16384-pixel screen).
MAX_STROKE_SAMPLES = LIMITS.max_view_stroke_samples
#: Undo keeps this many strokes.
UNDO_DEPTH = 32
#: Wall time the live loop may spend stepping per frame, s (keeps the window responsive).
FRAME_BUDGET_SECONDS = 0.05
#: What the panel shows of an error-controlled (SUNDIALS) run, from its counters.
SUNDIALS_FIGURES = (
    "internal_steps",
    "current_order",
    "current_internal_dt",
    "error_test_failures",
    "nonlinear_iterations",
    "nonlinear_failures",
    "linear_setups",
    "linear_solves",
)


def parse_pixels(text) -> np.ndarray:
    """``"x,y x,y ..."`` → (k, 2) float array of pixel coordinates; ValueError naming the
    sample that is not a pair of finite numbers."""
    if not isinstance(text, str) or not text.strip():
        raise ValueError('--stroke-px needs pixels as "x,y x,y ...", got an empty value')
    pixels = []
    for k, item in enumerate(text.replace(";", " ").split()):
        parts = item.split(",")
        try:
            if len(parts) != 2:
                raise ValueError
            x, y = float(parts[0]), float(parts[1])
        except ValueError:
            raise ValueError(
                f'--stroke-px sample {k + 1} is {item!r}; expected "x,y" (two numbers, pixels)'
            ) from None
        if not (math.isfinite(x) and math.isfinite(y)) or max(abs(x), abs(y)) > 1e6:
            raise ValueError(
                f"--stroke-px sample {k + 1} is {item!r}; pixels must be finite and within ±1e6"
            )
        pixels.append((x, y))
    return np.asarray(pixels, dtype=np.float64)


def densify(pixels, spacing=SAMPLE_SPACING_PX) -> np.ndarray:
    """The polyline through ``pixels`` (k×2) resampled so that consecutive samples are at
    most ``spacing`` apart (the given pixels are kept)."""
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    if len(pixels) < 2:
        return pixels
    # The size is counted before anything is allocated (a few far-apart pixels would
    # otherwise ask for gigabytes).
    lengths = np.linalg.norm(np.diff(pixels, axis=0), axis=1)
    pieces = np.maximum(1, np.ceil(lengths / spacing))
    total = 1 + float(pieces.sum())
    if total > MAX_STROKE_SAMPLES:
        raise ValueError(
            f"the stroke is {lengths.sum():.6g} px long: sampled every {spacing} "
            f"px it would pass the {MAX_STROKE_SAMPLES} samples a stroke may have; "
            f"draw one at most {(MAX_STROKE_SAMPLES - 1) * spacing:.6g} px long"
        )
    out = [pixels[:1]]
    for a, b, count in zip(pixels[:-1], pixels[1:], pieces.astype(np.int64)):
        t = np.arange(1, count + 1)[:, None] / count
        out.append(a + t * (b - a))
    return np.concatenate(out)


class ViewerModel:
    """A simulation under the viewer's control, without a window (see the module docstring).

    sim: the `yore.Simulation`; camera: the view strokes are drawn in (default: fitted to the
    cloth, 800×600); stroke_options: starting stroke options (expansion, mass_scale, width,
    growth, refine, and smooth: rest-length smoothing iterations, 0 none).
    """

    def __init__(self, sim, camera=None, *, stroke_options=None):
        if not isinstance(sim, Simulation):
            raise ValueError(f"sim must be a yore.Simulation, got {type(sim).__name__}")
        if camera is not None and not isinstance(camera, Camera):
            raise ValueError(f"camera must be a yore.Camera, got {type(camera).__name__}")
        self.sim = sim
        self.camera = camera or fit_camera(sim.cloth.positions, IMAGE_WIDTH, IMAGE_HEIGHT)
        self.stroke_options = {**STROKE_DEFAULTS, "smooth": 0}
        for name, value in (stroke_options or {}).items():
            if name not in self.stroke_options:
                raise ValueError(
                    f"unknown stroke option {name!r}; valid: {', '.join(self.stroke_options)}"
                )
            if value is not None or name == "width":
                self.stroke_options[name] = value
        self._check_stroke_options()
        self.start_state = sim.state()
        self.undo_states = []
        self.reports = []
        self.playing = False
        self._message = ""
        self.log = None  # a callable given each message (yore view: print)
        self.speed = 1.0
        self._frame_steps, self._frame_seconds = 0, 0.0
        self._blas = blas.describe()  # fixed for the process: OpenBLAS chose when it loaded

    def _changed(self):
        """Called after the simulation changed (a step, a stroke, undo): the window redraws."""

    @property
    def message(self) -> str:
        """The last thing the viewer did or refused (shown in the panel)."""
        return self._message

    @message.setter
    def message(self, text):
        self._message = text
        if self.log is not None and text:
            self.log(text)

    # -- picking: the one path from screen samples to points on the cloth --------------------
    def view_camera(self) -> Camera:
        """The camera of the current view (the model's; a window's as the user turned it)."""
        return self.camera

    def pick_surface(self, pixels):
        """Picks each pixel (k×2, yore pixel coordinates of the current view, fractions
        allowed) on the cloth. Returns (pixels, faces, barycentric): the samples that hit the
        cloth, the face under each and its barycentric coordinates (k×3, each row ≥ 0 summing
        to 1).

        Each pixel's ray of `view_camera` (`Camera.pixel_rays`) goes to its first hit on the
        cloth in the C++ core (``_core.pick_rays``: the rays a screen stroke casts, one AABB
        tree for all the samples)."""
        pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        if len(pixels) == 0:
            return np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.zeros((0, 3))
        camera = self.view_camera()
        d0, dx, dy = camera.pixel_rays()
        picked = _core.pick_rays(
            self.sim.cloth,
            np.column_stack([pixels, np.zeros(len(pixels))]),
            np.asarray(camera.eye, float),
            d0,
            dx,
            dy,
        )
        faces = np.asarray(picked["faces"], dtype=np.int64)
        weights = np.clip(picked["barycentric"], 0.0, None)
        total = weights.sum(axis=1)
        hit = (faces >= 0) & np.isfinite(total) & (total > 0)
        return (pixels[hit], faces[hit], weights[hit] / total[hit, None])

    def surface_points(self, faces, barycentric) -> np.ndarray:
        """3-D points (k×3) on the cloth as it is now at (face, barycentric) pairs."""
        cloth = self.sim.cloth
        corners = cloth.positions[cloth.faces[np.asarray(faces, dtype=np.int64)]]
        return np.einsum("kj,kji->ki", np.asarray(barycentric, dtype=np.float64), corners)

    @staticmethod
    def _runs(pixels, faces):
        """Index ranges of consecutive samples: a gap (a sample that missed the cloth, seen as
        a jump of more than 1.5 spacings between kept samples) starts a new run."""
        if len(faces) == 0:
            return []
        gaps = (
            np.flatnonzero(
                np.linalg.norm(np.diff(pixels, axis=0), axis=1) > 1.5 * SAMPLE_SPACING_PX
            )
            + 1
        )
        bounds = [0, *gaps.tolist(), len(faces)]
        return [(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]

    # -- strokes ------------------------------------------------------------------------------
    def stroke_pixels(self, pixels) -> list:
        """Draws a stroke through ``pixels`` (k×2, pixels of the current view: x right, y
        down, (0, 0) the top-left pixel's centre), exactly as a mouse drag through them
        would: densify, pick, then `apply_picked`. Returns the stroke reports. Raises
        yore.StrokeMissed when no sample lies on the cloth."""
        hits, faces, weights = self.pick_surface(densify(pixels))
        return self.apply_picked(hits, faces, weights)

    def apply_picked(self, pixels, faces, barycentric) -> list:
        """Applies picked samples as strokes (one per run of consecutive samples), with the
        stroke options and smoothing; one undo step for all. Returns the reports."""
        if len(faces) == 0:
            raise StrokeMissed("the stroke's pixels miss the cloth (no sample lies on it)")
        options = self.stroke_value()
        saved = self.sim.state()
        reports = []
        # every run's points on the cloth as it is now, before the first stroke renumbers faces
        pieces = [
            self.surface_points(faces[a:b], barycentric[a:b]) for a, b in self._runs(pixels, faces)
        ]
        try:
            for points in pieces:
                reports.append(self.sim.stroke(StrokePath.world(points), options))
        except Exception:
            # a stroke that fails halfway leaves nothing behind
            self.sim = Simulation.from_state(saved)
            self._changed()
            raise
        self.undo_states.append(saved)
        del self.undo_states[:-UNDO_DEPTH]
        self.reports.append(reports)
        del self.reports[:-UNDO_DEPTH]
        self._changed()
        split = sum(r.faces_split for r in reports)
        added = sum(r.vertices_added for r in reports)
        self.message = (
            f"stroke at t = {self.sim.time:.3f} s: {split} faces split, {added} vertices added"
        )
        return reports

    def undo(self) -> bool:
        """Restores the simulation saved before the last stroke; False when there is none."""
        if not self.undo_states:
            self.message = "nothing to undo"
            return False
        self.sim = Simulation.from_state(self.undo_states.pop())
        self.reports.pop()
        self._changed()
        self.message = f"stroke undone (t = {self.sim.time:.3f} s)"
        return True

    def reset(self) -> None:
        """Back to the simulation the viewer started with (strokes and undo steps dropped)."""
        self.sim = Simulation.from_state(self.start_state)
        self.undo_states.clear()
        self.reports.clear()
        self._changed()
        self.message = "reset to the start"

    def stroke_value(self) -> StrokeOptions:
        """The stroke options in force as a `yore.StrokeOptions`: the panel's, with its
        smoothing iterations (0: none) as the stroke's last stage over the stroke's region,
        conserving the rest length it added."""
        options = dict(self.stroke_options)
        smooth = options.pop("smooth")
        return StrokeOptions.of(options, smooth=smooth or None)

    def _check_stroke_options(self):
        options = self.stroke_options
        options["smooth"] = check_integer(
            options["smooth"],
            "smooth (iterations)",
            SMOOTHING_RULES["iterations"].low,
            SMOOTHING_RULES["iterations"].high,
        )
        checked = self.stroke_value()
        options.update({name: getattr(checked, name) for name in STROKE_DEFAULTS})

    # -- time -----------------------------------------------------------------------------------
    def advance(self, seconds, progress=None) -> None:
        """Advances the simulation by ``seconds`` (and updates the view)."""
        self.sim.advance(seconds, progress=progress)
        self._changed()

    def step_frame(self, wall_seconds=1.0 / 30.0) -> int:
        """One frame of the live loop: steps for ``speed × wall_seconds`` of simulated time,
        at least one, at most what fits in `FRAME_BUDGET_SECONDS` at the last frame's cost per
        step. A divergence pauses the viewer with its message. Returns the steps taken."""
        dt = self.sim.dt
        wanted = max(1, int(round(self.speed * min(wall_seconds, 0.1) / dt)))
        if self._frame_steps:
            per_step = self._frame_seconds / self._frame_steps
            wanted = max(1, min(wanted, int(FRAME_BUDGET_SECONDS / max(per_step, 1e-9))))
        start = time.perf_counter()
        try:
            with warnings.catch_warnings():
                # unconverged steps are counted in the statistics the panel shows
                warnings.simplefilter("ignore", RuntimeWarning)
                self.sim.step(wanted)
        except RuntimeError as error:  # yore.SimulationDiverged
            self.playing = False
            self.message = " ".join(str(error).split())
            self._changed()
            return 0
        self._frame_steps, self._frame_seconds = wanted, time.perf_counter() - start
        self._changed()
        return wanted

    def set_integrator(self, integrator, dt=None) -> None:
        """Rebuilds the integrator (its default options) from the current state; dt None takes
        the integrator's default for this cloth."""
        if integrator not in INTEGRATORS:
            raise ValueError(f"unknown integrator {integrator!r}; valid: {', '.join(INTEGRATORS)}")
        sim = Simulation(self.sim.cloth, integrator=integrator, dt=dt, gravity=self.sim.gravity)
        self.sim = sim
        self._frame_steps = 0
        self.message = f"{integrator}, dt = {sim.dt:.4g} s"

    # -- files and figures ----------------------------------------------------------------------
    def save_state(self, path) -> Path:
        from ..state import save_state

        path = save_state(path, self.sim, metadata={"source": "yore view"})
        self.message = f"state saved: {path}"
        return path

    def statistics(self) -> dict:
        """What the panel shows: time, steps, last frame's step time, steps per second,
        iterations per step, analyses, factorization time, vertices, faces, the BLAS kernels."""
        stats = self.sim.stats
        counters, phases = stats["counters"], stats["phases"]
        steps = max(stats["steps"], 1)
        iterations = counters.get("newton_iterations", counters.get("iterations"))
        # the live loop's last frame, else the mean over the simulation's steps so far
        per_step = (
            self._frame_seconds / self._frame_steps
            if self._frame_steps
            else stats["wall_seconds"] / stats["steps"]
            if stats["steps"]
            else None
        )
        return {
            "time": self.sim.time,
            "steps": stats["steps"],
            "integrator": stats["integrator"],
            "dt": stats["dt"],
            "step_ms": None if per_step is None else 1e3 * per_step,
            "steps_per_second": None if not per_step else 1.0 / per_step,
            "iterations_per_step": None if iterations is None else iterations / steps,
            "unconverged_steps": counters.get("unconverged_steps"),
            "analyses": counters.get("analyses"),
            "factorize_seconds": phases.get("factorize_seconds"),
            "vertices": stats["vertices"],
            "faces": int(len(self.sim.cloth.faces)),
            "strokes": len(self.reports),
            # the BLAS kernels CHOLMOD's factorization runs on (yore.blas)
            "blas": self._blas,
            # the error-controlled integrators' own (SUNDIALS): None for the others
            **{name: counters.get(name) for name in SUNDIALS_FIGURES},
        }
