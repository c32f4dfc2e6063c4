"""Accuracy over the seconds users simulate: energy histories, centroid paths and trajectories of
implicit runs against explicit over a long horizon, one cell per Dask task on the `yore.sweep`
engine (issue 39, item 1).

    python -m benchmarks.long_horizon [--out bench-results] [--quick] [--workers N]
        [--scheduler tcp://host:8786] [--resume] [--collect] [--merge EARLIER.json ...]
        [--sizes 32 64 128] [--stiffness 2e4 2e5 2e6 2e7] [--bending equal "real cloth"]
        [--families NAME ...] [--horizon 2] [--horizon-at SIZE=T ...] [--thresholds 0.05 0.01]
        [--repeats 3] [--max-run-seconds 600] [--max-ratio 8] [--max-cell-seconds 3600]

The crossover (`benchmarks.crossover`) judges every run over the first 1/8–1/4 s after the sheet
is let go. Over seconds the error of an implicit step is another one: the motion it damps away.
This benchmark measures that, with the crossover's machinery (imported from it, not copied):
its sheets and bending rows, its stability search, its per-cell journal (--resume replays a
cell stopped part-way), its sweep grid and records, its selection of the cheapest run per family,
its CPU clock and its budgets.

Cells: (size N, stretch stiffness k, bending row) on the crossover's sheet,
`yore.scenes.hanging_cloth(resolution=N, pin_spacing=1.0, mass=0.1, ...)`, N ∈ {32, 64, 128},
k ∈ {2e4, 2e5, 2e6, 2e7} N/m, bending "equal" (bending springs of k) or "real cloth"
(quadratic bending, 1e-5 N·m), as `benchmarks.crossover.bending_arguments` sets them.

Horizon T: 2 s (--horizon), 1 s at 128² (--horizon-at 128=1, the default): explicit's runs cost
∝ N³·√k·T, and an explicit 128² run at 2e7 N/m costs about 1.5 CPU hours per simulated 2 s
(about 45 min per second; a 128² cell at 2e7 runs explicit eleven times that long: see Cost).
--horizon-at 32=4 runs the 32² cells over 4 s. T must be a multiple of 1/32 s.

Sampling. Every run is sampled on one grid, every 1/64 s of simulated time (finer than the
1/60 s asked), at times its steps land on exactly, so no run is interpolated:
- explicit's step is 1/64 s divided by a whole number m (the smallest m whose step is at most
  the bisected stable limit: m is in the hundreds at 32² and more above, so the step is within
  a fraction of a percent of the limit);
  the reference runs 2m, the floor's finer run 4m steps per grid interval;
- the implicit ladder's steps 1/64 … 1/512 s divide 1/64 s; its first rung, 1/32 s, has no state
  between its steps and is sampled at every second grid point (every 1/32 s). A 1/32 s run is
  compared with the reference at its own points (the reference has them all): it is judged on
  the motion it has, not on an interpolation that would charge or hide an error of its own.
Samples include t = 0 and t = T. Each records the energies of `sim.energy()` (kinetic, spring,
gravity, bending and their total, J) and the mass-weighted centroid; positions are kept up to the
cell's predictability time (all of the run for the two references that define it).

Measures (each a number ≥ 0, judged against a threshold; a run "meets" t when measure ≤ t):
- kinetic_energy_history: ‖KE_run − KE_ref‖₂ / ‖KE_ref‖₂ over the run's sample times.
- total_energy_history: ‖E_run − E_ref‖₂ / ‖KE_ref‖₂, E = kinetic + spring + gravity + bending.
  Not over ‖E_ref‖₂: E starts at 0 and only the (physical) damping and drag move it, so ‖E_ref‖
  is the small energy those dissipate and would make any error look huge; over the motion's
  kinetic energy it reads as "the energy the run gains or loses, as a fraction of the motion's",
  the same unit as the kinetic-energy history (an integrator's numerical damping shows in both).
- centroid_path: the largest distance over the run between the run's and the reference's
  mass-weighted centroid, over the sheet's size (its edge, 1 m).
- energy_retained: |mean KE over the last 0.25 s / the reference's − 1| (a single instant is
  noisy: the sheet swings through a turning point); KE(T)/KE_ref(T) is recorded beside it
  (kinetic_energy_retained_at_end), as is the mean ratio itself.
- trajectory: RMS vertex distance to the reference over the bounding-box diagonal at the start
  (√2 m; the crossover's error), the largest over the sample times up to the cell's
  predictability time: the last sample at which two references whose starts differ by round-off
  (every free vertex moved 1e-12 × the size in a fixed random direction, `benchmarks.sensitivity`'s
  seed) are still within PREDICTABILITY (1e-3) of each other by the same distance; the whole run
  when they never part (`predictability_reached` false).

Reference and floors. The reference is explicit (symplectic Euler) at half its limit (2m steps
per grid interval). A measure's floor is how well the reference itself defines it: the larger of
the measure of (a) explicit at a quarter of the limit (4m) and of (b) the reference from the
round-off-perturbed start, each against the reference. A threshold t is judged for a measure only
where that measure's floor is below t/3 (FLOOR_FRACTION); elsewhere the verdict is "not judged",
with the floor. (The trajectory measure's floor is about PREDICTABILITY by construction.)

Families: one table, FAMILIES (display name → `yore.Simulation` options), filtered by what this
build accepts (a refused row is left out and named with the reason): explicit at its limit, BE
(`integrator="implicit"`) and BDF2 at yore's defaults, generalized-α at its default ρ∞ and at
ρ∞ = 0.5 (less damping, less robust), TR-BDF2, the implicit midpoint rule (no numerical damping:
the non-dissipative row); BDF2 with Newton solved tight (residual test at
1e-9 of a rest length, no truncation test), and the error-controlled TR-BDF2 (dt="auto") and
CVODE at rtol 1e-4, atol 1e-5 m, each one run with an output interval of 1/64 s (their steps
are their tolerance's, so they have no step ladder), the former also with Newton stopped ten
times tighter and by its residual test alone at 1e-7; and the rows "at tolerance"
(`benchmarks.tolerance`: TR-BDF2 and BDF2 with dt="auto" and CVODE at rtol 1e-2, 1e-3, 1e-4,
atol = rtol/10 m), read off per cell in `at_tolerance` and `at_tolerance_verdicts` as the
crossover does. --quick runs QUICK_FAMILIES.

Runs, as the crossover's: explicit at the limit over the whole horizon (diverged, or its
kinetic-energy history over BLOW_UP from the reference: m grows by 5 % and it runs again); each
implicit family over the ladder dt = 1/32 … 1/512 s, stopping once a run meets the smallest
threshold on the kinetic-energy history and the next one costs more, or after two runs in a row
aborted by the budget. Cost: CPU seconds of the stepping only (sampling excluded) per simulated
second, on the task thread's clock (`time.thread_time()`), yore pinned to one thread. Repeats:
explicit at its limit (the denominator of every ratio) and every run that could be its family's
cheapest at a judged (measure, threshold) run --repeats times in all; the cost is the median.
Budgets: an implicit run is aborted once its CPU, or its CPU extrapolated from the steps done,
exceeds min(--max-run-seconds, --max-ratio × explicit's cost); a cell whose explicit runs (the
limit with its repeats, reference, perturbed reference, quarter step: repeats + 8 limit-run
equivalents) would take more than --max-cell-seconds, predicted from the stability trials, is
skipped with the reason. A journal per cell (OUT/sweeps/long_horizon/journal/CELL/) keeps each
finished run, its sampled arrays included, so --resume goes on from the run a cell was on.

Verdict per (cell, measure, threshold), where judged: each family's cheapest run meeting it (the
crossover's `summarize_cell` selection), the cheapest implicit one, and its cost over explicit's
at the limit (`implicit_over_explicit_cost`; `explicit_meets` says whether explicit at its limit
meets the threshold itself: it is the cheapest explicit run either way).

Cost (a model, explicit only: E ≈ 4.4 CPU s per simulated s × (N/32)³ × √(k / 2e5) at its limit,
× (repeats + 8) runs × T; the bending row barely matters): 32² cells ~0.5 min (2e4) to ~16 min
(2e7); 64² ~40 min at 2e6 and ~2.1 h at 2e7; 128² at T = 1 s ~50 min (2e5), ~2.7 h (2e6),
~8.6 h (2e7). Implicit runs add up to about as much again. At the default --max-cell-seconds
3600 the 64² 2e7 and 128² ≥ 2e6 cells are skipped, and the rest of the grid takes ~5 CPU h of
explicit runs (~10 h in all, ~5 h on two workers); the skipped six need ~27 CPU h more: measure
them with a larger budget, a part at a time (--sizes/--stiffness/--bending, --merge), across
sessions (the journal).

Outputs: OUT/long_horizon.json (every run with its measures and kinetic-energy history; per cell
the floors, the predictability time and the verdicts; the summary lines), OUT/long_horizon.png
(one map per measure at the largest threshold: implicit/explicit cost, judged or not; and the
kinetic-energy histories of one cell's 1/32 s runs against the reference), the sweep's Dataset
OUT/sweeps/long_horizon/results.nc and its per-cell records (cells/ID.json). --quick: one 10²
cell, k = 2e4, equal bending, T = 0.5 s, explicit and BE, ladder 1/32 … 1/128 s (seconds).

Bad input (a horizon ≤ 0, not finite or not a multiple of 1/32 s, a threshold outside (0, 1), an
unknown family, a size < 4, ...): one `yore: error: ...` line on stderr, exit code 2.
"""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
import statistics
import sys
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

