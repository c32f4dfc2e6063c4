"""Where implicit integration overtakes explicit at equal accuracy: the crossover, one cell per
Dask task on the `yore.sweep` engine.

    python -m benchmarks.crossover [--out bench-results] [--quick] [--workers N]
        [--scheduler tcp://host:8786] [--resume] [--repeats 3] [--sizes 32 64 128]
        [--stiffness 2e3 2e4 2e5 2e6 2e7] [--bending equal soft "real cloth"]
        [--families NAME ...] [--max-run-seconds 120] [--max-ratio 8]
        [--max-reference-seconds 1800] [--max-cell-seconds 3600] [--collect]
        [--merge EARLIER.json ...]

Cells. One cell is one (size, stretch stiffness, bending row) combination, and one Dask task:
`yore.sweep.run(..., cell_function=crossover_cell)` runs them (a local cluster of --workers
one-thread processes, or the cluster at --scheduler), writes each finished cell's record as it
comes (OUT/sweeps/crossover/cells/ID.json) and the Dataset OUT/sweeps/crossover/results.nc
(dimensions size × stiffness × bending; the cell's summary numbers as variables; its runs, as
JSON, in its `message`). --resume runs only the cells that folder does not hold yet, with the
settings it was started with (its scene.toml; the grid and budget flags are then ignored).
Sizes and stiffnesses run largest first, so the longest cells start first. On a local cluster
each cell also keeps a journal of its finished runs (OUT/sweeps/crossover/journal/CELL/, one
record per run, written after it): a cell stopped part-way replays them under --resume and goes
on from the run it was on; a recorded cell's journal is removed.

- The sheet: `yore.scenes.hanging_cloth(resolution=N, pin_spacing=1.0, mass=0.1)`, an N × N
  *vertex* grid of a 1 m square, 0.1 kg in all, starting flat and horizontal between its two
  pinned corners, with the scenes' damping and drag; N ∈ {32, 64, 128}, stretch stiffness
  k ∈ {2e3, 2e4, 2e5, 2e6, 2e7} N/m.
- Bending rows: "equal" (bending springs of k, the paper's single constant), "soft" (bending
  springs of 200 N/m), "real cloth" (bending="quadratic", bending_modulus = 1e-5 N·m: a light
  cotton's bending rigidity, Kawabata B ≈ 0.1 gf·cm²/cm = 0.1 × 9.81e-3 N × 1e-4 m² / 1e-2 m
  ≈ 9.8e-6 N·m).
- Horizon T (speed_vs_error's, for its reasons): 0.25 s at 32² and 64² with equal bending;
  0.125 s at 128² (explicit's runs, and its reference, cost ∝ N³·√k·T) and with soft or real
  cloth bending, whose sheet buckles and makes a later state too sensitive to the step for a
  reference to converge (measured: 0.5 s is not convergeable at 32²; the real cloth row is
  softer still).

Families: one table, FAMILIES (display name → `yore.Simulation` options), filtered by what this
build accepts (`available_families`: a family whose options `yore.Simulation` refuses is left
out and named with the reason), so a new variant needs only a row. --quick runs QUICK_FAMILIES.
The rows "at tolerance" (`benchmarks.tolerance`: TR-BDF2 and BDF2 with dt="auto" and CVODE at
rtol 1e-2, 1e-3, 1e-4) are families too, each one run with output at T/2 and T only; per cell
`at_tolerance` holds what is read off them (slope against rtol, factorizations per internal
step, cost at equal error) and `at_tolerance_verdicts` the cheapest of them over the cheapest
fixed-step run at each judged threshold.

Inside each cell, the rules of the careful benchmark this replaces (speed_vs_error):

- Cost: CPU seconds of the stepping only, per simulated second, on the per-thread CPU clock
  (`time.thread_time()`). A cell runs in a Dask worker process that also runs the worker's own
  threads (its event loop, heartbeats, transfers); the process clock would charge their CPU to
  the cell, the thread clock does not. The cell pins yore (and so CHOLMOD's BLAS) to one thread
  (`yore.set_num_threads(1)`; the local cluster also pins OpenMP and OpenBLAS), so the stepping
  runs entirely on the task's thread and the thread clock holds all of it; each cell records
  its process CPU too (`cell_process_cpu_seconds`) beside the thread CPU, to show the gap. Wall
  time is never the measure: it counts whatever else shares the core.
- Explicit (symplectic Euler) at its largest stable step: short trials (SEARCH_STEPS steps;
  divergence = `yore.SimulationDiverged`) bracket the step from `Simulation.stable_dt()` by
  SEARCH_FACTOR and bisect it SEARCH_BISECTIONS times (known to ~2.5 %); then the whole
  interval confirms it (diverged, or error > BLOW_UP_ERROR: the step is cut by 5 % and tried
  again). Its ladder adds the reference chain's coarser runs.
- Reference: explicit at half the trial limit, halved (one more run each time) until it and the
  run at twice its step agree to REFERENCE_TOLERANCE (1e-4, a tenth of the smallest threshold),
  at most MAX_REFERENCE_HALVINGS times and while one more run fits --max-reference-seconds. A
  cell whose reference does not converge says so (reference_converged = false). A threshold t
  is judged only where the reference's last difference is at most REFERENCE_FRACTION × t (a
  tenth of it): a cell whose reference stalls at 5e-4 (a buckling sheet whose late motion
  round-off steers) is compared at 1 % and left out at 0.1 % (`reference_too_coarse`), of the
  summary, the map and the targets alike. `benchmarks.sensitivity` measures each cell's floor
  (how far a start moved by round-off ends up) and gives floor-aware verdicts beside these.
- Error: RMS vertex distance to the reference at T/2 and at T, each over the cloth's
  bounding-box diagonal at the start (√2 m); a run's error is the larger of the two.
- Implicit families run a ladder dt = 1/32 … 1/1024 s (--quick: … 1/128), stopping once a run
  reaches 0.1 % and the next one costs more; an error-controlled family runs once. Per-step
  figures count the steps taken (an error-controlled run's internal steps).
- Repeats: every run that could be its family's cheapest at 1 % or 0.1 % (it meets the
  threshold and costs at most REPEAT_MARGIN × the family's cheapest single run that does) runs
  --repeats times in all; its cost is the median. Other runs ran once and say so (`repeats`).
- Budgets: a run is aborted once its CPU time, or its time extrapolated from the steps done,
  exceeds min(--max-run-seconds, --max-ratio × explicit's cost) (`aborted`, with the reason and
  the extrapolated cost); a family's ladder stops after two aborted runs in a row. A cell whose
  explicit runs alone (limit, repeats, reference pair) would exceed --max-cell-seconds,
  predicted from the stability trials, is skipped (status "skipped", with the reason).
- Counters: every run records `sim.stats["counters"]` (totals, and per step: iterations,
  factorizations, solves, line-search backtracks, ...). Steps that reached their iteration cap
  are counted (`unconverged_steps`; the RuntimeWarning yore raises for them is silenced inside
  the cell, only that one) and the run is `flagged`: still a data point.

Cost at the defaults (a model from the explicit step's cost and the caps, not measured):
about 20 CPU hours, ~10 h on two workers; the longest cells (128², 2e7 N/m) ~1.5 h each.
--sizes / --stiffness / --bending run a part of the grid (the targets need 64² and 128² at
2e5–2e7 N/m); --merge EARLIER.json adds the cells of an earlier run with the same families and
budgets (e.g. the committed bench-results/crossover.json), so the grid is measured a part at a
time, across sessions or machines (each cell's ratio is measured within the cell's own run). A
family that ran there with other resolved options than today's keeps no row in those cells,
which name it in `families_dropped`, as they name a family added since (the earlier run's
families must be among this run's).

Writes crossover.json (every run; per cell the cheapest explicit and implicit run at 1 % and
0.1 %, implicit/explicit cost, each side's steps per simulated second × CPU per step, the
reference's convergence; the crossover stiffness per size and bending row; the issue's
targets, each with its measured value and met/missed) and crossover.png (rows: bending rows;
x: stiffness, y: size; colour: cheapest implicit over cheapest explicit cost on a log scale
centred at 1; text: the winner and the ratio; left at 1 %, right at 0.1 %), and prints the
summary table.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import platform
import shutil
import statistics
import sys
import textwrap
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

import yore

from . import tolerance
from .common import arguments, machine_info, save

THRESHOLDS = (0.01, 0.001)  # relative errors the summary picks the cheapest run at
REFERENCE_FRACTION = 0.1  # a comparison at error t needs a reference within t × this
REFERENCE_TOLERANCE = REFERENCE_FRACTION * min(THRESHOLDS)  # the reference chain's goal
BLOW_UP_ERROR = 0.05  # an explicit run erring beyond this is unstable even if it did not raise
SEARCH_STEPS = 4000  # steps of a stability trial
SEARCH_FACTOR = 1.1  # bracketing factor of the stability search
SEARCH_BISECTIONS = 2  # after bracketing: limit known to ~2.5 %
REPEAT_MARGIN = 1.5  # runs within this of their family's cheapest single run are repeated
RATES = (32, 64, 128, 256, 512, 1024)  # implicit ladder, steps per second
QUICK_RATES = RATES[:3]
MAX_REFERENCE_HALVINGS = 6  # the reference chain: at most limit / 2^7
SOFT_BENDING = 200.0  # N/m, bending springs of the "soft" row
FABRIC_BENDING_MODULUS = 1e-5  # N·m: light cotton, Kawabata B ≈ 0.1 gf·cm²/cm
#: N·s/m per spring, the "equal, damped" row's material damping: enough for a woven fabric's
#: internal friction to remove the stiff springs' vibration within a fraction of a second
#: (the scenes' 0.02 leaves it ringing), measured by an outside check on the 64² sheet
FABRIC_DAMPING = 1.0
SIZES = (32, 64, 128)  # vertices per edge
STIFFNESSES = (2e3, 2e4, 2e5, 2e6, 2e7)  # N/m
BENDING_ROWS = ("equal", "soft", "real cloth")
QUICK_GRID = {"sizes": (12,), "stiffness": (2e4,), "bending": ("equal", "real cloth")}
SWEEP_FOLDER = ("sweeps", "crossover")  # under --out
#: yore's warning for steps that reached their iteration cap (counted, not warned, per cell)
UNCONVERGED_WARNING = r".*accepted unconverged"

# The families, one row each: display name → yore.Simulation options. Every family but
# "explicit" counts as implicit. A row the build does not accept is left out (available_families).
# The Newton rows name their options in full, so a change of yore's defaults does not change
# what a row measures: "BE Newton" and "BDF2" are the former default (steihaug, the residual
# test alone), the clamp rows the former stiff-sheet setting.
TIGHT = {"truncation_fraction": 0.0}  # Newton stopped by the residual test (newton_tol) alone
FAMILIES = {
    "explicit": {"integrator": "explicit"},
    "BE linearized": {"integrator": "implicit", "linearized": True, "mixed": False, **TIGHT},
    "BDF2 linearized": {"integrator": "bdf2", "linearized": True, "mixed": False, **TIGHT},
    "BE Newton": {"integrator": "implicit", "projection": "steihaug", **TIGHT},
    "BDF2": {"integrator": "bdf2", "projection": "steihaug", **TIGHT},
    "BE lagged factors": {
        "integrator": "implicit",
        "projection": "steihaug",
        "lagged_factorization": True,
        **TIGHT,
    },
    "BDF2 lagged factors": {
        "integrator": "bdf2",
        "projection": "steihaug",
        "lagged_factorization": True,
        **TIGHT,
    },
    # the loose stops measured on stiff sheets (docs/limitations.md): clamp, no factor thrown
    # away, Newton ended by the step test, the springs' forces from the linearization (mixed)
    "BE clamp, step test": {
        "integrator": "implicit",
        "projection": "clamp",
        "step_tol": 3e-3,
        "mixed": True,
        **TIGHT,
    },
    "BDF2 clamp, step test": {
        "integrator": "bdf2",
        "projection": "clamp",
        "step_tol": 3e-3,
        "mixed": True,
        **TIGHT,
    },
    # yore's defaults (the clamp with the mixed matrices, the truncation test): a change of the
    # defaults changes their resolved options, and a merge then leaves their rows out
    "BE default": {"integrator": "implicit"},
    "BDF2 default": {"integrator": "bdf2"},
    # the second-order integrators that keep the motion (docs/integrators.md), at their defaults
    "generalized-alpha default": {"integrator": "generalized-alpha"},
    "TR-BDF2 default": {"integrator": "tr-bdf2"},
    "local-global": {"integrator": "local-global"},
    "quasi-Newton BE": {"integrator": "quasi-newton", "method": "backward-euler"},
    "quasi-Newton BDF2": {"integrator": "quasi-newton", "method": "bdf2"},
}
# rows "at tolerance" (issue 40, item 4; benchmarks.tolerance): yore's TR-BDF2 and BDF2 with
# dt="auto" and CVODE at rtol 1e-2, 1e-3, 1e-4 (atol = rtol / 10 m), one run each with output
# at T/2 and T only (the times the error is measured at), so the output does not cap the steps
TOLERANCE_LABELS = {"tr-bdf2 auto": "TR-BDF2 auto", "bdf2 auto": "BDF2 auto", "cvode": "CVODE"}
FAMILIES.update(tolerance.families(TOLERANCE_LABELS))
#: families whose steps their tolerance chooses: one run, dt = the output interval
ERROR_CONTROLLED = tuple(
    name for name, options in FAMILIES.items() if tolerance.is_error_controlled(options)
)
QUICK_FAMILIES = ("explicit", "BE linearized", "BDF2", "quasi-Newton BE")
ITERATION_COUNTERS = (
    "newton_iterations",
    "iterations",
    "lbfgs_iterations",
    "quasi_newton_iterations",
    "nonlinear_iterations",
)
#: counters that are states or sizes, not totals over the steps (not divided by steps)
STATE_COUNTERS = ("dofs", "factor_nonzeros", "factor_flops")


def available_families(names=None):
    """The families (of `names`, default all) this build can construct, and why the others
    are left out: {name: options}, {name: reason}."""
    V, F = yore.grid_mesh(3, 3)
    found, missing = {}, {}
    for name in names or FAMILIES:
        try:
            yore.Simulation(yore.Cloth(V, F), dt=1e-3, **FAMILIES[name])
        except (ValueError, TypeError, NotImplementedError) as error:
            missing[name] = str(error).splitlines()[0]
        else:
            found[name] = FAMILIES[name]
    return found, missing


# -- the sheet ----------------------------------------------------------------------------------
def horizon(size, bending):
    """T, s: see the module docstring."""
    return 0.125 if bending != "equal" or size >= 128 else 0.25


def bending_arguments(bending, stiffness):
    """hanging_cloth's bending keywords of a bending row."""
    if bending == "equal":
        return {"bend_stiffness": float(stiffness)}
    if bending == "equal, damped":
        return {"bend_stiffness": float(stiffness), "damping": FABRIC_DAMPING}
    if bending == "soft":
        return {"bend_stiffness": SOFT_BENDING}
    if bending == "real cloth":
        return {"bending": "quadratic", "bending_modulus": FABRIC_BENDING_MODULUS}
    raise ValueError(
        f"bending row must be one of {', '.join(BENDING_ROWS)} or 'equal, damped', got {bending!r}"
    )


