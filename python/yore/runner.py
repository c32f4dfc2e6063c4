"""Running a scene file: stepping, strokes at their times, frames, records, a summary and a state
file that continues the run exactly (what ``yore run`` does).

A run lives in one folder::

    frames/frame_00000.vtu ...   one mesh per frame (vtu, vtk, ply or obj; meshio)
    frames/frame.pvd             ParaView collection of every frame, across strokes and resumes
    summary.json                 settings, timings per phase, energies and areas per frame,
                                 stroke reports, outputs
    state.npz                    the simulation at the end (`yore run --resume` continues it)
    before_after.png, animation.gif   pictures, when the scene's [output] asks for them

Time is counted in steps: the run has round(duration / dt) steps, a stroke at time t is drawn
before step round(t / dt), and frames are written every ``frame_interval`` steps and at the end.
So a run split by ``until`` and resumed takes exactly the steps a straight run takes.
"""

from __future__ import annotations

import json
import math
import os
import time as _time
from pathlib import Path

import numpy as np

from . import metrics
from ._core import SimulationDiverged
from .io import FrameSeries, save_mesh
from .scene_file import Scene, SceneError, apply_scene_stroke, load_scene, scene_camera
from .state import load_state, save_state

__all__ = ["run_scene", "resume_run", "RunError", "RunInterrupted", "SUMMARY_NAME",
           "STATE_NAME"]

SUMMARY_NAME = "summary.json"
STATE_NAME = "state.npz"
BEFORE_NAME = "before.vtu"


class RunInterrupted(KeyboardInterrupt):
    """The run was interrupted (Ctrl-C); the state reached is saved at ``state_path`` and
    ``yore run --resume`` continues it exactly."""

    def __init__(self, state_path, time):
        super().__init__(f"interrupted at t = {time:.6g} s; state saved in {state_path}")
        self.state_path, self.time = state_path, time


class RunError(RuntimeError):
    """A run stopped (diverged, or a stroke missed at its time). The state before the failing
    call is saved; ``state_path`` says where."""

    def __init__(self, message, state_path=None):
        super().__init__(message)
        self.state_path = state_path


def run_scene(scene: Scene, out, until=None, quiet=False, render=True) -> dict:
    """Runs ``scene`` from t = 0 into folder ``out`` (created); returns the summary dict.

    until : stop at this simulated time (s) instead of the scene's duration (the state file
    then continues the run). quiet : no progress bar. render : write the pictures and the
    animation the scene's [output] asks for. Raises SceneError before anything runs when the
    scene is wrong, RunError when the run stops early (state saved).
    """
    sim, _ = scene.build()
    scene.check_strokes(sim)
    record = {"scene_text": scene.text,
              "scene_path": str(scene.path) if scene.path is not None else None,
              "overrides": scene.overrides, "step": 0, "next_stroke": 0, "frames": [],
              "records": [], "strokes": [], "before": None, "wall_seconds": 0.0,
              "resumed_from": [], "phases": {}}
    return _run(scene, sim, record, Path(os.fspath(out)), until, quiet, render)


def resume_run(state_path, out=None, until=None, quiet=False, render=True) -> dict:
    """Continues a run from its state file into ``out`` (default: the state's folder, whose
    frames and collection then simply grow); returns the summary of the whole run so far.
    The result is bit for bit that of a run that never stopped (see `yore.state` for the two
    solver options where it is only equal to solver tolerance)."""
    state_path = Path(os.fspath(state_path))
    sim, record = load_state(state_path)
    if not isinstance(record, dict) or "scene_text" not in record:
        raise ValueError(f"{state_path} is a simulation state but not a run's: it has no scene "
                         "(write run states with `yore run`)")
    scene_path = record["scene_path"]
    scene = load_scene(scene_path, text=record["scene_text"], overrides=record["overrides"])
    record["resumed_from"] = record["resumed_from"] + [str(state_path)]
    out = state_path.parent if out is None else Path(os.fspath(out))
    return _run(scene, sim, record, out, until, quiet, render)