import yore

from . import common, sensitivity, tolerance
from . import crossover as cx
from .common import arguments, machine_info, save

GRID_RATE = 64  # sample points per simulated second; every run's step divides 1/32 s
THRESHOLDS = (0.05, 0.01)
FLOOR_FRACTION = 1 / 3  # a threshold is judged where a measure's floor is below this × it
PREDICTABILITY = 1e-3  # references moved by round-off part at this distance / diagonal
PERTURBATION = 1e-12  # the perturbed start: free vertices moved by this × the sheet's size
RETAINED_WINDOW = 0.25  # s: energy retained = mean KE over the last RETAINED_WINDOW
BLOW_UP = 0.25  # explicit at its limit farther than this in KE history: unstable
RATES = (32, 64, 128, 256, 512)  # implicit ladder, steps per second
QUICK_RATES = RATES[:3]
SIZES = (32, 64, 128)
STIFFNESSES = (2e4, 2e5, 2e6, 2e7)  # N/m
BENDING_ROWS = ("equal", "real cloth")
#: rows run when asked (--bending): "equal, damped" is "equal" with the material damping of real
#: fabric (crossover.FABRIC_DAMPING), whose reference no longer rings with the stiff springs
EXTRA_ROWS = ("equal, damped",)
ALL_ROWS = BENDING_ROWS + EXTRA_ROWS
HORIZON = 2.0  # s
HORIZON_AT = ((128, 1.0),)  # (size, s): explicit 128² at 2e7 costs ~1.5 CPU h per 2 s
QUICK_GRID = {"sizes": (10,), "stiffness": (2e4,), "bending": ("equal",), "horizon": 0.5}
SWEEP_FOLDER = ("sweeps", "long_horizon")  # under --out
#: the measures, in the order of the tables and the map
MEASURES = {
    "kinetic_energy_history": "‖KE − KE_ref‖₂ / ‖KE_ref‖₂ over the sample times",
    "total_energy_history": "‖E − E_ref‖₂ / ‖KE_ref‖₂, E the total mechanical energy",
    "centroid_path": "largest centroid distance to the reference's / sheet size",
    "energy_retained": "|mean KE over the last 0.25 s / the reference's − 1|",
    "trajectory": "largest RMS vertex distance / diagonal up to the predictability time",
}
LADDER_MEASURE = "kinetic_energy_history"  # the implicit ladder stops on this one
#: columns of a run's sample table
COLUMNS = (
    "grid_point",
    "kinetic",
    "spring",
    "gravity",
    "bending",
    "total",
    "centroid_x",
    "centroid_y",
    "centroid_z",
)

# The families, one row each: display name → yore.Simulation options. Every family but
# "explicit" counts as implicit. A row the build does not accept is left out (available_families).
FAMILIES = {
    "explicit": {"integrator": "explicit"},
    "implicit": {"integrator": "implicit"},  # backward Euler at yore's defaults
    "bdf2": {"integrator": "bdf2"},
    "generalized-alpha": {"integrator": "generalized-alpha"},
    "generalized-alpha rho 0.5": {"integrator": "generalized-alpha", "rho_infinity": 0.5},
    "tr-bdf2": {"integrator": "tr-bdf2"},
    # the non-dissipative row (issue 54): the implicit midpoint rule damps no frequency, so its
    # runs show what the others' numerical damping costs and where no damping fails
    "implicit-midpoint": {"integrator": "implicit-midpoint"},
    # Newton solved tight (residual test at 1e-9, no truncation test): is the 2 % plateau of
    # the implicit runs at 2e6 N/m Newton's stopping error?
    "bdf2 tight Newton": {"integrator": "bdf2", "newton_tol": 1e-9, "truncation_fraction": 0.0},
    # error-controlled at one tolerance (rtol 1e-4, atol 1e-5 m): one run at an output
    # interval of the sampling grid (1/64 s), no step ladder
    "tr-bdf2 auto 1e-4": {"integrator": "tr-bdf2", "adaptive": True, "rtol": 1e-4, "atol": 1e-5},
    "cvode 1e-4": {"integrator": "cvode", "rtol": 1e-4, "atol": 1e-5},
    # the same TR-BDF2 with Newton stopped ten times tighter, and by its residual test alone at
    # 1e-7 of a rest length: does the plateau move with Newton's stop?
    "tr-bdf2 auto 1e-4, truncation 0.01": {
        "integrator": "tr-bdf2",
        "adaptive": True,
        "rtol": 1e-4,
        "atol": 1e-5,
        "truncation_fraction": 0.01,
    },
    "tr-bdf2 auto 1e-4, Newton 1e-7": {
        "integrator": "tr-bdf2",
        "adaptive": True,
        "rtol": 1e-4,
        "atol": 1e-5,
        "newton_tol": 1e-7,
        "truncation_fraction": 0.0,
    },
}
# "at tolerance" rows (issue 40, item 4): yore's own error-controlled BDF2 and TR-BDF2 and
# CVODE at rtol 1e-2, 1e-3, 1e-4, atol = rtol / 10 m (benchmarks.tolerance); the 1e-4 rows of
# TR-BDF2 and CVODE are the diagnostic rows above, unchanged
FAMILIES.update(
    {name: options for name, options in tolerance.families().items() if name not in FAMILIES}
)
#: families whose steps their tolerance chooses: dt is their output interval, one rung only
ERROR_CONTROLLED = tuple(
    name for name, options in FAMILIES.items() if tolerance.is_error_controlled(options)
)
QUICK_FAMILIES = ("explicit", "implicit")
#: the issue's targets: (name, size, k, bending, measure, threshold, goal ratio)
TARGETS = (
    ("64², k = 2e5, equal bending", 64, 2e5, "equal", LADDER_MEASURE, 0.05, 0.3),
    ("64², k = 2e6, equal bending", 64, 2e6, "equal", LADDER_MEASURE, 0.05, 0.1),
    ("128², k = 2e5, equal bending", 128, 2e5, "equal", LADDER_MEASURE, 0.05, 0.2),
    ("128², k = 2e6, equal bending", 128, 2e6, "equal", LADDER_MEASURE, 0.05, 0.05),
    ("128², k = 2e7, real cloth", 128, 2e7, "real cloth", LADDER_MEASURE, 0.05, 0.1),
)


