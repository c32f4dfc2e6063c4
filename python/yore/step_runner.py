"""Stepping a cloth with an integrator in batches: the loop behind `yore.Simulation.step` and
`advance` — batches short enough for Ctrl-C and a live progress bar, the cloth restored to the
call's start when a step diverges or fails to factor, the wall time kept, and one warning per
call for steps accepted unconverged."""

from __future__ import annotations

import time
import warnings

from ._core import NotPositiveDefinite, SimulationDiverged
from . import progress as progress_bars

__all__ = ["BATCH_SECONDS", "StepRunner", "warn_unconverged"]

#: Wall time of one batch of steps, s: short enough for Ctrl-C and a live progress bar.
BATCH_SECONDS = 0.1


class StepRunner:
    """Runs an integrator's steps on a cloth and keeps the wall time they took
    (``wall_seconds``, every call's, including those that failed)."""

    def __init__(self):
        self.wall_seconds = 0.0

    def timed(self, work):
        """work()'s result, its wall time added to ``wall_seconds`` (raised or not)."""
        started = time.perf_counter()
        try:
            return work()
        finally:
            self.wall_seconds += time.perf_counter() - started

    def run(self, integrator, cloth, gravity, dt, steps, progress, pending_reports, clock):
        """``steps`` steps of ``dt`` in batches. A stroke's reports waiting for the next step
        (``pending_reports``, emptied here) get the re-analysis time of the first batch.
        ``clock()`` is the simulated time for the progress bar. On SimulationDiverged or
        NotPositiveDefinite the cloth goes back to where it was, and the error says so."""
        saved = (cloth.positions, cloth.velocities, cloth.time)  # copies
        analyzed_before = integrator.statistics.phases.get("analyze_seconds", 0.0)
        done, batch, bar = 0, 1, None
        started = time.perf_counter()
        try:
            while done < steps:
                count = min(batch, steps - done)
                integrator.advance(cloth, gravity, dt, count)
                if pending_reports:
                    analyzed = integrator.statistics.phases.get("analyze_seconds", 0.0)
                    for report in pending_reports:
                        report.reanalyze_seconds = analyzed - analyzed_before
                    pending_reports.clear()
                done += count
                elapsed = time.perf_counter() - started
                rate = done / max(elapsed, 1e-9)
                batch = max(1, int(rate * BATCH_SECONDS))
                if bar is None and progress is not False and done < steps:
                    bar = _bar_if_due(steps, done, rate, elapsed, progress)
                elif bar is not None:
                    bar.update(count)
                    bar.set_postfix_str(f"t={clock():.3f} s")
        except SimulationDiverged as error:
            # Batches before the failing one may already hold a growing instability: go back to
            # the state before this call, which the caller knows to be good.
            _restore(cloth, saved)
            error.args = (
                f"{error.args[0]} The cloth was restored to t = {saved[2]:.6g} s, "
                "its state before this call.",
            )
            raise
        except NotPositiveDefinite as error:
            # A step's matrix (M/dt² + the projected stiffness) failed to factor: with a dt far
            # beyond the cloth's time scales the mass term sinks below the stiffness's round-off
            _restore(cloth, saved)
            error.args = (
                f"{error.args[0]} (a step of dt = {dt:g} s from t = {saved[2]:.6g} s; a smaller "
                "dt keeps the mass term M/dt² above the stiffness's round-off). The cloth was "
                f"restored to t = {saved[2]:.6g} s.",
            )
            raise
        finally:
            self.wall_seconds += time.perf_counter() - started
            if bar is not None:
                bar.close()


def _bar_if_due(steps, done, rate, elapsed, progress):
    """A progress bar once asked for, or once the rest of the call looks long; else None. The
    rate is trusted only after a few batches (the first step also prepares)."""
    remaining = (steps - done) / rate
    if progress or (
        elapsed > 2.5 * BATCH_SECONDS and elapsed + remaining > progress_bars.AFTER_SECONDS
    ):
        return progress_bars.open_bar(steps, done, "yore", progress)
    return None


def _restore(cloth, saved) -> None:
    """Puts the cloth back to ``saved`` (positions, velocities, time)."""
    cloth.positions, cloth.velocities = saved[0], saved[1]
    cloth.time = saved[2]


def warn_unconverged(name, spec, options, counters, steps, unconverged_before) -> None:
    """One RuntimeWarning per call for the steps it accepted unconverged, if any (``counters``:
    the integrator's after the call; ``spec``: its registry row, whose ``cap`` names the
    iteration cap and the tolerance)."""
    unconverged = counters.get("unconverged_steps", 0) - unconverged_before
    if not unconverged:
        return
    # once per call: the steps were taken at their last iterate, never silently
    cap, tolerance = spec.cap
    detail = (
        f"reached the iteration cap ({cap} = {options[cap]}) before the "
        f"tolerance ({tolerance} = {options[tolerance]:g})"
    )
    if "last_error_estimate" in counters:
        detail += f" (last error estimate {counters['last_error_estimate']:.3g} mean rest lengths)"
    warnings.warn(
        f"{name}: {unconverged} of {steps} steps {detail}; "
        "they were accepted unconverged "
        "(stats['counters']['unconverged_steps'])",
        RuntimeWarning,
        stacklevel=4,
    )