def _run(scene, sim, record, out, until, quiet, render):
    out.mkdir(parents=True, exist_ok=True)
    data = scene.data
    dt = sim.dt
    duration = data["simulation"]["duration"]
    if until is not None:
        until = float(until)
        if not math.isfinite(until) or until <= 0:
            raise ValueError(f"until must be a positive time in seconds, got {until}")
    last_step = _steps(duration if until is None else until, dt)
    every = scene.frame_interval(dt)
    schedule = sorted(((_steps(s["time"], dt), k) for k, s in enumerate(data["strokes"])))
    fmt = data["output"]["format"]
    frames = None
    if fmt != "none":
        frames = FrameSeries(out / "frames", stem="frame", fmt=fmt,
                             frames=[(t, p) for t, p in record["frames"]])
    camera = None
    previous_phases = dict(record.get("phases", {}))  # wall time per phase of earlier parts
    live_reports = []  # (record entry, StrokeReport): re-analysis time arrives with the next step
    step = record["step"]
    last_time = record["records"][-1]["time"] if record["records"] else None
    if last_time is None or (step % every == 0 and last_time < sim.time - 0.5 * dt):
        # the first frame, or the frame an interruption came before
        _write_frame(sim, frames, record, fmt)

    from tqdm.auto import tqdm

    bar = tqdm(total=last_step, initial=min(step, last_step), unit="step", desc="yore run",
               disable=quiet or None, delay=2.0, dynamic_ncols=True, leave=False)
    started = _time.perf_counter()
    try:
        while step < last_step:
            while record["next_stroke"] < len(schedule) and \
                    schedule[record["next_stroke"]][0] <= step:
                index = schedule[record["next_stroke"]][1]
                if record["before"] is None:
                    _save_before(sim, out, record)
                if camera is None and "screen" in data["strokes"][index]:
                    camera = scene_camera(scene, sim.cloth.positions)
                report = apply_scene_stroke(scene, sim, index, camera)
                record["strokes"].append(_stroke_record(index, sim.time, report))
                live_reports.append((record["strokes"][-1], report))
                record["next_stroke"] += 1
            next_stroke = schedule[record["next_stroke"]][0] \
                if record["next_stroke"] < len(schedule) else last_step
            next_frame = (step // every + 1) * every
            target = min(next_stroke, next_frame, last_step)
            if target > step:
                sim.step(target - step, progress=False)
                bar.update(target - step)
                bar.set_postfix_str(f"t={sim.time:.3f}/{last_step * dt:.3f} s", refresh=False)
                step = target
                record["step"] = step
            if step % every == 0 or step == last_step:
                _write_frame(sim, frames, record, fmt)
    except SimulationDiverged as error:
        bar.close()
        record["wall_seconds"] += _time.perf_counter() - started
        state = _save(out, sim, record, previous_phases)
        raise RunError(f"{error} State before the failing steps: {state}", state) from None
    except KeyboardInterrupt:
        bar.close()
        record["wall_seconds"] += _time.perf_counter() - started
        # Steps completed so far, from the step-counting clock (the interruption may come
        # between batches of a call).
        record["step"] = _steps(sim.time, dt)
        state = _save(out, sim, record, previous_phases)
        raise RunInterrupted(state, sim.time) from None
    except SceneError:  # a stroke missed at its time: keep what was computed
        bar.close()
        _save(out, sim, record, previous_phases)
        raise
    except Exception:
        bar.close()
        raise
    bar.close()
    record["wall_seconds"] += _time.perf_counter() - started
    for entry, report in live_reports:
        entry["reanalyze_seconds"] = report.reanalyze_seconds
    state_path = _save(out, sim, record, previous_phases)
    summary = _summary(scene, sim, record, out, state_path)
    summary_path = out / SUMMARY_NAME
    _write_json(summary_path, summary)
    if render and frames is not None:
        from .render_run import render_run

        output = data["output"]
        if output["pictures"] or output["animation"] != "none":
            summary["outputs"].update(render_run(
                out, pictures=output["pictures"],
                animation=None if output["animation"] == "none" else output["animation"],
                color_by=output["color_by"], quiet=quiet))
            _write_json(summary_path, summary)
    return summary


def _steps(seconds, dt):
    return int(round(seconds / dt))


def _write_frame(sim, frames, record, fmt):
    cloth = sim.cloth
    V, F = cloth.positions, cloth.faces
    energy = sim.energy()
    record["records"].append({
        "time": sim.time, "kinetic": energy["kinetic"], "spring": energy["spring"],
        "gravity": energy["gravity"], "total": energy["total"],
        "area": metrics.area(V, F), "rest_area": metrics.rest_area(cloth),
        "vertices": cloth.vertex_count, "faces": cloth.face_count})
    if frames is None:
        return
    point_data = None if fmt == "obj" else {"velocity": cloth.velocities,
                                            "expansion": metrics.vertex_expansion(cloth)}
    path = frames.write(sim.time, V, F, point_data=point_data)
    record["frames"].append((sim.time, str(path.resolve())))


def _save_before(sim, out, record):
    cloth = sim.cloth
    path = out / BEFORE_NAME
    save_mesh(path, cloth.positions, cloth.faces,
              point_data={"expansion": metrics.vertex_expansion(cloth)})
    record["before"] = {"time": sim.time, "file": str(path.resolve())}


def _stroke_record(index, time, report):
    return {"stroke": index, "time": time, "faces_split": report.faces_split,
            "faces_skipped": int(len(report.faces_skipped)),
            "vertices_added": report.vertices_added, "springs_added": report.springs_added,
            "springs_removed": report.springs_removed, "area_before": report.area_before,
            "rest_area_before": report.rest_area_before,
            "rest_area_after": report.rest_area_after,
            "missed_fraction": report.missed_fraction, "locate_seconds": report.locate_seconds,
            "subdivide_seconds": report.subdivide_seconds,
            # the stroke's new vertices in the order it crossed their faces: its polyline
            "new_vertices": [int(v) for v in report.new_vertices]}


def _save(out, sim, record, previous_phases):
    phases = sim.stats["phases"]
    record["phases"] = {name: previous_phases.get(name, 0.0) + phases.get(name, 0.0)
                        for name in set(previous_phases) | set(phases)}
    return save_state(out / STATE_NAME, sim, metadata=record)


def _summary(scene, sim, record, out, state_path):
    from . import build_info

    stats = sim.stats
    settings = _jsonable(scene.data)
    settings["simulation"]["dt"] = sim.dt
    settings["integrator"] = _jsonable(sim.options)
    # Paths in the summary are relative to the run folder, so the folder can be moved.
    outputs = {"state": _relative(state_path, out), "summary": SUMMARY_NAME}
    if record["frames"]:
        outputs["frames"] = _relative(Path(record["frames"][-1][1]).parent, out)
        pvd = out / "frames" / "frame.pvd"
        if pvd.exists():
            outputs["pvd"] = _relative(pvd, out)
    before = None
    if record["before"]:
        before = {"time": record["before"]["time"],
                  "file": _relative(record["before"]["file"], out)}
        outputs["before"] = before["file"]
    return {
        "yore": build_info(),
        "scene": record["scene_path"],
        "overrides": record["overrides"],
        "resumed_from": record["resumed_from"],
        "finished": sim.time >= scene.data["simulation"]["duration"] - 0.5 * sim.dt,
        "time": sim.time,
        "steps": record["step"],
        "dt": sim.dt,
        "integrator": sim.integrator,
        "wall_seconds": record["wall_seconds"],
        # wall time per phase over the whole run (all resumed parts); counters of the last part
        "phases": record["phases"],
        "counters": _jsonable(stats["counters"]),
        "active_terms": stats["active_terms"],
        "vertices": stats["vertices"],
        "springs": stats["springs"],
        "settings": settings,
        "records": record["records"],
        "strokes": record["strokes"],
        "before": before,
        "frames": [{"time": t, "file": _relative(p, out)} for t, p in record["frames"]],
        "camera": _jsonable(scene.data["camera"]),
        "outputs": outputs,
    }


def _relative(path, folder):
    return Path(os.path.relpath(os.path.abspath(path), os.path.abspath(folder))).as_posix()


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _write_json(path, document):
    partial = path.with_name(path.name + ".part")
    partial.write_text(json.dumps(document, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    os.replace(partial, path)
