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

from .. import metrics
from ..checks import MAX_STEPS
from .._core import NotPositiveDefinite, SimulationDiverged
from ..io import FrameSeries, save_mesh
from ..options import INTEGRATOR_SPECS
from ..runtime import deferred_interrupt
from ..simulation import Simulation
from ..state import load_metadata, load_state, save_state
from .building import apply_scene_stroke, scene_camera
from .loading import Scene, load_scene, step_of
from .record import BEFORE_NAME, FRAMES_DIR, RunRecord, check_against
from .schedule import EventSchedule
from .schema import SceneError

__all__ = [
    "run_scene",
    "resume_run",
    "check_scene",
    "RunError",
    "RunInterrupted",
    "SUMMARY_NAME",
    "STATE_NAME",
]

SUMMARY_NAME = "summary.json"
STATE_NAME = "state.npz"


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
    if scene.data["simulation"]["settle"] > 0.0:
        # before t = 0 and before the folder is claimed: an interrupted settle leaves nothing
        settle = sim.settle(scene.data["simulation"]["settle"], progress=False if quiet else None)
    record = RunRecord.new(scene, settle)
    out = Path(os.fspath(out))
    claim_folder(out, record, overwrite)
    return _run(scene, sim, record, out, until, quiet, render)


def check_scene(scene, until=None, allow_long=False):
    """What a run checks of its scene before anything runs, in one place (`run_scene`, `yore
    check` and a sweep's check of its cells all call it): the cloth and simulation build,
    every stroke lies on the cloth, and the run's length is within the limit (see
    `check_length`). Returns ``(simulation, steps)``; raises SceneError or ValueError naming
    the problem."""
    sim, _ = scene.build()
    steps = check_length(scene, sim, until, allow_long)
    scene.check_strokes(sim)
    return sim, steps


def _check_pictures(scene, render):
    """Raises, before any work, what the pictures at the end would raise: no ffmpeg for an MP4,
    no EGL (`yore.viz.BackendUnavailable`) for any picture."""
    output = scene.data["output"]
    if (
        not render
        or output["format"] == "none"
        or not (output["pictures"] or output["animation"] != "none")
    ):
        return
    from ..viz import backend, check_ffmpeg

    if output["animation"] == "mp4":
        check_ffmpeg()
    backend.ensure()


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
    if record.before is not None and not (folder / record.before["file"]).is_file():
        missing.insert(0, record.before["file"])
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
    if record.next_stroke > len(scene.data["strokes"]):
        raise ValueError(
            f"{state_path}: field metadata.next_stroke: {record.next_stroke} "
            f"strokes done, but the scene has {len(scene.data['strokes'])}"
        )
    check_against(state_path, metadata, scene, sim)
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
        record.frames = [[t, _relative(folder / path, out)] for t, path in record.frames]
        if record.before is not None:
            record.before = {
                **record.before,
                "file": _relative(folder / record.before["file"], out),
            }
    _check_pictures(scene, render)
    return _run(scene, sim, record, out, until, quiet, render)


def check_length(scene, sim, until=None, allow_long=False) -> int:
    """The steps the run will take (to ``until`` or the scene's end); ValueError for an
    ``until`` that is not a time in the run, or more than `MAX_STEPS` steps without
    ``allow_long``."""
    duration = scene.data["simulation"]["duration"]
    if until is not None:
        until = float(until)
        if not math.isfinite(until) or until <= 0:
            raise ValueError(f"until must be a positive time in seconds, got {until}")
        if until > duration + 0.5 * sim.dt:
            raise ValueError(
                f"--until {until:g} s is after the scene's end "
                f"(simulation.duration = {duration:g} s)"
            )
    steps = _steps(duration if until is None else until, sim.dt)
    if steps < 1:
        raise ValueError(
            f"the run has no step: {duration if until is None else until:g} s is "
            f"less than half of dt = {sim.dt:.6g} s; give a longer "
            f"{'duration' if until is None else '--until'} or a smaller dt"
        )
    if steps > MAX_STEPS and not allow_long:
        raise ValueError(
            f"the run is {steps} steps ({duration if until is None else until:g} s "
            f"at dt = {sim.dt:.6g} s), more than the limit of {MAX_STEPS}: use a "
            "larger dt or a shorter duration, or give --allow-long"
        )
    return steps