def sheet(size, stiffness, bending):
    """make(**options) -> a fresh Simulation of the cell's sheet at its start."""
    material = bending_arguments(bending, stiffness)

    def make(**options):
        return yore.scenes.hanging_cloth(
            resolution=size,
            pin_spacing=1.0,
            mass=0.1,
            stretch_stiffness=float(stiffness),
            **material,
            **options,
        )

    return make


# -- one run ------------------------------------------------------------------------------------
def even_steps(duration, dt):
    """Steps of at most dt covering duration, an even number (a snapshot at half time)."""
    return max(2, 2 * math.ceil(duration / dt / 2 - 1e-9))


def numeric_counters(counters):
    return {
        k: float(v)
        for k, v in counters.items()
        if isinstance(v, (int, float)) and not isinstance(v, bool)
    }


def _simulate(make, options, steps, duration, cap_seconds=math.inf, chunks=16):
    """Runs steps of duration/steps from the start: positions at steps/2 and steps, thread CPU
    seconds of the stepping, the integrator's counters. Diverged → {"diverged": True}; CPU
    (spent, or extrapolated from the steps done) beyond cap_seconds → {"aborted": ...} with the
    extrapolated cost."""
    sim = make(dt=duration / steps, **options)
    half = steps // 2
    bounds = sorted(
        {
            *np.linspace(0, half, chunks // 2 + 1).astype(int),
            *np.linspace(half, steps, chunks // 2 + 1).astype(int),
        }
    )
    snapshots, cpu, done = [], 0.0, 0
    for target in bounds[1:]:
        start = time.thread_time()
        try:
            sim.step(int(target - done), progress=False)
        except yore.SimulationDiverged:
            return {"diverged": True, "steps_done": done}
        cpu += time.thread_time() - start
        done = int(target)
        if done == half:
            snapshots.append(sim.cloth.positions)
        predicted = cpu * steps / done
        if done < steps and max(cpu, predicted) > cap_seconds:
            return {
                "aborted": f"CPU {cpu:.3g} s after {done} of {steps} steps, "
                f"extrapolated {predicted:.3g} s > cap {cap_seconds:.3g} s",
                "cost_estimate": predicted / duration,
                "steps_done": done,
            }
    snapshots.append(sim.cloth.positions)
    return {
        "snapshots": snapshots,
        "cpu_seconds": cpu,
        "counters": numeric_counters(sim.stats["counters"]),
        "internal_steps": tolerance.internal_steps(sim),
    }


def relative_errors(snapshots, reference, scale):
    """RMS vertex distance at T/2 and at T over scale."""
    return [
        float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1)))) / scale
        for a, b in zip(snapshots, reference)
    ]


def is_stable(make, dt):
    """Whether SEARCH_STEPS explicit steps at dt stay bounded, and their CPU seconds per step."""
    sim = make(dt=dt, integrator="explicit")
    start = time.thread_time()
    try:
        sim.step(SEARCH_STEPS, progress=False)
    except yore.SimulationDiverged as error:
        return False, (time.thread_time() - start) / max(1, getattr(error, "step", 1))
    return (
        bool(np.isfinite(sim.cloth.positions).all()),
        (time.thread_time() - start) / SEARCH_STEPS,
    )


def trial_limit(make, estimate, check=None):
    """Largest dt stable over SEARCH_STEPS steps, from the estimate: bracket by SEARCH_FACTOR,
    then bisect (geometrically). Returns the dt and the trials [{dt, stable, cpu_per_step}].
    check(dt): is_stable's answer (default: is_stable itself)."""
    trials = []
    check = check or (lambda dt: is_stable(make, dt))

    def trial(dt):
        stable, cpu_per_step = check(dt)
        trials.append({"dt": dt, "stable": stable, "cpu_per_step": cpu_per_step})
        return stable

    low = high = estimate
    if trial(estimate):
        for _ in range(8):
            high = low * SEARCH_FACTOR
            if not trial(high):
                break
            low = high
    else:
        for _ in range(20):
            low = high / SEARCH_FACTOR
            if trial(low):
                break
            high = low
    for _ in range(SEARCH_BISECTIONS):
        middle = math.sqrt(low * high)
        if trial(middle):
            low = middle
        else:
            high = middle
    return low, trials


