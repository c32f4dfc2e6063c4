"""Error-controlled stepping (cvode, arkode) against yore's fixed-step BDF2 and explicit, on
the crossover's sheet over its short horizon (issue 40, first measurements).

    python -m benchmarks.error_control [--out bench-results] [--quick] [--repeats 3]
        [--velocity-time SECONDS --name NAME]

One thread (`yore.set_num_threads(1)`); writes error_control.json and error_control.png.

The sheet: `yore.scenes.hanging_cloth` with pin_spacing 1 (flat, let go from rest), mass 0.1 kg,
bending springs as stiff as the structural ones (the crossover's "bending equal"), over
T = 0.25 s. The reference is explicit at half its default step; its floor is the error of
explicit at the default step against it (what the reference itself may be off by). Every
run's error is the crossover's: the RMS vertex distance to the reference at T/2 and at T over
the sheet's diagonal (√2 m), the larger; a threshold (1 %, 0.1 %) is judged in a cell only
where the floor is at most a tenth of it, and then each family's cheapest run within it is
recorded (`verdicts`). Rows: explicit at its default step; bdf2 at 1/32 … 1/256 s; cvode (BDF,
max_order 2, the default) and arkode (ESDIRK order 3) at rtol 1e-2, 1e-3, 1e-4 with
atol = rtol/10 m (atol_velocity at its default, atol per 1/60 s) and an output interval of
1/60 s; and yore's own tr-bdf2 and bdf2 with dt="auto" at the same rtol and atol (their steps
chosen by TR-BDF2's embedded estimate and variable-step BDF2's; "error_test_failures" are then
their rejected steps). --families runs a subset of the error-controlled families. Cost is CPU seconds (process time, one
thread), the median of `--repeats` runs (one run when the first takes over 20 s). Per
error-controlled row: the internal steps, factorizations per internal step, the log-log slope
of error against rtol (judged where both errors are above three times the floor), and its cost
against the cheapest bdf2 row and explicit at equal or smaller error.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

import yore
from yore.scenes import hanging_cloth

from . import common

HORIZON = 0.25
CELLS = [(16, 2e3), (32, 2e3), (32, 2e5), (32, 2e6), (64, 2e5)]
THRESHOLDS = (0.01, 0.001)  # the crossover's
REFERENCE_FRACTION = 0.1  # a threshold is judged where the floor is at most this fraction
QUICK_CELLS = [(10, 2e3)]
BDF2_STEPS = [1 / 32, 1 / 64, 1 / 128, 1 / 256]
TOLERANCES = [1e-2, 1e-3, 1e-4]
OUTPUT_INTERVAL = 1 / 60
ERROR_CONTROLLED = ("cvode", "arkode", "tr-bdf2 auto", "bdf2 auto")
#: yore's own error control (dt="auto"): the family and the integrator it runs
OWN_CONTROL = {"tr-bdf2 auto": "tr-bdf2", "bdf2 auto": "bdf2"}
SLOW_RUN = 20.0  # s: a run this long is not repeated


def sheet(n, k, integrator, **options):
    return hanging_cloth(
        resolution=n,
        pin_spacing=1.0,
        mass=0.1,
        stretch_stiffness=k,
        bend_stiffness=k,
        integrator=integrator,
        **options,
    )


def run(n, k, integrator, repeats, **options):
    """Median CPU seconds of `repeats` runs to T, and the last run's positions at T/2 and T
    (in .snapshots) with its simulation; a run that diverges (or fails its tolerance) is a
    failure naming why."""
    samples, sim = [], None
    for _ in range(repeats):
        sim = sheet(n, k, integrator, **options)
        sim.snapshots = []
        cpu = 0.0
        for _half in range(2):
            start = time.process_time()
            try:
                sim.advance(HORIZON / 2)
            except yore.SimulationDiverged as error:
                return {"failure": str(error).split(". The cloth")[0]}, None
            cpu += time.process_time() - start
            sim.snapshots.append(sim.cloth.positions)
        samples.append(cpu)
        if samples[-1] > SLOW_RUN:
            break
    return {"cpu_seconds": statistics.median(samples), "repeats": len(samples)}, sim


def crossover_error(sim, reference):
    """The crossover's error: the RMS vertex distance to the reference at T/2 and at T over the
    sheet's diagonal at the start (√2 m), the larger of the two."""
    return max(
        float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1)))) / math.sqrt(2.0)
        for a, b in zip(sim.snapshots, reference.snapshots)
    )


