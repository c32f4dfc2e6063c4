"""One part of a run, stepped (`yore.runs.runner` starts it): strokes and frames at the steps
of the event schedule, state files saved on the way, the summary at the end, and the exceptions
a stopped run raises."""

from __future__ import annotations

import math
import time as _time

from .._core import NotPositiveDefinite, SimulationDiverged
from ..checks import MAX_STEPS
from ..io import FrameSeries
from ..runtime import deferred_interrupt
from ..simulation import Simulation
from .building import apply_scene_stroke, scene_camera
from .folder import SUMMARY_NAME
from .loading import step_of
from .output import (
    measure_frame,
    non_finite_names,
    NonFiniteEnergy,
    save_run_state,
    save_before,
    stable_advice,
    stroke_record,
    run_summary,
    UnsaveableState,
    write_frame,
    write_json,
)
from .record import FRAMES_DIR
from .schedule import EventSchedule
from .schema import SceneError

_steps = step_of  # the one rounding of times to steps (Scene.check_strokes uses it too)


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


#: Wall time between the state files a run saves at its frames (besides the one at its end);
#: longer once a save takes over a tenth of it (a long run's record is long).
CHECKPOINT_SECONDS = 10.0
#: Largest share of a run's wall time its periodic state files may take.
CHECKPOINT_SHARE = 0.1


def check_length(scene, sim, until=None, allow_long=False) -> int:
    """The steps the run will take (to ``until`` or the scene's end); ValueError for an
    ``until`` that is not a time in the run, or more than `MAX_STEPS` steps without
    ``allow_long``."""
    duration = scene.data.simulation.duration
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


def run_part(scene, sim, record, out, until, quiet, render):
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
        self.fmt = self.data.output.format
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
        last_time = record.records[-1].time if record.records else None
        self._start(last_time)
        try:
            self._steps_and_events(last_time)
        except (SimulationDiverged, NonFiniteEnergy) as error:
            self.status, self.message = "diverged", str(error)
        except UnsaveableState as error:
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
            self._interrupted()
        except SceneError as error:  # a stroke missed at its time: keep what was computed
            self.status, self.message, self.missed = "stroke missed", str(error), error
        finally:
            self.bar.close()
            record.wall_seconds += _time.perf_counter() - self.started
        return self._finish(render)

    def _start(self, last_time):
        """Before the first step: the initial state checked (a new run), a state file saved,
        the progress bar."""
        if last_time is None:
            bad = non_finite_names(measure_frame(self.sim))
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
            save_run_state(self.out, self.sim, self.record, self.previous_phases)
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

    def _interrupted(self):
        """A Ctrl-C: the record's step from the clock, and for SUNDIALS the last frame."""
        self.status, self.message = "interrupted", None
        if (
            self.sim.restarts_on_resume
            and self.good is not None
            and self.sim.time != self.good.time
        ):
            # SUNDIALS' step history is not in the state: only at a frame, where the
            # straight run restarts it too, does a resumed run go on as that one would
            self.phases = self.sim.stats.phases
            self.sim = self.good.restore(self.record, self.live_reports)
        # Steps completed so far, from the step-counting clock (the interruption may come
        # between batches of a call).
        self.record.step = _steps(self.sim.time, self.dt)

    def _steps_and_events(self, last_time):
        """Steps to the end of the part, drawing strokes and writing frames when they are due."""
        schedule = self.schedule
        if schedule.frame_due(self.step) and (
            last_time is None or last_time < self.sim.time - 0.5 * self.dt
        ):
            # the first frame, or a frame an interruption came before
            write_frame(self.sim, self.frames, self.record, self.fmt, measure_frame(self.sim))
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
                    save_before(sim, self.out, record)
                if self.camera is None and self.data.strokes[index].screen is not None:
                    self.camera = scene_camera(scene, sim.cloth.positions)
                report = apply_scene_stroke(scene, sim, index, self.camera)
                bad = non_finite_names(measure_frame(sim))
                if bad:
                    raise NonFiniteEnergy(
                        f"stroke {index} at t = {sim.time:.6g} s made the "
                        f"cloth's energy or area non-finite ({bad}); check "
                        "its expansion. The stroke was undone"
                    )
                with deferred_interrupt():
                    record.strokes.append(stroke_record(index, sim.time, report))
                    self.live_reports.append((record.strokes[-1], report))
                    record.next_stroke += 1
            except BaseException:
                self.phases = sim.stats.phases
                self.sim = before_stroke.restore(record, self.live_reports)
                raise

    def _checked_measure(self):
        """The frame record of now; NonFiniteEnergy (back at the last frame) when it is not finite."""
        entry = measure_frame(self.sim)
        bad = non_finite_names(entry)
        if bad:
            failed = self.sim.time
            self.phases = self.sim.stats.phases
            good = self.good
            self.sim = sim = good.restore(self.record, self.live_reports)
            raise NonFiniteEnergy(
                f"simulation diverged between t = {good.time:.6g} s and "
                f"t = {failed:.6g} s (dt = {self.dt:.6g} s, {sim.integrator} integrator): the "
                f"cloth's energy or area became non-finite ({bad}). "
                f"{stable_advice(sim)} The run went back to t = {good.time:.6g} s"
            )
        return entry

    def _frame(self, entry):
        """Writes a frame, makes it the point to go back to, and saves the state when due."""
        write_frame(self.sim, self.frames, self.record, self.fmt, entry)
        self.good = _Checkpoint(self.sim, self.record, self.live_reports)
        # SUNDIALS starts afresh at every frame, where a resumed run starts it (an interrupted
        # run goes back to its last frame): straight and resumed runs take the same steps
        self.sim.restart_integrator()
        if _time.perf_counter() - self.saved_at > self.save_every:
            # a crash (or a kill) then costs at most this much of the run
            saving = _time.perf_counter()
            with deferred_interrupt():
                save_run_state(
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
        self.phases = self.sim.stats.phases
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
        duration = self.data.simulation.duration
        if self.status is None:
            self.status = (
                "finished" if sim.time >= duration - 0.5 * self.dt else "stopped at --until"
            )
            for entry, report in self.live_reports:
                entry.update(reanalyze_seconds=report.reanalyze_seconds)
        try:
            with deferred_interrupt():
                try:
                    state_path = save_run_state(out, sim, record, self.previous_phases, self.phases)
                except UnsaveableState as error:
                    # kept from the last state file the run wrote (if any); said in the summary
                    state_path = None
                    self.status, self.message = "failed", str(error)
                summary = run_summary(
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

            output = self.data.output
            if output.pictures or output.animation != "none":
                summary["outputs"].update(
                    render_run(
                        out,
                        pictures=output.pictures,
                        animation=None if output.animation == "none" else output.animation,
                        color_by=output.color_by,
                        framing=output.framing,
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
