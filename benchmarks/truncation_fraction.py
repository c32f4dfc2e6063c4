"""TR-BDF2's Newton stop over the long horizon: Newton iterations per stage, energy gained and
the kinetic-energy history's error at several truncation fractions, against explicit's cost.

    python -m benchmarks.truncation_fraction [--out bench-results] [--quick]
        [--fractions 0.01 0.03 0.1] [--rates 32 64] [--auto RTOL ...] [--cells LABEL ...]

Newton stops a TR-BDF2 stage once its estimated distance to the stage's solution is at most
`truncation_fraction` × the step's estimated truncation error. The default was lowered from 0.1
to 0.01 after an energy gain on the 64² sheet at 2e6 N/m (issue 53); that roughly tripled the
iterations. From this benchmark's figures (with the redo of a gaining step) it is 0.03 since
issue 51. This benchmark measures what each fraction buys on the long horizon's own cells:
the crossover's 64² sheet (`benchmarks.crossover.sheet`, bending springs as stiff as the
stretch springs), k = 2e5 and 2e6 N/m, with the scene's damping alone ("equal") and with
material damping 1 N·s/m ("equal, damped"), 2 s from the flat start, at 1/32 s and 1/64 s.

The reference of each cell is the long-horizon benchmark's own (explicit at half its stability
limit), read from the committed JSON named in CELLS: its kinetic energy every 1/64 s and its
floor (how far a 1e-12 m perturbation or a halved step moves it). The explicit integrator has
no BLAS, so the reference does not depend on the machine beyond rounding. The measure is the
long horizon's `kinetic_energy_history` (‖KE − KE_ref‖₂/‖KE_ref‖₂ over the run's samples).
Explicit's cost is measured here, in the same run: its CPU per step at the reference file's
explicit dt (median of 3 runs of EXPLICIT_PROBE_STEPS steps) times the steps of 2 s.

Per row: Newton iterations per stage and per step, the trapezoid stages' share, thrown-away
factorizations, the largest energy rise above the lowest energy reached (`energy_gain`, J; a
damped scene should show none), the error, CPU seconds (time.thread_time around the stepping,
one thread) and that over explicit's, and the steps redone to Newton's residual test because
their energy rose past the growth check's allowance (`energy_retries`). --quick: a 12² sheet
over 0.25 s against an explicit reference computed here at half the stable step. --auto:
also TR-BDF2 with ``dt="auto"`` at each of these rtol (atol rtol/10, as the long horizon's
families), output every 1/64 s, at the default fraction (rows with ``rtol``; ``steps`` are the
steps taken, retaken ones included); --rates with no value leaves the fixed-step rows out;
--cells: only these cells (labels of CELLS). Writes truncation_fraction.json and .png.
"""

from __future__ import annotations

import json
import statistics
import time
import warnings
from pathlib import Path

import numpy as np

import yore

from . import long_horizon as lh
from .common import arguments, machine_info, save
from .crossover import sheet

ROOT = Path(__file__).resolve().parent.parent
#: label → (k N/m, bending row, the long-horizon JSON holding the cell's reference)
CELLS = {
    "k = 2e5, equal": (2e5, "equal", "long-horizon-64-2e5-rerun"),
    "k = 2e5, equal, damped": (2e5, "equal, damped", "long-horizon-64-2e5-rerun"),
    "k = 2e6, equal": (2e6, "equal", "long-horizon-64-2e6-undamped"),
    "k = 2e6, equal, damped": (2e6, "equal, damped", "long-horizon-64-2e6-damped"),
}
SIZE, DURATION = 64, 2.0
QUICK_SIZE, QUICK_DURATION = 12, 0.25
FRACTIONS = (0.01, 0.03, 0.1)
RATES = (32, 64)  # steps per simulated second
EXPLICIT_PROBE_STEPS = 2000
REPEATS = 3


