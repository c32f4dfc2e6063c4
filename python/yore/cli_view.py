"""``yore view`` and the picture checks it shares with ``yore render``: a scene or a state in
the viewer's window, or scripted headless (`yore.cli` dispatches to it)."""

from __future__ import annotations

import math
from pathlib import Path

from .limits import LIMITS
from .cli_parser import scene_overrides


def check_view_numbers(arguments):
    """Image sizes, field of view and vectors of render/view, checked before any work."""
    from .checks import check_image_size, check_vector

    for name in ("width", "height"):
        value = getattr(arguments, name, None)
        if value is not None:
            check_image_size(
                value if name == "width" else 1, value if name == "height" else 1, f"--{name}"
            )
    if arguments.fov is not None:
        from .camera import check_fov

        check_fov(arguments.fov, "--fov")
    for name in ("eye", "target", "up"):
        value = getattr(arguments, name, None)
        if value is not None:
            check_vector(value, f"--{name}") if name == "up" else None
            if not all(abs(v) < 1e12 for v in value):
                raise ValueError(f"--{name} must be 3 finite numbers, got {value}")


#: Smallest picture side with --panel (the panels are drawn into it; 1 px failed in OpenGL).
MIN_PANEL_SIDE = LIMITS.min_picture_side


def view_command(arguments):
    if getattr(arguments, "panel", False):
        for name in ("width", "height"):
            value = getattr(arguments, name, None)
            if value is not None and value < MIN_PANEL_SIDE:
                raise ValueError(
                    f"--{name} must be at least {MIN_PANEL_SIDE} px with --panel, got {value}"
                )

    check_view_numbers(arguments)
    _run_view(arguments, scene_overrides(arguments))


# -- yore view ------------------------------------------------------------------------------------
def _view_source(source, overrides):
    """(simulation, camera settings, first stroke's options) of a scene file or a state."""
    source = Path(source)
    if source.suffix.lower() == ".npz":
        if overrides:
            raise ValueError("--set changes a scene file; a state (.npz) takes none")
        from .state import load_state

        sim, metadata = load_state(source)
        settings = None
        overrides = metadata.get("overrides") if isinstance(metadata, dict) else None
        if (
            isinstance(metadata, dict)
            and isinstance(metadata.get("scene_text"), str)
            and (overrides is None or isinstance(overrides, dict))
        ):
            # a run's state: its scene's [camera] (a record that is not a run's is ignored)
            from .runs import load_scene

            try:
                scene = load_scene(text=metadata["scene_text"], overrides=overrides or {})
                settings = scene.data.camera
            except ValueError:
                settings = None
        return sim, settings, {}
    from .runs import load_scene

    scene = load_scene(source, overrides=overrides)
    sim, _ = scene.build()
    if scene.data.simulation.settle > 0.0:
        # the scene's starting state is its settled cloth, as in `yore run`
        sim.settle(scene.data.simulation.settle)
    strokes = scene.data.strokes or []
    first = {}
    if strokes:
        for name in ("expansion", "mass_scale", "width", "growth", "refine"):
            if getattr(strokes[0], name) is not None:
                first[name] = getattr(strokes[0], name)
    return sim, scene.data.camera, first


def _run_view(arguments, overrides) -> None:
    """``yore view``: a scene or state in the viewer's window, or scripted headless."""
    from .camera import camera_from_settings
    from .viz.viewer import Viewer

    strokes = _check_view_arguments(arguments)
    sim, settings, first = _view_source(arguments.source, overrides)
    at = sim.time if arguments.at is None else arguments.at
    until = at if arguments.until is None else arguments.until
    if at < sim.time - 1e-12:
        raise ValueError(f"--at {at} s is before the simulation's time {sim.time:.6g} s")
    if until < at:
        raise ValueError(f"--until {until} s is before --at {at} s")
    options = dict(first)
    for name, value in (
        ("expansion", arguments.expansion),
        ("width", arguments.stroke_width),
        ("growth", arguments.growth),
        ("refine", arguments.refine),
        ("smooth", arguments.smooth),
    ):
        if value is not None:
            options[name] = value
    camera = camera_from_settings(
        settings,
        sim.cloth.positions,
        arguments.width,
        arguments.height,
        arguments.eye,
        arguments.target,
        arguments.up,
        arguments.fov,
    )
    viewer = Viewer(sim, camera, headless=arguments.headless, stroke_options=options)
    if not arguments.headless:
        if not getattr(arguments, "quiet", False):
            viewer.log = lambda text: print(f"yore view: {text}", flush=True)
        viewer.show()
        return
    _script_view(viewer, arguments, strokes, at, until)


def _check_view_arguments(arguments):
    """The flags that go together, and the strokes' pixels (their sample limit checked)
    before anything is loaded."""
    from .viz.viewer import densify, parse_pixels

    if not arguments.headless and (
        arguments.stroke_px or arguments.at is not None or arguments.until is not None
    ):
        raise ValueError("--stroke-px, --at and --until script a headless view: add --headless")
    if arguments.headless and arguments.screenshot is None:
        raise ValueError("a headless view shows nothing: give --screenshot PICTURE.png")
    if arguments.screenshot is not None and arguments.screenshot.suffix.lower() != ".png":
        raise ValueError(f"--screenshot writes PNG files; got {str(arguments.screenshot)!r}")
    strokes = [parse_pixels(text) for text in arguments.stroke_px]
    for pixels in strokes:
        densify(pixels)  # its sample limit, before the scene is loaded and run
    for name in ("at", "until"):
        value = getattr(arguments, name)
        if value is not None and not (math.isfinite(value) and 0.0 <= value <= 1e6):
            raise ValueError(f"--{name} must be a time in [0, 1e6] s, got {value}")
    return strokes


def _script_view(viewer, arguments, strokes, at, until):
    """A headless view: run to ``at``, draw the strokes, run to ``until``, save the picture."""
    quiet = getattr(arguments, "quiet", False)

    def run_to(target):
        if target > viewer.sim.time:
            # Simulation.advance shows its own progress bar on a terminal for long runs
            viewer.advance(target - viewer.sim.time, progress=False if quiet else None)

    run_to(at)
    for k, pixels in enumerate(strokes):
        reports = viewer.stroke_pixels(pixels)
        if not quiet:
            print(
                f"stroke {k + 1} at t = {viewer.sim.time:.3f} s: "
                f"{sum(r.faces_split for r in reports)} faces split, "
                f"{sum(r.vertices_added for r in reports)} vertices added"
                + (f" ({len(reports)} pieces)" if len(reports) > 1 else "")
            )
    run_to(until)
    path = viewer.save_picture(arguments.screenshot, panel=arguments.panel)
    if not quiet:
        print(f"picture:      {Path(path).resolve()}")