def _set_threads(scene, threads):
    threads = scene.data["simulation"].get("threads") if threads is None else threads
    if threads is not None:
        from ..runtime import set_num_threads

        set_num_threads(threads)


#: Wall time between the state files a run saves at its frames (besides the one at its end);
#: longer once a save takes over a tenth of it (a long run's record is long).
CHECKPOINT_SECONDS = 10.0
#: Largest share of a run's wall time its periodic state files may take.
CHECKPOINT_SHARE = 0.1

#: Files a run writes into its folder (besides frames/).
RUN_FILES = (
    SUMMARY_NAME,
    STATE_NAME,
    BEFORE_NAME,
    "before_after.png",
    "last.png",
    "animation.gif",
    "animation.mp4",
)


def run_files(out) -> list:
    """The files of a yore run in folder ``out`` (its summary, state, frames, pictures), as
    paths; empty when the folder holds no run."""
    out = Path(os.fspath(out))
    found = [out / name for name in RUN_FILES if (out / name).is_file()]
    frames = out / FRAMES_DIR
    if frames.is_dir():
        found += sorted(
            p
            for p in frames.iterdir()
            if p.is_file()
            and (
                p.name.startswith("frame_") or p.name == "frame.pvd" or p.name.startswith(".frame_")
            )
        )
    return found


def claim_folder(out, record, overwrite=False) -> None:
    """Makes ``out`` ready for the run ``record`` describes (a new run, or a resumed one
    writing elsewhere). A folder holding no run is used as it is. A folder holding a run is
    cleared of that run's files (nothing else) when ``overwrite`` is true, or when it holds a
    finished run of the very same scene (scene text and overrides): running it again repeats
    it. Anything else raises ValueError saying how to continue or replace it, so frames of two
    runs never mix."""
    out = Path(os.fspath(out))
    if out.exists() and not out.is_dir():
        raise ValueError(f"output folder {out} is a file")
    found = run_files(out)
    if not found:
        return
    if not overwrite:
        previous = _previous_run(out)
        same = (
            previous is not None
            and previous.get("status") == "finished"
            and previous.get("scene_text") == record.scene_text
            and previous.get("overrides") == record.overrides
        )
        if not same:
            what = (
                "an unfinished run of the same scene"
                if previous is not None
                and previous.get("scene_text") == record.scene_text
                and previous.get("overrides") == record.overrides
                else "another run"
            )
            hint = (
                f"continue it with `yore run --resume {out / STATE_NAME}`, "
                if (out / STATE_NAME).is_file()
                else ""
            )
            raise ValueError(
                f"output folder {out} already holds {what} ({len(found)} files, "
                f"e.g. {found[0].name}); {hint}replace it with --overwrite, or "
                "choose another folder with -o"
            )
    for path in found:
        path.unlink()
    frames = out / FRAMES_DIR
    if frames.is_dir() and not any(frames.iterdir()):
        frames.rmdir()


def _previous_run(out):
    """{"status", "scene_text", "overrides"} of the run in ``out``, or None if unreadable."""
    try:
        metadata = load_metadata(out / STATE_NAME)
        # no summary: the run stopped without one (killed after a periodic state save)
        summary = (
            json.loads((out / SUMMARY_NAME).read_text(encoding="utf-8"))
            if (out / SUMMARY_NAME).is_file()
            else {"status": "unfinished"}
        )
        return {
            "status": summary.get("status"),
            "scene_text": metadata.get("scene_text"),
            "overrides": metadata.get("overrides"),
        }
    except (OSError, ValueError, AttributeError):
        return None