# -- a cell's journal ------------------------------------------------------------------------------
_BUILD = None


def build_fingerprint():
    """A hash of the installed yore (its extension and Python files): runs journaled by another
    build are not replayed."""
    global _BUILD
    if _BUILD is None:
        digest = hashlib.sha256()
        package = Path(yore.__file__).parent
        for path in sorted(package.rglob("*")):
            if path.suffix in (".py", ".so", ".pyd") and path.is_file():
                digest.update(path.relative_to(package).as_posix().encode())
                digest.update(path.read_bytes())
        _BUILD = digest.hexdigest()[:16]
    return _BUILD


def journal_folder(root, cell):
    return Path(root) / (
        f"{int(cell['size'])}-{float(cell['stretch_stiffness']):g}-"
        + str(cell["bending"]).replace(" ", "_")
    )


class Journal:
    """The runs of one cell so far, on disk, so that a cell stopped part-way (the session or
    the worker ends) resumes at the run it was on instead of from the start: a cell at 128² or
    2e7 N/m takes hours. Each run is recorded after it ends, in the order the cell asks for
    them: its arrays first, then the JSON naming what was asked and what came out (each
    written to a temporary name and renamed). A resumed cell replays the records while they
    answer what it asks again, with their CPU seconds as measured then, and runs the rest; the
    first record that does not match, and every later one, is dropped. Records of another
    build of yore are dropped too. ``folder`` None: nothing is kept."""

    def __init__(self, folder, log):
        self.folder, self.count, self.replayed, self.replayed_cpu = None, 0, 0, 0.0
        if folder is None:
            return
        folder = Path(folder)
        try:
            folder.mkdir(parents=True, exist_ok=True)
            build = folder / "build.txt"
            if not build.is_file() or build.read_text(encoding="utf-8") != build_fingerprint():
                self._drop(0, folder)
                self._write(build, build_fingerprint().encode())
        except OSError as error:
            log(f"journal off ({error})")
            return
        self.folder = folder

    @staticmethod
    def _write(path, data):
        scratch = path.with_name(path.name + ".part")
        scratch.write_bytes(data)
        os.replace(scratch, path)

    @staticmethod
    def _drop(first, folder):
        for path in folder.glob("run-*"):
            if int(path.name[4:9]) >= first:
                path.unlink(missing_ok=True)

    def run(self, asked, compute):
        """compute()'s result for what ``asked`` names (JSON values), replayed or run now."""
        index, self.count = self.count, self.count + 1
        if self.folder is None:
            return compute()
        asked = json.loads(json.dumps(asked))
        record = self.folder / f"run-{index:05d}.json"
        arrays = self.folder / f"run-{index:05d}.npz"
        if record.is_file():
            try:
                kept = json.loads(record.read_text(encoding="utf-8"))
                if kept["asked"] == asked:
                    result = kept["result"]
                    if kept["arrays"]:
                        with np.load(arrays) as data:
                            result["snapshots"] = [data["half"], data["end"]]
                    if "stable" in result:
                        result = (result["stable"], result["cpu_per_step"])
                    self.replayed += 1
                    self.replayed_cpu += kept["cpu_seconds"]
                    return result
            except (OSError, ValueError, KeyError, TypeError):
                pass  # a record damaged by hand: run it again
            self._drop(index, self.folder)
        result = compute()
        if isinstance(result, tuple):  # a stability trial: (stable, cpu per step)
            kept, cpu = {"stable": result[0], "cpu_per_step": result[1]}, result[1] * SEARCH_STEPS
        else:
            kept = {k: v for k, v in result.items() if k != "snapshots"}
            cpu = result.get("cpu_seconds", 0.0)
        has_arrays = isinstance(result, dict) and "snapshots" in result
        if has_arrays:
            buffer = io.BytesIO()
            np.savez(buffer, half=result["snapshots"][0], end=result["snapshots"][1])
            self._write(arrays, buffer.getvalue())
        self._write(
            record,
            json.dumps(
                {"asked": asked, "result": kept, "cpu_seconds": cpu, "arrays": has_arrays},
                default=float,
            ).encode(),
        )
        return result