def committed_reference(folder, stiffness, bending):
    """(KE every 1/64 s, floor of the KE measure, explicit dt, the file's CPU) of a cell."""
    path = ROOT / "bench-results" / folder / "long_horizon.json"
    data = json.loads(path.read_text())
    rows = data["rows"]

    def row(method):
        return next(
            r
            for r in rows
            if r["method"] == method
            and r["stretch_stiffness"] == stiffness
            and r["bending"] == bending
            and r["size"] == SIZE
        )

    cell = next(
        c
        for c in data["summary"]["cells"]
        if c["stretch_stiffness"] == stiffness and c["bending"] == bending
    )
    return {
        "kinetic_energy": np.asarray(row("reference")["kinetic_energy"], float),
        "floor": cell["floors"]["kinetic_energy_history"]["floor"],
        "explicit_dt": row("explicit")["dt"],
        "file": str(path.relative_to(ROOT)),
        "file_cpu": data["machine"]["cpu"],
    }


def computed_reference(make, duration):
    """The quick mode's reference: explicit at half the stable step, KE every 1/64 s."""
    limit = make(dt=1e-3, integrator="explicit").stable_dt()
    per_sample = int(np.ceil(1.0 / (lh.GRID_RATE * 0.5 * limit)))
    run = lh.history(make, {"integrator": "explicit"}, per_sample, 1, duration, 0.0)
    return {
        "kinetic_energy": run["snapshots"][1][:, 1].tolist(),
        "floor": None,
        "explicit_dt": 1.0 / (lh.GRID_RATE * per_sample) * 2.0,
        "file": None,
        "file_cpu": None,
    }


def explicit_cpu_per_step(make, dt):
    """Median thread CPU of one explicit step at dt (EXPLICIT_PROBE_STEPS steps, REPEATS runs)."""
    seconds = []
    for _ in range(REPEATS):
        sim = make(dt=dt, integrator="explicit")
        start = time.thread_time()
        sim.step(EXPLICIT_PROBE_STEPS, progress=False)
        seconds.append((time.thread_time() - start) / EXPLICIT_PROBE_STEPS)
    return statistics.median(seconds)


