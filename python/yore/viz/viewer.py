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

What the viewer does to the simulation (picking, strokes, undo, stepping, the panel's figures)
is `yore.viz.viewer_model.ViewerModel`, which needs no window; `Viewer` shows it in polyscope.

Undo restores the simulation saved before the stroke (`Simulation.state`, so bit for bit,
BDF2's history and Newton's memory included); `Viewer.sim` is then a new `Simulation` object.
The mesh is registered again with polyscope after every change of topology.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ..camera import Camera
from ..options import INTEGRATORS
from ..stroke import GROWTH_MODES
from . import backend
from .viewer_model import SAMPLE_SPACING_PX, ViewerModel, densify, parse_pixels

__all__ = ["Viewer", "ViewerModel", "parse_pixels", "densify", "SAMPLE_SPACING_PX", "KEYS"]

#: Width of the viewer's panel, pixels.
PANEL_WIDTH = 330
#: The keys, as listed in docs/viewer.md and the window's help line.
KEYS = {
    "Space": "play / pause",
    "N": "one frame",
    "D": "draw mode on / off",
    "Z": "undo the last stroke",
    "R": "reset to the start",
    "S": "save a picture",
    "Q": "close the viewer",
}
CLOTH = backend.VIEWER_SURFACES[0]
DRAFT = backend.VIEWER_CURVES[0]
COLORINGS = ("expansion", "wrinkles", "none")
_ACTIVE = [None]  # the viewer whose cloth polyscope shows


class Viewer(ViewerModel):
    """A live view of ``sim`` where strokes are drawn with the mouse (see the module docstring):
    the `ViewerModel` (picking, strokes, undo, stepping, figures) in a polyscope window.

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

    def __init__(
        self, sim, camera=None, *, headless=False, stroke_options=None, coloring="expansion"
    ):
        super().__init__(sim, camera, stroke_options=stroke_options)
        if coloring not in COLORINGS:
            raise ValueError(f"coloring must be one of {', '.join(COLORINGS)}, got {coloring!r}")
        self.headless = bool(headless)
        self.coloring = coloring
        self.draw_mode = False
        self.polyscope_panels = False
        self._draft = []  # (pixel, face, barycentric) of the drag being drawn
        self._drag_pixel = None  # the drag's last mouse sample
        self._last_frame = None
        self._topology = None
        self._mesh = None
        self._ps = backend.ensure(window=not self.headless)
        backend.set_camera(self.camera)
        self._register()

    # -- the scene in polyscope -------------------------------------------------------------
    def _changed(self):
        self._register()

    def view_camera(self) -> Camera:
        """The camera of the current view (the window's, as the user turned it; headless:
        the viewer's camera)."""
        return self.camera if self.headless else backend.camera_from_view()

    def pick_surface(self, pixels):
        """`ViewerModel.pick_surface` in the view polyscope shows."""
        self._activate()
        return super().pick_surface(pixels)

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
            self._mesh = ps.register_surface_mesh(
                CLOTH,
                cloth.positions,
                cloth.faces,
                color=(0.42, 0.62, 0.84),
                smooth_shade=True,
                material="clay",
                back_face_policy="different",
            )
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
        self._mesh.add_scalar_quantity(
            label,
            values,
            defined_on="vertices",
            cmap=polyscope_colormap(self._ps, cmap),
            vminmax=(low, high),
            enabled=True,
            onscreen_colorbar_enabled=not self.headless,
        )
        self._colored_version = key

    # -- pictures -------------------------------------------------------------------------------
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

    # -- the window -----------------------------------------------------------------------------
    def show(self) -> None:
        """Opens the window and runs until it is closed (not in headless mode)."""
        if self.headless:
            raise ValueError(
                "a headless viewer has no window; use stroke_pixels, advance and screenshot"
            )
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
        self.message = (
            "draw mode on: drag with the left button to draw a stroke"
            if self.draw_mode
            else "draw mode off"
        )

    def mouse(self, down, released, position, captured=False) -> list | None:
        """One frame of mouse input in draw mode: ``position`` in window pixels (corner
        coordinates, as ImGui reports them). Samples are picked while the button is down and
        applied on release; returns the reports of a stroke applied now, else None."""
        if not self.draw_mode or captured:
            return None
        if down:
            self._drag_to(np.asarray(position, dtype=np.float64) - 0.5)
            return None
        if released and self._drag_pixel is not None and not self._draft:
            self._drag_pixel = None
            self.message = "the stroke missed the cloth (no sample on it)"
        if released and self._draft:
            return self._apply_draft()
        return None

    def _drag_to(self, pixel):
        """The drag reached ``pixel`` (centre coordinates): picks the samples since the last."""
        previous = self._drag_pixel
        if previous is not None and np.array_equal(previous, pixel):
            return
        samples = densify([previous, pixel])[1:] if previous is not None else pixel[None]
        self._drag_pixel = pixel
        if previous is None:
            self.message = "drawing a stroke (release to apply it)"
        hits, faces, weights = self.pick_surface(samples)
        self._draft.extend(zip(hits, faces, weights))
        self._show_draft()

    def _apply_draft(self):
        """The button was released over a drawn stroke: apply it, and clear the draft."""
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
        curve = ps.register_curve_network(
            DRAFT, points, "line", color=(0.9, 0.06, 0.1), material="flat"
        )
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
        self.mouse(
            psim.IsMouseDown(0),
            psim.IsMouseReleased(0),
            psim.GetMousePos(),
            captured=io.WantCaptureMouse,
        )
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
        self._run_buttons(psim)
        changed, draw = psim.Checkbox("draw mode (D)", self.draw_mode)
        if changed:
            self.set_draw_mode(draw)
        _, self.speed = psim.SliderFloat("speed (x real time)", self.speed, 0.01, 4.0)
        self._integrator_panel(psim)
        coloring = COLORINGS.index(self.coloring)
        changed, coloring = psim.Combo("colour by", coloring, list(COLORINGS))
        if changed:
            self.coloring = COLORINGS[coloring]
            self._update_colors(force=True)
        if psim.CollapsingHeader("stroke"):
            self._stroke_panel(psim)
        if psim.Button("save state"):
            self._safely(self.save_state, Path(f"yore-view-{time.strftime('%Y%m%d-%H%M%S')}.npz"))
        psim.SameLine()
        if psim.Button("save picture"):
            self._safely(self.save_picture, Path(f"yore-view-{time.strftime('%Y%m%d-%H%M%S')}.png"))
        psim.Separator()
        for line in _statistics_lines(self.statistics()):
            psim.TextWrapped(line)
        changed, self.polyscope_panels = psim.Checkbox("polyscope's panels", self.polyscope_panels)
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

    def _run_buttons(self, psim):
        """play/pause, step, reset and undo stroke, on one line."""
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

    def _integrator_panel(self, psim):
        """The integrator's choice, and dt (applied on Enter, not at every keystroke of a
        number being typed)."""
        names = list(INTEGRATORS)
        index = names.index(self.sim.integrator)
        changed, index = psim.Combo("integrator", index, names)
        if changed:
            self._safely(self.set_integrator, names[index])
        changed, dt = psim.InputFloat(
            "dt (s)",
            float(self.sim.dt),
            format="%.3g",
            flags=psim.ImGuiInputTextFlags_EnterReturnsTrue,
        )
        if changed and dt > 0 and math.isfinite(dt):
            self._safely(self.set_integrator, self.sim.integrator, float(dt))

    def _stroke_panel(self, psim):
        """The panel's stroke options: expansion, width, growth, refinement, smoothing."""
        options = self.stroke_options
        _, options["expansion"] = psim.SliderFloat(
            "expansion", float(options["expansion"]), 1.0, 1.5
        )
        width = options["width"] or 0.0
        _, width = psim.SliderFloat("width (m, 0 = paper)", float(width), 0.0, 0.5)
        options["width"] = width if width > 0 else None
        growth = GROWTH_MODES.index(options["growth"])
        _, growth = psim.Combo("growth", growth, list(GROWTH_MODES))
        options["growth"] = GROWTH_MODES[growth]
        _, options["refine"] = psim.SliderInt("refine", int(options["refine"]), 0, 2)
        _, options["smooth"] = psim.SliderInt("smoothing iterations", int(options["smooth"]), 0, 50)

    def _safely(self, function, *arguments):
        try:
            return function(*arguments)
        except (ValueError, OSError, RuntimeError) as error:
            self.message = " ".join(str(error).split())
            return None


def _statistics_lines(s) -> list:
    def number(value, form):
        return "–" if value is None else form.format(value)

    sundials = []
    if s.get("internal_steps") is not None:
        sundials = [
            f"internal steps {s['internal_steps']}, order {s['current_order']}, "
            f"next step {s['current_internal_dt']:.3g} s",
            f"error-test failures {s['error_test_failures']}, Newton iterations "
            f"{s['nonlinear_iterations']} (failed {s['nonlinear_failures']})",
            f"setups (factorizations) {s['linear_setups']}, solves {s['linear_solves']}",
        ]
    return (
        sundials
        + [
            f"t = {s['time']:.3f} s, {s['steps']} steps of {s['dt']:.3g} s ({s['integrator']})",
            f"step {number(s['step_ms'], '{:.2f}')} ms, "
            f"{number(s['steps_per_second'], '{:.0f}')} steps/s",
            f"iterations per step {number(s['iterations_per_step'], '{:.1f}')}, "
            f"unconverged {number(s['unconverged_steps'], '{}')}",
            f"analyses {number(s['analyses'], '{}')}, "
            f"factorization {number(s['factorize_seconds'], '{:.3f}')} s",
            f"{s['vertices']} vertices, {s['faces']} faces; strokes: {s['strokes']}",
        ]
        + ([f"BLAS: {s['blas']}"] if s.get("blas") else [])
    )