class _Checkpoint:
    """A point the run can go back to: the simulation's state and the extent of its record
    (lists are only appended to, so their lengths say what was recorded by then)."""

    _LISTS = ("frames", "records", "strokes")
    _SCALARS = ("step", "next_stroke", "before")

    def __init__(self, sim, record, live_reports):
        self.state = sim.state()
        self.time = sim.time
        self.lengths = {key: len(getattr(record, key)) for key in self._LISTS}
        self.scalars = {key: getattr(record, key) for key in self._SCALARS}
        self.live_reports = len(live_reports)

    def restore(self, record, live_reports):
        """Puts ``record`` back as it was; returns a new simulation in the saved state."""
        for key, length in self.lengths.items():
            del getattr(record, key)[length:]
        for key, value in self.scalars.items():
            setattr(record, key, value)
        del live_reports[self.live_reports :]
        return Simulation.from_state(self.state)


def _run(scene, sim, record, out, until, quiet, render):
    return _Run(scene, sim, record, out, until, quiet).execute(render)


class _Run:
    """One part of a run, from the record's step to ``until`` or the scene's end: strokes and
    frames at the steps of the event schedule, a state file saved on the way, then the summary.
    Whatever stops it (a divergence, a miss, Ctrl-C, no memory) leaves a state and a summary."""

    def __init__(self, scene, sim, record, out, until, quiet):
        out.mkdir(parents=True, exist_ok=True)
        self.scene, self.sim, self.record, self.out, self.quiet = scene, sim, record, out, quiet
        self.data = scene.data
        self.dt = sim.dt
        # (the callers checked the length against the limit, before anything was written)
        self.schedule = EventSchedule(
            scene, self.dt, check_length(scene, sim, until, allow_long=True)
        )
        self.fmt = self.data["output"]["format"]
        self.frames = None
        if self.fmt != "none":
            self.frames = FrameSeries(
                out / FRAMES_DIR,
                stem="frame",
                fmt=self.fmt,
                frames=[(t, out / p) for t, p in record.frames],
            )
        self.camera = None
        self.previous_phases = dict(record.phases)  # wall time per phase of earlier parts
        self.live_reports = []  # (record entry, StrokeReport): re-analysis time comes later
        self.step = record.step
        self.status, self.message = None, None  # None: ran to its last step
        self.missed = None  # the SceneError of a stroke that missed at its time
        self.phases = None  # the live simulation's phases, when a rollback replaced it
        self.good = None  # the last recorded frame's checkpoint

    def execute(self, render):
        """Runs the part; returns the summary (RunInterrupted, RunError or the miss's
        SceneError when it stopped early, its state saved)."""
        record = self.record
        last_time = record.records[-1]["time"] if record.records else None
        if last_time is None:
            bad = _non_finite(_measure(self.sim))
            if bad:
                raise ValueError(
                    f"the scene's initial state is not finite ({bad}): a value in "
                    "[material], [[driven]] or [simulation] is too large"
                )
        from tqdm.auto import tqdm

        self.started = self.saved_at = _time.perf_counter()
        self.save_every = CHECKPOINT_SECONDS
        # A state file before the first frame: from here on the folder always holds one, so an
        # interruption (or a kill) at any point leaves a run that `--resume` continues.
        with deferred_interrupt():
            _save(self.out, self.sim, record, self.previous_phases)
        last_step = self.schedule.last_step
        self.bar = tqdm(
            total=last_step,
            initial=min(self.step, last_step),
            unit="step",
            desc="yore run",
            disable=self.quiet or None,
            delay=2.0,
            dynamic_ncols=True,
            leave=False,
        )
        try:
            self._steps_and_events(last_time)
        except (SimulationDiverged, _NonFinite) as error:
            self.status, self.message = "diverged", str(error)
        except _Unsaveable as error:
            self.status, self.message = "failed", str(error)
        except MemoryError:
            self._out_of_memory()
        except NotPositiveDefinite as error:
            # the integrator put the cloth back where the failed call began
            sim = self.sim
            self.status, self.message = (
                "diverged",
                (
                    f"the {sim.integrator} integrator's linear solver refused a step's matrix after "
                    f"t = {sim.time:.6g} s ({' '.join(str(error).split())}): check for extreme "
                    "stiffnesses or masses, or try a smaller dt. The run went back to "
                    f"t = {sim.time:.6g} s"
                ),
            )
        except KeyboardInterrupt:
            self.status, self.message = "interrupted", None
            if (
                self.sim.restarts_on_resume
                and self.good is not None
                and self.sim.time != self.good.time
            ):
                # SUNDIALS' step history is not in the state: only at a frame, where the
                # straight run restarts it too, does a resumed run go on as that one would
                self.phases = self.sim.stats["phases"]
                self.sim = self.good.restore(record, self.live_reports)
            # Steps completed so far, from the step-counting clock (the interruption may come
            # between batches of a call).
            record.step = _steps(self.sim.time, self.dt)
        except SceneError as error:  # a stroke missed at its time: keep what was computed
            self.status, self.message, self.missed = "stroke missed", str(error), error
        finally:
            self.bar.close()
            record.wall_seconds += _time.perf_counter() - self.started
        return self._finish(render)

    def _steps_and_events(self, last_time):
        """Steps to the end of the part, drawing strokes and writing frames when they are due."""
        schedule = self.schedule
        if schedule.frame_due(self.step) and (
            last_time is None or last_time < self.sim.time - 0.5 * self.dt
        ):
            # the first frame, or a frame an interruption came before
            _write_frame(self.sim, self.frames, self.record, self.fmt, _measure(self.sim))
        self.good = _Checkpoint(self.sim, self.record, self.live_reports)  # the last frame's
        while self.step < schedule.last_step:
            self._draw_due_strokes()
            # (at most MAX_STEPS per call: a frame interval may be longer, with --allow-long)
            target = schedule.next_event(self.step, self.record.next_stroke, MAX_STEPS)
            if target > self.step:
                self.sim.step(target - self.step, progress=False)
                self.bar.update(target - self.step)
                self.bar.set_postfix_str(
                    f"t={self.sim.time:.3f}/{schedule.last_step * self.dt:.3f} s", refresh=False
                )
                self.step = target
                self.record.step = target
            due = schedule.frame_due(self.step)
            if due or self.step == schedule.last_step:  # (a part's end is checked, framed or not)
                entry = self._checked_measure()
                if due:
                    self._frame(entry)

    def _draw_due_strokes(self):
        """Draws every stroke due at the current step. A stroke and its record are one step:
        whatever stops it half-way (Ctrl-C, a miss, an error) puts the cloth and the record
        back as they were before it."""
        record, scene = self.record, self.scene
        while (index := self.schedule.stroke_due(self.step, record.next_stroke)) is not None:
            before_stroke = _Checkpoint(self.sim, record, self.live_reports)
            sim = self.sim
            try:
                if record.before is None:
                    _save_before(sim, self.out, record)
                if self.camera is None and "screen" in self.data["strokes"][index]:
                    self.camera = scene_camera(scene, sim.cloth.positions)
                report = apply_scene_stroke(scene, sim, index, self.camera)
                bad = _non_finite(_measure(sim))
                if bad:
                    raise _NonFinite(
                        f"stroke {index} at t = {sim.time:.6g} s made the "
                        f"cloth's energy or area non-finite ({bad}); check "
                        "its expansion. The stroke was undone"
                    )
                with deferred_interrupt():
                    record.strokes.append(_stroke_record(index, sim.time, report))
                    self.live_reports.append((record.strokes[-1], report))
                    record.next_stroke += 1
            except BaseException:
                self.phases = sim.stats["phases"]
                self.sim = before_stroke.restore(record, self.live_reports)
                raise

    def _checked_measure(self):
        """The frame record of now; _NonFinite (back at the last frame) when it is not finite."""
        entry = _measure(self.sim)
        bad = _non_finite(entry)
        if bad:
            failed = self.sim.time
            self.phases = self.sim.stats["phases"]
            good = self.good
            self.sim = sim = good.restore(self.record, self.live_reports)
            raise _NonFinite(
                f"simulation diverged between t = {good.time:.6g} s and "
                f"t = {failed:.6g} s (dt = {self.dt:.6g} s, {sim.integrator} integrator): the "
                f"cloth's energy or area became non-finite ({bad}). "
                f"{_stable_advice(sim)} The run went back to t = {good.time:.6g} s"
            )
        return entry

    def _frame(self, entry):
        """Writes a frame, makes it the point to go back to, and saves the state when due."""
        _write_frame(self.sim, self.frames, self.record, self.fmt, entry)
        self.good = _Checkpoint(self.sim, self.record, self.live_reports)
        # SUNDIALS starts afresh at every frame, where a resumed run starts it (an interrupted
        # run goes back to its last frame): straight and resumed runs take the same steps
        self.sim.restart_integrator()
        if _time.perf_counter() - self.saved_at > self.save_every:
            # a crash (or a kill) then costs at most this much of the run
            saving = _time.perf_counter()
            with deferred_interrupt():
                _save(
                    self.out,
                    self.sim,
                    self.record.with_wall_time(_time.perf_counter() - self.started),
                    self.previous_phases,
                )
            self.saved_at = _time.perf_counter()
            # the record grows with the frames: saves take at most CHECKPOINT_SHARE of the
            # wall time, so a frame costs the same at frame 100 000 as at 1
            self.save_every = max(CHECKPOINT_SECONDS, (self.saved_at - saving) / CHECKPOINT_SHARE)

    def _out_of_memory(self):
        """(CHOLMOD's out of memory is a MemoryError too) back to the last recorded frame, whose
        state is then saved: the run fails cleanly, and can continue with more memory."""
        failed = self.sim.time
        self.phases = self.sim.stats["phases"]
        if self.good is not None:
            self.sim = self.good.restore(self.record, self.live_reports)
        sim = self.sim
        back = sim.time
        self.status, self.message = (
            "failed",
            (
                f"out of memory between t = {back:.6g} s and t = {failed:.6g} s "
                f"({sim.cloth.vertex_count} vertices, {sim.integrator} integrator): the "
                'integrator\'s matrices do not fit; try integrator = "explicit", or fewer or '
                f"narrower refining strokes. The run went back to t = {back:.6g} s"
            ),
        )

    def _finish(self, render):
        """Saves the state and the summary; raises for a part that stopped early; renders."""
        sim, record, out = self.sim, self.record, self.out
        duration = self.data["simulation"]["duration"]
        if self.status is None:
            self.status = (
                "finished" if sim.time >= duration - 0.5 * self.dt else "stopped at --until"
            )
            for entry, report in self.live_reports:
                entry["reanalyze_seconds"] = report.reanalyze_seconds
        try:
            with deferred_interrupt():
                try:
                    state_path = _save(out, sim, record, self.previous_phases, self.phases)
                except _Unsaveable as error:
                    # kept from the last state file the run wrote (if any); said in the summary
                    state_path = None
                    self.status, self.message = "failed", str(error)
                summary = _summary(
                    self.scene, sim, record, out, state_path, self.status, self.message
                )
                summary_path = out / SUMMARY_NAME
                write_json(summary_path, summary)
        except KeyboardInterrupt:
            # a (second) Ctrl-C held back while the state and summary were written: they are
            # complete, so the run stops as interrupted there, with its resume hint
            raise RunInterrupted(state_path, sim.time) from None
        self._raise_if_stopped(state_path)
        if render and self.frames is not None:
            from ..viz.pictures import render_run

            output = self.data["output"]
            if output["pictures"] or output["animation"] != "none":
                summary["outputs"].update(
                    render_run(
                        out,
                        pictures=output["pictures"],
                        animation=None if output["animation"] == "none" else output["animation"],
                        color_by=output["color_by"],
                        framing=output["framing"],
                        quiet=self.quiet,
                    )
                )
                write_json(summary_path, summary)
        return summary

    def _raise_if_stopped(self, state_path):
        status, message = self.status, self.message
        if status == "interrupted":
            raise RunInterrupted(state_path, self.sim.time)
        if self.missed is not None:
            raise self.missed
        if status == "diverged":
            raise RunError(f"{message} State kept: {state_path}", state_path)
        if status == "failed":
            raise RunError(
                message if state_path is None else f"{message} State kept: {state_path}", state_path
            )


