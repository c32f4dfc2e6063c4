"""Speed against error, and where implicit integration overtakes explicit: the crossover.

    python -m benchmarks.speed_vs_error [--out bench-results] [--quick] [--sizes 32 64 128]
        [--stiffness 2e3 2e4 2e5 2e6] [--bending equal soft] [--scenes sheet hanging cylinder]
        [--repeats 3] [--max-run-seconds 60] [--max-ratio 8] [--max-reference-seconds 240]
        [--max-128-stiffness 2e5] [--no-extend]

Scenes. "sheet": `yore.scenes.hanging_cloth(resolution=N, pin_spacing=1.0, mass=0.1)`, an N × N
*vertex* grid (N − 1 squares a side) of a 1 m square, 0.1 kg in all, starting flat and
horizontal between its two pinned corners, at stretch stiffness k ∈ {2e3, 2e4, 2e5, 2e6} N/m
(extended to 2e7 where explicit still wins at the largest k) with bending equal to k (the
paper's single constant) or soft (200 N/m). "hanging": the same sheet at 32² (the scene's
material, 200 N/m) with a stroke across it near the pinned edge at t = 0. "cylinder": the
rotating cylinder (13 rings × 32 segments) with a stroke round its lower part at t = 0.

Families: explicit (symplectic Euler), BE linearized, BE Newton, BDF2, local-global (its
defaults) and, when this build has it, quasi-Newton (backward Euler and BDF2). Every run starts
from the scene's start and goes to the horizon T (0.25 s at 32² and 64², 0.125 s at 128²; 0.125 s
for soft bending, whose sheet buckles and makes a later state too sensitive to the step for a
reference to converge; measured: the 0.5 s of the issue is not convergeable at 32²).
Implicit families run a ladder dt = 1/32 … 1/1024 s, stopping once a run reaches 0.1 % and the
next one costs more. Explicit runs at its largest stable step, found by trying: short trials
(SEARCH_STEPS steps; divergence = `yore.SimulationDiverged`) bracket and bisect the step from
`Simulation.stable_dt()`, then the whole interval confirms it (diverged or error > 5 %: the step
is cut by 5 % and tried again); its ladder adds the reference chain's coarser runs (half that step and below).

Error: RMS vertex distance to the reference at T/2 and T, over the cloth's bounding-box diagonal
at the start. The reference is explicit at half the trial limit, halved (each time one more
run) until it and the run at twice its step agree to 1e-4 (a tenth of the smallest threshold,
0.1 %), at most MAX_REFERENCE_HALVINGS times and while one more run fits
--max-reference-seconds; a cell whose reference does not converge is marked
reference_converged = false and left out of the summary. The chain's coarser runs are points
of explicit's ladder. Cost: CPU seconds
(`time.process_time()` around the stepping only, one thread) per simulated second, the median of
`--repeats` runs for every run that could be its family's cheapest at 1 % or 0.1 % (within
REPEAT_MARGIN of the cheapest single run); other runs (dominated, or erring above 1 %) are run
once, and say so (`repeats`). A run is aborted once its CPU time, or its time extrapolated from
the steps done, exceeds min(--max-run-seconds, --max-ratio × explicit's cost) (`aborted`, with
the extrapolated cost); a family's ladder stops after two aborted runs in a row. A cell whose
explicit runs alone (limit, repeats, reference pair) would exceed --max-cell-seconds, predicted
from the trials, is skipped and says so; so are 128² cells above --max-128-stiffness. On the stroke
scenes, wrinkle retention = `yore.metrics.wrinkle_measure` of the stroke region at T over the
reference's.

Writes speed_vs_error.json (rows: every run; summary: per cell the cheapest run of each family
at 1 % and 0.1 %, the cheapest implicit over the cheapest explicit cost, the winner with its
iterations per step and CPU per iteration against explicit's steps and CPU per step; the
crossover stiffness per size and bending; the 64² targets), speed_vs_error.png (error against
cost, one panel per cell) and crossover.png (resolution × stiffness, colour: cheapest implicit
cost over cheapest explicit cost at 1 %, text: the winner).
"""

from __future__ import annotations

import math
import statistics
import time
import warnings

import numpy as np

import yore
from yore import metrics

from .common import arguments, machine_info, save