class BadInput(ValueError):
    """A command line or an earlier file this benchmark cannot judge."""


def refusal(options):
    """Why this build refuses a family's options (the first line of yore's error), or None."""
    try:
        cx.resolved_families({"probe": options})
    except (ValueError, TypeError, NotImplementedError) as error:
        return str(error).splitlines()[0]
    return None


def available_families(names):
    """The families of `names` this build can construct, and why the others are left out."""
    why = {name: refusal(FAMILIES[name]) for name in names}
    return (
        {name: FAMILIES[name] for name in names if why[name] is None},
        {name: reason for name, reason in why.items() if reason is not None},
    )


def horizon(settings, size):
    """T of a size, s: --horizon-at's where given, else --horizon."""
    return float(
        dict((int(n), t) for n, t in settings["horizon_at"]).get(int(size), settings["horizon"])
    )


# -- the measures -------------------------------------------------------------------------------
def relative_l2(values, reference, norm_of=None):
    """‖values − reference‖₂ / ‖norm_of‖₂ (norm_of: the reference by default)."""
    values, reference = np.asarray(values, float), np.asarray(reference, float)
    scale = np.linalg.norm(reference if norm_of is None else np.asarray(norm_of, float))
    return float(np.linalg.norm(values - reference) / scale)


def centroid(masses, positions):
    """Mass-weighted centroid of positions (n×3, or k×n×3 for k of them), m."""
    masses = np.asarray(masses, float)
    return np.tensordot(np.asarray(positions, float), masses, axes=([-2], [0])) / masses.sum()


def largest_distance(path, reference, scale):
    """The largest distance between two paths (k×3) at the same times, over scale."""
    return float(np.max(np.linalg.norm(np.asarray(path) - np.asarray(reference), axis=1)) / scale)


def rms_distance(a, b, scale):
    """RMS vertex distance between two position arrays (n×3), over scale."""
    return float(np.sqrt(np.mean(np.sum((np.asarray(a) - np.asarray(b)) ** 2, axis=1)))) / scale


def run_measures(run, reference, scales, until):
    """The measures of a run (`history`'s result) against the reference's (sampled at every grid
    point), over the run's own sample times; the trajectory over those up to `until` s."""
    positions, table = run["snapshots"]
    ref_positions, ref_table = reference["snapshots"]
    points = table[:, 0].astype(int)
    ref = ref_table[points]
    times = points / GRID_RATE
    kinetic, ref_kinetic = table[:, 1], ref[:, 1]
    late = times >= times[-1] - RETAINED_WINDOW - 1e-12
    retained = float(kinetic[late].mean() / ref_kinetic[late].mean())
    within = [i for i in range(len(positions)) if times[i] <= until + 1e-12]
    return {
        "kinetic_energy_history": relative_l2(kinetic, ref_kinetic),
        "total_energy_history": relative_l2(table[:, 5], ref[:, 5], norm_of=ref_kinetic),
        "centroid_path": largest_distance(table[:, 6:9], ref[:, 6:9], scales["sheet_size"]),
        "energy_retained": abs(retained - 1.0),
        "trajectory": max(
            (
                rms_distance(positions[i], ref_positions[points[i]], scales["diagonal"])
                for i in within
            ),
            default=0.0,
        ),
        "kinetic_energy_retained_at_end": float(kinetic[-1] / ref_kinetic[-1]),
        "kinetic_energy_retained_last_quarter_second": retained,
    }


def predictability_time(perturbed, reference, diagonal):
    """The last sample time at which the perturbed reference is within PREDICTABILITY of the
    reference (RMS vertex distance / diagonal), whether they parted at all, and the distances."""
    positions, ref_positions = perturbed["snapshots"][0], reference["snapshots"][0]
    distances = [rms_distance(a, b, diagonal) for a, b in zip(positions, ref_positions)]
    parted = next((i for i, d in enumerate(distances) if d > PREDICTABILITY), None)
    last = len(distances) - 1 if parted is None else max(0, parted - 1)
    return last / GRID_RATE, parted is not None, distances


# -- one run ------------------------------------------------------------------------------------
def perturb(sim, epsilon):
    """Moves every free vertex of the cloth by epsilon m, in `benchmarks.sensitivity`'s fixed
    random directions."""
    positions = np.array(sim.cloth.positions)
    directions = np.random.default_rng(sensitivity.SEED).standard_normal(positions.shape)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions[np.asarray(sim.cloth.fixed_vertices, int)] = 0.0
    sim.cloth.positions = positions + epsilon * directions


def history(
    make, options, per_sample, stride, duration, keep_until, cap_seconds=math.inf, epsilon=0.0
):
    """Runs from the start (moved by epsilon) with steps of stride / (GRID_RATE · per_sample) s,
    sampling every `stride` grid points: {"snapshots": [positions at the samples up to
    keep_until (k×n×3), the sample table (COLUMNS)], "cpu_seconds": of the stepping alone,
    "counters"}. Diverged (or not finite) → {"diverged": True, "message" when the simulation
    said why}; CPU spent, or extrapolated from
    the steps done once a sixteenth of them ran, beyond cap_seconds → {"aborted": ...}."""
    samples = round(duration * GRID_RATE) // stride
    steps = samples * per_sample
    sim = make(dt=stride / (GRID_RATE * per_sample), **options)
    if epsilon:
        perturb(sim, epsilon)
    masses = np.asarray(sim.cloth.masses)
    table, positions, cpu = [], [], 0.0

    def sample(k):
        X = np.array(sim.cloth.positions)
        energy = sim.energy()
        table.append([k * stride, *(energy[n] for n in COLUMNS[1:6]), *centroid(masses, X)])
        if k * stride / GRID_RATE <= keep_until + 1e-12:
            positions.append(X)

    sample(0)
    for k in range(1, samples + 1):
        start = time.thread_time()
        try:
            sim.step(per_sample, progress=False)
        except yore.SimulationDiverged as error:
            message = " ".join(str(error).split())
            return {"diverged": True, "steps_done": (k - 1) * per_sample, "message": message}
        cpu += time.thread_time() - start
        sample(k)
        predicted = cpu * samples / k
        if k < samples and 16 * k >= samples and max(cpu, predicted) > cap_seconds:
            return {
                "aborted": f"CPU {cpu:.3g} s after {k * per_sample} of {steps} steps, "
                f"extrapolated {predicted:.3g} s > cap {cap_seconds:.3g} s",
                "cost_estimate": predicted / duration,
                "steps_done": k * per_sample,
            }
    table = np.array(table)
    if not np.isfinite(table).all():
        return {"diverged": True, "steps_done": steps}
    return {
        "snapshots": [np.array(positions), table],
        "cpu_seconds": cpu,
        "counters": cx.numeric_counters(sim.stats["counters"]),
        "internal_steps": tolerance.internal_steps(sim),
    }


# -- one cell -----------------------------------------------------------------------------------
def judged(floor, threshold):
    """Whether a measure with this floor is judged at threshold (floor below a third of it)."""
    return floor is not None and floor < FLOOR_FRACTION * threshold


