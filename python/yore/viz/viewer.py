"""The viewer: a simulation running live in a polyscope window, strokes drawn with the mouse.

`Viewer(sim)` shows ``sim``'s cloth. In a window (`Viewer.show`) the simulation runs as fast as
real time allows; an ImGui panel has play/pause/step, the integrator and dt (a change rebuilds
the integrator from the current state), reset, undo of the last stroke, save state, save
picture, the stroke options and live statistics. Keys: Space play/pause, N one frame, D draw
mode, Z undo, R reset, S save picture, Q close.

Drawing: in draw mode the default camera motion is off and a left-button drag draws. Every
mouse sample (densified to at most `SAMPLE_SPACING_PX` pixels apart) is picked on the current
surface as (face, barycentric coordinates); on release the samples become 3-D points on the
cloth *as it is then* (the same faces and barycentric coordinates, today's positions: the cloth
may have moved during the drag) and each run of consecutive samples on the cloth becomes one
`Simulation.stroke` with the panel's options, followed by the panel's rest-length smoothing.
A drag that leaves the cloth and comes back draws two strokes; the undo step holds both.

Headless (`Viewer(sim, headless=True)`, ``yore view --headless``) the same methods run without a
window: `stroke_pixels` turns pixels into picked points by the very function the mouse uses
(`pick_surface`), `advance` steps, `screenshot` renders the view.

Undo restores the simulation saved before the stroke (`Simulation.state`, so bit for bit,
BDF2's history and Newton's memory included); `Viewer.sim` is then a new `Simulation` object.
The mesh is registered again with polyscope after every change of topology.
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import numpy as np

from .. import _core
from ..camera import Camera, fit_camera
from ..options import (IMAGE_HEIGHT, IMAGE_WIDTH, INTEGRATORS, SMOOTHING_RULES,
                       STROKE_DEFAULTS)
from ..simulation import Simulation
from ..checks import check_integer
from ..stroke import GROWTH_MODES, StrokeMissed, StrokeOptions, StrokePath
from . import backend

__all__ = ["Viewer", "parse_pixels", "densify", "SAMPLE_SPACING_PX", "KEYS"]

#: Mouse or given pixels are densified so that consecutive samples are at most this far apart.
SAMPLE_SPACING_PX = 2.0
#: Most samples one stroke may have after densifying (a drag across a 16384-pixel screen).
MAX_STROKE_SAMPLES = 100_000
#: Undo keeps this many strokes.
MAX_UNDO = 32
#: Wall time the live loop may spend stepping per frame, s (keeps the window responsive).
FRAME_BUDGET_SECONDS = 0.05
#: Width of the viewer's panel, pixels.
PANEL_WIDTH = 330
#: The keys, as listed in docs/viewer.md and the window's help line.
KEYS = {"Space": "play / pause", "N": "one frame", "D": "draw mode on / off",
        "Z": "undo the last stroke", "R": "reset to the start", "S": "save a picture",
        "Q": "close the viewer"}
CLOTH = backend.VIEWER_SURFACES[0]
DRAFT = backend.VIEWER_CURVES[0]
COLORINGS = ("expansion", "wrinkles", "none")
_ACTIVE = [None]  # the viewer whose cloth polyscope shows


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
            raise ValueError(f'--stroke-px sample {k + 1} is {item!r}; expected "x,y" (two '
                             'numbers, pixels)') from None
        if not (math.isfinite(x) and math.isfinite(y)) or max(abs(x), abs(y)) > 1e6:
            raise ValueError(f"--stroke-px sample {k + 1} is {item!r}; pixels must be finite "
                             "and within ±1e6")
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
        raise ValueError(f"the stroke would be {total:.0f} samples long at {spacing} px spacing "
                         f"({lengths.sum():.6g} px in all); at most {MAX_STROKE_SAMPLES}")
    out = [pixels[:1]]
    for a, b, count in zip(pixels[:-1], pixels[1:], pieces.astype(np.int64)):
        t = np.arange(1, count + 1)[:, None] / count
        out.append(a + t * (b - a))
    return np.concatenate(out)


class Viewer:
    """A live view of ``sim`` where strokes are drawn with the mouse (see the module docstring).

    Parameters
    ----------
    sim : yore.Simulation
    camera : yore.Camera, optional
        The starting view and the window or picture size. Default: fitted to the cloth,
        800×600.
    headless : bool
        No window: EGL off-screen (strokes by `stroke_pixels`, pictures by `screenshot`).
    stroke_options : dict, optional
        Starting stroke options: expansion (1.1), mass_scale (0.95), width (None), growth
        ("paper"), refine (0) and smooth (rest-length smoothing iterations, 0).
    coloring : str
        "expansion" (rest expansion, default), "wrinkles" (signed wrinkle height) or "none".
    """

    def __init__(self, sim, camera=None, *, headless=False, stroke_options=None,
                 coloring="expansion"):
        if not isinstance(sim, Simulation):
            raise ValueError(f"sim must be a yore.Simulation, got {type(sim).__name__}")
        if camera is not None and not isinstance(camera, Camera):
            raise ValueError(f"camera must be a yore.Camera, got {type(camera).__name__}")
        if coloring not in COLORINGS:
            raise ValueError(f"coloring must be one of {', '.join(COLORINGS)}, got {coloring!r}")
        self.sim = sim
        self.headless = bool(headless)
        self.camera = camera or fit_camera(sim.cloth.positions, IMAGE_WIDTH, IMAGE_HEIGHT)
        self.coloring = coloring
        self.stroke_options = {**STROKE_DEFAULTS, "smooth": 0}
        for name, value in (stroke_options or {}).items():
            if name not in self.stroke_options:
                raise ValueError(f"unknown stroke option {name!r}; valid: "
                                 f"{', '.join(self.stroke_options)}")
            if value is not None or name == "width":
                self.stroke_options[name] = value
        self._check_stroke_options()
        self.start_state = sim.state()
        self.undo_states = []
        self.reports = []
        self.playing = False
        self.draw_mode = False
        self.polyscope_panels = False
        self._message = ""
        self.log = None  # a callable given each message (yore view: print)
        self.speed = 1.0
        self._draft = []  # (pixel, face, barycentric) of the drag being drawn
        self._drag_pixel = None  # the drag's last mouse sample
        self._frame_steps, self._frame_seconds = 0, 0.0
        self._last_frame = None
        self._topology = None
        self._mesh = None
        self._ps = backend.ensure(window=not self.headless)
        backend.set_camera(self.camera)
        self._register()

    @property
    def message(self) -> str:
        """The last thing the viewer did or refused (shown in the panel)."""
        return self._message

    @message.setter
    def message(self, text):
        self._message = text
        if self.log is not None and text:
            self.log(text)

    # -- the scene in polyscope -------------------------------------------------------------
    def _activate(self):
        """Makes this viewer's cloth and camera polyscope's (a process has one polyscope
        scene; several viewers, e.g. in a script or tests, take turns)."""
        if _ACTIVE[0] is not self:
            _ACTIVE[0] = self
            self._mesh = None
            backend.set_camera(self.camera)
            self._register()

    def _register(self):
        """(Re-)registers the cloth; only positions are updated while the topology stays."""
        ps, cloth = self._ps, self.sim.cloth
        _ACTIVE[0] = self
        version = (id(cloth), cloth.topology_version)
        if self._mesh is not None and self._topology == version:
            self._mesh.update_vertex_positions(cloth.positions)
        else:
            if ps.has_surface_mesh(CLOTH):
                ps.remove_surface_mesh(CLOTH)
            self._mesh = ps.register_surface_mesh(CLOTH, cloth.positions, cloth.faces,
                                                  color=(0.42, 0.62, 0.84), smooth_shade=True,
                                                  material="clay", back_face_policy="different")
            self._mesh.set_selection_mode("faces_only")
            self._topology = version
            self._colored_version = None
            self._update_colors()

    def _update_colors(self, force=False):
        from ..metrics import vertex_expansion, wrinkle_height
        from .render import polyscope_colormap

        cloth = self.sim.cloth
        if self.coloring == "none":
            self._mesh.remove_all_quantities()
            self._colored_version = None
            return
        if self.coloring == "expansion":
            # changes only with strokes, undo and reset
            key = ("expansion", self._topology, len(self.reports), len(self.undo_states))
            if key == self._colored_version and not force:
                return
            values, cmap, label = vertex_expansion(cloth), "viridis", "expansion"
            low, high = 1.0, max(1.0 + 1e-3, float(values.max()))
        else:
            key = None
            values = 1e3 * wrinkle_height(cloth.positions, cloth.faces)
            half = max(float(np.abs(values).max()), 1e-6)
            cmap, label, low, high = "coolwarm", "wrinkles (mm)", -half, half
        self._mesh.add_scalar_quantity(label, values, defined_on="vertices",
                                       cmap=polyscope_colormap(self._ps, cmap), vminmax=(low, high),
                                       enabled=True, onscreen_colorbar_enabled=not self.headless)
        self._colored_version = key

    # -- picking: the one path from screen samples to points on the cloth --------------------
    def view_camera(self) -> Camera:
        """The camera of the current view (the window's, as the user turned it; headless:
        the viewer's camera)."""
        return self.camera if self.headless else backend.camera_from_view()

    def pick_surface(self, pixels):
        """Picks each pixel (k×2, yore pixel coordinates of the current view, fractions
        allowed) on the cloth. Returns (pixels, faces, barycentric): the samples that hit the
        cloth, the face under each and its barycentric coordinates (k×3, each row ≥ 0 summing
        to 1).

        Each pixel's ray of `view_camera` (`Camera.pixel_rays`) goes to its first hit on the
        cloth in the C++ core (``_core.pick_rays``: the rays a screen stroke casts, one AABB
        tree for all the samples)."""
        self._activate()
        pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        if len(pixels) == 0:
            return np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.zeros((0, 3))
        camera = self.view_camera()
        d0, dx, dy = camera.pixel_rays()
        picked = _core.pick_rays(self.sim.cloth, np.column_stack([pixels, np.zeros(len(pixels))]),
                                 np.asarray(camera.eye, float), d0, dx, dy)
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
        gaps = np.flatnonzero(np.linalg.norm(np.diff(pixels, axis=0), axis=1)
                              > 1.5 * SAMPLE_SPACING_PX) + 1
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
        pieces = [self.surface_points(faces[a:b], barycentric[a:b])
                  for a, b in self._runs(pixels, faces)]
        try:
            for points in pieces:
                reports.append(self.sim.stroke(StrokePath.world(points), options))
        except Exception:
            # a stroke that fails halfway leaves nothing behind
            self.sim = Simulation.from_state(saved)
            self._register()
            raise
        self.undo_states.append(saved)
        del self.undo_states[:-MAX_UNDO]
        self.reports.append(reports)
        del self.reports[:-MAX_UNDO]
        self._register()
        split = sum(r.faces_split for r in reports)
        added = sum(r.vertices_added for r in reports)
        self.message = (f"stroke at t = {self.sim.time:.3f} s: {split} faces split, "
                        f"{added} vertices added")
        return reports

    def undo(self) -> bool:
        """Restores the simulation saved before the last stroke; False when there is none."""
        if not self.undo_states:
            self.message = "nothing to undo"
            return False
        self.sim = Simulation.from_state(self.undo_states.pop())
        self.reports.pop()
        self._register()
        self.message = f"stroke undone (t = {self.sim.time:.3f} s)"
        return True

    def reset(self) -> None:
        """Back to the simulation the viewer started with (strokes and undo steps dropped)."""
        self.sim = Simulation.from_state(self.start_state)
        self.undo_states.clear()
        self.reports.clear()
        self._register()
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
        options["smooth"] = check_integer(options["smooth"], "smooth (iterations)",
                                          SMOOTHING_RULES["iterations"].low,
                                          SMOOTHING_RULES["iterations"].high)
        checked = self.stroke_value()
        options.update({name: getattr(checked, name) for name in STROKE_DEFAULTS})

    # -- time -----------------------------------------------------------------------------------
    def advance(self, seconds, progress=None) -> None:
        """Advances the simulation by ``seconds`` and updates the view."""
        self.sim.advance(seconds, progress=progress)
        self._register()

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
            self._register()
            return 0
        self._frame_steps, self._frame_seconds = wanted, time.perf_counter() - start
        self._register()
        return wanted

    def set_integrator(self, integrator, dt=None) -> None:
        """Rebuilds the integrator (its default options) from the current state; dt None takes
        the integrator's default for this cloth."""
        if integrator not in INTEGRATORS:
            raise ValueError(f"unknown integrator {integrator!r}; valid: "
                             f"{', '.join(INTEGRATORS)}")
        sim = Simulation(self.sim.cloth, integrator=integrator, dt=dt, gravity=self.sim.gravity)
        self.sim = sim
        self._frame_steps = 0
        self.message = f"{integrator}, dt = {sim.dt:.4g} s"

    # -- pictures and files ---------------------------------------------------------------------
    def screenshot(self, panel=False) -> np.ndarray:
        """The current view as an (h, w, 3) uint8 image; ``panel``: with polyscope's and the
        viewer's panels drawn over it, as the window shows them."""
        self._activate()
        if panel:
            return self._screenshot_with_panel()
        if not self.headless:
            return backend.screenshot()
        # headless: supersampled like every picture, then the view is set back for picking
        camera = self.camera
        factor = backend.supersampling(camera.width, camera.height)
        backend.set_camera(camera.resized(camera.width * factor, camera.height * factor))
        try:
            image = backend.screenshot()
        finally:
            backend.set_camera(camera)
        return backend.downsample(image, factor)

    def _screenshot_with_panel(self) -> np.ndarray:
        ps = self._ps
        if self.headless:
            import polyscope.imgui as psim

            backend.set_camera(self.camera)
            self._prepare_panels()
            ps.set_user_callback(lambda: self._panel(psim))
            try:
                ps.show(forFrames=2)  # ImGui lays its windows out over two frames
                # the screenshot draws one more frame, the panel's callback still set
                image = ps.screenshot_to_buffer(transparent_bg=False, include_UI=True)
            finally:
                ps.clear_user_callback()
        else:
            image = ps.screenshot_to_buffer(transparent_bg=False, include_UI=True)
        return np.ascontiguousarray(image[:, :, :3])

    def save_picture(self, path, panel=False) -> Path:
        from .images import save_png

        path = save_png(path, self.screenshot(panel=panel))
        self.message = f"picture saved: {path}"
        return path

    def save_state(self, path) -> Path:
        from ..state import save_state

        path = save_state(path, self.sim, metadata={"source": "yore view"})
        self.message = f"state saved: {path}"
        return path

    def statistics(self) -> dict:
        """What the panel shows: time, steps, last frame's step time, steps per second,
        iterations per step, analyses, factorization time, vertices, faces."""
        stats = self.sim.stats
        counters, phases = stats["counters"], stats["phases"]
        steps = max(stats["steps"], 1)
        iterations = counters.get("newton_iterations", counters.get("iterations"))
        # the live loop's last frame, else the mean over the simulation's steps so far
        per_step = (self._frame_seconds / self._frame_steps if self._frame_steps else
                    stats["wall_seconds"] / stats["steps"] if stats["steps"] else None)
        return {"time": self.sim.time, "steps": stats["steps"], "integrator": stats["integrator"],
                "dt": stats["dt"], "step_ms": None if per_step is None else 1e3 * per_step,
                "steps_per_second": None if not per_step else 1.0 / per_step,
                "iterations_per_step": None if iterations is None else iterations / steps,
                "unconverged_steps": counters.get("unconverged_steps"),
                "analyses": counters.get("analyses"),
                "factorize_seconds": phases.get("factorize_seconds"),
                "vertices": stats["vertices"], "faces": int(len(self.sim.cloth.faces)),
                "strokes": len(self.reports),
                # the error-controlled integrators' own (SUNDIALS): None for the others
                **{name: counters.get(name) for name in _SUNDIALS_FIGURES}}

    # -- the window -----------------------------------------------------------------------------
    def show(self) -> None:
        """Opens the window and runs until it is closed (not in headless mode)."""
        if self.headless:
            raise ValueError("a headless viewer has no window; use stroke_pixels, advance and "
                             "screenshot")
        ps = self._ps
        ps.set_window_size(self.camera.width, self.camera.height)
        backend.set_camera(self.camera)
        self._prepare_panels()
        ps.set_user_callback(self._frame)
        self.playing = True
        try:
            ps.show()
        finally:
            ps.clear_user_callback()
            ps.set_do_default_mouse_interaction(True)

    def set_draw_mode(self, on) -> None:
        """Draw mode on (a left drag draws, the camera stays) or off (the mouse moves the
        camera)."""
        self.draw_mode = bool(on)
        self._ps.set_do_default_mouse_interaction(not self.draw_mode)
        self.message = ("draw mode on: drag with the left button to draw a stroke"
                        if self.draw_mode else "draw mode off")

    def mouse(self, down, released, position, captured=False) -> list | None:
        """One frame of mouse input in draw mode: ``position`` in window pixels (corner
        coordinates, as ImGui reports them). Samples are picked while the button is down and
        applied on release; returns the reports of a stroke applied now, else None."""
        if not self.draw_mode or captured:
            return None
        if down:
            pixel = np.asarray(position, dtype=np.float64) - 0.5
            previous = self._drag_pixel
            if previous is not None and np.array_equal(previous, pixel):
                return None
            samples = densify([previous, pixel])[1:] if previous is not None else pixel[None]
            self._drag_pixel = pixel
            if previous is None:
                self.message = "drawing a stroke (release to apply it)"
            hits, faces, weights = self.pick_surface(samples)
            self._draft.extend(zip(hits, faces, weights))
            self._show_draft()
            return None
        if released and self._drag_pixel is not None and not self._draft:
            self._drag_pixel = None
            self.message = "the stroke missed the cloth (no sample on it)"
        if released and self._draft:
            self._drag_pixel = None
            pixels = np.asarray([d[0] for d in self._draft])
            faces = np.asarray([d[1] for d in self._draft])
            weights = np.asarray([d[2] for d in self._draft])
            self._draft = []
            if self._ps.has_curve_network(DRAFT):
                self._ps.remove_curve_network(DRAFT)
            try:
                return self.apply_picked(pixels, faces, weights)
            except ValueError as error:  # StrokeMissed, a bad option
                self.message = " ".join(str(error).split())
        return None

    def _show_draft(self):
        ps = self._ps
        if len(self._draft) < 2:
            return
        faces = np.asarray([d[1] for d in self._draft])
        weights = np.asarray([d[2] for d in self._draft])
        points = self.surface_points(faces, weights)
        if ps.has_curve_network(DRAFT):
            ps.remove_curve_network(DRAFT)
        curve = ps.register_curve_network(DRAFT, points, "line", color=(0.9, 0.06, 0.1),
                                          material="flat")
        curve.set_radius(0.004, relative=True)

    def _frame(self):
        """polyscope's per-frame callback: keys, panel, mouse, stepping."""
        import polyscope.imgui as psim

        if self._last_frame is None:
            self.message = "viewer ready: D to draw strokes, Space to pause"
        io = psim.GetIO()
        if not io.WantCaptureKeyboard:
            if psim.IsKeyPressed(psim.ImGuiKey_Space):
                self.playing = not self.playing
            if psim.IsKeyPressed(psim.ImGuiKey_D):
                self.set_draw_mode(not self.draw_mode)
            if psim.IsKeyPressed(psim.ImGuiKey_Z):
                self.undo()
            if psim.IsKeyPressed(psim.ImGuiKey_R):
                self.reset()
            if psim.IsKeyPressed(psim.ImGuiKey_S):
                self.save_picture(Path(f"yore-view-{time.strftime('%Y%m%d-%H%M%S')}.png"))
            if psim.IsKeyPressed(psim.ImGuiKey_N):
                self.step_frame()
            if psim.IsKeyPressed(psim.ImGuiKey_Q):
                self.message = "closing"
                self._ps.unshow()
                return
        self._ps.set_do_default_mouse_interaction(not self.draw_mode)
        self._panel(psim)
        self.mouse(psim.IsMouseDown(0), psim.IsMouseReleased(0), psim.GetMousePos(),
                   captured=io.WantCaptureMouse)
        now = time.perf_counter()
        elapsed = 1.0 / 30.0 if self._last_frame is None else now - self._last_frame
        self._last_frame = now
        if self.playing and not self._draft:
            self.step_frame(elapsed)

    def _prepare_panels(self):
        """A narrow panel at the right; polyscope's own panels (structures, options) start
        hidden, so the cloth has the window (a checkbox brings them back)."""
        self._ps.set_right_gui_pane_width(PANEL_WIDTH)
        self._ps.set_build_default_gui_panels(self.polyscope_panels)

    def _panel(self, psim):
        psim.PushItemWidth(120)
        if psim.Button("pause" if self.playing else "play"):
            self.playing = not self.playing
        psim.SameLine()
        if psim.Button("step"):
            self.step_frame()
        psim.SameLine()
        if psim.Button("reset"):
            self.reset()
        psim.SameLine()
        if psim.Button("undo stroke"):
            self.undo()
        changed, draw = psim.Checkbox("draw mode (D)", self.draw_mode)
        if changed:
            self.set_draw_mode(draw)
        _, self.speed = psim.SliderFloat("speed (x real time)", self.speed, 0.01, 4.0)
        names = list(INTEGRATORS)
        index = names.index(self.sim.integrator)
        changed, index = psim.Combo("integrator", index, names)
        if changed:
            self._safely(self.set_integrator, names[index])
        # applied on Enter, not at every keystroke of a number being typed
        changed, dt = psim.InputFloat("dt (s)", float(self.sim.dt), format="%.3g",
                                      flags=psim.ImGuiInputTextFlags_EnterReturnsTrue)
        if changed and dt > 0 and math.isfinite(dt):
            self._safely(self.set_integrator, self.sim.integrator, float(dt))
        coloring = COLORINGS.index(self.coloring)
        changed, coloring = psim.Combo("colour by", coloring, list(COLORINGS))
        if changed:
            self.coloring = COLORINGS[coloring]
            self._update_colors(force=True)
        if psim.CollapsingHeader("stroke"):
            options = self.stroke_options
            _, options["expansion"] = psim.SliderFloat("expansion", float(options["expansion"]),
                                                       1.0, 1.5)
            width = options["width"] or 0.0
            _, width = psim.SliderFloat("width (m, 0 = paper)", float(width), 0.0, 0.5)
            options["width"] = width if width > 0 else None
            growth = GROWTH_MODES.index(options["growth"])
            _, growth = psim.Combo("growth", growth, list(GROWTH_MODES))
            options["growth"] = GROWTH_MODES[growth]
            _, options["refine"] = psim.SliderInt("refine", int(options["refine"]), 0, 2)
            _, options["smooth"] = psim.SliderInt("smoothing iterations",
                                                  int(options["smooth"]), 0, 50)
        if psim.Button("save state"):
            self._safely(self.save_state, Path(f"yore-view-{time.strftime('%Y%m%d-%H%M%S')}.npz"))
        psim.SameLine()
        if psim.Button("save picture"):
            self._safely(self.save_picture,
                         Path(f"yore-view-{time.strftime('%Y%m%d-%H%M%S')}.png"))
        psim.Separator()
        for line in _statistics_lines(self.statistics()):
            psim.TextWrapped(line)
        changed, self.polyscope_panels = psim.Checkbox("polyscope's panels",
                                                       self.polyscope_panels)
        if changed:
            self._ps.set_build_default_gui_panels(self.polyscope_panels)
        if self.message:
            psim.Separator()
            psim.TextWrapped(self.message)
        psim.Separator()
        for key, action in KEYS.items():
            psim.TextUnformatted(f"{key:>6}  {action}")
        psim.TextUnformatted("  drag  draw (in draw mode), else turn the view")
        psim.PopItemWidth()

    def _safely(self, function, *arguments):
        try:
            return function(*arguments)
        except (ValueError, OSError, RuntimeError) as error:
            self.message = " ".join(str(error).split())
            return None


#: What the panel shows of an error-controlled (SUNDIALS) run, from its counters.
_SUNDIALS_FIGURES = ("internal_steps", "current_order", "current_internal_dt",
                     "error_test_failures", "nonlinear_iterations", "nonlinear_failures",
                     "linear_setups", "linear_solves")


def _statistics_lines(s) -> list:
    def number(value, form):
        return "–" if value is None else form.format(value)

    sundials = []
    if s.get("internal_steps") is not None:
        sundials = [f"internal steps {s['internal_steps']}, order {s['current_order']}, "
                    f"next step {s['current_internal_dt']:.3g} s",
                    f"error-test failures {s['error_test_failures']}, Newton iterations "
                    f"{s['nonlinear_iterations']} (failed {s['nonlinear_failures']})",
                    f"setups (factorizations) {s['linear_setups']}, solves "
                    f"{s['linear_solves']}"]
    return sundials + [f"t = {s['time']:.3f} s, {s['steps']} steps of {s['dt']:.3g} s ({s['integrator']})",
            f"step {number(s['step_ms'], '{:.2f}')} ms, "
            f"{number(s['steps_per_second'], '{:.0f}')} steps/s",
            f"iterations per step {number(s['iterations_per_step'], '{:.1f}')}, "
            f"unconverged {number(s['unconverged_steps'], '{}')}",
            f"analyses {number(s['analyses'], '{}')}, "
            f"factorization {number(s['factorize_seconds'], '{:.3f}')} s",
            f"{s['vertices']} vertices, {s['faces']} faces; strokes: {s['strokes']}"]
