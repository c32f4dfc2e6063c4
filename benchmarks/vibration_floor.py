"""Why the error of the error-controlled rows does not follow their tolerance on the stiff sheets:
every implicit family's error against the explicit reference, against its mean step, beside the
stiff springs' time scale (issue 40, item 4's proportionality).

    python -m benchmarks.vibration_floor [--out bench-results] [--quick]

One thread. The crossover's sheet (`benchmarks.crossover.sheet`, bending equal) at 16² and 32²,
k = 2e5 N/m, over T = 0.25 s; the error is the crossover's RMS vertex distance at T over the
sheet's start diagonal, against explicit (symplectic Euler) at its stable step
(`stable_dt()`) over 16, whose own convergence is recorded (explicit at 1, 1/2, 1/4 and 1/8 of
the stable step against it). Rows, each with its mean internal step:
- cvode at rtol 1e-2 … 1e-8 (atol = rtol/10 m), output every 1/64 s;
- tr-bdf2 with dt="auto" at rtol 1e-2 … 1e-6, output at T/2 and T;
- tr-bdf2 at fixed steps 1/64 … 1/16384 s with Newton solved tight (residual test at 1e-9 of a
  rest length, no truncation test, at most 200 iterations: a step that reaches the cap is
  counted), so neither Newton's stop nor a controller is in the error.
If the error were the controlled truncation error it would fall with rtol (slope ~2/3 for a
second-order method controlled per step) and with the fixed step as h². If it is the motion of the
stiff springs, which an L-stable step longer than their period damps and the reference keeps,
every family stays near one level until its steps come down to the stable explicit step's order,
and the controllers' estimates (of the resolved motion) do not see it.
Writes vibration_floor.json and vibration_floor.png.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

import yore

from . import common
from . import crossover as cx

HORIZON = 0.25
CELLS = [(16, 2e5), (32, 2e5)]
QUICK_CELLS = [(8, 2e4)]
CVODE_TOLERANCES = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
AUTO_TOLERANCES = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6]
FIXED_RATES = [64, 256, 1024, 4096, 16384]
REFERENCE_DIVISOR = 16  # the reference's step: the stable step over this
TIGHT = {"newton_tol": 1e-9, "truncation_fraction": 0.0, "max_newton": 200}
MAX_SECONDS = 120.0  # CPU cap of one run; a dearer one is left out (named)


def end_positions(make, **options):
    """Positions at T, the CPU seconds and the simulation, or None if it failed. A step that
    reached Newton's iteration cap is counted (the row's unconverged_steps), not warned."""
    sim = make(**options)
    start = time.process_time()
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", cx.UNCONVERGED_WARNING, RuntimeWarning)
            sim.advance(HORIZON)
    except yore.SimulationDiverged as error:
        return None, str(error).split(". ")[0], sim
    return np.array(sim.cloth.positions), time.process_time() - start, sim


def measure_cell(n, k, quick=False):
    make = cx.sheet(n, k, "equal")
    probe = make()
    stable = probe.stable_dt()
    diagonal = float(np.linalg.norm(np.ptp(np.array(probe.cloth.positions), axis=0)))
    reference, _, _ = end_positions(make, integrator="explicit", dt=stable / REFERENCE_DIVISOR)

    def error(positions):
        return float(np.sqrt(np.mean(np.sum((positions - reference) ** 2, axis=1)))) / diagonal

    rows = []

    def add(family, setting, options, steps_of):
        positions, cpu, sim = end_positions(make, **options)
        row = {"family": family, "setting": setting}
        if positions is None:
            row["failure"] = cpu
        else:
            steps = steps_of(sim)
            row.update(
                error=error(positions),
                cpu_seconds=cpu,
                internal_steps=steps,
                mean_step=HORIZON / steps,
                unconverged_steps=int(sim.stats["counters"].get("unconverged_steps", 0)),
            )
        rows.append(row)
        return row

    for divisor in (1, 2, 4, 8):
        add(
            "explicit",
            divisor,
            {"integrator": "explicit", "dt": stable / divisor},
            lambda sim: sim.stats["steps"],
        )
    for rtol in CVODE_TOLERANCES[:3] if quick else CVODE_TOLERANCES:
        r = add(
            "cvode",
            rtol,
            {
                "integrator": "cvode",
                "dt": 1 / 64,
                "rtol": rtol,
                "atol": rtol / 10,
                "max_steps": 10**6,
            },
            lambda sim: int(sim.stats["counters"]["internal_steps"]),
        )
        if r.get("cpu_seconds", 0.0) > MAX_SECONDS:
            break
    for rtol in AUTO_TOLERANCES[:3] if quick else AUTO_TOLERANCES:
        r = add(
            "tr-bdf2 auto",
            rtol,
            {
                "integrator": "tr-bdf2",
                "dt": HORIZON / 2,
                "adaptive": True,
                "rtol": rtol,
                "atol": rtol / 10,
                "max_steps": 10**6,
            },
            lambda sim: sim.stats["steps"],
        )
        if r.get("cpu_seconds", 0.0) > MAX_SECONDS:
            break
    for rate in FIXED_RATES[:3] if quick else FIXED_RATES:
        r = add(
            "tr-bdf2 fixed, tight Newton",
            1 / rate,
            {"integrator": "tr-bdf2", "dt": 1 / rate, **TIGHT},
            lambda sim: sim.stats["steps"],
        )
        if r.get("cpu_seconds", 0.0) > MAX_SECONDS:
            break
    for family in ("cvode", "tr-bdf2 auto", "tr-bdf2 fixed, tight Newton"):
        mine = [r for r in rows if r["family"] == family and "error" in r]
        for a, b in zip(mine, mine[1:]):
            b["slope_vs_step"] = math.log(a["error"] / b["error"]) / math.log(
                a["mean_step"] / b["mean_step"]
            )
            if family != "tr-bdf2 fixed, tight Newton":
                b["slope_vs_rtol"] = math.log(a["error"] / b["error"]) / math.log(
                    a["setting"] / b["setting"]
                )
    for r in rows:
        r.update(size=n, stiffness=k)
        if "mean_step" in r:
            r["mean_step_over_stable_dt"] = r["mean_step"] / stable
    return {
        "size": n,
        "stiffness": k,
        "stable_dt": stable,
        "reference_dt": stable / REFERENCE_DIVISOR,
        "rows": rows,
    }


def draw(cells, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(cells), figsize=(5.5 * len(cells), 4.2), squeeze=False)
    styles = {
        "explicit": ("k", "*"),
        "cvode": ("tab:red", "s"),
        "tr-bdf2 auto": ("tab:purple", "D"),
        "tr-bdf2 fixed, tight Newton": ("tab:blue", "o"),
    }
    for ax, cell in zip(axes[0], cells):
        for family, (colour, marker) in styles.items():
            rows = [r for r in cell["rows"] if r["family"] == family and "error" in r]
            if rows:
                ax.loglog(
                    [r["mean_step"] for r in rows],
                    [r["error"] for r in rows],
                    marker=marker,
                    color=colour,
                    label=family,
                )
        ax.axvline(cell["stable_dt"], color="grey", ls=":", label="explicit stable step")
        ax.set_title(f"{cell['size']}², k = {cell['stiffness']:g} N/m, T = {HORIZON} s")
        ax.set_xlabel("mean internal step (s)")
        ax.set_ylabel("RMS distance at T / diagonal")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    args = common.arguments(__doc__, argv)
    yore.set_num_threads(1)
    cells = []
    for n, k in QUICK_CELLS if args.quick else CELLS:
        print(f"== {n}² k = {k:g}", flush=True)
        cells.append(measure_cell(n, k, args.quick))
        for r in cells[-1]["rows"]:
            print(
                "  ",
                {
                    key: (f"{v:.3g}" if isinstance(v, float) else v)
                    for key, v in r.items()
                    if key not in ("size", "stiffness")
                },
                flush=True,
            )
    payload = {
        "benchmark": "vibration_floor",
        "machine": common.machine_info(),
        "quick": args.quick,
        "horizon": HORIZON,
        "cells": [
            {key: c[key] for key in ("size", "stiffness", "stable_dt", "reference_dt")}
            for c in cells
        ],
        "rows": [r for c in cells for r in c["rows"]],
    }
    common.save(args.out, "vibration_floor", payload, lambda path: draw(cells, path))


if __name__ == "__main__":
    main()