def tr_bdf2_row(make, reference, fraction, rate, duration, rtol=None):
    """One TR-BDF2 run at 1/rate s with this truncation fraction, measured; with ``rtol``,
    error-controlled (dt="auto", output every 1/rate s)."""
    stride = lh.GRID_RATE // rate
    options = {"integrator": "tr-bdf2", "truncation_fraction": fraction}
    if rtol is not None:
        options.update(adaptive=True, rtol=rtol, atol=rtol / 10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # capped steps are counted
        run = lh.history(make, options, 1, stride, duration, 0.0)
    if run.get("diverged"):
        return {
            "diverged": True,
            "steps_done": run["steps_done"],
            "message": run.get("message", "not finite"),
        }
    table, c = run["snapshots"][1], run["counters"]
    points = table[:, 0].astype(int)
    kinetic = table[:, 1]
    steps, stages = round(duration * rate), c["stages"]
    if rtol is not None:
        steps = run["internal_steps"]
    return {
        "steps": steps,
        "stages": stages,
        "newton_iterations": c["newton_iterations"],
        "trapezoid_newton_iterations": c["trapezoid_newton_iterations"],
        "iterations_per_stage": c["newton_iterations"] / stages,
        "iterations_per_step": c["newton_iterations"] / steps,
        "factorizations_per_step": c["factorizations"] / steps,
        "thrown_away": c["factorizations_thrown_away"],
        "unconverged_steps": c["unconverged_steps"],
        "energy_gain": c["energy_gain"],
        "energy_retries": c.get("energy_retries", 0.0),
        "kinetic_energy_history": lh.relative_l2(
            kinetic, np.asarray(reference["kinetic_energy"])[points]
        ),
        "cpu_seconds": run["cpu_seconds"],
        "kinetic_energy": kinetic.tolist(),
    }


def main(argv=None):
    def extra(parser):
        parser.add_argument("--fractions", type=float, nargs="+", default=list(FRACTIONS))
        parser.add_argument("--rates", type=int, nargs="*", default=list(RATES))
        parser.add_argument("--auto", type=float, nargs="+", default=[], metavar="RTOL")
        parser.add_argument("--cells", nargs="+", choices=list(CELLS), default=list(CELLS))

    args = arguments(__doc__, argv, extra)
    for f in args.fractions:
        if not 0.0 < f <= 1.0:
            raise SystemExit(f"truncation_fraction: error: {f} is not in (0, 1]")
    for r in args.rates:
        if r <= 0 or lh.GRID_RATE % r:
            raise SystemExit(f"truncation_fraction: error: rate {r} does not divide {lh.GRID_RATE}")
    for r in args.auto:
        if not 1e-12 <= r < 1.0:
            raise SystemExit(f"truncation_fraction: error: rtol {r} is not in [1e-12, 1)")
    size, duration = (QUICK_SIZE, QUICK_DURATION) if args.quick else (SIZE, DURATION)
    cells = dict(list(CELLS.items())[:2]) if args.quick else CELLS
    cells = {label: cell for label, cell in cells.items() if label in args.cells}
    default = yore.options.defaults("tr-bdf2")["truncation_fraction"]
    yore.set_num_threads(1)
    rows, references = [], {}
    for label, (stiffness, bending, folder) in cells.items():
        make = sheet(size, stiffness, bending)
        reference = (
            computed_reference(make, duration)
            if args.quick
            else committed_reference(folder, stiffness, bending)
        )
        per_step = explicit_cpu_per_step(make, reference["explicit_dt"])
        explicit_cost = per_step * duration / reference["explicit_dt"]
        references[label] = {
            k: v for k, v in reference.items() if k != "kinetic_energy" or args.quick
        } | {
            "explicit_cpu_per_step": per_step,
            "explicit_cpu_seconds": explicit_cost,
        }
        runs = [(rate, fraction, None) for rate in args.rates for fraction in args.fractions]
        runs += [(lh.GRID_RATE, default, rtol) for rtol in args.auto]
        for rate, fraction, rtol in runs:
            row = tr_bdf2_row(make, reference, fraction, rate, duration, rtol)
            row.update(cell=label, dt=1.0 / rate, truncation_fraction=fraction)
            if rtol is not None:
                row["rtol"] = rtol
            if not row.get("diverged"):
                row["cost_over_explicit"] = row["cpu_seconds"] / explicit_cost
            rows.append(row)
            print(
                f"{size}², {label:24s} 1/{rate} s fraction {fraction:<5g} "
                + (f"rtol {rtol:g} " if rtol is not None else "")
                + (
                    "diverged"
                    if row.get("diverged")
                    else f"{row['iterations_per_stage']:5.2f} it/stage, "
                    f"KE error {row['kinetic_energy_history']:.4f}, "
                    f"gain {row['energy_gain']:.3g} J, redone {row['energy_retries']:g}, "
                    f"{row['cost_over_explicit']:.3f}× explicit"
                ),
                flush=True,
            )
    payload = {
        "benchmark": "truncation_fraction",
        "machine": machine_info(),
        "quick": args.quick,
        "size": size,
        "duration": duration,
        "default_fraction": default,
        "references": references,
        "rows": rows,
    }
    save(args.out, "truncation_fraction", payload, lambda path: plot(payload, path))
    return payload


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for label in payload["references"]:
        for dt in sorted({r["dt"] for r in payload["rows"]}):
            rows = [
                r
                for r in payload["rows"]
                if r["cell"] == label
                and r["dt"] == dt
                and not r.get("diverged")
                and r.get("rtol") is None  # (error-controlled rows: the table's)
            ]
            if not rows:
                continue
            f = [r["truncation_fraction"] for r in rows]
            name = f"{payload['size']}², {label}, 1/{round(1 / dt)} s"
            (line,) = left.plot(f, [r["iterations_per_stage"] for r in rows], "o-", label=name)
            right.plot(f, [r["kinetic_energy_history"] for r in rows], "o-", color=line.get_color())
            for r in payload["rows"]:  # a run that diverged: × at the top of the error axis
                if (
                    r["cell"] == label
                    and r["dt"] == dt
                    and r.get("diverged")
                    and r.get("rtol") is None
                ):
                    right.plot([r["truncation_fraction"]], [0.3], "x", ms=9, color=line.get_color())
    for ax, what in (
        (left, "Newton iterations per stage"),
        (right, "kinetic-energy history error"),
    ):
        ax.set_xscale("log")
        ax.set_xlabel("truncation_fraction")
        ax.set_ylabel(what)
        ax.grid(alpha=0.3)
    right.set_yscale("log")
    if left.get_lines():
        left.legend(fontsize=6)
    right.set_title("× at 0.3: diverged (the energy-growth check)", fontsize=8)
    fig.suptitle(f"TR-BDF2's Newton stop, {payload['size']}² sheets, {payload['duration']} s")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
