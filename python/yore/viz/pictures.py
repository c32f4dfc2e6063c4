"""Pictures of runs and frames (what ``yore render`` and the end of ``yore run`` do).

A run folder (see `yore.runs.runner`) gives: ``before_after.png`` — the cloth just before the
first stroke (or at t = 0 without strokes) next to the last frame, as in the paper's figures,
with the strokes drawn on the cloth — ``last.png``, and an animation of the frames
(``animation.gif``, or ``.mp4`` where ffmpeg is installed). A single frame file gives one PNG.

Framing (``framing``): "cloth" (default) frames each picture tightly on the cloth it shows
(before/after: both states in one camera, so they compare at one scale; last.png: the last
frame) and lets the animation's camera follow the cloth (`yore.camera.follow_cameras`); "run"
uses one camera fitted to every frame shown, for all of them. A scene's [camera] eye and
target, or ``eye``/``target`` arguments, fix the view instead.

Strokes are drawn through their line vertices (in the order the stroke crossed its faces) at
the frame's positions, so the line follows the cloth as it moves. ``color_by``: "expansion"
colours by the rest-length expansion of each vertex's springs (1 = untouched; frames store it
as point data, not in OBJ files), "wrinkles" by the signed wrinkle height
(`yore.metrics.wrinkle_height`, mm), with a colour bar.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ..limits import LIMITS
from ..camera import camera_from_settings, fit_camera, follow_cameras
from ..io import load_frame
from .images import check_ffmpeg, save_animation, save_png, side_by_side
from .render import framing_camera, picture_layout, render_image

__all__ = ["render_run", "render_frame", "save_panels", "stroke_lines", "COLOR_BY", "FRAMINGS"]

#: Longest animation, in frames; longer runs use every k-th frame.
MAX_ANIMATION_FRAMES = LIMITS.max_animation_frames
COLOR_BY = ("none", "expansion", "wrinkles")
FRAMINGS = ("cloth", "run")
_COLORING = {"expansion": ("viridis", "expansion"), "wrinkles": ("coolwarm", "wrinkles (mm)")}


def _read_frame(path):
    """(V, F, point_data) of a mesh file; ValueError naming the file when it cannot be read
    (`yore.io.load_frame`: regular files of bounded size only, any meshio failure caught)."""
    path = Path(path)
    try:
        V, F, point_data = load_frame(path)
    except FileNotFoundError:
        raise ValueError(f"frame file {path} does not exist") from None
    # a camera has to frame the cloth: coordinates it cannot square without overflow (the
    # strokes' bound) are refused before any arithmetic warns about them
    with np.errstate(invalid="ignore"):
        largest = float(np.max(np.abs(V))) if V.size else 0.0
    if not np.isfinite(largest) or largest > MAX_FRAME_COORDINATE:
        raise ValueError(
            f"frame file {path}: a coordinate of {largest:.3g} m is beyond "
            f"±{MAX_FRAME_COORDINATE:g} m; it cannot be framed in a picture"
        )
    return V, F, point_data


#: Largest vertex coordinate of a frame a picture is made of, m (as for strokes).
MAX_FRAME_COORDINATE = LIMITS.max_frame_coordinate


def _check_color_by(color_by):
    if color_by not in COLOR_BY:
        raise ValueError(f"color_by must be one of {', '.join(COLOR_BY)}, got {color_by!r}")
    return color_by


def _vertex_values(V, F, point_data, color_by, path):
    """Per-vertex values to colour by (None for "none")."""
    if color_by == "none":
        return None
    if color_by == "wrinkles":
        from ..metrics import wrinkle_height

        return 1e3 * wrinkle_height(V, F)
    if "expansion" not in point_data:
        raise ValueError(
            f"frame {path} has no 'expansion' point data to colour by (OBJ files "
            "cannot hold it; write VTU, VTK or PLY frames)"
        )
    return np.asarray(point_data["expansion"], dtype=np.float64).reshape(-1)


def stroke_lines(strokes, V):
    """Polylines of the strokes whose vertices exist in a frame with these positions."""
    lines = []
    for stroke in strokes:
        # runs recorded before line_vertices existed drew their (paper) new vertices
        vertices = np.asarray(stroke.get("line_vertices", stroke["new_vertices"]), dtype=np.int64)
        if vertices.size >= 1 and vertices.max() < len(V):
            lines.append(V[vertices])
    return lines


def _scene_output(summary):
    return ((summary or {}).get("settings") or {}).get("output") or {}


def _load_summary(folder):
    path = Path(folder) / "summary.json"
    if not path.is_file():
        return None
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as error:
        raise ValueError(f"{path} is not a run summary ({error})") from None
    if not isinstance(summary, dict):
        raise ValueError(f"{path} is not a run summary (a {type(summary).__name__}, not a table)")
    return summary


class _Painter:
    """Renders frames with one colouring, one set of strokes and a value range shared by all
    pictures of a call (so before/after and the animation's frames compare)."""

    def __init__(self, color_by, strokes, value_range=None):
        self.color_by, self.strokes, self.value_range = color_by, strokes, value_range

    def values(self, mesh, path):
        V, F, point_data = mesh
        return _vertex_values(V, F, point_data, self.color_by, path)

    def share_range(self, meshes_and_paths):
        """Fixes the value range to cover the given frames."""
        if self.color_by == "none":
            return
        values = np.concatenate([self.values(mesh, path) for mesh, path in meshes_and_paths])
        low, high = float(values.min()), float(values.max())
        if self.color_by == "wrinkles":
            half = max(abs(low), abs(high), 1e-9)
            low, high = -half, half
        elif high <= low:
            low, high = low - 1e-3, high + 1e-3
        self.value_range = (low, high)

    def __call__(self, mesh, path, camera, title=None, antialias=True):
        V, F, _ = mesh
        values = self.values(mesh, path)
        colormap, label = _COLORING.get(self.color_by, ("viridis", None))
        return render_image(
            V,
            F,
            camera,
            vertex_values=values,
            value_range=self.value_range,
            colormap=colormap,
            colorbar=label if values is not None else None,
            strokes=stroke_lines(self.strokes, V),
            title=title,
            antialias=antialias,
        )


def _camera(settings, points, width, height, eye, target, up, fov, colored, titled):
    """The picture's camera: the settings' (or arguments') eye and target when an eye is
    given, else fitted so the cloth fills the picture's part left by the colour bar and the
    title (`yore.viz.render.picture_layout`)."""
    full = camera_from_settings(settings, points, width, height, eye, target, up, fov)
    if _fixed(settings, eye, target):
        return full
    inner_width, inner_height = picture_layout(full.width, full.height, colored, titled)
    inner = fit_camera(points, inner_width, inner_height, None, full.up, full.fov_degrees)
    return framing_camera(inner, full.width, full.height)


def _fixed(settings, eye, target):
    return (
        eye is not None
        or target is not None
        or (settings or {}).get("eye") is not None
        or (settings or {}).get("target") is not None
    )


def render_frame(
    frame,
    out=None,
    width=None,
    height=None,
    color_by=None,
    eye=None,
    target=None,
    up=None,
    fov_degrees=None,
) -> Path:
    """One PNG of a frame file (default: next to it, same name, .png). Strokes of the run are
    drawn when the frame lies in a run folder (its summary.json beside it or one level up);
    ``color_by`` None takes the run's [output] color_by ("none" outside a run)."""
    frame = Path(os.fspath(frame))
    mesh = _read_frame(frame)
    summary = _load_summary(frame.parent) or _load_summary(frame.parent.parent)
    color_by = _check_color_by(
        _scene_output(summary).get("color_by", "none") if color_by is None else color_by
    )
    camera = _camera(
        (summary or {}).get("camera"),
        mesh[0],
        width,
        height,
        eye,
        target,
        up,
        fov_degrees,
        color_by != "none",
        False,
    )
    painter = _Painter(color_by, (summary or {}).get("strokes", []))
    image = painter(mesh, frame, camera)
    return save_png(frame.with_suffix(".png") if out is None else Path(os.fspath(out)), image)


def _checked_run(run_dir, animation, color_by, framing):
    """`render_run`'s arguments checked against the run folder: (run_dir, summary, color_by,
    framing, frames); ValueError naming what is wrong, before any work."""
    run_dir = Path(os.fspath(run_dir))
    if animation not in (None, "gif", "mp4"):
        raise ValueError(f"animation must be 'gif', 'mp4' or None, got {animation!r}")
    if animation == "mp4":
        check_ffmpeg()
    summary = _load_summary(run_dir)
    if summary is None:
        raise ValueError(
            f"{run_dir} is not a run folder (no summary.json); give a frame file "
            "or the -o folder of `yore run`"
        )
    output = _scene_output(summary)
    color_by = _check_color_by(output.get("color_by", "none") if color_by is None else color_by)
    framing = output.get("framing", "cloth") if framing is None else framing
    if framing not in FRAMINGS:
        raise ValueError(f"framing must be one of {', '.join(FRAMINGS)}, got {framing!r}")
    frames = summary.get("frames") or []
    if not frames:
        raise ValueError(f"the run in {run_dir} wrote no frames (output.format = 'none')")
    return run_dir, summary, color_by, framing, frames


# over 60 lines: 13 keyword parameters and their documentation (the code is 57 lines)
def render_run(
    run_dir,
    pictures=True,
    animation="gif",
    color_by=None,
    width=None,
    height=None,
    out=None,
    eye=None,
    target=None,
    up=None,
    fov_degrees=None,
    framing=None,
    quiet=False,
) -> dict:
    """Pictures of a run folder: before_after.png and last.png (``pictures``) and
    animation.<gif|mp4> (``animation``, None for none) into ``out`` (default the run folder);
    ``color_by`` and ``framing`` None take the run's [output] settings. Returns {name: path
    relative to the run folder or absolute}. Raises ValueError when the folder holds no run, or
    before any work when an MP4 is asked for and ffmpeg is not on the PATH;
    `yore.viz.BackendUnavailable` when polyscope cannot render headless."""
    from . import backend

    run_dir, summary, color_by, framing, frames = _checked_run(
        run_dir, animation, color_by, framing
    )
    backend.ensure()  # fails here, before any work, when EGL is missing
    out = run_dir if out is None else Path(os.fspath(out))
    paths = [run_dir / frame["file"] for frame in frames]
    times = [frame["time"] for frame in frames]
    if animation:
        chosen = list(range(0, len(paths), max(1, -(-len(paths) // MAX_ANIMATION_FRAMES))))
        if chosen[-1] != len(paths) - 1:
            chosen.append(len(paths) - 1)
    else:
        chosen = [0, len(paths) - 1]
    loaded = {k: _read_frame(paths[k]) for k in sorted(set(chosen))}
    before = summary.get("before")
    before_path = run_dir / before["file"] if before else paths[0]
    before_mesh = _read_frame(before_path) if before else loaded[0]
    settings = summary.get("camera")
    painter = _Painter(color_by, summary.get("strokes", []))

    colored = color_by != "none"

    def camera_for(points, titled):
        return _camera(
            settings, points, width, height, eye, target, up, fov_degrees, colored, titled
        )

    written = {}
    frames_of_run = SimpleNamespace(
        paths=paths,
        times=times,
        loaded=loaded,
        chosen=chosen,
        before=before,
        before_mesh=before_mesh,
        before_path=before_path,
        settings=settings,
    )
    if pictures:
        written.update(_render_pictures(out, frames_of_run, painter, camera_for, framing))
    if animation:
        written["animation"] = _render_animation(
            out,
            animation,
            frames_of_run,
            painter,
            camera_for,
            framing,
            (eye, target, width, height, up, fov_degrees, colored),
            quiet,
        )
    return {
        name: (Path(os.path.relpath(path, run_dir)).as_posix() if out == run_dir else str(path))
        for name, path in written.items()
    }


def _render_pictures(out, run, painter, camera_for, framing) -> dict:
    """before_after.png (before the first stroke and the last frame, one camera) and
    last.png."""
    paths, times, loaded, before = run.paths, run.times, run.loaded, run.before
    before_mesh, before_path = run.before_mesh, run.before_path
    last = len(paths) - 1
    written = {}
    painter.share_range([(before_mesh, before_path), (loaded[last], paths[last])])
    everything = [before_mesh[0], loaded[last][0]]
    if framing == "run":
        everything += [mesh[0] for mesh in loaded.values()]
    # both states in one camera, so they compare at one scale
    camera = camera_for(everything, False)
    first_title = (
        f"before the stroke, t = {before['time']:.2f} s" if before else f"t = {times[0]:.2f} s"
    )
    pair = [painter(before_mesh, before_path, camera), painter(loaded[last], paths[last], camera)]
    written["before_after"] = save_png(
        out / "before_after.png", side_by_side(pair, titles=[first_title, f"t = {times[-1]:.2f} s"])
    )
    last_camera = camera_for(everything if framing == "run" else loaded[last][0], True)
    written["last"] = save_png(
        out / "last.png",
        painter(loaded[last], paths[last], last_camera, title=f"t = {times[-1]:.2f} s"),
    )
    return written


def _render_animation(out, animation, run, painter, camera_for, framing, view, quiet):
    """animation.<gif|mp4> of the chosen frames, framed on the run or following the cloth."""
    from tqdm.auto import tqdm

    eye, target, width, height, up, fov_degrees, colored = view
    paths, times, loaded, chosen, settings = (
        run.paths,
        run.times,
        run.loaded,
        run.chosen,
        run.settings,
    )
    painter.share_range([(loaded[k], paths[k]) for k in chosen])
    frames_shown = [loaded[k][0] for k in chosen]
    if framing == "run" or _fixed(settings, eye, target):
        cameras = [camera_for(frames_shown, True)] * len(chosen)
    else:
        full = camera_from_settings(
            settings, frames_shown[0], width, height, None, None, up, fov_degrees
        )
        inner_width, inner_height = picture_layout(full.width, full.height, colored, True)
        cameras = [
            framing_camera(inner, full.width, full.height)
            for inner in follow_cameras(
                frames_shown, inner_width, inner_height, None, full.up, full.fov_degrees
            )
        ]
    # animation frames supersampled 2× (half the cost of 3×; they are seen moving)
    images = [
        painter(loaded[k], paths[k], camera, title=f"t = {times[k]:.2f} s", antialias=2)
        for k, camera in tqdm(
            list(zip(chosen, cameras)),
            desc="yore render",
            unit="frame",
            leave=False,
            disable=quiet or None,
            delay=2.0,
        )
    ]
    spacing = np.diff([times[k] for k in chosen])
    fps = 1.0 / float(np.median(spacing)) if spacing.size and np.median(spacing) > 0 else 15.0
    return save_animation(out / f"animation.{animation}", images, fps=min(max(fps, 1.0), 50.0))


def save_panels(
    path, panels, width=480, height=400, camera=None, values=None, **render_options
) -> Path:
    """One PNG of several states side by side, titled, under one camera (fitted to all of
    them unless ``camera`` is given), so shapes compare at one scale.

    panels : list of (title, V, F) or (title, V, F, strokes); values : None, or one array of
    vertex values per panel (coloured on one scale: pass ``value_range`` to share it);
    render_options go to `yore.viz.render_image` (``value_range``, ``colormap``, ``colorbar``,
    ...)."""
    if not panels:
        raise ValueError("panels is empty: save_panels needs at least one (title, V, F)")
    if values is not None and len(values) != len(panels):
        raise ValueError(f"values has {len(values)} arrays for {len(panels)} panels")
    if camera is None:
        camera = fit_camera([np.asarray(panel[1], float) for panel in panels], width, height)
    images = [
        render_image(
            panel[1],
            panel[2],
            camera,
            strokes=panel[3] if len(panel) > 3 else (),
            **({} if values is None else {"vertex_values": values[k]}),
            **render_options,
        )
        for k, panel in enumerate(panels)
    ]
    return save_png(path, side_by_side(images, [str(panel[0]) for panel in panels]))
