"""Pictures of runs and frames (what ``yore render`` and the end of ``yore run`` do).

A run folder (see `yore.runs.runner`) gives: ``before_after.png`` — the cloth just before the first
stroke (or at t = 0 without strokes) next to the last frame, as in the paper's figures, with
the strokes in red — ``last.png``, and an animation of all frames (``animation.gif``, or
``.mp4`` where ffmpeg is installed). One camera fits every frame, so nothing jumps.
A single frame file gives one PNG.

Strokes are drawn through their new vertices (in the order the stroke crossed their faces) at
the frame's positions, so the red line follows the cloth as it moves. ``color_by="expansion"``
colours faces by the mean rest-length expansion of their corners (1 = untouched, stroke
regions ≈ 1.05–1.1), which frames store as point data (not in OBJ files).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from .io import load_frame
from .render import (check_ffmpeg, fit_camera, render_image, save_animation, save_png,
                     side_by_side)
from .stroke import Camera

__all__ = ["render_run", "render_frame", "camera_from_settings"]

#: Longest animation, in frames; longer runs use every k-th frame.
MAX_ANIMATION_FRAMES = 300


def _read_frame(path):
    """(V, F, point_data) of a mesh file; ValueError naming the file when it cannot be read
    (`yore.io.load_frame`: regular files of bounded size only, any meshio failure caught)."""
    path = Path(path)
    try:
        return load_frame(path)
    except FileNotFoundError:
        raise ValueError(f"frame file {path} does not exist") from None


def _face_values(F, point_data, color_by, path):
    if color_by in (None, "none"):
        return None
    if color_by != "expansion":
        raise ValueError(f"color_by must be 'none' or 'expansion', got {color_by!r}")
    if "expansion" not in point_data:
        raise ValueError(f"frame {path} has no 'expansion' point data to colour by (OBJ files "
                         "cannot hold it; write VTU, VTK or PLY frames)")
    values = np.asarray(point_data["expansion"], dtype=np.float64).reshape(-1)
    return values[F].mean(axis=1)


def _stroke_lines(strokes, V):
    """Polylines of the strokes whose vertices exist in a frame with these positions."""
    lines = []
    for stroke in strokes:
        # runs recorded before line_vertices existed drew their (paper) new vertices
        vertices = np.asarray(stroke.get("line_vertices", stroke["new_vertices"]),
                              dtype=np.int64)
        if vertices.size >= 1 and vertices.max() < len(V):
            lines.append(V[vertices])
    return lines


def camera_from_settings(settings, points, width=None, height=None, eye=None, target=None):
    """A camera from [camera] settings (a scene's table, or a run summary's copy of it):
    eye and target as given, else fitted to ``points`` (one (k, 3) array or a list of them);
    the arguments, when given, override the settings."""
    settings = settings or {}
    width = int(width or settings.get("width", 800))
    height = int(height or settings.get("height", 600))
    up = tuple(settings.get("up", (0.0, 1.0, 0.0)))
    fov = float(settings.get("fov_degrees", 35.0))
    fitted = fit_camera(points, width=width, height=height, up=up, fov_degrees=fov)
    eye = eye if eye is not None else settings.get("eye")
    target = target if target is not None else settings.get("target")
    return Camera(eye=tuple(fitted.eye if eye is None else eye),
                  target=tuple(fitted.target if target is None else target), up=up,
                  fov_degrees=fov, width=width, height=height)


def _scene_color_by(summary):
    """The [output] color_by of the run a summary describes ("none" without one)."""
    output = ((summary or {}).get("settings") or {}).get("output") or {}
    return output.get("color_by", "none")


def _load_summary(folder):
    path = Path(folder) / "summary.json"
    if not path.is_file():
        return None
    return json.loads(path.read_text(encoding="utf-8"))


def render_frame(frame, out=None, width=None, height=None, color_by=None, eye=None,
                 target=None) -> Path:
    """One PNG of a frame file (default: next to it, same name, .png). Strokes of the run are
    drawn when the frame lies in a run folder (its summary.json beside it or one level up);
    ``color_by`` None takes the run's [output] color_by ("none" outside a run)."""
    frame = Path(os.fspath(frame))
    V, F, point_data = _read_frame(frame)
    summary = _load_summary(frame.parent) or _load_summary(frame.parent.parent)
    color_by = _scene_color_by(summary) if color_by is None else color_by
    camera = camera_from_settings((summary or {}).get("camera"), V, width, height, eye, target)
    image = render_image(V, F, camera, face_values=_face_values(F, point_data, color_by, frame),
                         strokes=_stroke_lines((summary or {}).get("strokes", []), V))
    return save_png(frame.with_suffix(".png") if out is None else Path(os.fspath(out)), image)