class _Unsaveable(ValueError):
    """The simulation reached a state no state file may hold (`yore.save_state` refused it).
    A ValueError: before the run starts (its first state) it is bad input."""


class _NonFinite(Exception):
    """The cloth's energy or area became non-finite: a divergence the integrators' own bound
    cannot see, because the bound itself is then infinite."""


def _stable_advice(sim):
    stable = sim.stable_dt()
    if (
        INTEGRATOR_SPECS[sim.integrator].conditionally_stable
        and math.isfinite(stable)
        and stable > 0
    ):
        return (
            f"The estimated stable time step is {stable:.3g} s: use dt <= "
            f"{0.9 * stable:.3g} s or an implicit integrator."
        )
    return f"Try a smaller dt, e.g. {sim.dt / 4:.3g} s."


_steps = step_of  # the one rounding of times to steps (Scene.check_strokes uses it too)


def _measure(sim):
    """The record of a frame: time, energies (J), area and rest area (m²), counts."""
    cloth = sim.cloth
    energy = sim.energy()
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported, not warned
        area, rest_area = metrics.area(cloth.positions, cloth.faces), metrics.rest_area(cloth)
    record = {
        "time": sim.time,
        "kinetic": energy["kinetic"],
        "spring": energy["spring"],
        "gravity": energy["gravity"],
        "total": energy["total"],
        "area": area,
        "rest_area": rest_area,
        "vertices": cloth.vertex_count,
        "faces": cloth.face_count,
    }
    if cloth.bending == "quadratic":  # (part of total; recorded for the cloths that have it)
        record["bending"] = energy["bending"]
    if cloth.stretch == "membrane":  # likewise
        record["membrane"] = energy["membrane"]
        record["membrane_collapsed_faces"] = int(cloth.membrane_status()["collapsed_faces"])
    return record