def measure_cell(n, k, repeats, velocity_time=None, families=ERROR_CONTROLLED):
    _, reference = run(n, k, "explicit", 1, dt=sheet(n, k, "explicit").dt / 2)
    rows = []
    explicit, sim = run(n, k, "explicit", repeats)
    floor = crossover_error(sim, reference)
    rows.append({"integrator": "explicit", "dt": sim.dt, **explicit, "error": floor})
    for dt in BDF2_STEPS:
        row, sim = run(n, k, "bdf2", repeats, dt=dt)
        if sim is not None:
            counters = sim.stats["counters"]
            row.update(
                error=crossover_error(sim, reference),
                factorizations_per_step=counters["factorizations"] / sim.stats["steps"],
            )
        rows.append({"integrator": "bdf2", "dt": dt, **row})
    for integrator in families:
        for tol in TOLERANCES:
            if integrator in OWN_CONTROL:
                row, sim = run(
                    n, k, OWN_CONTROL[integrator], repeats, dt="auto", rtol=tol, atol=tol / 10
                )
            else:
                extra = {} if velocity_time is None else {"atol_velocity": tol / 10 / velocity_time}
                row, sim = run(
                    n, k, integrator, repeats, dt=OUTPUT_INTERVAL, rtol=tol, atol=tol / 10, **extra
                )
            if sim is not None and integrator in OWN_CONTROL:
                c = sim.stats["counters"]
                row.update(
                    error=crossover_error(sim, reference),
                    internal_steps=sim.stats["steps"],
                    factorizations_per_step=c["factorizations"] / sim.stats["steps"],
                    mean_internal_dt=HORIZON / sim.stats["steps"],
                    newton_iterations_per_step=c["newton_iterations"] / sim.stats["steps"],
                    error_test_failures=c["rejected_steps"],
                )
            elif sim is not None:
                c = sim.stats["counters"]
                row.update(
                    error=crossover_error(sim, reference),
                    internal_steps=c["internal_steps"],
                    factorizations_per_step=c["factorizations"] / max(c["internal_steps"], 1),
                    mean_internal_dt=HORIZON / max(c["internal_steps"], 1),
                    newton_iterations_per_step=c["nonlinear_iterations"]
                    / max(c["internal_steps"], 1),
                    error_test_failures=c["error_test_failures"],
                )
            rows.append({"integrator": integrator, "rtol": tol, **row})
    derive(rows, floor)
    verdicts = {}
    for threshold in THRESHOLDS:
        if floor > REFERENCE_FRACTION * threshold:
            verdicts[f"{threshold:g}"] = {"judged": False}
            continue
        cheapest = {}
        for r in rows:
            if r.get("error") is not None and r["error"] <= threshold:
                best = cheapest.get(r["integrator"])
                if best is None or r["cpu_seconds"] < best["cpu_seconds"]:
                    cheapest[r["integrator"]] = r
        verdicts[f"{threshold:g}"] = {
            "judged": True,
            "cheapest": {
                name: {
                    "cpu_seconds": r["cpu_seconds"],
                    "error": r["error"],
                    "setting": r.get("rtol", r.get("dt")),
                }
                for name, r in cheapest.items()
            },
        }
    for r in rows:
        r.update(size=n, stiffness=k)
        r.setdefault("error", None)  # a failed run has none
        r.setdefault("cpu_seconds", None)
    return {"size": n, "stiffness": k, "floor": floor, "verdicts": verdicts, "rows": rows}