def measure_cell(cell, make, families, settings, log, journal=None):
    """Rows of every run of one cell, and the cell's facts (stability search, references,
    predictability time, floors). journal: a `crossover.Journal` that keeps (and replays) the
    cell's runs."""
    duration = cell["horizon"]
    journal = journal or cx.Journal(None, log)
    thresholds = settings["thresholds"]

    def simulate(options, per_sample, stride, keep_until, cap=math.inf, epsilon=0.0):
        asked = {
            "run": options,
            "per_sample": per_sample,
            "stride": stride,
            "duration": duration,
            "keep_until": keep_until,
            "cap": cap,
            "epsilon": epsilon,
        }
        return journal.run(
            asked,
            lambda: history(make, options, per_sample, stride, duration, keep_until, cap, epsilon),
        )

    probe = make()
    extent = np.ptp(np.asarray(probe.cloth.positions), axis=0)
    scales = {"sheet_size": float(extent.max()), "diagonal": float(np.linalg.norm(extent))}
    estimate = probe.stable_dt()
    limit, trials = cx.trial_limit(
        make,
        estimate,
        lambda dt: journal.run(
            {"stability trial": dt, "steps": cx.SEARCH_STEPS}, lambda: cx.is_stable(make, dt)
        ),
    )
    per_sample = math.ceil(1.0 / (GRID_RATE * limit) - 1e-9)  # explicit's step ≤ the limit
    grid_points = round(duration * GRID_RATE)
    info = dict(
        cell, stable_dt_estimate=estimate, trial_limit_dt=limit, stability_trials=trials, **scales
    )
    per_step = statistics.median(t["cpu_per_step"] for t in trials)
    predicted = per_step * per_sample * grid_points * (settings["repeats"] + 8)
    info["predicted_explicit_cpu_seconds"] = predicted
    if predicted > settings["max_cell_seconds"]:
        info["skipped"] = (
            f"explicit's runs and references ~{predicted:.0f} CPU s > "
            f"--max-cell-seconds {settings['max_cell_seconds']:g}"
        )
        log(f"{cx.describe(cell)}: {info['skipped']}; cell skipped")
        return [], info
    explicit = families["explicit"]
    reference = simulate(explicit, 2 * per_sample, 1, duration)
    perturbed = simulate(
        explicit, 2 * per_sample, 1, duration, epsilon=PERTURBATION * scales["sheet_size"]
    )
    if reference.get("diverged") or perturbed.get("diverged"):
        log(f"{cx.describe(cell)}: the reference diverged; cell left out")
        info["reference_diverged"] = True
        return [
            dict(
                cell,
                method="reference",
                dt=1 / (2 * GRID_RATE * per_sample),
                steps=2 * per_sample * grid_points,
                diverged=True,
                aborted=None,
            )
        ], info
    until, parted, distances = predictability_time(perturbed, reference, scales["diagonal"])
    info.update(
        predictability_time=until,
        predictability_reached=parted,
        perturbed_distance_at_end=distances[-1],
        perturbation_m=PERTURBATION * scales["sheet_size"],
        reference_dt=1 / (2 * GRID_RATE * per_sample),
    )

    def row(method, per_sample, stride, result, **extra):
        steps = per_sample * (grid_points // stride)
        base = dict(
            cell,
            method=method,
            dt=duration / steps,
            steps=steps,
            steps_per_sample=per_sample,
            sample_stride=stride,
            sample_seconds=stride / GRID_RATE,
            diverged=bool(result.get("diverged")),
            aborted=result.get("aborted"),
            repeats=0,
            **extra,
        )
        if "snapshots" in result:
            counters = result["counters"]
            found = run_measures(result, reference, scales, until)
            unconverged = int(counters.get("unconverged_steps", 0))
            base.update(
                found,
                error=found[LADDER_MEASURE],
                counters=counters,
                iterations=int(
                    next((counters[k] for k in cx.ITERATION_COUNTERS if k in counters), steps)
                ),
                factorizations=int(counters.get("factorizations", 0)),
                unconverged_steps=unconverged,
                flagged=unconverged > 0,
                repeats=1,
                internal_steps=result.get("internal_steps"),
                cpu_seconds_samples=[result["cpu_seconds"]],
                kinetic_energy=result["snapshots"][1][:, 1].tolist(),
                total_energy=result["snapshots"][1][:, 5].tolist(),
            )
            cx.set_cost(base, result["cpu_seconds"])
        elif result.get("aborted"):
            base["cost_estimate_seconds_per_simulated_second"] = result["cost_estimate"]
        return base

    quarter = simulate(explicit, 4 * per_sample, 1, until)
    rows = [
        row("reference", 2 * per_sample, 1, reference),
        row("reference, perturbed start", 2 * per_sample, 1, perturbed),
        row("reference, quarter step", 4 * per_sample, 1, quarter),
    ]
    if rows[2]["diverged"]:
        info["floors"] = None
        log(f"{cx.describe(cell)}: explicit at a quarter of its limit diverged; no floors")
        return rows, info
    info["floors"] = {
        m: {
            "quarter_step": rows[2][m],
            "perturbed_start": rows[1][m],
            "floor": max(rows[2][m], rows[1][m]),
        }
        for m in MEASURES
    }
    log(
        f"{cx.describe(cell)}: limit {limit:.3g} s, explicit {per_sample} steps per 1/64 s; "
        f"predictability {until:g} s{'' if parted else ' (never parted)'}; floors "
        + ", ".join(f"{m} {f['floor']:.1e}" for m, f in info["floors"].items())
    )

    # explicit at its limit over the whole horizon: 5 % more steps until it stays close
    for _ in range(6):
        r = row("explicit", per_sample, 1, simulate(explicit, per_sample, 1, until), at_limit=True)
        r["unstable"] = r["diverged"] or not r.get("error", math.inf) <= BLOW_UP
        rows.append(r)
        log_run(log, r)
        if not r["unstable"]:
            break
        per_sample = max(per_sample + 1, math.ceil(per_sample / 0.95))
    else:
        log(f"{cx.describe(cell)}: no stable explicit step found near the trial limit")
        return rows, info
    cap = min(settings["max_run_seconds"], settings["max_ratio"] * r["cpu_seconds"])

    for family, options in families.items():
        if family == "explicit":
            continue
        aborted_in_a_row, previous = 0, None
        rates = [GRID_RATE] if family in ERROR_CONTROLLED else settings["rates"]
        for rate in rates:
            stride, per = max(1, GRID_RATE // rate), max(1, rate // GRID_RATE)
            r = row(family, per, stride, simulate(options, per, stride, until, cap))
            rows.append(r)
            log_run(log, r)
            aborted_in_a_row = aborted_in_a_row + 1 if r["aborted"] else 0
            if aborted_in_a_row >= 2:
                break
            if "error" not in r:
                continue
            if (
                previous
                and previous["error"] <= min(thresholds)
                and r["cpu_seconds"] > previous["cpu_seconds"]
            ):
                break
            previous = r

    for r in repeat_candidates(rows, info["floors"], families, thresholds):
        for _ in range(settings["repeats"] - 1):
            again = simulate(families[r["method"]], r["steps_per_sample"], r["sample_stride"], -1.0)
            r["cpu_seconds_samples"].append(again["cpu_seconds"])
        r["repeats"] = len(r["cpu_seconds_samples"])
        cx.set_cost(r, statistics.median(r["cpu_seconds_samples"]))
        log(
            f"    repeated {r['method']} dt={r['dt']:.3g}: median CPU {r['cpu_seconds']:.3g} s "
            f"of {', '.join(f'{s:.3g}' for s in r['cpu_seconds_samples'])}"
        )
    if journal.replayed:
        info.update(replayed_runs=journal.replayed, replayed_cpu_seconds=journal.replayed_cpu)
        log(
            f"{cx.describe(cell)}: {journal.replayed} runs replayed from the journal "
            f"({journal.replayed_cpu:.0f} CPU s measured before the cell was stopped)"
        )
    return rows, info


def repeat_candidates(rows, floors, families, thresholds):
    """The runs to repeat: explicit at its limit (every ratio's denominator) and, per family,
    measure and judged threshold, every run that meets it at most cx.REPEAT_MARGIN × the CPU
    of the family's cheapest run that does."""
    chosen = {i for i, r in enumerate(rows) if r.get("at_limit") and cx.usable(r)}
    for family in families:
        mine = [i for i, r in enumerate(rows) if r["method"] == family and cx.usable(r)]
        for measure, threshold in ((m, t) for m in MEASURES for t in thresholds):
            if not judged(floors[measure]["floor"], threshold):
                continue
            meeting = [i for i in mine if rows[i][measure] <= threshold]
            least = min((rows[i]["cpu_seconds"] for i in meeting), default=math.inf)
            chosen |= {i for i in meeting if rows[i]["cpu_seconds"] <= cx.REPEAT_MARGIN * least}
    return [rows[i] for i in sorted(chosen)]


def log_run(log, r):
    if r["diverged"] or r["aborted"]:
        state = "diverged" if r["diverged"] else f"aborted ({r['aborted']})"
    else:
        state = (
            " ".join(f"{m.split('_')[0]} {r[m]:.2e}" for m in MEASURES)
            + f" cost {r['cost_seconds_per_simulated_second']:.3g} s/s"
            + (f" UNCONVERGED {r['unconverged_steps']}" if r["flagged"] else "")
            + (" UNSTABLE" if r.get("unstable") else "")
        )
    log(f"    {r['method']:26s} dt={r['dt']:.3g} {state}")


# -- a cell's verdicts --------------------------------------------------------------------------
def judge(rows, families, explicit, measure, threshold, floor):
    """The verdict at (measure, threshold): "not judged" where the floor is not below a third of
    the threshold; else each family's cheapest run meeting it and the cheapest implicit one
    (the crossover's selection, `summarize_cell`, fed this measure as the error, scaled so its
    first threshold stands for this one), over explicit's cost at its limit."""
    verdict = {"judged": judged(floor, threshold), "floor": floor}
    if not verdict["judged"]:
        verdict["why"] = f"floor {floor:.2g} not below a third of {threshold:g}"
        return verdict
    scale = cx.THRESHOLDS[0] / threshold
    scaled = [dict(r, error=r[measure] * scale) if cx.usable(r) else r for r in rows]
    picked = cx.summarize_cell({"reference_error": 0.0}, scaled, list(families))[
        f"at_{cx.THRESHOLDS[0]:g}"
    ]
    value = {(r["method"], r["steps"]): r[measure] for r in rows if cx.usable(r)}
    for e in picked["families"].values():
        if "method" in e:
            del e["error"]
            e[measure] = value[(e["method"], e["steps"])]
    best = picked["best_implicit"]
    cost = explicit["cost_seconds_per_simulated_second"]
    verdict.update(
        families=picked["families"],
        best_implicit=best,
        explicit_cost=cost,
        explicit_meets=explicit[measure] <= threshold,
    )
    if best:
        ratio = best["cost_seconds_per_simulated_second"] / cost
        verdict.update(
            implicit_over_explicit_cost=ratio, winner=best["method"] if ratio < 1 else "explicit"
        )
    else:
        verdict.update(winner="explicit", note="no implicit run met it within the caps")
    return verdict


def summarize(info, rows, families, thresholds):
    """The cell's facts with explicit's run at its limit and, per measure and threshold, its
    verdict (`judge`)."""
    out = {k: v for k, v in info.items() if k != "verdicts"}
    limit = next((r for r in rows if r.get("at_limit") and cx.usable(r)), None)
    out["explicit"] = (
        None if limit is None else dict(cx.entry(limit), **{m: limit[m] for m in MEASURES})
    )
    if limit is None or not info.get("floors"):
        return out
    out["verdicts"] = {
        m: {
            f"at_{t:g}": judge(rows, families, limit, m, t, info["floors"][m]["floor"])
            for t in thresholds
        }
        for m in MEASURES
    }
    groups = {
        m: tuple((f, r) for f, r in members if f in families)
        for m, members in tolerance.groups().items()
    }
    fixed = [f for f in families if f != "explicit" and f not in ERROR_CONTROLLED]
    floor = info["floors"][LADDER_MEASURE]["floor"]
    out["at_tolerance"] = tolerance.at_tolerance(
        rows,
        floor,
        limit["cost_seconds_per_simulated_second"],
        fixed,
        {m: g for m, g in groups.items() if g},
    )
    out["at_tolerance_verdicts"] = tolerance.at_thresholds(
        rows,
        [t for t in thresholds if judged(floor, t)],
        fixed,
        [f for f in families if f in ERROR_CONTROLLED],
    )
    return out


def cell_values(summary, rows):
    """The cell's numbers for the sweep's Dataset (finite floats only)."""
    values = {
        k: summary[k]
        for k in (
            "horizon",
            "trial_limit_dt",
            "reference_dt",
            "predictability_time",
            "predicted_explicit_cpu_seconds",
            "cell_thread_cpu_seconds",
            "cell_process_cpu_seconds",
            "cell_wall_seconds",
        )
        if isinstance(summary.get(k), float)
    }
    values["runs"] = float(sum(not r["method"].startswith("reference") for r in rows))
    if summary.get("explicit"):
        values["explicit_cost"] = summary["explicit"]["cost_seconds_per_simulated_second"]
    for measure, floor in (summary.get("floors") or {}).items():
        values[f"floor_{measure}"] = floor["floor"]
    for measure, at in summary.get("verdicts", {}).items():
        for key, verdict in at.items():
            if "implicit_over_explicit_cost" in verdict:
                values[f"{measure}_ratio_{key}"] = verdict["implicit_over_explicit_cost"]
    return {k: float(v) for k, v in values.items() if math.isfinite(float(v))}


# -- the Dask task ------------------------------------------------------------------------------
def long_horizon_cell(settings_toml, scene_path, overrides) -> dict:
    """One cell as a `yore.sweep` task (the engine's cell-function signature; the sweep's
    'scene' is this benchmark's settings, as TOML; overrides name the cell, keyed as
    `crossover.grid_sweep` keys them). Never raises: a failure is a "failed" result."""
    import tomllib

    wall, thread, process = time.perf_counter(), time.thread_time(), time.process_time()
    log = []
    try:
        settings = tomllib.loads(settings_toml)
        cell = cx.cell_of(overrides, lambda size, bending: horizon(settings, size))
        size, stiffness, bending = cell["size"], cell["stretch_stiffness"], cell["bending"]
        yore.set_num_threads(1)  # the thread clock then holds all of the stepping
        families = settings["families"]
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", cx.UNCONVERGED_WARNING, RuntimeWarning)
            root = settings.get("journal")
            journal = cx.Journal(cx.journal_folder(root, cell) if root else None, log.append)
            rows, info = measure_cell(
                cell, cx.sheet(size, stiffness, bending), families, settings, log.append, journal
            )
        summary = (
            info if "skipped" in info else summarize(info, rows, families, settings["thresholds"])
        )
    except Exception as error:  # noqa: BLE001 - a cell's failure is its result
        where = traceback.extract_tb(error.__traceback__)[-1:]
        return {
            "status": "failed",
            "message": f"{type(error).__name__}: "
            f"{' '.join(str(error).split())}"
            + "".join(f" (at {Path(w.filename).name}:{w.lineno})" for w in where),
            "values": {"cell_wall_seconds": time.perf_counter() - wall},
            "positions": None,
            "faces": None,
        }
    summary.update(
        cell_thread_cpu_seconds=time.thread_time() - thread,
        cell_process_cpu_seconds=time.process_time() - process,
        cell_wall_seconds=time.perf_counter() - wall,
    )
    record = {"cell": summary, "rows": rows, "log": log}
    return {
        "status": "skipped" if "skipped" in summary else "done",
        "message": json.dumps(record, separators=(",", ":"), default=float),
        "values": cell_values(summary, rows),
        "positions": None,
        "faces": None,
    }


# -- the sweep ------------------------------------------------------------------------------------
def grid_sweep(settings):
    """The crossover's grid sweep of these settings (size × stiffness × bending, largest first),
    its texts naming this benchmark: its cells are run by long_horizon_cell."""
    sweep = cx.grid_sweep(settings)

    def own(text):
        for theirs, mine in (
            ("benchmarks/crossover.py", "benchmarks/long_horizon.py"),
            ("benchmarks.crossover", "benchmarks.long_horizon"),
            ("crossover_cell", "long_horizon_cell"),
            ("this crossover", "this long-horizon run"),
        ):
            text = text.replace(theirs, mine)
        return text

    return dataclasses.replace(sweep, text=own(sweep.text), scene_text=own(sweep.scene_text))


def collect(sweep, results, settings):
    """Rows and per-cell summaries of the finished cells (`crossover.collect`), each done cell
    summarised again by this code's rules, each cell with its own horizon."""
    rows, cells = cx.collect(sweep, results)
    for i, cell in enumerate(cells):
        cell["horizon"] = horizon(settings, cell["size"])
        if cell["status"] == "done":
            mine = [r for r in rows if key(r) == key(cell)]
            cells[i] = dict(
                summarize(cell, mine, settings["families"], settings["thresholds"]),
                status="done",
                log=cell["log"],
            )
    return rows, cells


def key(cell):
    return int(cell["size"]), float(cell["stretch_stiffness"]), str(cell["bending"])


#: Settings two runs must share for their cells to make one table (the grid may differ).
#: max_cell_seconds is not one: a budget that decides which cells run (a cell over it is
#: skipped and says so), not what a cell that ran measures; the merged table keeps the larger.
MERGE_KEYS = (
    "quick",
    "repeats",
    "max_run_seconds",
    "max_ratio",
    "rates",
    "thresholds",
    "horizon",
    "horizon_at",
)


def earlier_run(path, settings, resolved):
    """An earlier run's payload (--merge), checked before anything runs: BadInput when it cannot
    be read, its settings differ from this run's, or a family both ran with other resolved
    options (its costs and verdicts would not compare). A family only the earlier run has joins
    the table (`join_families`): this run's cells did not run it."""
    try:
        earlier = json.loads(Path(path).read_text(encoding="utf-8"))
        theirs = earlier["family_resolved_options"]
        if earlier.get("benchmark") != "long_horizon":
            raise KeyError("benchmark")
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise BadInput(f"--merge {path}: not a long_horizon.json ({error})") from None
    for name in MERGE_KEYS:
        if json.dumps(earlier["settings"].get(name)) != json.dumps(settings.get(name)):
            raise BadInput(
                f"--merge {path}: its {name} is {earlier['settings'].get(name)!r}, "
                f"this run's {settings.get(name)!r}; only runs with the same "
                "settings merge"
            )
    # options yore gained since the earlier run count as their old behaviour (cx.LEGACY_OPTIONS)
    theirs = cx.earlier_resolved(earlier, resolved, {})
    other = sorted(
        n
        for n in theirs
        if n in resolved
        and json.dumps(theirs[n], sort_keys=True) != json.dumps(resolved[n], sort_keys=True)
    )
    # a family only the earlier run has joins with the options it recorded; one it did not
    # record (a run from before the record) cannot join
    recorded = earlier.get("family_resolved_options", {})
    unknown = sorted(
        n for n in earlier.get("family_options", {}) if n not in resolved and not recorded.get(n)
    )
    if other or unknown:
        raise BadInput(
            f"--merge {path}: families run here with other options, or of unknown "
            "options: " + ", ".join(other + unknown)
        )
    return earlier


def join_families(settings, resolved, earlier):
    """The families of an earlier run (`earlier_run`) that this run did not run join this run's
    table, after them: its cells report them, this run's cells name them as not run."""
    theirs = earlier.get("family_resolved_options", {})
    for name, options in earlier.get("family_options", {}).items():
        if name not in settings["families"]:
            settings["families"][name] = options
            resolved[name] = theirs[name]


def merge(settings, cells, rows, earlier, source):
    """This run's (cells, rows) with an earlier run's payload (`earlier_run`): the earlier cells
    this run does not hold, or did not finish where the earlier one did, join with their rows,
    summarised by this run's rules; the grid becomes the union."""
    theirs = earlier["family_resolved_options"]
    finished = {key(c) for c in earlier["summary"]["cells"] if c.get("status") == "done"}
    cells = [c for c in cells if c.get("status") == "done" or key(c) not in finished]
    held = {key(c) for c in cells}
    added = [c for c in earlier["summary"]["cells"] if key(c) not in held]
    joined = [r for r in earlier["rows"] if key(r) in {key(c) for c in added}]
    for c in added:
        if c.get("status") == "done":
            mine = [r for r in joined if key(r) == key(c)]
            c.update(
                summarize(c, mine, settings["families"], settings["thresholds"]),
                families_missing=[n for n in settings["families"] if n not in theirs],
            )
    grid = dict(
        settings,
        sizes=sorted({*settings["sizes"], *(c["size"] for c in added)}),
        stiffness=sorted({*settings["stiffness"], *(c["stretch_stiffness"] for c in added)}),
        bending=[
            b for b in ALL_ROWS if b in settings["bending"] or any(c["bending"] == b for c in added)
        ],
        max_cell_seconds=max(
            settings["max_cell_seconds"], earlier["settings"].get("max_cell_seconds", 0.0)
        ),
    )
    origin = {
        "from": source,
        "machine": earlier.get("machine"),
        "cells": [list(key(c)) for c in added],
    }
    return grid, cells + added, [r for r in rows if key(r) in held] + joined, origin


# -- the summary --------------------------------------------------------------------------------
def summary_lines(cells, thresholds):
    """Per measure and threshold: cells judged, implicit wins, the median ratio; the targets."""
    lines = []
    for measure in MEASURES:
        for t in thresholds:
            verdicts = [c["verdicts"][measure][f"at_{t:g}"] for c in cells if "verdicts" in c]
            judged_here = [v for v in verdicts if v["judged"]]
            ratios = [
                v["implicit_over_explicit_cost"]
                for v in judged_here
                if "implicit_over_explicit_cost" in v
            ]
            wins = sum(v["winner"] != "explicit" for v in judged_here)
            lines.append(
                f"{measure} within {100 * t:g} %: judged in {len(judged_here)} of "
                f"{len(verdicts)} cells, implicit cheaper in {wins}"
                + (f", median implicit/explicit {statistics.median(ratios):.2f}" if ratios else "")
            )
    for target in targets(cells):
        lines.append(
            f"target {target['target']} ({target['measure']} within "
            f"{100 * target['threshold']:g} %, goal ≤ {target['goal_ratio']:g}×): "
            + (
                f"{'met' if target['met'] else 'missed'} ({target['ratio']:.2f})"
                if target["ratio"] is not None
                else f"not measured ({target['why']})"
            )
        )
    return lines


def targets(cells):
    """The issue's cost targets, each with its measured ratio and met/missed."""
    out = []
    for name, size, k, bending, measure, threshold, goal in TARGETS:
        cell = next((c for c in cells if key(c) == (size, k, bending)), None)
        verdict = (cell or {}).get("verdicts", {}).get(measure, {}).get(f"at_{threshold:g}", {})
        ratio = verdict.get("implicit_over_explicit_cost")
        why = (
            "not in the grid"
            if cell is None
            else cell.get("skipped") or cell.get("status")
            if cell.get("status") != "done"
            else verdict.get("why", "no implicit run met it")
        )
        out.append(
            {
                "target": name,
                "measure": measure,
                "threshold": threshold,
                "goal_ratio": goal,
                "ratio": ratio,
                "met": ratio is not None and ratio <= goal,
                "why": None if ratio is not None else why,
            }
        )
    return out


def table_lines(cells, thresholds):
    """One markdown line per cell: its floors' verdicts and ratios per measure."""
    head = "| cell | T | predictability | explicit s/s | " + " | ".join(MEASURES) + " |"
    out = [head, "|" + "---|" * (4 + len(MEASURES))]
    for c in sorted(cells, key=key):
        start = f"| {c['size']}² k={c['stretch_stiffness']:g} {c['bending']} | {c['horizon']:g} s"
        if "verdicts" not in c:
            out.append(f"{start} | {c.get('status')}: {c.get('skipped', '')} |")
            continue
        parts = []
        for measure in MEASURES:
            texts = []
            for t in thresholds:
                v = c["verdicts"][measure][f"at_{t:g}"]
                texts.append(
                    f"{100 * t:g} %: "
                    + (
                        "not judged"
                        if not v["judged"]
                        else f"{v['implicit_over_explicit_cost']:.2f} ({v['best_implicit']['method']} "
                        f"{v['best_implicit']['dt']:.3g} s)"
                        if "implicit_over_explicit_cost" in v
                        else "explicit (no implicit run met it)"
                    )
                )
            parts.append(f"floor {c['floors'][measure]['floor']:.1e}; " + "; ".join(texts))
        out.append(
            f"{start} | {c['predictability_time']:g} s | "
            f"{c['explicit']['cost_seconds_per_simulated_second']:.3g} | "
            + " | ".join(parts)
            + " |"
        )
    return out


# -- main ---------------------------------------------------------------------------------------
def number(convert, valid, expected):
    """A command-line value: convert(text), refused (ValueError naming what was expected)
    unless valid(value)."""

    def parse(text):
        try:
            value = convert(text)
        except (ValueError, OverflowError):
            value = None
        if value is None or not valid(value):
            raise ValueError(f"expected {expected}, got {text!r}")
        return value

    return parse


# every run ends on a sample of the 1/32 s rung: a horizon is a multiple of 1/32 s
horizon_value = number(
    float,
    lambda t: math.isfinite(t) and t > 0 and abs(32 * t - round(32 * t)) < 1e-9,
    "a horizon in seconds, a positive multiple of 1/32 s",
)
threshold_value = number(float, lambda t: 0.0 < t < 1.0, "a threshold in (0, 1)")
size_value = number(int, lambda n: n >= 4, "a size of at least 4 vertices per edge")
count = number(int, lambda n: n >= 1, "a whole number of at least 1")
positive = number(float, lambda x: math.isfinite(x) and x > 0, "a positive number")


def horizon_at(text):
    """ "SIZE=T" -> [size, horizon]."""
    size, _, value = text.partition("=")
    return [size_value(size), horizon_value(value)]


def options(parser):
    """This benchmark's flags; bad input is one `yore: error:` line and exit code 2."""
    import argparse

    def checked(function):  # argparse shows an ArgumentTypeError's own message
        def parse(text):
            try:
                return function(text)
            except ValueError as error:
                raise argparse.ArgumentTypeError(str(error)) from None

        return parse

    parser.error = lambda message: parser.exit(2, f"yore: error: {message}\n")
    add = parser.add_argument
    add("--workers", type=checked(count), default=None, help="local Dask workers, one thread each")
    add("--scheduler", default=None, help="a running Dask scheduler instead of a local cluster")
    add(
        "--resume",
        action="store_true",
        help="run only the cells OUT/sweeps/long_horizon does "
        "not hold yet, with its settings; a cell stopped part-way replays its journal",
    )
    add("--collect", action="store_true", help="run no cell: write the results held so far")
    add(
        "--merge",
        type=Path,
        action="append",
        default=[],
        metavar="JSON",
        help="a long_horizon.json of an earlier run with the same settings: its cells join",
    )
    add("--sizes", type=checked(size_value), nargs="+", default=None)
    add("--stiffness", type=checked(positive), nargs="+", default=None)
    add(
        "--bending",
        nargs="+",
        choices=ALL_ROWS,
        default=None,
        help="bending rows (default: equal, real cloth; also: equal, damped)",
    )
    add(
        "--families",
        nargs="+",
        choices=list(FAMILIES),
        default=None,
        help="families to run (explicit always runs)",
    )
    add("--horizon", type=checked(horizon_value), default=None, help="T, s (default 2)")
    add(
        "--horizon-at",
        type=checked(horizon_at),
        action="append",
        default=None,
        metavar="SIZE=T",
        help="T at one size (default 128=1; e.g. 32=4)",
    )
    add(
        "--thresholds",
        type=checked(threshold_value),
        nargs="+",
        default=None,
        help="relative thresholds (default 0.05 0.01)",
    )
    add(
        "--repeats",
        type=checked(count),
        default=3,
        help="runs of explicit at its limit and of every candidate winner (default 3)",
    )
    add(
        "--max-run-seconds",
        type=checked(positive),
        default=None,
        help="CPU cap of one implicit run (default 600; quick 5)",
    )
    add(
        "--max-ratio",
        type=checked(positive),
        default=8.0,
        help="cap of one implicit run over explicit's cost (default 8)",
    )
    add(
        "--max-cell-seconds",
        type=checked(positive),
        default=3600.0,
        help="skip a cell whose explicit runs are predicted to take longer (default 3600)",
    )


def new_settings(args):
    quick = args.quick
    names = ("explicit",) + tuple(
        n for n in args.families or (QUICK_FAMILIES if quick else FAMILIES) if n != "explicit"
    )
    families, missing = available_families(names)
    if "explicit" not in families:
        raise BadInput(f"explicit cannot be built: {missing['explicit']}")
    return {
        "quick": quick,
        "sizes": list(args.sizes or (QUICK_GRID["sizes"] if quick else SIZES)),
        "stiffness": [
            float(k) for k in args.stiffness or (QUICK_GRID["stiffness"] if quick else STIFFNESSES)
        ],
        "bending": list(args.bending or (QUICK_GRID["bending"] if quick else BENDING_ROWS)),
        "horizon": args.horizon or (QUICK_GRID["horizon"] if quick else HORIZON),
        "horizon_at": args.horizon_at or ([] if quick else [list(h) for h in HORIZON_AT]),
        "thresholds": sorted(args.thresholds or THRESHOLDS, reverse=True),
        "repeats": args.repeats,
        "max_run_seconds": args.max_run_seconds or (5.0 if quick else 600.0),
        "max_ratio": args.max_ratio,
        "max_cell_seconds": args.max_cell_seconds,
        "rates": list(QUICK_RATES if quick else RATES),
        "families_unavailable": [f"{n}: {why}" for n, why in missing.items()],
        "families": families,
    }


def bad_input(message):
    print(f"yore: error: {' '.join(str(message).split())}", file=sys.stderr)
    raise SystemExit(2)


def main(argv=None):
    from yore.sweep.spec import SweepError

    try:
        return run(arguments(__doc__, argv, options))
    except (BadInput, SweepError) as error:
        bad_input(error)


def settings_of(args, folder):
    """The run's settings: the folder's (--resume, --collect) or new ones from the flags."""
    import tomllib

    scene = folder / "scene.toml"
    if args.resume or args.collect:
        if not scene.is_file():
            raise BadInput(f"{folder} holds no long-horizon run to resume (no scene.toml)")
        print(f"{'collecting' if args.collect else 'resuming'} {folder} with its settings")
        return tomllib.loads(scene.read_text(encoding="utf-8"))
    settings = new_settings(args)
    if not args.scheduler:  # a cluster's workers need not share this file system
        settings["journal"] = str((folder / "journal").resolve())
    return settings


def results_of(args, sweep, folder):
    """The sweep's results: the cells finished so far (--collect) or after running the rest."""
    from yore.sweep import run as run_sweep
    from yore.sweep.results import Results

    if not args.collect:
        return run_sweep(
            sweep,
            folder,
            scheduler=args.scheduler,
            workers=args.workers,
            overwrite=not args.resume,
            resume=args.resume,
            cell_function=long_horizon_cell,
        )
    results = Results(sweep, folder)
    results.load_finished()
    return results


def run(args):
    folder = Path(args.out).joinpath(*SWEEP_FOLDER)
    settings = settings_of(args, folder)
    resolved = cx.resolved_families(settings["families"])
    earlier_runs = [earlier_run(path, settings, resolved) for path in args.merge]
    if not (args.resume or args.collect):  # a new run measures afresh
        shutil.rmtree(folder / "journal", ignore_errors=True)
    print("".join(f"left out: {line}\n" for line in settings["families_unavailable"]), end="")
    sweep = grid_sweep(settings)
    send_code_by_value()
    started = time.perf_counter()
    results = results_of(args, sweep, folder)
    rows, cells = collect(sweep, results, settings)
    for cell in cells:  # a recorded cell needs its journal no more
        if settings.get("journal") and cell["status"] in ("done", "skipped"):
            shutil.rmtree(cx.journal_folder(settings["journal"], cell), ignore_errors=True)
    merged_from = []
    for path, earlier in zip(args.merge, earlier_runs):
        ran_here = list(settings["families"])
        join_families(settings, resolved, earlier)
        for cell in cells:
            if cell.get("status") == "done":
                missing = [n for n in settings["families"] if n not in ran_here]
                if missing:
                    cell["families_missing"] = sorted({*cell.get("families_missing", []), *missing})
        settings, cells, rows, origin = merge(settings, cells, rows, earlier, str(path))
        merged_from.append(origin)
    payload = {
        "benchmark": "long_horizon",
        "machine": machine_info(),
        "quick": settings["quick"],
        "clock": "time.thread_time() of the task's thread around the stepping only; yore "
        "pinned to one thread",
        "families": list(settings["families"]),
        "family_options": settings["families"],
        "family_resolved_options": resolved,
        "families_unavailable": settings["families_unavailable"],
        "thresholds": settings["thresholds"],
        "floor_fraction": FLOOR_FRACTION,
        "measures": MEASURES,
        "predictability_distance": PREDICTABILITY,
        "perturbation": PERTURBATION,
        "sample_rate": GRID_RATE,
        "sample_times": f"every 1/{GRID_RATE} s from 0 to T (the 1/32 s rung: every 1/32 s)",
        "settings": {k: v for k, v in settings.items() if k != "families"},
        "sweep": folder.as_posix(),
        "cells": len(cells),
        "statuses": dict(Counter(c.get("status", "not run") for c in cells)),
        "merged_from": merged_from,
        "wall_seconds": time.perf_counter() - started,
        "cell_cpu_seconds": sum(c.get("cell_thread_cpu_seconds", 0.0) for c in cells),
        "rows": rows,
        "summary": {
            "cells": [{k: v for k, v in c.items() if k != "log"} for c in cells],
            "targets": targets(cells),
            "lines": summary_lines(cells, settings["thresholds"]),
            "table": table_lines(cells, settings["thresholds"]),
        },
    }
    save(Path(args.out), "long_horizon", payload, lambda path: plot(payload, path))
    for line in payload["summary"]["table"] + [""] + payload["summary"]["lines"]:
        print(line)
    return payload


def send_code_by_value():
    """Workers of a remote cluster have yore but not this repository: this module and the
    benchmark modules it uses go to them by value (cloudpickle)."""
    import cloudpickle

    for module in (cx, common, sensitivity, sys.modules[__name__]):
        if module.__name__ != "__main__":  # __main__'s functions are sent by value anyway
            cloudpickle.register_pickle_by_value(module)


# -- the picture --------------------------------------------------------------------------------
def plot(payload, path):
    """One map per measure at the largest threshold (x: stiffness, y: size and bending; colour:
    cheapest implicit over explicit's cost; text: the ratio, or why not judged) and the
    kinetic-energy histories of one cell's 1/32 s runs against the reference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    cells = payload["summary"]["cells"]
    threshold = max(payload["thresholds"])
    lines = sorted({(c["bending"], c["size"]) for c in cells}) or [("equal", 0)]
    stiffnesses = sorted({c["stretch_stiffness"] for c in cells}) or [0.0]
    fig, axes = plt.subplots(2, 3, figsize=(15, 4 + 1.1 * len(lines)), layout="constrained")
    norm = LogNorm(0.1, 10.0)
    image = None
    for ax, measure in zip(axes.flat, MEASURES):
        grid = np.full((len(lines), len(stiffnesses)), np.nan)
        for c in cells:
            i = lines.index((c["bending"], c["size"]))
            j = stiffnesses.index(c["stretch_stiffness"])
            verdict = c.get("verdicts", {}).get(measure, {}).get(f"at_{threshold:g}")
            if verdict is None:
                text = str(c.get("status"))
            elif not verdict["judged"]:
                text = f"not judged\nfloor {verdict['floor']:.1e}"
            elif "implicit_over_explicit_cost" in verdict:
                grid[i, j] = verdict["implicit_over_explicit_cost"]
                text = f"{verdict['best_implicit']['method']}\n{grid[i, j]:.2g}"
            else:
                text = "explicit\n(no implicit\nrun met it)"
            ax.text(j, i, text, ha="center", va="center", fontsize=6)
        image = ax.imshow(
            np.ma.masked_invalid(np.clip(grid, 0.1, 10.0)),
            cmap="RdBu_r",
            norm=norm,
            origin="lower",
            aspect="auto",
        )
        ax.set_xticks(range(len(stiffnesses)), [f"{k:g}" for k in stiffnesses], fontsize=6)
        ax.set_yticks(range(len(lines)), [f"{n}² {b}" for b, n in lines], fontsize=6)
        ax.set_xlabel("stretch stiffness, N/m", fontsize=7)
        ax.set_title(f"{measure.replace('_', ' ')} within {100 * threshold:g} %", fontsize=8)
    fig.colorbar(
        image,
        ax=axes.ravel().tolist(),
        shrink=0.6,
        label="cheapest implicit / explicit at its limit (blue: implicit cheaper)",
    )
    plot_histories(axes.flat[5], payload)
    fig.suptitle(
        f"long horizon: implicit / explicit CPU cost at {100 * threshold:g} % "
        f"(a measure is judged where its floor < {FLOOR_FRACTION:.2g} × threshold)",
        fontsize=9,
    )
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def plot_histories(ax, payload):
    """Kinetic energy against time: the reference, explicit at its limit and each family's
    1/32 s run, in the cell that has the most of them (32² k = 2e5 equal first)."""
    runs = [r for r in payload["rows"] if "kinetic_energy" in r]
    shown = [key(r) for r in runs if r["method"] == "reference"]
    if not shown:
        ax.set_title("no measured cell", fontsize=8)
        return
    cell = (
        (32, 2e5, "equal")
        if (32, 2e5, "equal") in shown
        else max(
            shown, key=lambda k: sum(key(r) == k and math.isclose(r["dt"], 1 / 32) for r in runs)
        )
    )
    for r in runs:
        if key(r) != cell or not (
            r["method"] in ("reference", "explicit") or math.isclose(r["dt"], 1 / 32)
        ):
            continue
        times = np.arange(len(r["kinetic_energy"])) * r["sample_seconds"]
        label = r["method"] if r["method"] in ("reference", "explicit") else f"{r['method']} 1/32 s"
        ax.plot(
            times,
            r["kinetic_energy"],
            lw=1.6 if r["method"] == "reference" else 0.9,
            color="k" if r["method"] == "reference" else None,
            ls="--" if r["method"] == "explicit" else "-",
            label=label,
        )
    ax.set_xlabel("time, s", fontsize=7)
    ax.set_ylabel("kinetic energy, J", fontsize=7)
    ax.set_title(f"{cell[0]}² k={cell[1]:g} {cell[2]}: kinetic energy", fontsize=8)
    ax.legend(fontsize=6)


if __name__ == "__main__":
    main()