def _non_finite(entry):
    """'name value, ...' of the non-finite quantities of a `_measure` record ('' if none)."""
    return ", ".join(
        f"{name} {value}"
        for name, value in entry.items()
        if isinstance(value, float) and not math.isfinite(value)
    )


def _write_frame(sim, frames, record, fmt, entry):
    """Writes the frame file (atomically), then records it: an interruption before the record
    is complete leaves no trace in the record, and the resumed run writes the frame again."""
    cloth = sim.cloth
    with deferred_interrupt():
        if frames is not None:
            point_data = (
                None
                if fmt == "obj"
                else {"velocity": cloth.velocities, "expansion": metrics.vertex_expansion(cloth)}
            )
            path = frames.write(sim.time, cloth.positions, cloth.faces, point_data=point_data)
            # relative to the run folder, so the folder can be moved
            record.frames.append((sim.time, _relative(path, frames.folder.parent)))
        record.records.append(entry)


def _save_before(sim, out, record):
    cloth = sim.cloth
    path = out / BEFORE_NAME
    save_mesh(
        path,
        cloth.positions,
        cloth.faces,
        point_data={"expansion": metrics.vertex_expansion(cloth)},
    )
    record.before = {"time": sim.time, "file": BEFORE_NAME}  # relative to the run folder


