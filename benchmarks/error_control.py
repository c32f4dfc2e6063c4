"""Error-controlled stepping (cvode, arkode) against yore's fixed-step BDF2 and explicit, on
the crossover's sheet over its short horizon (issue 40, first measurements).

    python -m benchmarks.error_control [--out bench-results] [--quick] [--repeats 3]

One thread (`yore.set_num_threads(1)`); writes error_control.json and error_control.png.

The sheet: `yore.scenes.hanging_cloth` with pin_spacing 1 (flat, let go from rest), mass 0.1 kg,
bending springs as stiff as the structural ones (the crossover's "bending equal"), over
T = 0.25 s. The reference is explicit at half its default step; its floor is the distance
between explicit at the default step and at half of it (what the reference itself may be off
by). Every run's error is the largest distance of a vertex from the reference at T, over the
sheet's 1 m size. Rows: explicit at its default step; bdf2 at 1/32 … 1/256 s; cvode (BDF,
max_order 2, the default) and arkode (ESDIRK order 3) at rtol 1e-2, 1e-3, 1e-4 with
atol = rtol/10 m and an output interval of 1/60 s. Cost is CPU seconds (process time, one
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
CELLS = [(16, 2e3), (32, 2e3), (32, 2e5)]
QUICK_CELLS = [(10, 2e3)]
BDF2_STEPS = [1 / 32, 1 / 64, 1 / 128, 1 / 256]
TOLERANCES = [1e-2, 1e-3, 1e-4]
OUTPUT_INTERVAL = 1 / 60
SLOW_RUN = 20.0  # s: a run this long is not repeated


def sheet(n, k, integrator, **options):
    return hanging_cloth(resolution=n, pin_spacing=1.0, mass=0.1, stretch_stiffness=k,
                         bend_stiffness=k, integrator=integrator, **options)


def run(n, k, integrator, repeats, **options):
    samples, sim, failure = [], None, None
    for _ in range(repeats):
        sim = sheet(n, k, integrator, **options)
        start = time.process_time()
        try:
            sim.advance(HORIZON)
        except yore.SimulationDiverged as error:
            return {"failure": str(error).split(". The cloth")[0]}, None
        samples.append(time.process_time() - start)
        if samples[-1] > SLOW_RUN:
            break
    return {"cpu_seconds": statistics.median(samples), "repeats": len(samples)}, sim


def measure_cell(n, k, repeats):
    reference = sheet(n, k, "explicit")
    reference = sheet(n, k, "explicit", dt=reference.dt / 2)
    reference.advance(HORIZON)
    rows = []
    explicit, sim = run(n, k, "explicit", repeats)
    floor = float(np.abs(sim.cloth.positions - reference.cloth.positions).max())
    rows.append({"integrator": "explicit", "dt": sim.dt, **explicit, "error": floor})
    for dt in BDF2_STEPS:
        row, sim = run(n, k, "bdf2", repeats, dt=dt)
        if sim is not None:
            counters = sim.stats["counters"]
            row.update(error=float(np.abs(sim.cloth.positions - reference.cloth.positions).max()),
                       factorizations_per_step=counters["factorizations"] / sim.stats["steps"])
        rows.append({"integrator": "bdf2", "dt": dt, **row})
    for integrator in ("cvode", "arkode"):
        for tol in TOLERANCES:
            row, sim = run(n, k, integrator, repeats, dt=OUTPUT_INTERVAL, rtol=tol,
                           atol=tol / 10)
            if sim is not None:
                c = sim.stats["counters"]
                row.update(
                    error=float(np.abs(sim.cloth.positions - reference.cloth.positions).max()),
                    internal_steps=c["internal_steps"],
                    factorizations_per_step=c["factorizations"] / max(c["internal_steps"], 1),
                    mean_internal_dt=HORIZON / max(c["internal_steps"], 1),
                    newton_iterations_per_step=c["nonlinear_iterations"]
                    / max(c["internal_steps"], 1),
                    error_test_failures=c["error_test_failures"])
            rows.append({"integrator": integrator, "rtol": tol, **row})
    derive(rows, floor)
    return {"size": n, "stiffness": k, "floor": floor, "rows": rows}


def derive(rows, floor):
    explicit = rows[0]
    bdf2 = [r for r in rows if r["integrator"] == "bdf2" and "error" in r]
    for integrator in ("cvode", "arkode"):
        mine = [r for r in rows if r["integrator"] == integrator]
        for a, b in zip(mine, mine[1:]):
            if "error" in a and "error" in b and min(a["error"], b["error"]) > 3 * floor:
                b["slope"] = math.log10(a["error"] / b["error"]) / math.log10(a["rtol"] / b["rtol"])
        for r in mine:
            if "error" not in r:
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
    styles = {"explicit": ("k", "*"), "bdf2": ("tab:blue", "o"), "cvode": ("tab:red", "s"),
              "arkode": ("tab:green", "^")}
    for ax, cell in zip(axes[0], cells):
        for name, (colour, marker) in styles.items():
            rows = [r for r in cell["rows"] if r["integrator"] == name and "error" in r]
            if rows:
                ax.loglog([r["cpu_seconds"] for r in rows], [max(r["error"], 1e-9) for r in rows],
                          marker=marker, color=colour, label=name)
        ax.axhline(cell["floor"], color="grey", ls=":", label="reference floor")
        ax.set_title(f"{cell['size']}², k = {cell['stiffness']:g} N/m, {HORIZON} s")
        ax.set_xlabel("CPU s (one thread)")
        ax.set_ylabel("error at T (m, 1 m sheet)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    args = common.arguments(__doc__, argv, lambda p: p.add_argument("--repeats", type=int,
                                                                    default=3))
    yore.set_num_threads(1)
    cells = []
    for n, k in (QUICK_CELLS if args.quick else CELLS):
        print(f"== {n}² k = {k:g}", flush=True)
        cells.append(measure_cell(n, k, 1 if args.quick else args.repeats))
        for r in cells[-1]["rows"]:
            print("  ", {key: (f"{v:.3g}" if isinstance(v, float) else v) for key, v in r.items()},
                  flush=True)
    payload = {"benchmark": "error_control", "machine": common.machine_info(),
               "horizon": HORIZON, "output_interval": OUTPUT_INTERVAL, "cells": cells}
    common.save(args.out, "error_control", payload, lambda path: draw(cells, path))


if __name__ == "__main__":
    main()
