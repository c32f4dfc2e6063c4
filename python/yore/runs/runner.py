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

import math
import os
from pathlib import Path

from ..state import load_state
from .folder import STATE_NAME, SUMMARY_NAME, claim_folder, run_files  # noqa: F401
from .loading import Scene, load_scene, step_of
from .output import relative_path, write_json  # noqa: F401  (the demo writes with write_json)
from .record import Before, RunRecord, check_against
from .stepping import RunError, RunInterrupted, run_part, check_length

__all__ = [
    "run_scene",
    "resume_run",
    "check_scene",
    "RunError",
    "RunInterrupted",
    "SUMMARY_NAME",
    "STATE_NAME",
]

_steps = step_of  # the one rounding of times to steps (Scene.check_strokes uses it too)


def run_scene(
    scene: Scene,
    out,
    until=None,
    quiet=False,
    render=True,
    overwrite=False,
    threads=None,
    allow_long=False,
) -> dict:
    """Runs ``scene`` from t = 0 into folder ``out`` (created); returns the summary dict.

    until : stop at this simulated time (s) instead of the scene's duration (the state file
    then continues the run). quiet : no progress bar. render : write the pictures and the
    animation the scene's [output] asks for. overwrite : replace a run that ``out`` already
    holds (without it, a folder holding another run, or an unfinished one, is refused: see
    `claim_folder`). threads : `yore.set_num_threads` for the run (default: the scene's
    [simulation] threads, else left as it is). allow_long : allow a run of more than
    `yore.checks.MAX_STEPS` steps (see `check_length`). Raises SceneError before anything runs when the
    scene is wrong, ValueError when ``out`` holds another run, RunError when the run stops early
    (state saved).
    """
    _set_threads(scene, threads)
    sim, _ = check_scene(scene, until, allow_long)
    _check_pictures(scene, render)
    settle = None
    if scene.data.simulation.settle > 0.0:
        # before t = 0 and before the folder is claimed: an interrupted settle leaves nothing
        settle = sim.settle(scene.data.simulation.settle, progress=False if quiet else None)
    record = RunRecord.new(scene, settle)
    out = Path(os.fspath(out))
    claim_folder(out, record, overwrite)
    return run_part(scene, sim, record, out, until, quiet, render)


def check_scene(scene, until=None, allow_long=False):
    """What a run checks of its scene before anything runs, in one place (`run_scene`, `yore
    check` and a sweep's check of its cells all call it): the cloth and simulation build,
    every stroke lies on the cloth, and the run's length is within the limit (see
    `check_length`). An explicit scene that leaves its dt to the default runs at the default
    step of its cloth after the strokes tried here (`Scene.check_strokes`): a run keeps its
    step, and a refining stroke lowers the stable one (issue 53, R09). Returns
    ``(simulation, steps)``; raises SceneError or ValueError naming the problem."""
    sim, _ = scene.build()
    steps = check_length(scene, sim, until, allow_long)
    lowered = scene.check_strokes(sim)
    if lowered is not None:
        sim, _ = scene.build(dt=_on_frame_grid(scene, lowered))
        steps = check_length(scene, sim, until, allow_long)
    return sim, steps


def _on_frame_grid(scene, dt):
    """``dt`` lowered to the next step that divides the frame interval 1/fps a whole number of
    times, so the frames of a run whose step the strokes chose fall on their times (a step
    at most a fraction 1/k smaller, k the steps a frame); as it is when frames are counted in
    steps or there are none."""
    output = scene.data.output
    if output.every_steps is not None or not output.fps > 0.0:
        return dt
    interval = 1.0 / output.fps
    steps = math.ceil(interval / dt * (1.0 - 1e-12))
    return interval / steps if steps < 2**52 else dt


def _check_pictures(scene, render):
    """Raises, before any work, what the pictures at the end would raise: no ffmpeg for an MP4,
    no EGL (`yore.viz.BackendUnavailable`) for any picture."""
    output = scene.data.output
    if not render or output.format == "none" or not (output.pictures or output.animation != "none"):
        return
    from ..viz import backend, check_ffmpeg

    if output.animation == "mp4":
        check_ffmpeg()
    backend.ensure()


# over 60 lines: 8 keyword parameters and their documentation (the code is 51 lines)
def resume_run(
    state_path,
    out=None,
    until=None,
    quiet=False,
    render=True,
    overwrite=False,
    threads=None,
    allow_long=False,
) -> dict:
    """Continues a run from its state file into ``out`` (default: the state's folder, whose
    frames and collection then simply grow); returns the summary of the whole run so far.
    The result is bit for bit that of a run that never stopped (see `yore.state` for the
    solver options where it is only equal to solver tolerance). Every frame the run's record
    lists must still exist (ValueError otherwise). An ``out`` other than the state's folder is
    claimed as by `run_scene` (``overwrite`` replaces a run it holds); ``threads`` as there."""
    state_path = Path(os.fspath(state_path))
    sim, metadata = load_state(state_path)
    if not isinstance(metadata, dict) or "scene_text" not in metadata:
        raise ValueError(
            f"{state_path} is a simulation state but not a run's: it has no scene "
            "(write run states with `yore run`)"
        )
    record = RunRecord.from_metadata(state_path, metadata)
    folder = state_path.parent  # the record's paths are relative to it (absolute in old files)
    missing = [path for _, path in record.frames if not (folder / path).is_file()]
    if record.before is not None and not (folder / record.before.file).is_file():
        missing.insert(0, record.before.file)
    if missing:
        raise ValueError(
            f"{state_path}: the run's record lists {len(missing)} file(s) that no "
            f"longer exist, e.g. {missing[0]}; put them back, or start the run "
            "again with --overwrite"
        )
    scene = load_scene(record.scene_path, text=record.scene_text, overrides=record.overrides)
    if record.step != _steps(sim.time, sim.dt):
        raise ValueError(
            f"{state_path}: field metadata.step: {record.step} does not match "
            f"the state's clock ({_steps(sim.time, sim.dt)} steps)"
        )
    if record.next_stroke > len(scene.data.strokes):
        raise ValueError(
            f"{state_path}: field metadata.next_stroke: {record.next_stroke} "
            f"strokes done, but the scene has {len(scene.data.strokes)}"
        )
    check_against(state_path, record, scene, sim)
    _set_threads(scene, threads)
    check_length(scene, sim, until, allow_long)
    if until is not None and _steps(float(until), sim.dt) <= record.step:
        raise ValueError(
            f"--until {float(until):g} s is not after the state's time "
            f"(t = {sim.time:.6g} s): the run is already there; give a later "
            "time, or none to run to the scene's end"
        )
    record.resumed_from = record.resumed_from + [str(state_path)]
    if out is None or Path(os.fspath(out)).resolve() == folder.resolve():
        out = folder
    else:
        out = Path(os.fspath(out))
        claim_folder(out, record, overwrite)
        # the frames and the before picture stay where they are: relative to the new folder
        record.frames = [[t, relative_path(folder / path, out)] for t, path in record.frames]
        if record.before is not None:
            file = relative_path(folder / record.before.file, out)
            record.before = Before(record.before.time, file)
    _check_pictures(scene, render)
    return run_part(scene, sim, record, out, until, quiet, render)


def _set_threads(scene, threads):
    threads = scene.data.simulation.threads if threads is None else threads
    if threads is not None:
        from ..runtime import set_num_threads

        set_num_threads(threads)