def _stroke_record(index, time, report):
    return {
        "stroke": index,
        "time": time,
        "faces_split": report.faces_split,
        "faces_skipped": int(len(report.faces_skipped)),
        "vertices_added": report.vertices_added,
        "springs_added": report.springs_added,
        "springs_removed": report.springs_removed,
        "area_before": report.area_before,
        "rest_area_before": report.rest_area_before,
        "rest_area_after": report.rest_area_after,
        "missed_fraction": report.missed_fraction,
        "locate_seconds": report.locate_seconds,
        "subdivide_seconds": report.subdivide_seconds,
        "growth": report.growth,
        "width": report.width,
        "refine": report.refine,
        "faces_refined": report.faces_refined,
        "faces_bisected": report.faces_bisected,
        "springs_grown": report.springs_grown,
        "rest_length_added": report.rest_length_added,
        "mass_added": report.mass_added,
        "new_vertices": [int(v) for v in report.new_vertices],
        "region_faces": [int(f) for f in report.region_faces],
        # vertices along the stroke in stroke order: its polyline in pictures (the paper's
        # new vertices in the order it crossed their faces)
        "line_vertices": [int(v) for v in report.line_vertices],
    }


def _save(out, sim, record, previous_phases, phases=None):
    """Saves the state with the record; ``phases``: this part's wall time per phase (default:
    ``sim``'s, unless a rollback replaced the simulation that ran)."""
    phases = sim.stats["phases"] if phases is None else phases
    record.phases = {
        name: previous_phases.get(name, 0.0) + phases.get(name, 0.0)
        for name in set(previous_phases) | set(phases)
    }
    try:
        return save_state(out / STATE_NAME, sim, metadata=_finite_json(record.to_dict())[0])
    except ValueError as error:
        raise _Unsaveable(
            f"the run stopped at t = {sim.time:.6g} s: {error}. Nothing can "
            "continue it; check the scene's extreme values"
        ) from None