THRESHOLDS = (0.01, 0.001)  # relative errors the summary picks the cheapest run at
REFERENCE_TOLERANCE = 0.1 * min(THRESHOLDS)  # check run against reference, relative
BLOW_UP_ERROR = 0.05  # an explicit run erring beyond this is unstable even if it did not raise
SEARCH_STEPS = 4000  # steps of a stability trial
SEARCH_FACTOR = 1.1  # bracketing factor of the stability search
SEARCH_BISECTIONS = 2  # after bracketing: limit known to ~2.5 %
REPEAT_MARGIN = 1.5  # runs within this of their family's cheapest single run are repeated
RATES = (32, 64, 128, 256, 512, 1024)  # implicit ladder, steps per second
SOFT_BENDING = 200.0  # N/m
MAX_REFERENCE_HALVINGS = 6  # the reference chain: at most limit / 2^7

FAMILIES = {
    "explicit": {"integrator": "explicit"},
    "BE linearized": {"integrator": "implicit", "linearized": True},
    "BE Newton": {"integrator": "implicit"},
    "BDF2": {"integrator": "bdf2"},
    "local-global": {"integrator": "local-global"},
    "quasi-Newton BE": {"integrator": "quasi-newton", "method": "backward-euler"},
    "quasi-Newton BDF2": {"integrator": "quasi-newton", "method": "bdf2"},
}
ITERATION_COUNTERS = ("newton_iterations", "iterations", "lbfgs_iterations",
                      "quasi_newton_iterations")


def available_families():
    """The families this build can construct, and why the others are left out."""
    V, F = yore.grid_mesh(3, 3)
    found, missing = {}, {}
    for name, options in FAMILIES.items():
        try:
            yore.Simulation(yore.Cloth(V, F), dt=1e-3, **options)
        except (ValueError, NotImplementedError) as error:
            missing[name] = str(error).splitlines()[0]
        else:
            found[name] = options
    return found, missing


# -- scenes -------------------------------------------------------------------------------------
def horizon(size, bending, quick):
    if bending == "soft" or size >= 128:
        return 0.125
    return 0.25


def sheet(size, stiffness, bending):
    bend = stiffness if bending == "equal" else SOFT_BENDING

    def make(**options):
        return yore.scenes.hanging_cloth(resolution=size, pin_spacing=1.0, mass=0.1,
                                         stretch_stiffness=stiffness, bend_stiffness=bend,
                                         **options), None
    return make, bend


def hanging_with_stroke(size):
    def make(**options):
        sim = yore.scenes.hanging_cloth(resolution=size, pin_spacing=1.0, mass=0.1, **options)
        # across the pattern, a fifth of the way from the pinned edge (v = 0)
        report = sim.stroke_material(np.array([[0.15, 0.2], [0.85, 0.2]]))
        return sim, report.region_faces
    return make


def cylinder_with_stroke(rings, segments):
    def make(**options):
        sim = yore.scenes.rotating_cylinder(rings=rings, segments=segments, **options)
        X = sim.cloth.positions
        y = X[:, 1].min() + 0.25 * np.ptp(X[:, 1])
        r = float(np.median(np.hypot(X[:, 0], X[:, 2])))
        angles = np.linspace(0.0, 2.0 * math.pi, 73)
        report = sim.stroke(np.column_stack([r * np.cos(angles), np.full_like(angles, y),
                                             r * np.sin(angles)]))
        return sim, report.region_faces
    return make


def cells(args):
    """(description, make) of every cell the options ask for; description has the cell's keys."""
    out = []
    if "sheet" in args.scenes:
        for bending in args.bending:
            for size in args.sizes:
                for k in args.stiffness:
                    make, bend = sheet(size, k, bending)
                    out.append(({"scene": "sheet", "size": size, "bending": bending,
                                 "stretch_stiffness": k, "bend_stiffness": bend,
                                 "horizon": horizon(size, bending, args.quick)}, make))
    if "hanging" in args.scenes:
        size = 9 if args.quick else 32
        out.append(({"scene": "hanging cloth + stroke", "size": size, "bending": "equal",
                     "stretch_stiffness": 200.0, "bend_stiffness": 200.0,
                     "horizon": 0.125 if args.quick else 0.25}, hanging_with_stroke(size)))
    if "cylinder" in args.scenes:
        rings, segments = (5, 12) if args.quick else (13, 32)
        out.append(({"scene": "rotating cylinder + stroke", "size": segments, "bending": "equal",
                     "stretch_stiffness": 200.0, "bend_stiffness": 200.0,
                     "horizon": 0.125 if args.quick else 0.25},
                    cylinder_with_stroke(rings, segments)))
    return out


# -- one run ------------------------------------------------------------------------------------
def even_steps(duration, dt):
    """Steps of at most dt covering duration, an even number (a snapshot at half time)."""
    return max(2, 2 * math.ceil(duration / dt / 2 - 1e-9))