# -- one cell -----------------------------------------------------------------------------------
def measure_cell(cell, make, families, settings, log, journal=None):
    """Rows of every run of one cell, and the cell's facts (stability search, reference).
    journal: a Journal that keeps (and replays) the cell's runs."""
    duration = cell["horizon"]
    journal = journal or Journal(None, log)

    def simulate(make, options, steps, duration, cap_seconds=math.inf):
        asked = {"run": options, "steps": steps, "duration": duration, "cap": cap_seconds}
        return journal.run(asked, lambda: _simulate(make, options, steps, duration, cap_seconds))

    probe = make()
    estimate = probe.stable_dt()
    scale = float(np.linalg.norm(np.ptp(probe.cloth.positions, axis=0)))
    limit, trials = trial_limit(
        make,
        estimate,
        lambda dt: journal.run(
            {"stability trial": dt, "steps": SEARCH_STEPS}, lambda: is_stable(make, dt)
        ),
    )
    explicit = families["explicit"]
    steps_limit = even_steps(duration, limit)
    info = dict(
        cell,
        stable_dt_estimate=estimate,
        trial_limit_dt=limit,
        stability_trials=trials,
        scale=scale,
    )
    # explicit's least work in this cell: the run at the limit, its repeats, the reference pair
    per_step = statistics.median(t["cpu_per_step"] for t in trials)
    predicted = per_step * steps_limit * (settings["repeats"] + 2 + 4)
    info["predicted_explicit_cpu_seconds"] = predicted
    if predicted > settings["max_cell_seconds"]:
        log(
            f"{describe(cell)}: explicit's runs would take ~{predicted:.0f} CPU s > "
            f"--max-cell-seconds {settings['max_cell_seconds']:g}; cell skipped"
        )
        info["skipped"] = (
            f"explicit's runs and reference ~{predicted:.0f} CPU s > "
            f"--max-cell-seconds {settings['max_cell_seconds']:g}"
        )
        return [], info
    # reference chain: steps_limit × 2, × 4, ... until the last two agree or the budget ends
    chain = [(2 * steps_limit, simulate(make, explicit, 2 * steps_limit, duration))]
    links = [
        {
            "steps": 2 * steps_limit,
            "dt": duration / (2 * steps_limit),
            "cpu_seconds": chain[0][1].get("cpu_seconds"),
            "difference_to_previous": None,
        }
    ]
    info["reference_chain"] = links
    while True:
        steps = 2 * chain[-1][0]
        chain.append((steps, simulate(make, explicit, steps, duration)))
        if any(result.get("diverged") for _, result in chain[-2:]):
            log(f"{describe(cell)}: the reference diverged; cell left out")
            info.update(reference_converged=False, reference_error=None, reference_diverged=True)
            return [
                dict(
                    cell,
                    method="reference",
                    dt=duration / steps,
                    steps=steps,
                    diverged=True,
                    aborted=None,
                    reference_converged=False,
                )
            ], info
        reference_error = max(
            relative_errors(chain[-2][1]["snapshots"], chain[-1][1]["snapshots"], scale)
        )
        converged = reference_error <= REFERENCE_TOLERANCE
        links.append(
            {
                "steps": steps,
                "dt": duration / steps,
                "cpu_seconds": chain[-1][1]["cpu_seconds"],
                "difference_to_previous": reference_error,
            }
        )
        if (
            converged
            or len(chain) > MAX_REFERENCE_HALVINGS
            or 2 * chain[-1][1]["cpu_seconds"] > settings["max_reference_seconds"]
        ):
            break
    reference = chain[-1][1]
    info.update(
        reference_error=reference_error,
        reference_converged=converged,
        reference_dt=duration / chain[-1][0],
    )
    log(
        f"{describe(cell)}: stable_dt() {estimate:.3g} s, trial limit {limit:.3g} s, reference "
        f"error {reference_error:.2e}{'' if converged else ' (NOT converged: left out)'}"
    )

    def row(method, steps, result, **extra):
        base = dict(
            cell,
            method=method,
            dt=duration / steps,
            steps=steps,
            scale=scale,
            sample_steps=[steps // 2, steps],
            sample_times=[duration / 2, duration],
            reference_converged=converged,
            diverged=bool(result.get("diverged")),
            aborted=result.get("aborted"),
            repeats=0,
            **extra,
        )
        if "snapshots" in result:
            half, end = relative_errors(result["snapshots"], reference["snapshots"], scale)
            counters = result["counters"]
            unconverged = int(counters.get("unconverged_steps", 0))
            base.update(
                error_half=half,
                error_end=end,
                error=max(half, end),
                cpu_seconds_samples=[result["cpu_seconds"]],
                repeats=1,
                counters=counters,
                counters_per_step={
                    k: v / steps
                    for k, v in counters.items()
                    if k not in STATE_COUNTERS and not k.startswith("last_")
                },
                iterations=int(
                    next((counters[k] for k in ITERATION_COUNTERS if k in counters), steps)
                ),
                factorizations=int(counters.get("factorizations", 0)),
                unconverged_steps=unconverged,
                flagged=unconverged > 0,
                internal_steps=result.get("internal_steps"),
            )
            set_cost(base, result["cpu_seconds"])
        elif result.get("aborted"):
            base["cost_estimate_seconds_per_simulated_second"] = result["cost_estimate"]
        return base

    rows = [
        dict(row("reference", chain[-1][0], reference), error=0.0, reference_error=reference_error)
    ]
    # explicit at the limit over the whole interval: cut by 5 % until it runs and stays close
    steps = steps_limit
    for _ in range(6):
        r = row("explicit", steps, simulate(make, explicit, steps, duration), at_limit=True)
        r["unstable"] = r["diverged"] or not r["error"] <= BLOW_UP_ERROR
        rows.append(r)
        log_row(log, r)
        if not r["unstable"]:
            break
        steps = even_steps(duration, 0.95 * duration / steps)
    else:
        log(f"{describe(cell)}: no stable explicit step found near the trial limit")
    for steps, result in chain[:-1]:  # the coarser runs of the chain are explicit's ladder
        rows.append(row("explicit", steps, result))
        log_row(log, rows[-1])
    best_explicit = min(
        (
            r["cost_seconds_per_simulated_second"]
            for r in rows
            if r["method"] == "explicit" and usable(r) and r["error"] <= max(THRESHOLDS)
        ),
        default=math.inf,
    )
    cap = min(settings["max_run_seconds"], settings["max_ratio"] * best_explicit * duration)

    for family, options in families.items():
        if family == "explicit":
            continue
        aborted_in_a_row, previous = 0, None
        # an error-controlled row: one run, output at T/2 and T only (its steps are its own)
        rates = [2 / duration] if family in ERROR_CONTROLLED else settings["rates"]
        for rate in rates:
            steps = even_steps(duration, 1.0 / rate)
            r = row(family, steps, simulate(make, options, steps, duration, cap))
            rows.append(r)
            log_row(log, r)
            aborted_in_a_row = aborted_in_a_row + 1 if r["aborted"] else 0
            if aborted_in_a_row >= 2:
                break
            if "error" in r:
                if (
                    previous is not None
                    and previous["error"] <= min(THRESHOLDS)
                    and r["cost_seconds_per_simulated_second"]
                    > previous["cost_seconds_per_simulated_second"]
                ):
                    break
                previous = r

    repeat_candidates(rows, make, families, duration, settings["repeats"], log, simulate)
    if journal.replayed:
        info.update(replayed_runs=journal.replayed, replayed_cpu_seconds=journal.replayed_cpu)
        log(
            f"{describe(cell)}: {journal.replayed} runs replayed from the journal "
            f"({journal.replayed_cpu:.0f} CPU s measured before the cell was stopped)"
        )
    return rows, info


def set_cost(row, cpu):
    """The row's cost from its CPU seconds; per step means per step taken (an error-controlled
    row's internal steps, not its output intervals)."""
    steps = row.get("internal_steps") or row["steps"]
    row["cpu_seconds"] = cpu
    row["cost_seconds_per_simulated_second"] = cpu / row["horizon"]
    row["steps_per_simulated_second"] = steps / row["horizon"]
    row["iterations_per_step"] = row["iterations"] / steps
    row["factorizations_per_step"] = row["factorizations"] / steps
    row["cpu_per_step"] = cpu / steps
    row["cpu_per_iteration"] = cpu / max(1, row["iterations"])


def usable(row):
    """A run that measured an error and may be picked (not the reference, not unstable)."""
    return "error" in row and row["method"] != "reference" and not row.get("unstable")


def repeat_candidates(rows, make, families, duration, repeats, log, simulate=None):
    """Repeats (to `repeats` in all) every run that could be its family's cheapest at a
    threshold: it meets the threshold and costs at most REPEAT_MARGIN × the family's cheapest
    single run that meets it. The cost becomes the median."""
    if repeats <= 1:
        return
    candidates = set()
    for family in families:
        sel = [i for i, r in enumerate(rows) if r["method"] == family and usable(r)]
        for threshold in THRESHOLDS:
            meeting = [i for i in sel if rows[i]["error"] <= threshold]
            if meeting:
                cheapest = min(rows[i]["cpu_seconds"] for i in meeting)
                candidates |= {
                    i for i in meeting if rows[i]["cpu_seconds"] <= REPEAT_MARGIN * cheapest
                }
    for i in sorted(candidates):
        r = rows[i]
        for _ in range(repeats - 1):
            again = (simulate or _simulate)(make, families[r["method"]], r["steps"], duration)
            r["cpu_seconds_samples"].append(again["cpu_seconds"])
        r["repeats"] = len(r["cpu_seconds_samples"])
        set_cost(r, statistics.median(r["cpu_seconds_samples"]))
        log(
            f"    repeated {r['method']} dt={r['dt']:.3g}: median CPU {r['cpu_seconds']:.3g} s "
            f"of {', '.join(f'{s:.3g}' for s in r['cpu_seconds_samples'])}"
        )


def describe(cell):
    return (
        f"{cell['size']}² k={cell['stretch_stiffness']:g} bending {cell['bending']} "
        f"T={cell['horizon']:g} s"
    )


def log_row(log, r):
    if r["diverged"]:
        state = "diverged"
    elif r["aborted"]:
        state = f"aborted ({r['aborted']})"
    else:
        state = (
            f"error {r['error']:.2e} cost {r['cost_seconds_per_simulated_second']:.3g} s/s "
            f"it/step {r['iterations_per_step']:.1f}"
            + (f" UNCONVERGED {r['unconverged_steps']}" if r["flagged"] else "")
            + (" UNSTABLE" if r.get("unstable") else "")
        )
    log(f"    {r['method']:20s} dt={r['dt']:.3g} {state}")


# -- a cell's summary ---------------------------------------------------------------------------
def entry(row):
    keys = (
        "method",
        "dt",
        "steps",
        "internal_steps",
        "error",
        "error_half",
        "error_end",
        "cost_seconds_per_simulated_second",
        "cpu_seconds",
        "repeats",
        "steps_per_simulated_second",
        "cpu_per_step",
        "iterations_per_step",
        "factorizations_per_step",
        "cpu_per_iteration",
        "unconverged_steps",
        "flagged",
    )
    return {k: row[k] for k in keys if k in row}


def reference_serves(cell, threshold):
    """Whether the cell's reference is fine enough to judge errors at ``threshold``: its last
    difference to the run at twice its step is at most REFERENCE_FRACTION × threshold."""
    error = cell.get("reference_error")
    return error is not None and error <= REFERENCE_FRACTION * threshold * (1 + 1e-12)


def summarize_cell(info, rows, families):
    """Per threshold: each family's cheapest run meeting it, the cheapest implicit one, and the
    implicit/explicit cost with each side's steps and CPU per step. A threshold the reference
    is too coarse for gets no verdict (``reference_too_coarse``)."""
    out = {k: v for k, v in info.items() if k != "scale"}
    limit = [r for r in rows if r.get("at_limit") and not r["unstable"]]
    out["explicit_limit_dt"] = limit[0]["dt"] if limit else None
    if info.get("reference_error") is None:
        return out
    for threshold in THRESHOLDS:
        if not reference_serves(info, threshold):
            out[f"at_{threshold:g}"] = {
                "families": {},
                "best_implicit": None,
                "best_explicit": None,
                "reference_too_coarse": info["reference_error"],
            }
            continue
        per_family = {}
        for family in families:
            sel = [
                r for r in rows if r["method"] == family and usable(r) and r["error"] <= threshold
            ]
            best = min(sel, key=lambda r: r["cost_seconds_per_simulated_second"], default=None)
            if best is None:
                tried = [r for r in rows if r["method"] == family]
                estimates = [
                    r["cost_estimate_seconds_per_simulated_second"]
                    for r in tried
                    if r.get("aborted")
                ]
                per_family[family] = {
                    "none": "no run reached the error" if tried else "not run",
                    "aborted_runs": len(estimates),
                    "least_extrapolated_cost": min(estimates, default=None),
                }
            else:
                per_family[family] = entry(best)
        implicit = [e for f, e in per_family.items() if f != "explicit" and "method" in e]
        best_implicit = min(
            implicit, key=lambda e: e["cost_seconds_per_simulated_second"], default=None
        )
        best_explicit = per_family.get("explicit")
        if best_explicit is not None and "method" not in best_explicit:
            best_explicit = None
        verdict = {
            "families": per_family,
            "best_implicit": best_implicit,
            "best_explicit": best_explicit,
        }
        if best_implicit and best_explicit:
            ratio = (
                best_implicit["cost_seconds_per_simulated_second"]
                / best_explicit["cost_seconds_per_simulated_second"]
            )
            verdict.update(
                implicit_over_explicit_cost=ratio,
                winner=best_implicit["method"] if ratio < 1 else "explicit",
                # cost per simulated second = steps per simulated second × CPU per step
                explicit_over_implicit_steps=(
                    (best_explicit.get("internal_steps") or best_explicit["steps"])
                    / (best_implicit.get("internal_steps") or best_implicit["steps"])
                ),
                implicit_over_explicit_cpu_per_step=(
                    best_implicit["cpu_per_step"] / best_explicit["cpu_per_step"]
                ),
            )
        elif best_explicit:
            # every implicit run erred more or was stopped at its cap (≥ --max-ratio × explicit)
            verdict.update(winner="explicit", note="no implicit run reached it within the caps")
        out[f"at_{threshold:g}"] = verdict
    groups = {
        m: tuple((f, rtol) for f, rtol in members if f in families)
        for m, members in tolerance.groups(TOLERANCE_LABELS).items()
    }
    groups = {m: g for m, g in groups.items() if g}
    at_limit = [r for r in limit if "cost_seconds_per_simulated_second" in r]
    if groups and at_limit:
        fixed = [f for f in families if f != "explicit" and f not in ERROR_CONTROLLED]
        out["at_tolerance"] = tolerance.at_tolerance(
            rows,
            info["reference_error"],
            at_limit[0]["cost_seconds_per_simulated_second"],
            fixed,
            groups,
        )
        out["at_tolerance_verdicts"] = tolerance.at_thresholds(
            rows,
            [t for t in THRESHOLDS if reference_serves(info, t)],
            fixed,
            [f for f in families if f in ERROR_CONTROLLED],
        )
    return out


def percent(threshold):
    return f"{100 * threshold:g}pct"


def cell_values(summary, rows):
    """The cell's numbers for the sweep's Dataset (floats only; NaN-free)."""
    values = {}
    for key in (
        "horizon",
        "stable_dt_estimate",
        "trial_limit_dt",
        "explicit_limit_dt",
        "reference_error",
        "reference_dt",
        "predicted_explicit_cpu_seconds",
        "cell_thread_cpu_seconds",
        "cell_process_cpu_seconds",
        "cell_wall_seconds",
    ):
        if isinstance(summary.get(key), (int, float)):
            values[key] = float(summary[key])
    if "reference_converged" in summary:
        values["reference_converged"] = float(bool(summary["reference_converged"]))
    measured = [r for r in rows if "error" in r and r["method"] != "reference"]
    values["runs"] = float(len([r for r in rows if r["method"] != "reference"]))
    values["flagged_runs"] = float(sum(bool(r.get("flagged")) for r in measured))
    values["aborted_runs"] = float(sum(bool(r.get("aborted")) for r in rows))
    for threshold in THRESHOLDS:
        at = summary.get(f"at_{threshold:g}")
        if not at:
            continue
        tag = percent(threshold)
        if "implicit_over_explicit_cost" in at:
            values[f"implicit_over_explicit_at_{tag}"] = at["implicit_over_explicit_cost"]
        for side in ("explicit", "implicit"):
            best = at[f"best_{side}"]
            if best:
                values[f"{side}_cost_at_{tag}"] = best["cost_seconds_per_simulated_second"]
                values[f"{side}_steps_at_{tag}"] = float(best["steps"])
                values[f"{side}_cpu_per_step_at_{tag}"] = best["cpu_per_step"]
        for family, e in at["families"].items():
            if "method" in e:
                name = "".join(c if c.isalnum() else "_" for c in family.lower())
                values[f"cost_at_{tag}_{name}"] = e["cost_seconds_per_simulated_second"]
    return {k: float(v) for k, v in values.items() if math.isfinite(float(v))}


# -- the Dask task ------------------------------------------------------------------------------
def cell_of(overrides, horizon_seconds):
    """A cell's record from its sweep overrides (size, stiffness and bending row, keyed as
    `grid_sweep` keys them) and its horizon (s): what crossover and long_horizon cells start
    from."""
    size = int(overrides["crossover.size"])
    stiffness = float(overrides["crossover.stretch_stiffness"])
    bending = str(overrides["crossover.bending"])
    material = bending_arguments(bending, stiffness)
    return {
        "size": size,
        "stretch_stiffness": stiffness,
        "bending": bending,
        "bend_stiffness": material.get("bend_stiffness"),
        "bending_modulus": material.get("bending_modulus"),
        "horizon": horizon_seconds(size, bending),
    }


def crossover_cell(settings_toml, scene_path, overrides) -> dict:
    """One cell as a `yore.sweep` task (the engine's cell-function signature: the sweep's
    'scene' is this benchmark's settings, as TOML; overrides name the cell). Never raises: a
    failure is a "failed" result naming the error."""
    import tomllib

    wall, thread, process = time.perf_counter(), time.thread_time(), time.process_time()
    log = []
    try:
        settings = tomllib.loads(settings_toml)
        cell = cell_of(overrides, horizon)
        size, stiffness, bending = cell["size"], cell["stretch_stiffness"], cell["bending"]
        yore.set_num_threads(1)  # the thread clock then holds all of the stepping
        families = settings["families"]
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", UNCONVERGED_WARNING, RuntimeWarning)
            root = settings.get("journal")
            journal = Journal(journal_folder(root, cell) if root else None, log.append)
            rows, info = measure_cell(
                cell, sheet(size, stiffness, bending), families, settings, log.append, journal
            )
        summary = info if "skipped" in info else summarize_cell(info, rows, families)
    except Exception as error:  # noqa: BLE001 - a cell's failure is its result
        message = f"{type(error).__name__}: {' '.join(str(error).split())}"
        last = traceback.extract_tb(error.__traceback__)[-1:]
        if last:
            message += f" (at {Path(last[0].filename).name}:{last[0].lineno})"
        return {
            "status": "failed",
            "message": message,
            "values": {"cell_wall_seconds": time.perf_counter() - wall},
            "positions": None,
            "faces": None,
        }
    summary.update(
        cell_thread_cpu_seconds=time.thread_time() - thread,
        cell_process_cpu_seconds=time.process_time() - process,
        cell_wall_seconds=time.perf_counter() - wall,
        worker={"cpu": _cpu_model(), "yore_threads_set": 1, "python": platform.python_version()},
    )
    record = {"cell": summary, "rows": rows, "log": log}
    return {
        "status": "skipped" if "skipped" in summary else "done",
        "message": json.dumps(record, separators=(",", ":"), default=float),
        "values": cell_values(summary, rows),
        "positions": None,
        "faces": None,
    }


def _cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            return next(
                (line.split(":", 1)[1].strip() for line in f if line.startswith("model name")),
                platform.processor(),
            )
    except OSError:
        return platform.processor() or "unknown"


# -- the sweep ------------------------------------------------------------------------------------
def toml_value(value):
    """A TOML value of a number, string, boolean or a list of them (JSON's spelling is TOML's
    for these; infinities are refused)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{value} has no TOML spelling here")
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return json.dumps(value)


def settings_text(settings):
    """The settings as the TOML every cell reads (the sweep's scene.toml)."""
    lines = [
        "# benchmarks/crossover.py: the settings every cell of this crossover runs with",
        "# (python -m benchmarks.crossover --resume reads them back)",
    ]
    for key, value in settings.items():
        if key != "families":
            lines.append(f"{key} = {toml_value(value)}")
    for name, options in settings["families"].items():
        lines += ["", f"[families.{json.dumps(name)}]"]
        lines += [f"{key} = {toml_value(value)}" for key, value in options.items()]
    return "\n".join(lines) + "\n"


def grid_sweep(settings):
    """The sweep of the settings' grid (size × stiffness × bending, largest first), its cells
    run by crossover_cell. Its sweep.toml is not a scene sweep: `yore sweep --resume` refuses
    it (no such scene), `python -m benchmarks.crossover --resume` continues it."""
    from yore.sweep.spec import Dimension, Sweep

    axes = (
        ("size", "crossover.size", sorted(settings["sizes"], reverse=True)),
        ("stiffness", "crossover.stretch_stiffness", sorted(settings["stiffness"], reverse=True)),
        ("bending", "crossover.bending", list(settings["bending"])),
    )
    text = [
        "# benchmarks/crossover.py's cells: one task each, run by its cell function",
        "# (crossover_cell), not by `yore sweep`; scene.toml holds the settings.",
        "[sweep]",
        'scene = "benchmarks.crossover settings (scene.toml)"',
    ]
    dimensions = []
    for name, key, values in axes:
        text += [f"[zip.{name}]", f"{json.dumps(key)} = {toml_value(values)}"]
        dimensions.append(Dimension(name, (key,), tuple((v,) for v in values)))
    return Sweep(
        text="\n".join(text) + "\n",
        path=None,
        scene_text=settings_text(settings),
        scene_path=None,
        sets={},
        dimensions=dimensions,
        repeats=1,
    )


def collect(sweep, results, families=None):
    """Rows and per-cell summaries of the finished cells, from the engine's records; with
    ``families``, each done cell is summarised again from its rows by this code's rules (a
    cell collected after the rules changed)."""
    rows, cells = [], []
    for cell in sweep.cells():
        status = str(results.status[cell.position])
        message = str(results.message[cell.position])
        where = {
            "size": int(cell.overrides["crossover.size"]),
            "stretch_stiffness": float(cell.overrides["crossover.stretch_stiffness"]),
            "bending": str(cell.overrides["crossover.bending"]),
        }
        if status in ("done", "skipped"):
            record = json.loads(message)
            rows.extend(record["rows"])
            cell = record["cell"]
            if families is not None and status == "done":
                info = {k: v for k, v in cell.items() if not k.startswith("at_")}
                cell = summarize_cell(info, record["rows"], list(families))
            cells.append(dict(cell, status=status, log=record["log"]))
        else:
            cells.append(
                dict(
                    where,
                    horizon=horizon(where["size"], where["bending"]),
                    status=status or "not run",
                    skipped=f"{status or 'not run'}: {message}".rstrip(": "),
                )
            )
    return rows, cells


# -- the grid's summary ---------------------------------------------------------------------------
def measured(cells):
    """The cells judged at the largest threshold (1 %)."""
    return [c for c in cells if c.get("status") == "done" and reference_serves(c, max(THRESHOLDS))]


def crossovers(cells):
    """Per (bending, size): the cost ratios at 1 % against stiffness and the stiffness where
    the ratio crosses 1 (log-log interpolation), or a bound."""
    out = []
    for bending in [b for b in BENDING_ROWS if any(c["bending"] == b for c in cells)]:
        for size in sorted({c["size"] for c in cells if c["bending"] == bending}):
            points = sorted(
                (c["stretch_stiffness"], c["at_0.01"]["implicit_over_explicit_cost"])
                for c in cells
                if c["bending"] == bending
                and c["size"] == size
                and "implicit_over_explicit_cost" in c.get("at_0.01", {})
            )
            found = None
            for (k0, r0), (k1, r1) in zip(points, points[1:]):
                if r0 >= 1.0 > r1:
                    f = math.log(r0) / (math.log(r0) - math.log(r1))
                    found = math.exp(math.log(k0) + f * (math.log(k1) - math.log(k0)))
            item = {
                "bending": bending,
                "size": size,
                "ratios": points,
                "crossover_stiffness": found,
            }
            if found is None and points:
                item["bound"] = (
                    "implicit cheaper at every stiffness measured"
                    if all(r < 1 for _, r in points)
                    else "explicit cheaper at every stiffness measured"
                    if all(r >= 1 for _, r in points)
                    else "no single crossing"
                )
            out.append(item)
    return out


def _cell_verdict(cells, size, stiffness, bending, threshold):
    """A target's view of one cell: its ratio at threshold (None: not measured, and why)."""
    cell = next(
        (
            c
            for c in cells
            if c["size"] == size and c["stretch_stiffness"] == stiffness and c["bending"] == bending
        ),
        None,
    )
    item = {"size": size, "stretch_stiffness": stiffness, "bending": bending, "ratio": None}
    if cell is None:
        item["why"] = "not in the grid"
    elif cell.get("status") != "done":
        item["why"] = cell.get("skipped") or cell.get("status")
    elif not reference_serves(cell, threshold):
        error = cell.get("reference_error")
        item["why"] = f"reference not converged to {REFERENCE_FRACTION * threshold:g}" + (
            f" ({error:.2g})" if error is not None else ""
        )
    else:
        at = cell[f"at_{threshold:g}"]
        if "implicit_over_explicit_cost" in at:
            item.update(
                ratio=at["implicit_over_explicit_cost"],
                winner=at["winner"],
                implicit=at["best_implicit"],
                explicit=at["best_explicit"],
            )
        elif at["best_explicit"]:  # decided: explicit, by more than the caps allow
            item.update(
                winner="explicit",
                explicit=at["best_explicit"],
                why=f"no implicit run reached {100 * threshold:g} % within the caps",
            )
        else:
            item["why"] = f"no explicit run reached {100 * threshold:g} %"
    return item


def targets(cells, stiffnesses):
    """The issue's targets, each with its measured value and met/missed (not measured: not
    met). A target over several bending rows is met by the best of them."""
    goals = [
        ("64², k = 2e5, equal bending", 64, 2e5, ("equal",), 0.01, 0.5, False),
        ("64², k = 2e6, equal bending", 64, 2e6, ("equal",), 0.01, 0.25, False),
        (
            "128², k = 2e6, soft or real cloth bending",
            128,
            2e6,
            ("soft", "real cloth"),
            0.01,
            0.2,
            False,
        ),
        (
            "moonshot: 128², k = 2e7, soft or real cloth bending",
            128,
            2e7,
            ("soft", "real cloth"),
            0.01,
            0.1,
            True,
        ),
    ]
    out = []
    for name, size, k, rows, threshold, goal, moonshot in goals:
        seen = [_cell_verdict(cells, size, k, b, threshold) for b in rows]
        best = min(
            (s for s in seen if s["ratio"] is not None), key=lambda s: s["ratio"], default=None
        )
        out.append(
            {
                "target": name,
                "threshold": threshold,
                "goal_ratio": goal,
                "moonshot": moonshot,
                "cells": seen,
                "ratio": best["ratio"] if best else None,
                "measured": any("winner" in s for s in seen),
                "met": best is not None and best["ratio"] <= goal,
                "best": best,
            }
        )
    # at 0.1 %: implicit cheaper in the stiffest cell of each row of the map (bending × size)
    top = max(stiffnesses)
    sizes = sorted({c["size"] for c in cells})
    for bending in [b for b in BENDING_ROWS if any(c["bending"] == b for c in cells)]:
        for size in sizes:
            seen = _cell_verdict(cells, size, top, bending, 0.001)
            item = {
                "target": f"0.1 %: implicit cheaper at {size}², k = {top:g}, "
                f"{bending} bending (the row's stiffest cell)",
                "threshold": 0.001,
                "goal_ratio": 1.0,
                "moonshot": False,
                "cells": [seen],
                "ratio": seen["ratio"],
                "measured": "winner" in seen,
                "met": seen["ratio"] is not None and seen["ratio"] < 1.0,
                "best": seen if seen["ratio"] is not None else None,
            }
            if "winner" not in seen:
                # not judged at the grid's stiffest: the row's stiffest cell that was, shown
                # beside it (the target itself stays unmeasured)
                judged = [
                    c
                    for c in cells
                    if c["size"] == size
                    and c["bending"] == bending
                    and "winner"
                    in _cell_verdict(cells, size, c["stretch_stiffness"], bending, 0.001)
                ]
                if judged:
                    k = max(c["stretch_stiffness"] for c in judged)
                    item["stiffest_judged"] = _cell_verdict(cells, size, k, bending, 0.001)
            out.append(item)
    return out


def _cost(e):
    steps = e.get("internal_steps") or e["steps"]
    return (
        f"{e['method']} dt {e['dt']:.3g} s: {steps} steps × "
        f"{duration_text(e['cpu_per_step'])} = {e['cost_seconds_per_simulated_second']:.3g} "
        "s/s"
    )


def duration_text(seconds):
    return f"{seconds:.3g} s" if seconds >= 1.0 else f"{1e3 * seconds:.3g} ms"


def summary_table(payload):
    """The summary table (markdown): one line per cell."""
    out = [
        "| bending | size | k (N/m) | T | explicit at 1 % | cheapest implicit at 1 % "
        "| implicit / explicit at 1 % | at 0.1 % | reference |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    order = {b: i for i, b in enumerate(BENDING_ROWS)}
    for c in sorted(
        payload["summary"]["cells"],
        key=lambda c: (order.get(c["bending"], 9), c["size"], c["stretch_stiffness"]),
    ):
        head = (
            f"| {c['bending']} | {c['size']}² | {c['stretch_stiffness']:g} | {c['horizon']:g} s |"
        )
        if c.get("status") != "done":
            out.append(f"{head} {c.get('status')}: {c.get('skipped', '')} | | | | |")
            continue
        if not reference_serves(c, max(THRESHOLDS)):
            error = c.get("reference_error")
            out.append(
                f"{head} | | | | reference not converged"
                + (f" ({error:.1e})" if error is not None else "")
                + " |"
            )
            continue
        one, tenth = c["at_0.01"], c["at_0.001"]
        explicit = _cost(one["best_explicit"]) if one["best_explicit"] else "none"
        implicit = one["best_implicit"]
        implicit = (
            (
                _cost(implicit) + f" ({implicit['iterations_per_step']:.1f} it, "
                f"{implicit['factorizations_per_step']:.2g} fact. per step"
                + (
                    f"; {implicit['unconverged_steps']} unconverged steps"
                    if implicit.get("flagged")
                    else ""
                )
                + ")"
            )
            if implicit
            else "none"
        )
        ratios = [
            f"{a['implicit_over_explicit_cost']:.2f} ({a['winner']})"
            if "implicit_over_explicit_cost" in a
            else "> caps (explicit)"
            if a.get("winner")
            else f"reference too coarse ({a['reference_too_coarse']:.1e} > "
            f"{REFERENCE_FRACTION * t:g})"
            if "reference_too_coarse" in a
            else "—"
            for a, t in ((one, THRESHOLDS[0]), (tenth, THRESHOLDS[1]))
        ]
        out.append(
            f"{head} {explicit} | {implicit} | {ratios[0]} | {ratios[1]} | "
            f"{c['reference_error']:.1e} at dt {c['reference_dt']:.2g} s |"
        )
    return out


def finding(payload):
    """One sentence: who wins where at 1 %, and why, in steps × CPU per step."""
    cells = [
        c
        for c in measured(payload["summary"]["cells"])
        if "implicit_over_explicit_cost" in c.get("at_0.01", {})
    ]
    if not cells:
        return (
            "No cell has both an explicit and an implicit run at 1 % with a converged "
            "reference: nothing to compare yet."
        )
    wins = [c for c in cells if c["at_0.01"]["winner"] != "explicit"]
    losses = [c for c in cells if c["at_0.01"]["winner"] == "explicit"]

    def where(group):
        parts = []
        for bending in BENDING_ROWS:
            sizes = {}
            for c in group:
                if c["bending"] == bending:
                    sizes.setdefault(c["size"], []).append(c["stretch_stiffness"])
            if sizes:
                parts.append(
                    f"{bending} bending at "
                    + ", ".join(
                        f"{n}² k = " + "/".join(f"{k:g}" for k in sorted(ks))
                        for n, ks in sorted(sizes.items())
                    )
                )
        return "; ".join(parts)

    def medians(group):
        steps = statistics.median(c["at_0.01"]["explicit_over_implicit_steps"] for c in group)
        per_step = statistics.median(
            c["at_0.01"]["implicit_over_explicit_cpu_per_step"] for c in group
        )
        return steps, per_step

    text = f"At 1 % error implicit is cheaper in {len(wins)} of {len(cells)} measured cells"
    if wins:
        steps, per_step = medians(wins)
        best = min(wins, key=lambda c: c["at_0.01"]["implicit_over_explicit_cost"])
        at = best["at_0.01"]
        imp, exp = at["best_implicit"], at["best_explicit"]
        text += (
            f" ({where(wins)}): there its cheapest run takes a median {steps:.3g}× fewer "
            f"steps than explicit at its stability limit, each costing {per_step:.3g}× an "
            f"explicit step (best: {best['size']}², k = {best['stretch_stiffness']:g}, "
            f"{best['bending']} bending, {imp['method']} "
            f"{imp.get('internal_steps') or imp['steps']} steps × "
            f"{duration_text(imp['cpu_per_step'])} against {exp['steps']} × "
            f"{duration_text(exp['cpu_per_step'])}, "
            f"{at['implicit_over_explicit_cost']:.2f}×)"
        )
    if losses:
        steps, per_step = medians(losses)
        text += (
            f"; explicit wins the other {len(losses)}, where the implicit step's cost "
            f"({per_step:.3g}× an explicit one, median) outweighs its {steps:.3g}× fewer "
            "steps"
        )
    return text + "."


def stiffest_judged_text(g):
    """For a 0.1 % target not judged at the grid's stiffest cell: the row's stiffest judged
    cell and its verdict, or nothing."""
    seen = g.get("stiffest_judged")
    if not seen:
        return ""
    verdict = (
        f"{seen['ratio']:.2f}, {seen['winner']}"
        if seen["ratio"] is not None
        else f"{seen['winner']}, no implicit run within the caps"
    )
    return f"; the row's stiffest judged cell, k = {seen['stretch_stiffness']:g}: {verdict}"


def target_text(g):
    """A target's outcome: met/missed with its ratio, or why it is not measured."""
    whys = "; ".join(f"{c['bending']}: {c['why']}" for c in g["cells"] if c.get("why"))
    if not g["measured"]:
        return f"not measured ({whys})" + stiffest_judged_text(g)
    if g["ratio"] is None:
        return f"missed ({whys})"
    return f"{'met' if g['met'] else 'missed'} ({g['ratio']:.2f}, {g['best']['bending']} bending)"


def summary_lines(payload):
    lines = []
    for item in payload["summary"]["crossovers"]:
        lines.append(
            f"crossover {item['bending']} bending {item['size']}²: "
            + (
                f"k ≈ {item['crossover_stiffness']:.3g} N/m"
                if item["crossover_stiffness"]
                else item.get("bound", "no data")
            )
        )
    for g in payload["summary"]["targets"]:
        lines.append(
            f"target {g['target']} (goal {'<' if g['goal_ratio'] == 1.0 else '≤'} "
            f"{g['goal_ratio']:g}): " + target_text(g)
        )
    for c in payload["summary"]["cells"]:
        for name, why in c.get("families_dropped", {}).items():
            lines.append(f"{describe(c)}: {name} left out ({why})")
    lines.append(finding(payload))
    return lines


# -- main -----------------------------------------------------------------------------------------
def options(parser):
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local Dask workers, one thread each (default: the cores)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        help="a running Dask scheduler (tcp://host:8786) instead of a local "
        "cluster; its workers need yore installed",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="run only the cells OUT/sweeps/crossover does not hold yet, with "
        "the settings it was started with; a cell stopped part-way "
        "replays the runs it had finished (OUT/sweeps/crossover/journal, "
        "kept on local clusters) and goes on from there",
    )
    parser.add_argument(
        "--sizes",
        type=int,
        nargs="+",
        default=None,
        help="sheet resolutions, vertices per edge (default 32 64 128)",
    )
    parser.add_argument(
        "--stiffness",
        type=float,
        nargs="+",
        default=None,
        help="stretch stiffnesses, N/m (default 2e3 2e4 2e5 2e6 2e7)",
    )
    parser.add_argument(
        "--bending",
        nargs="+",
        choices=BENDING_ROWS,
        default=None,
        help="bending rows (default all three)",
    )
    parser.add_argument(
        "--families",
        nargs="+",
        choices=list(FAMILIES),
        default=None,
        help="families to run (default all this build accepts; quick: "
        + ", ".join(QUICK_FAMILIES)
        + "); explicit is always run",
    )
    parser.add_argument(
        "--repeats",
        type=int,
        default=3,
        help="runs of every candidate-cheapest run; its cost is the median (default 3)",
    )
    parser.add_argument(
        "--max-run-seconds",
        type=float,
        default=None,
        help="CPU cap of one implicit run (default 120; quick: 2)",
    )
    parser.add_argument(
        "--max-ratio",
        type=float,
        default=8.0,
        help="cap of one implicit run over explicit's cost (default 8)",
    )
    parser.add_argument(
        "--max-reference-seconds",
        type=float,
        default=1800.0,
        help="CPU budget of one more reference halving (default 1800)",
    )
    parser.add_argument(
        "--collect",
        action="store_true",
        help="run no cell: write the results of the cells OUT/sweeps/crossover "
        "holds (e.g. while a run goes on, or after it was stopped)",
    )
    parser.add_argument(
        "--merge",
        type=Path,
        action="append",
        default=[],
        metavar="JSON",
        help="a crossover.json of an earlier run with the same families and "
        "budgets: its cells join this run's (this run's win where both "
        "hold a cell), so the grid can be measured a part at a time",
    )
    parser.add_argument(
        "--max-cell-seconds",
        type=float,
        default=3600.0,
        help="skip a cell whose explicit runs (limit, repeats, reference pair) "
        "would take more CPU seconds, predicted from the stability trials "
        "(default 3600)",
    )


def new_settings(args):
    quick = args.quick
    names = args.families or (QUICK_FAMILIES if quick else tuple(FAMILIES))
    names = ("explicit",) + tuple(n for n in names if n != "explicit")
    families, missing = available_families(names)
    if "explicit" not in families:
        raise SystemExit(f"explicit cannot be built: {missing['explicit']}")
    settings = {
        "quick": quick,
        "sizes": list(args.sizes or (QUICK_GRID["sizes"] if quick else SIZES)),
        "stiffness": [
            float(k)
            for k in (args.stiffness or (QUICK_GRID["stiffness"] if quick else STIFFNESSES))
        ],
        "bending": list(args.bending or (QUICK_GRID["bending"] if quick else BENDING_ROWS)),
        "repeats": args.repeats,
        "max_run_seconds": args.max_run_seconds or (2.0 if quick else 120.0),
        "max_ratio": args.max_ratio,
        "max_reference_seconds": args.max_reference_seconds,
        "max_cell_seconds": args.max_cell_seconds,
        "rates": list(QUICK_RATES if quick else RATES),
        "families_unavailable": [f"{n}: {why}" for n, why in missing.items()],
        "families": families,
    }
    if settings["repeats"] < 1:
        raise SystemExit("--repeats must be at least 1")
    return settings


#: Settings two runs must share for their cells to make one table (the grid may differ).
MERGE_KEYS = (
    "quick",
    "repeats",
    "max_run_seconds",
    "max_ratio",
    "max_reference_seconds",
    "max_cell_seconds",
    "rates",
)


def _cell_key(cell):
    return (int(cell["size"]), float(cell["stretch_stiffness"]), str(cell["bending"]))


#: Options that yore gained after runs were recorded, with the value that reproduces what those
#: runs ran (the behaviour before the option existed): a family of such a run that takes one of
#: them ran with this value.
LEGACY_OPTIONS = {
    "mixed": False,
    "truncation_fraction": 0.0,
    # tr-bdf2's error control (dt="auto"): off, and its tolerances idle
    "adaptive": False,
    "rtol": 1e-3,
    "atol": 1e-4,
    "max_steps": 5000,
}


def resolved_families(families):
    """Each family's options as yore resolves them (defaults and None decided), so two runs
    can tell whether a family ran the same way: {name: {option: value}}."""
    V, F = yore.grid_mesh(3, 3)
    return {
        name: dict(yore.Simulation(yore.Cloth(V, F), dt=1e-3, **options).resolved_options)
        for name, options in families.items()
    }


def earlier_resolved(earlier, current, given):
    """The earlier run's resolved family options: recorded, or for runs that predate the
    record, this run's (``current``) with `LEGACY_OPTIONS` in place of the options it did not
    know — for the families whose given options (``given``, this run's) were the same then
    apart from those; a family given otherwise counts as unknown ({})."""
    if "family_resolved_options" in earlier:
        # a recorded family ran an option added since as it was then (LEGACY_OPTIONS)
        return {
            name: (
                {
                    **{k: v for k, v in LEGACY_OPTIONS.items() if k in current.get(name, {})},
                    **options,
                }
                if options
                else options
            )
            for name, options in earlier["family_resolved_options"].items()
        }
    theirs = earlier.get("family_options", {})

    def core(options):
        return {k: v for k, v in options.items() if k not in LEGACY_OPTIONS}

    return {
        name: (
            {k: LEGACY_OPTIONS.get(k, v) for k, v in options.items()}
            if name in theirs and core(theirs[name]) == core(given.get(name, {}))
            else {}
        )
        for name, options in current.items()
    }


def merge_runs(settings, cells, rows, earlier, source="earlier run", resolved=None):
    """This run's (cells, rows) with an earlier run's payload: the earlier cells this run does
    not hold, or did not finish where the earlier run did, and their rows, join; the grid of
    ``settings`` becomes the union. SystemExit when the earlier run has a family this one does
    not, or they differ in thresholds or budgets (their costs would not compare). A family
    whose resolved options (``resolved``, this run's; see `earlier_resolved`) differ between the
    runs keeps no row in the earlier cells, which are summarised again without it and name it in
    ``families_dropped``: a number is kept only with the options it ran with. A family this run has and the earlier did not is named there too,
    as not run in those cells."""
    theirs = earlier.get("settings", {})
    for key in MERGE_KEYS:
        if theirs.get(key) != settings.get(key):
            raise SystemExit(
                f"--merge {source}: its {key} is {theirs.get(key)!r}, this run's "
                f"{settings.get(key)!r}; only runs with the same settings merge"
            )
    theirs_names = set(earlier.get("family_options", {}))
    if not theirs_names <= set(settings["families"]):
        raise SystemExit(
            f"--merge {source}: it has families this run has not: "
            + ", ".join(sorted(theirs_names - set(settings["families"])))
        )
    new = [name for name in settings["families"] if name not in theirs_names]
    if (
        list(earlier.get("thresholds", ())) != list(THRESHOLDS)
        or earlier.get("reference_tolerance") != REFERENCE_TOLERANCE
    ):
        raise SystemExit(f"--merge {source}: its thresholds differ from this run's")
    # a cell this run did not finish (stopped, skipped) gives way to the earlier run's cell
    # when that one finished: an interrupted run never erases a measured cell
    finished_before = {
        _cell_key(c) for c in earlier["summary"]["cells"] if c.get("status") == "done"
    }
    cells = [c for c in cells if c.get("status") == "done" or _cell_key(c) not in finished_before]
    held = {_cell_key(c) for c in cells}
    rows = [r for r in rows if _cell_key(r) in held]
    added = [c for c in earlier["summary"]["cells"] if _cell_key(c) not in held]
    keys = {_cell_key(c) for c in added}
    theirs_resolved = (
        earlier_resolved(earlier, resolved, settings["families"]) if resolved is not None else {}
    )
    dropped = {
        name: sorted(
            k
            for k in set(options) | set(theirs_resolved.get(name, {}))
            if options.get(k) != theirs_resolved.get(name, {}).get(k)
        )
        for name, options in (resolved or {}).items()
        if name not in new
    }
    dropped = {name: changed for name, changed in dropped.items() if changed}
    earlier_rows = [
        r
        for r in earlier["rows"]
        if (int(r["size"]), float(r["stretch_stiffness"]), str(r["bending"])) in keys
        and r["method"] not in dropped
    ]
    rows = rows + earlier_rows
    # the earlier cells are summarised again by this run's rules (families, reference rule)
    kept = [name for name in settings["families"] if name not in dropped and name not in new]
    resummarized = []
    for c in added:
        cell = dict(c)
        if c.get("status") == "done" and c.get("reference_error") is not None:
            info = {k: v for k, v in c.items() if not k.startswith("at_")}
            mine = [r for r in earlier_rows if _cell_key(r) == _cell_key(c)]
            cell = summarize_cell(info, mine, kept)
        if dropped or new:
            cell["families_dropped"] = {
                **c.get("families_dropped", {}),
                **{
                    name: "measured with other options: "
                    + ", ".join(
                        f"{k} {theirs_resolved.get(name, {}).get(k)!r} (now {resolved[name].get(k)!r})"
                        for k in changed
                    )
                    for name, changed in dropped.items()
                },
                **{name: "not run: not a family yet when the cell ran" for name in new},
            }
        resummarized.append(cell)
    added = resummarized
    merged = dict(settings)
    merged["sizes"] = sorted({*settings["sizes"], *(k[0] for k in keys)})
    merged["stiffness"] = sorted({*settings["stiffness"], *(k[1] for k in keys)})
    merged["bending"] = [
        b for b in BENDING_ROWS if b in settings["bending"] or any(k[2] == b for k in keys)
    ]
    origin = {
        "from": source,
        "machine": earlier.get("machine"),
        "cells": [list(k) for k in sorted(keys, key=str)],
        "families_dropped": {name: changed for name, changed in dropped.items()},
        "families_new": new,
    }
    return merged, cells + added, rows, origin


def main(argv=None):
    import tomllib

    from yore.sweep import run

    args = arguments(__doc__, argv, options)
    folder = Path(args.out).joinpath(*SWEEP_FOLDER)
    if args.resume or args.collect:
        scene = folder / "scene.toml"
        if not scene.is_file():
            raise SystemExit(f"{folder} holds no crossover to resume (no scene.toml)")
        settings = tomllib.loads(scene.read_text(encoding="utf-8"))
        print(
            f"{'collecting' if args.collect else 'resuming'} {folder} with its settings "
            "(grid and budget flags ignored)"
        )
    else:
        settings = new_settings(args)
        shutil.rmtree(folder / "journal", ignore_errors=True)  # a new run measures afresh
        if not args.scheduler:  # a cluster's workers need not share this file system
            settings["journal"] = str((folder / "journal").resolve())
    for line in settings["families_unavailable"]:
        print(f"left out: {line}")
    sweep = grid_sweep(settings)
    _send_code_by_value()
    started = time.perf_counter()
    if args.collect:  # the cells finished so far; the others stay "not run"
        from yore.sweep.results import Results

        results = Results(sweep, folder)
        results.load_finished()
    else:
        results = run(
            sweep,
            folder,
            scheduler=args.scheduler,
            workers=args.workers,
            overwrite=not args.resume,
            resume=args.resume,
            cell_function=crossover_cell,
        )
    rows, cells = collect(sweep, results, settings["families"])
    if settings.get("journal"):  # a recorded cell needs its runs no more
        for cell in cells:
            if cell.get("status") in ("done", "skipped"):
                shutil.rmtree(journal_folder(settings["journal"], cell), ignore_errors=True)
    merged_from = []
    grid = settings
    resolved = resolved_families(settings["families"])
    for path in args.merge:
        earlier = json.loads(Path(path).read_text(encoding="utf-8"))
        grid, cells, rows, origin = merge_runs(grid, cells, rows, earlier, str(path), resolved)
        merged_from.append(origin)
    good = measured(cells)
    payload = {
        "benchmark": "crossover",
        "machine": machine_info(),
        "quick": settings["quick"],
        "clock": "time.thread_time() of the task's thread around the stepping only; yore "
        "pinned to one thread",
        "families": list(settings["families"]),
        "family_options": settings["families"],
        # as this code resolves them (a run resumed or collected after yore changed: today's)
        "family_resolved_options": resolved,
        "families_unavailable": settings["families_unavailable"],
        "thresholds": list(THRESHOLDS),
        "reference_tolerance": REFERENCE_TOLERANCE,
        "sample_times": "T/2 and T of each cell (its horizon); a run's error is the larger",
        "settings": {k: v for k, v in grid.items() if k != "families"},
        "sweep": folder.as_posix(),
        "cells": len(cells),
        "statuses": dict(Counter(c.get("status", "not run") for c in cells)),
        "merged_from": merged_from,
        "wall_seconds": time.perf_counter() - started,
        "cell_cpu_seconds": sum(c.get("cell_thread_cpu_seconds", 0.0) for c in cells),
        "rows": rows,
        "summary": {
            "cells": [{k: v for k, v in c.items() if k != "log"} for c in cells],
            "crossovers": crossovers(good),
            "targets": targets(cells, grid["stiffness"]),
        },
    }
    payload["summary"]["lines"] = summary_lines(payload)
    save(Path(args.out), "crossover", payload, lambda path: plot(payload, path))
    for line in summary_table(payload) + [""] + payload["summary"]["lines"]:
        print(line)
    return payload


def _send_code_by_value():
    """Workers of a remote cluster have yore but not this repository: the cell function goes
    to them by value (cloudpickle), not as a reference to the `benchmarks` package."""
    import cloudpickle

    module = sys.modules[__name__]
    if __name__ != "__main__":  # __main__'s functions are sent by value anyway
        cloudpickle.register_pickle_by_value(module)


# -- the map --------------------------------------------------------------------------------------
def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    cells = payload["summary"]["cells"]
    bendings = [b for b in BENDING_ROWS if any(c["bending"] == b for c in cells)] or ["equal"]
    sizes = sorted({c["size"] for c in cells}) or [0]
    stiffnesses = sorted({c["stretch_stiffness"] for c in cells}) or [0.0]
    fig, axes = plt.subplots(
        len(bendings),
        len(THRESHOLDS),
        squeeze=False,
        figsize=(
            1.5 * len(stiffnesses) * len(THRESHOLDS) + 1.5,
            (0.7 * len(sizes) + 0.8) * len(bendings) + 0.8,
        ),
    )
    norm = LogNorm(0.1, 10.0)  # symmetric about 1 in log: implicit 10× cheaper … 10× dearer
    image = None
    for (b, bending), (t, threshold) in (
        (x, y) for x in enumerate(bendings) for y in enumerate(THRESHOLDS)
    ):
        ax = axes[b][t]
        grid = np.full((len(sizes), len(stiffnesses)), np.nan)
        for c in cells:
            if c["bending"] != bending:
                continue
            i, j = sizes.index(c["size"]), stiffnesses.index(c["stretch_stiffness"])
            item = _cell_verdict(cells, c["size"], c["stretch_stiffness"], bending, threshold)
            if item["ratio"] is not None:
                grid[i, j] = item["ratio"]
                # the winner and the ratio; where explicit wins, also the implicit family
                # family names wrapped to fit a cell ("BDF2 clamp,\nstep test")
                text = "\n".join(textwrap.wrap(item["winner"], 12) + [f"{item['ratio']:.2g}"])
                if item["winner"] == "explicit":
                    text += "\n" + "\n".join(
                        textwrap.wrap(f"(vs {item['implicit']['method']})", 14)
                    )
            elif item.get("winner"):
                text = "explicit\n(no implicit run\nwithin the caps)"
            elif c.get("status") != "done":
                text = str(c.get("status"))
            elif not reference_serves(c, threshold):
                error = c.get("reference_error")
                text = (
                    "reference\ndiverged"
                    if error is None
                    else f"reference\ntoo coarse\n({error:.1e})"
                )
            else:
                text = item["why"].replace(" reached", "\nat")
            dark = np.isfinite(grid[i, j]) and abs(math.log10(grid[i, j])) > 0.6
            ax.text(
                j,
                i,
                text,
                ha="center",
                va="center",
                fontsize=5.5,
                color="white" if dark else "black",
            )
        image = ax.imshow(
            np.ma.masked_invalid(np.clip(grid, 0.1, 10.0)),
            cmap="RdBu_r",
            norm=norm,
            origin="lower",
            aspect="auto",
        )
        ax.set_xticks(range(len(stiffnesses)), [f"{k:g}" for k in stiffnesses], fontsize=6)
        ax.set_yticks(range(len(sizes)), [f"{n}²" for n in sizes], fontsize=6)
        if b == len(bendings) - 1:
            ax.set_xlabel("stretch stiffness, N/m", fontsize=7)
        if t == 0:
            ax.set_ylabel(f"{bending} bending\nsheet, vertices", fontsize=7)
        if b == 0:
            ax.set_title(f"at {100 * threshold:g} % error", fontsize=8)
    fig.suptitle("cheapest implicit / cheapest explicit CPU cost (cell: winner, ratio)", fontsize=9)
    fig.colorbar(
        image,
        ax=axes.ravel().tolist(),
        shrink=0.8,
        label="implicit / explicit cost (blue: implicit cheaper)",
    )
    fig.savefig(path, dpi=110, bbox_inches="tight")  # the colour bar's label fits
    plt.close(fig)


if __name__ == "__main__":
    main()