def render_run(run_dir, pictures=True, animation="gif", color_by=None, width=None,
               height=None, out=None, eye=None, target=None, quiet=False) -> dict:
    """Pictures of a run folder: before_after.png and last.png (``pictures``) and
    animation.<gif|mp4> (``animation``, None for none) into ``out`` (default the run folder);
    ``color_by`` None takes the run's [output] color_by. Returns {name: path relative to the
    run folder or absolute}. Raises ValueError when the folder holds no run, or before any
    work when an MP4 is asked for and ffmpeg is not on the PATH."""
    run_dir = Path(os.fspath(run_dir))
    if animation == "mp4":
        check_ffmpeg()
    summary = _load_summary(run_dir)
    if summary is None:
        raise ValueError(f"{run_dir} is not a run folder (no summary.json); give a frame file "
                         "or the -o folder of `yore run`")
    color_by = _scene_color_by(summary) if color_by is None else color_by
    frames = summary.get("frames") or []
    if not frames:
        raise ValueError(f"the run in {run_dir} wrote no frames (output.format = 'none')")
    if animation not in (None, "gif", "mp4"):
        raise ValueError(f"animation must be 'gif', 'mp4' or None, got {animation!r}")
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
    before_mesh = _read_frame(run_dir / before["file"]) if before else loaded[0]
    strokes = summary.get("strokes", [])

    def picture(mesh, path, camera):
        V, F, point_data = mesh
        return render_image(V, F, camera, face_values=_face_values(F, point_data, color_by, path),
                            strokes=_stroke_lines(strokes, V))

    written = {}
    if pictures:
        # fitted to the two states shown, so they fill the picture
        camera = camera_from_settings(summary.get("camera"),
                                      [before_mesh[0], loaded[len(paths) - 1][0]], width,
                                      height, eye, target)
        last = picture(loaded[len(paths) - 1], paths[-1], camera)
        first = picture(before_mesh, run_dir / before["file"] if before else paths[0], camera)
        first_title = (f"before the stroke, t = {before['time']:.2f} s" if before
                       else f"t = {times[0]:.2f} s")
        written["before_after"] = save_png(
            out / "before_after.png",
            side_by_side([first, last], titles=[first_title, f"t = {times[-1]:.2f} s"]))
        written["last"] = save_png(out / "last.png", last)
    if animation:
        from tqdm.auto import tqdm

        # one camera for every frame, so nothing jumps
        camera = camera_from_settings(summary.get("camera"),
                                      [mesh[0] for mesh in loaded.values()], width, height,
                                      eye, target)
        images = [picture(loaded[k], paths[k], camera)
                  for k in tqdm(chosen, desc="yore render", unit="frame", leave=False,
                                disable=quiet or None, delay=2.0)]
        spacing = np.diff([times[k] for k in chosen])
        fps = 1.0 / float(np.median(spacing)) if spacing.size and np.median(spacing) > 0 else 15.0
        written["animation"] = save_animation(out / f"animation.{animation}", images,
                                              fps=min(max(fps, 1.0), 50.0))
    return {name: (Path(os.path.relpath(path, run_dir)).as_posix() if out == run_dir
                   else str(path)) for name, path in written.items()}