def simulate(make, options, steps, duration, cap_seconds=math.inf, chunks=16):
    """Runs steps of duration/steps from make's start: snapshots at half time and at the end,
    CPU seconds of the stepping, iterations, the stroke region's wrinkle measure. Diverged →
    {"diverged": True}; CPU (spent, or extrapolated from the steps done) beyond cap_seconds →
    {"aborted": ...} with the extrapolated cost."""
    sim, region = make(dt=duration / steps, **options)
    half = steps // 2
    bounds = sorted({*np.linspace(0, half, chunks // 2 + 1).astype(int),
                     *np.linspace(half, steps, chunks // 2 + 1).astype(int)})
    snapshots, cpu, done = [], 0.0, 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # unconverged steps: counted below
        for target in bounds[1:]:
            start = time.process_time()
            try:
                sim.step(target - done, progress=False)
            except yore.SimulationDiverged:
                return {"diverged": True, "steps_done": done}
            cpu += time.process_time() - start
            done = target
            if done == half:
                snapshots.append(sim.cloth.positions)
            predicted = cpu * steps / done
            if done < steps and max(cpu, predicted) > cap_seconds:
                return {"aborted": f"CPU {cpu:.3g} s after {done} of {steps} steps, "
                                   f"extrapolated {predicted:.3g} s > cap {cap_seconds:.3g} s",
                        "cost_estimate": predicted / duration, "steps_done": done}
    snapshots.append(sim.cloth.positions)
    counters = sim.stats["counters"]
    iterations = next((counters[key] for key in ITERATION_COUNTERS if key in counters), steps)
    wrinkles = (metrics.wrinkle_measure(sim.cloth.positions, sim.cloth.faces, region)
                if region is not None else None)
    return {"snapshots": snapshots, "cpu_seconds": cpu, "iterations": int(iterations),
            "unconverged_steps": int(counters.get("unconverged_steps", 0)),
            "wrinkle_measure": wrinkles}


def rms_error(snapshots, reference, scale):
    return float(np.sqrt(np.mean([np.mean(np.sum((a - b) ** 2, axis=1))
                                  for a, b in zip(snapshots, reference)])) / scale)


def is_stable(make, dt):
    """Whether SEARCH_STEPS explicit steps at dt stay bounded, and their CPU seconds per step."""
    sim, _ = make(dt=dt, integrator="explicit")
    start = time.process_time()
    try:
        sim.step(SEARCH_STEPS, progress=False)
    except yore.SimulationDiverged as error:
        return False, (time.process_time() - start) / max(1, getattr(error, "step", 1))
    return (bool(np.isfinite(sim.cloth.positions).all()),
            (time.process_time() - start) / SEARCH_STEPS)


def trial_limit(make, estimate):
    """Largest dt stable over SEARCH_STEPS steps, from the estimate: bracket by SEARCH_FACTOR,
    then bisect (geometrically). Returns the dt and the trials [(dt, stable)]."""
    trials = []

    def trial(dt):
        stable, cpu_per_step = is_stable(make, dt)
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


# -- one cell -----------------------------------------------------------------------------------
def measure_cell(cell, make, families, args, log):
    """Rows of every run of one cell (and the cell's reference facts)."""
    duration = cell["horizon"]
    probe, _ = make()
    estimate = probe.stable_dt()
    scale = float(np.linalg.norm(np.ptp(probe.cloth.positions, axis=0)))
    limit, trials = trial_limit(make, estimate)
    explicit = {"integrator": "explicit"}
    steps_limit = even_steps(duration, limit)
    # explicit's least work in this cell: the run at the limit, its repeats, the reference pair
    per_step = statistics.median(t["cpu_per_step"] for t in trials)
    predicted = per_step * steps_limit * (args.repeats + 2 + 4)
    if predicted > args.max_cell_seconds:
        log(f"{describe(cell)}: explicit's runs would take ~{predicted:.0f} CPU s > "
            f"--max-cell-seconds {args.max_cell_seconds:g}; cell skipped")
        return [], dict(cell, skipped=f"explicit's runs and reference ~{predicted:.0f} CPU s > "
                                      f"--max-cell-seconds {args.max_cell_seconds:g}",
                        stable_dt_estimate=estimate, trial_limit_dt=limit)
    # reference chain: steps_limit × 2, × 4, ... until the last two agree or the budget ends
    chain = [(2 * steps_limit, simulate(make, explicit, 2 * steps_limit, duration))]
    info = dict(cell, stable_dt_estimate=estimate, trial_limit_dt=limit, stability_trials=trials,
                scale=scale)
    while True:
        steps = 2 * chain[-1][0]
        chain.append((steps, simulate(make, explicit, steps, duration)))
        if any(result.get("diverged") for _, result in chain[-2:]):
            log(f"{describe(cell)}: the reference diverged; cell left out")
            return [dict(info, method="reference", dt=duration / steps, diverged=True,
                         reference_converged=False)], info
        reference_error = rms_error(chain[-2][1]["snapshots"], chain[-1][1]["snapshots"], scale)
        converged = reference_error <= REFERENCE_TOLERANCE
        if (converged or len(chain) > MAX_REFERENCE_HALVINGS
                or 2 * chain[-1][1]["cpu_seconds"] > args.max_reference_seconds):
            break
    reference = chain[-1][1]
    info.update(reference_error=reference_error, reference_converged=converged)
    log(f"{describe(cell)}: stable_dt() {estimate:.3g} s, trial limit {limit:.3g} s, reference "
        f"error {reference_error:.2e}{'' if converged else ' (NOT converged: left out)'}")

    def row(method, steps, result, **extra):
        base = dict(cell, method=method, dt=duration / steps, steps=steps, scale=scale,
                    reference_converged=converged, diverged=bool(result.get("diverged")),
                    aborted=result.get("aborted"), repeats=0, **extra)
        if "snapshots" in result:
            cpu = result["cpu_seconds"]
            base.update(error=rms_error(result["snapshots"], reference["snapshots"], scale),
                        cpu_seconds_samples=[cpu], repeats=1,
                        iterations=result["iterations"],
                        unconverged_steps=result["unconverged_steps"])
            set_cost(base, cpu)
            if result["wrinkle_measure"] is not None:
                base.update(wrinkle_measure=result["wrinkle_measure"],
                            wrinkle_retention=result["wrinkle_measure"]
                            / reference["wrinkle_measure"])
        elif result.get("aborted"):
            base["cost_estimate_seconds_per_simulated_second"] = result["cost_estimate"]
        return base

    rows = [dict(row("reference", chain[-1][0], reference), error=0.0,
                 reference_error=reference_error,
                 reference_wrinkle_measure=reference["wrinkle_measure"])]
    # explicit at the limit over the whole interval: cut by 5 % until it runs and stays close
    steps = steps_limit
    for _ in range(6):
        result = simulate(make, explicit, steps, duration)
        r = row("explicit", steps, result, at_limit=True)
        blown = not r["diverged"] and not r["error"] <= BLOW_UP_ERROR
        r["unstable"] = r["diverged"] or blown
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
    best_explicit = min((r["cost_seconds_per_simulated_second"] for r in rows
                         if r["method"] == "explicit" and "error" in r and not r.get("unstable")
                         and r["error"] <= max(THRESHOLDS)), default=math.inf)
    cap = min(args.max_run_seconds, args.max_ratio * best_explicit * duration)

    for family, options in families.items():
        if family == "explicit":
            continue
        aborted_in_a_row, previous = 0, None
        for rate in rates(args):
            steps = even_steps(duration, 1.0 / rate)
            r = row(family, steps, simulate(make, options, steps, duration, cap))
            rows.append(r)
            log_row(log, r)
            aborted_in_a_row = aborted_in_a_row + 1 if r["aborted"] else 0
            if aborted_in_a_row >= 2:
                break
            if "error" in r:
                if (previous is not None and previous["error"] <= min(THRESHOLDS)
                        and r["cost_seconds_per_simulated_second"]
                        > previous["cost_seconds_per_simulated_second"]):
                    break
                previous = r

    repeat_candidates(rows, make, families, duration, args.repeats, log)
    return rows, info


def rates(args):
    return RATES[:3] if args.quick else RATES


def set_cost(row, cpu):
    row["cpu_seconds"] = cpu
    row["cost_seconds_per_simulated_second"] = cpu / row["horizon"]
    row["iterations_per_step"] = row["iterations"] / row["steps"]
    row["cpu_per_step"] = cpu / row["steps"]
    row["cpu_per_iteration"] = cpu / max(1, row["iterations"])


def usable(row):
    return "error" in row and row["method"] != "reference" and not row.get("unstable")


def repeat_candidates(rows, make, families, duration, repeats, log):
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
                candidates |= {i for i in meeting
                               if rows[i]["cpu_seconds"] <= REPEAT_MARGIN * cheapest}
    for i in sorted(candidates):
        r = rows[i]
        for _ in range(repeats - 1):
            again = simulate(make, families[r["method"]], r["steps"], duration)
            r["cpu_seconds_samples"].append(again["cpu_seconds"])
        r["repeats"] = len(r["cpu_seconds_samples"])
        set_cost(r, statistics.median(r["cpu_seconds_samples"]))
        log(f"    repeated {r['method']} dt={r['dt']:.3g}: median CPU {r['cpu_seconds']:.3g} s "
            f"of {', '.join(f'{s:.3g}' for s in r['cpu_seconds_samples'])}")


def describe(cell):
    return (f"{cell['scene']} {cell['size']}² k={cell['stretch_stiffness']:g} "
            f"bend={cell['bend_stiffness']:g} T={cell['horizon']:g} s")


def log_row(log, r):
    if r["diverged"]:
        state = "diverged"
    elif r["aborted"]:
        state = f"aborted ({r['aborted']})"
    else:
        state = (f"error {r['error']:.2e} cost {r['cost_seconds_per_simulated_second']:.3g} s/s "
                 f"it/step {r['iterations_per_step']:.1f}"
                 + (" UNSTABLE" if r.get("unstable") else ""))
    log(f"    {r['method']:18s} dt={r['dt']:.3g} {state}")


# -- summary ------------------------------------------------------------------------------------
def entry(row):
    if row is None:
        return None
    keys = ("method", "dt", "steps", "error", "cost_seconds_per_simulated_second", "cpu_seconds",
            "repeats", "iterations_per_step", "cpu_per_iteration", "cpu_per_step",
            "unconverged_steps", "wrinkle_retention")
    return {k: row[k] for k in keys if k in row}


def summarize_cell(info, rows, families):
    out = {k: info.get(k) for k in ("scene", "size", "bending", "stretch_stiffness",
                                     "bend_stiffness", "horizon", "reference_error",
                                     "reference_converged", "stable_dt_estimate",
                                     "trial_limit_dt", "stability_trials")}
    limit = [r for r in rows if r.get("at_limit") and not r["unstable"]]
    out["explicit_limit_dt"] = limit[0]["dt"] if limit else None
    if not info.get("reference_converged"):
        return out
    for threshold in THRESHOLDS:
        per_family = {}
        for family in families:
            sel = [r for r in rows if r["method"] == family and usable(r)
                   and r["error"] <= threshold]
            best = min(sel, key=lambda r: r["cost_seconds_per_simulated_second"], default=None)
            if best is None:
                tried = [r for r in rows if r["method"] == family]
                estimates = [r["cost_estimate_seconds_per_simulated_second"] for r in tried
                             if r.get("aborted")]
                best = {"none": "no run reached the error" if tried else "not run",
                        "aborted_runs": len(estimates),
                        "least_extrapolated_cost": min(estimates, default=None)}
                per_family[family] = best
            else:
                per_family[family] = entry(best)
        implicit = [e for f, e in per_family.items() if f != "explicit" and "method" in e]
        best_implicit = min(implicit, key=lambda e: e["cost_seconds_per_simulated_second"],
                            default=None)
        best_explicit = per_family.get("explicit")
        verdict = {"families": per_family, "best_implicit": best_implicit}
        if best_implicit and best_explicit and "method" in best_explicit:
            ratio = (best_implicit["cost_seconds_per_simulated_second"]
                     / best_explicit["cost_seconds_per_simulated_second"])
            verdict.update(implicit_over_explicit_cost=ratio,
                           winner=best_implicit["method"] if ratio < 1 else "explicit")
        out[f"at_{threshold:g}"] = verdict
    return out


def crossovers(cell_summaries):
    """Per (bending, size) of the sheet: the cost ratios at 1 % against stiffness and the
    stiffness where the ratio crosses 1 (log-log interpolation), or a bound."""
    out = []
    sheet = [c for c in cell_summaries if c["scene"] == "sheet"]
    for bending in dict.fromkeys(c["bending"] for c in sheet):
        for size in sorted({c["size"] for c in sheet if c["bending"] == bending}):
            points = sorted((c["stretch_stiffness"], c["at_0.01"]["implicit_over_explicit_cost"])
                            for c in sheet if c["bending"] == bending and c["size"] == size
                            and "implicit_over_explicit_cost" in c.get("at_0.01", {}))
            found = None
            for (k0, r0), (k1, r1) in zip(points, points[1:]):
                if r0 >= 1.0 > r1:
                    f = math.log(r0) / (math.log(r0) - math.log(r1))
                    found = math.exp(math.log(k0) + f * (math.log(k1) - math.log(k0)))
            item = {"bending": bending, "size": size, "ratios": points, "crossover_stiffness": found}
            if found is None and points:
                item["bound"] = ("implicit cheaper at every stiffness measured"
                                 if all(r < 1 for _, r in points) else
                                 "explicit cheaper at every stiffness measured"
                                 if all(r >= 1 for _, r in points) else "no single crossing")
            out.append(item)
    return out


def targets(cell_summaries):
    """The issue's two targets at 64², equal bending: ratio <= 1 at 2e5, <= 0.5 at 2e6."""
    out = []
    for k, goal in ((2e5, 1.0), (2e6, 0.5)):
        cell = next((c for c in cell_summaries if c["scene"] == "sheet" and c["size"] == 64
                     and c["bending"] == "equal" and c["stretch_stiffness"] == k), None)
        item = {"size": 64, "stretch_stiffness": k, "goal_ratio": goal, "measured": cell is not None}
        if cell is not None:
            at = cell.get("at_0.01", {})
            ratio = at.get("implicit_over_explicit_cost")
            item.update(ratio=ratio, met=ratio is not None and ratio <= goal,
                        reference_converged=cell["reference_converged"])
            if ratio is not None:
                item["shortfall"] = ratio / goal
                imp, exp = at["best_implicit"], at["families"]["explicit"]
                item["limits"] = {
                    "implicit": {"method": imp["method"], "steps": imp["steps"],
                                 "iterations_per_step": imp["iterations_per_step"],
                                 "cpu_per_iteration": imp["cpu_per_iteration"]},
                    "explicit": {"steps": exp["steps"], "cpu_per_step": exp["cpu_per_step"]}}
        out.append(item)
    return out


def summary_lines(cell_summaries, crossing, goals):
    lines = []
    for c in cell_summaries:
        head = (f"{c['scene']} {c['size']}² {c['bending']} k={c['stretch_stiffness']:g}: ")
        if not c.get("reference_converged"):
            lines.append(head + f"reference not converged ({c.get('reference_error')}); left out")
            continue
        parts = []
        for threshold in THRESHOLDS:
            at = c[f"at_{threshold:g}"]
            exp, imp = at["families"].get("explicit"), at["best_implicit"]
            text = f"{100 * threshold:g} %: explicit " + (
                f"{exp['cost_seconds_per_simulated_second']:.3g} s/s" if exp and "method" in exp
                else "none")
            text += ", best implicit " + (
                f"{imp['method']} dt 1/{round(1 / imp['dt'])} "
                f"{imp['cost_seconds_per_simulated_second']:.3g} s/s" if imp else "none")
            if "implicit_over_explicit_cost" in at:
                text += f" (ratio {at['implicit_over_explicit_cost']:.2f}, {at['winner']})"
            parts.append(text)
        lines.append(head + "; ".join(parts))
    for item in crossing:
        lines.append(f"crossover {item['bending']} bending {item['size']}²: "
                     + (f"k ≈ {item['crossover_stiffness']:.3g} N/m"
                        if item["crossover_stiffness"] else item.get("bound", "no data")))
    for g in goals:
        if g.get("ratio") is not None:
            lines.append(f"target 64² k={g['stretch_stiffness']:g}: implicit/explicit "
                         f"{g['ratio']:.2f} (goal ≤ {g['goal_ratio']:g}) "
                         + ("met" if g["met"] else f"missed by {g['shortfall']:.2f}×"))
    return lines


# -- main ---------------------------------------------------------------------------------------
def options(parser):
    parser.add_argument("--sizes", type=int, nargs="+", default=None,
                        help="sheet resolutions, vertices per edge (default 32 64 128)")
    parser.add_argument("--stiffness", type=float, nargs="+", default=None,
                        help="stretch stiffnesses, N/m (default 2e3 2e4 2e5 2e6)")
    parser.add_argument("--bending", nargs="+", choices=("equal", "soft"),
                        default=["equal", "soft"])
    parser.add_argument("--scenes", nargs="+", choices=("sheet", "hanging", "cylinder"),
                        default=["sheet", "hanging", "cylinder"])
    parser.add_argument("--repeats", type=int, default=None, help="default 3 (quick: 1)")
    parser.add_argument("--max-run-seconds", type=float, default=None,
                        help="CPU cap of one implicit run (default 60; quick: 2)")
    parser.add_argument("--max-ratio", type=float, default=8.0,
                        help="cap of one implicit run over explicit's cost (default 8)")
    parser.add_argument("--max-reference-seconds", type=float, default=240.0,
                        help="CPU budget of one more reference halving (default 240)")
    parser.add_argument("--max-cell-seconds", type=float, default=600.0,
                        help="skip a cell whose explicit runs (limit, repeats, reference pair) "
                             "would take more CPU seconds, predicted from the stability trials "
                             "(default 600)")
    parser.add_argument("--no-extend", action="store_true",
                        help="do not add 2e7 N/m where explicit wins at the largest stiffness")
    parser.add_argument("--merge", nargs="+", default=None, metavar="JSON",
                        help="run nothing: combine the rows and cells of partial runs (each a "
                             "speed_vs_error.json, e.g. one per size run side by side) into one "
                             "result with its summary and pictures")
    parser.add_argument("--max-128-stiffness", type=float, default=2e5,
                        help="largest stiffness run at 128² and above (explicit's reference "
                             "costs grow as k^0.5; default 2e5)")


def main(argv=None):
    args = arguments(__doc__, argv, options)
    args.sizes = args.sizes or ([9, 13] if args.quick else [32, 64, 128])
    args.stiffness = args.stiffness or ([2e3, 2e5] if args.quick else [2e3, 2e4, 2e5, 2e6])
    args.repeats = args.repeats or (1 if args.quick else 3)
    args.max_run_seconds = args.max_run_seconds or (2.0 if args.quick else 60.0)
    yore.set_num_threads(1)
    families, missing = available_families()
    for name, why in missing.items():
        print(f"{name}: left out ({why})")
    started = time.process_time()
    all_rows, summaries = [], []

    def run_cells(todo):
        for cell, make in todo:
            if cell["size"] >= 128 and cell["stretch_stiffness"] > args.max_128_stiffness:
                summaries.append(dict(cell, skipped=f"stiffness above --max-128-stiffness "
                                                    f"{args.max_128_stiffness:g}"))
                continue
            rows, info = measure_cell(cell, make, families, args, print)
            all_rows.extend(rows)
            summaries.append(info if "skipped" in info else summarize_cell(info, rows, families))

    merged_cpu = 0.0
    if args.merge:
        import json

        families = {}
        for name in args.merge:
            part = json.loads(open(name).read())
            all_rows.extend(part["rows"])
            summaries.extend(part["summary"]["cells"])
            families.update({family: FAMILIES[family] for family in part["families"]})
            missing.update(part["families_unavailable"])
            merged_cpu += part["benchmark_cpu_seconds"]
            args.repeats, args.max_run_seconds = part["repeats"], part["max_run_seconds"]
            args.max_ratio = part["max_ratio"]
    else:
        run_cells(cells(args))
    if not args.merge and not args.no_extend and "sheet" in args.scenes and not args.quick:
        extra = []
        for item in crossovers([s for s in summaries if "skipped" not in s]):
            top = max(args.stiffness)
            if (item["ratios"] and all(r >= 1 for _, r in item["ratios"]) and top < 2e7
                    and item["ratios"][-1][0] == top):
                make, bend = sheet(item["size"], 2e7, item["bending"])
                extra.append(({"scene": "sheet", "size": item["size"],
                               "bending": item["bending"], "stretch_stiffness": 2e7,
                               "bend_stiffness": bend,
                               "horizon": horizon(item["size"], item["bending"], False),
                               "extended": True}, make))
        run_cells(extra)
    measured = [s for s in summaries if "skipped" not in s]
    crossing = crossovers(measured)
    goals = targets(measured)
    lines = summary_lines(measured, crossing, goals)
    payload = {"benchmark": "speed_vs_error", "machine": machine_info(), "quick": args.quick,
               "families": list(families), "families_unavailable": missing,
               "thresholds": list(THRESHOLDS), "reference_tolerance": REFERENCE_TOLERANCE,
               "repeats": args.repeats, "max_run_seconds": args.max_run_seconds,
               "max_ratio": args.max_ratio,
               "duration_seconds": {describe(s): s["horizon"] for s in summaries},
               "sample_times": "T/2 and T of each cell (its horizon)",
               "benchmark_cpu_seconds": merged_cpu + time.process_time() - started,
               "rows": all_rows,
               "summary": {"cells": summaries, "crossovers": crossing, "targets": goals,
                           "lines": lines}}
    save(args.out, "speed_vs_error", payload, lambda path: plot(payload, path))
    for line in lines:
        print(line)
    return payload


# -- pictures -----------------------------------------------------------------------------------
def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = payload["rows"]
    groups = list(dict.fromkeys((r["scene"], r["size"], r["bending"]) for r in rows))
    stiffnesses = sorted({r["stretch_stiffness"] for r in rows})
    if not rows:  # every cell skipped (budget): say so rather than fail
        fig, ax = plt.subplots(figsize=(5, 2))
        ax.axis("off")
        ax.text(0.5, 0.5, "no cell measured (all skipped: see the JSON's summary)",
                ha="center", va="center")
        fig.savefig(path, dpi=100)
        plt.close(fig)
        return
    fig, axes = plt.subplots(len(groups), len(stiffnesses), squeeze=False,
                             figsize=(3.2 * len(stiffnesses), 2.8 * len(groups)))
    colours = dict(zip(FAMILIES, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for (g, group), (j, k) in ((x, y) for x in enumerate(groups) for y in enumerate(stiffnesses)):
        ax = axes[g][j]
        sel = [r for r in rows if (r["scene"], r["size"], r["bending"]) == group
               and r["stretch_stiffness"] == k]
        if not sel:
            ax.axis("off")
            continue
        converged = sel[0]["reference_converged"]
        for family in FAMILIES:
            runs = sorted((r for r in sel if r["method"] == family and usable(r)
                           and r["error"] > 0), key=lambda r: r["dt"])
            if runs:
                ax.loglog([r["cost_seconds_per_simulated_second"] for r in runs],
                          [r["error"] for r in runs], marker="o", markersize=3,
                          color=colours[family], label=family)
        for threshold in THRESHOLDS:
            ax.axhline(threshold, color="gray", linestyle=":", linewidth=0.8)
        ax.set_title(f"{group[0]} {group[1]}², {group[2]} bending, k={k:g}"
                     + ("" if converged else "\nreference NOT converged"), fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(True, which="both", alpha=0.3)
    axes[-1][0].set_xlabel("CPU s per simulated s", fontsize=7)
    axes[-1][0].set_ylabel("RMS error / cloth size", fontsize=7)
    handles, labels = {}, {}
    for ax in axes.flat:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    fig.legend(handles.values(), handles.keys(), loc="upper center", ncol=len(handles),
               fontsize=7)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=100)
    plt.close(fig)
    plot_crossover(payload, path.with_name("crossover.png"))


def plot_crossover(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells_ = [c for c in payload["summary"]["cells"] if c["scene"] == "sheet"]
    bendings = [b for b in ("equal", "soft") if any(c["bending"] == b for c in cells_)] or ["equal"]
    sizes = sorted({c["size"] for c in cells_}) or [0]
    stiffnesses = sorted({c["stretch_stiffness"] for c in cells_}) or [0.0]
    fig, axes = plt.subplots(1, len(bendings), squeeze=False,
                             figsize=(1.9 * len(stiffnesses) * len(bendings) + 1.5,
                                      1.1 * len(sizes) + 1.6))
    limit = 1.0  # colour range: log10 ratio in [-1, 1]
    for ax, bending in zip(axes[0], bendings):
        grid = np.full((len(sizes), len(stiffnesses)), np.nan)
        for c in cells_:
            if c["bending"] != bending:
                continue
            i, j = sizes.index(c["size"]), stiffnesses.index(c["stretch_stiffness"])
            at = c.get("at_0.01", {})
            ratio = at.get("implicit_over_explicit_cost")
            if ratio is not None:
                grid[i, j] = math.log10(ratio)
                text = f"{at['winner']}\n{ratio:.2g}"
            elif "skipped" in c:
                text = "skipped"
            elif not c.get("reference_converged"):
                text = "reference\nnot converged"
            else:
                text = "no implicit\nrun at 1 %"
            ax.text(j, i, text, ha="center", va="center", fontsize=6)
        image = ax.imshow(grid, cmap="RdBu_r", vmin=-limit, vmax=limit, origin="lower",
                          aspect="auto")
        ax.set_xticks(range(len(stiffnesses)), [f"{k:g}" for k in stiffnesses], fontsize=7)
        ax.set_yticks(range(len(sizes)), [f"{n}²" for n in sizes], fontsize=7)
        ax.set_xlabel("stretch stiffness, N/m", fontsize=8)
        ax.set_ylabel("sheet, vertices", fontsize=8)
        ax.set_title(f"bending {'= stretch' if bending == 'equal' else f'{SOFT_BENDING:g} N/m'}",
                     fontsize=8)
    fig.suptitle("cheapest implicit / cheapest explicit CPU cost at 1 % error (cell: winner, "
                 "ratio)", fontsize=9)
    fig.colorbar(image, ax=list(axes[0]), label="log10 cost ratio (blue: implicit wins)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