def _summary(scene, sim, record, out, state_path, status, message):
    from ..runtime import build_info

    stats = sim.stats
    # the scene as run (copied into JSON types by _finite_json below)
    settings = {
        **scene.data,
        "simulation": {**scene.data["simulation"], "dt": sim.dt},
        "integrator": sim.options,
    }
    # Paths in the summary are relative to the run folder, so the folder can be moved.
    outputs = {
        "state": None if state_path is None else _relative(state_path, out),
        "summary": SUMMARY_NAME,
    }
    if record.frames:
        outputs["frames"] = _relative((out / record.frames[-1][1]).parent, out)
        pvd = out / "frames" / "frame.pvd"
        if pvd.exists():
            outputs["pvd"] = _relative(pvd, out)
    before = None
    if record.before:
        before = {
            "time": record.before["time"],
            "file": _relative(out / record.before["file"], out),
        }
        outputs["before"] = before["file"]
    summary = {
        "yore": build_info(),
        # finished | stopped at --until | interrupted | diverged | stroke missed | failed
        "status": status,
        "message": message,
        "scene": record.scene_path,
        "overrides": record.overrides,
        "resumed_from": record.resumed_from,
        "finished": sim.time >= scene.data["simulation"]["duration"] - 0.5 * sim.dt,
        "time": sim.time,
        "steps": record.step,
        "dt": sim.dt,
        "integrator": sim.integrator,
        "wall_seconds": record.wall_seconds,
        # wall time per phase over the whole run (all resumed parts); counters of the last part
        "phases": record.phases,
        "counters": stats["counters"],
        "active_terms": stats["active_terms"],
        "vertices": stats["vertices"],
        "springs": stats["springs"],
        "settings": settings,
        "records": record.records,
        "strokes": record.strokes,
        # relaxation to rest before t = 0 ([simulation] settle), or null
        "settle": record.settled(),
        "before": before,
        "frames": [{"time": t, "file": _relative(out / p, out)} for t, p in record.frames],
        "camera": scene.data["camera"],
        "outputs": outputs,
    }
    summary, non_finite = _finite_json(summary)
    # JSON has no inf or nan: such a number is written as null, and listed here with its value
    summary["non_finite"] = non_finite
    return summary


def _relative(path, folder):
    return Path(os.path.relpath(os.path.abspath(path), os.path.abspath(folder))).as_posix()


def _finite_json(value, where=""):
    """(a copy of ``value`` in JSON types — numpy arrays and scalars as lists and numbers, keys
    as text — with every non-finite float replaced by None, [{"field": dotted name, "value":
    "inf" | "-inf" | "nan"}, ...])."""
    found = []

    def visit(item, name):
        if isinstance(item, dict):
            return {
                str(key): visit(child, f"{name}.{key}" if name else str(key))
                for key, child in item.items()
            }
        if isinstance(item, np.ndarray):
            item = item.tolist()
        elif isinstance(item, np.generic):
            item = item.item()
        if isinstance(item, (list, tuple)):
            return [visit(child, f"{name}.{index}") for index, child in enumerate(item)]
        if isinstance(item, float) and not math.isfinite(item):
            found.append({"field": name, "value": repr(item)})
            return None
        return item

    return visit(value, where), found


def write_json(path, document):
    partial = path.with_name(path.name + ".part")
    partial.write_text(json.dumps(document, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    os.replace(partial, path)