def derive(rows, floor):
    explicit = rows[0]
    bdf2 = [r for r in rows if r["integrator"] == "bdf2" and r.get("error") is not None]
    for integrator in ERROR_CONTROLLED:
        mine = [r for r in rows if r["integrator"] == integrator]
        for a, b in zip(mine, mine[1:]):
            if a.get("error") and b.get("error") and min(a["error"], b["error"]) > 3 * floor:
                b["slope"] = math.log10(a["error"] / b["error"]) / math.log10(a["rtol"] / b["rtol"])
        for r in mine:
            if r.get("error") is None:
                continue
            r["cpu_over_explicit"] = r["cpu_seconds"] / explicit["cpu_seconds"]
            as_good = [b for b in bdf2 if b["error"] <= r["error"]]
            if as_good:
                cheapest = min(as_good, key=lambda b: b["cpu_seconds"])
                r["cpu_over_bdf2"] = r["cpu_seconds"] / cheapest["cpu_seconds"]
                r["bdf2_dt"] = cheapest["dt"]


def draw(cells, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(cells), figsize=(5 * len(cells), 4), squeeze=False)
    styles = {
        "explicit": ("k", "*"),
        "bdf2": ("tab:blue", "o"),
        "cvode": ("tab:red", "s"),
        "arkode": ("tab:green", "^"),
        "tr-bdf2 auto": ("tab:purple", "D"),
        "bdf2 auto": ("tab:cyan", "v"),
    }
    for ax, cell in zip(axes[0], cells):
        for name, (colour, marker) in styles.items():
            rows = [r for r in cell["rows"] if r["integrator"] == name and r["error"] is not None]
            if rows:
                ax.loglog(
                    [r["cpu_seconds"] for r in rows],
                    [max(r["error"], 1e-9) for r in rows],
                    marker=marker,
                    color=colour,
                    label=name,
                )
        ax.axhline(cell["floor"], color="grey", ls=":", label="reference floor")
        ax.set_title(f"{cell['size']}², k = {cell['stiffness']:g} N/m, {HORIZON} s")
        ax.set_xlabel("CPU s (one thread)")
        ax.set_ylabel("error (RMS at T/2 and T over the diagonal)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    def extra(parser):
        parser.add_argument("--repeats", type=int, default=3)
        parser.add_argument(
            "--velocity-time",
            type=float,
            default=None,
            metavar="SECONDS",
            help="cvode/arkode: atol_velocity = atol / SECONDS (default: "
            "the integrators' default, the same number as atol)",
        )
        parser.add_argument("--name", default="error_control", help="output file name")
        parser.add_argument(
            "--families",
            nargs="+",
            choices=ERROR_CONTROLLED,
            default=list(ERROR_CONTROLLED),
            help="error-controlled families to run (explicit and the bdf2 "
            "ladder always run: the ratios are measured in the same run)",
        )

    args = common.arguments(__doc__, argv, extra)
    yore.set_num_threads(1)
    cells = []
    for n, k in QUICK_CELLS if args.quick else CELLS:
        print(f"== {n}² k = {k:g}", flush=True)
        cells.append(
            measure_cell(
                n, k, 1 if args.quick else args.repeats, args.velocity_time, tuple(args.families)
            )
        )
        for r in cells[-1]["rows"]:
            print(
                "  ",
                {key: (f"{v:.3g}" if isinstance(v, float) else v) for key, v in r.items()},
                flush=True,
            )
    payload = {
        "benchmark": "error_control",
        "machine": common.machine_info(),
        "quick": args.quick,
        "horizon": HORIZON,
        "output_interval": OUTPUT_INTERVAL,
        "velocity_time": args.velocity_time,
        "families": list(args.families),
        "thresholds": list(THRESHOLDS),
        "cells": [
            {key: c[key] for key in ("size", "stiffness", "floor", "verdicts")} for c in cells
        ],
        "rows": [r for c in cells for r in c["rows"]],
    }
    common.save(args.out, args.name, payload, lambda path: draw(cells, path))


if __name__ == "__main__":
    main()
