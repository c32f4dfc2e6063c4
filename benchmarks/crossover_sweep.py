"""The explicit/implicit crossover as a sweep: who is cheaper at 1 % error, by size and stiffness.

    python -m benchmarks.crossover_sweep [--out bench-results] [--quick] [--workers N]

The grid is benchmarks/crossover.toml (--quick: crossover_quick.toml) over
benchmarks/crossover_scene.toml, speed_vs_error's pinned sheet with equal bending: sizes × stiffnesses ×
methods, where a method is explicit at its default step (0.98 × the stable-step bound), the
reference (explicit at a fixed fine step), or an implicit family (BE linearized, BE Newton, BDF2,
local-global, quasi-Newton) at one step of a ladder 1/32 … 1/1024 s. It runs through
`yore.sweep` (one Dask task per cell; the sweep's folder is OUT/sweeps/crossover) and everything
below comes from its Dataset:

- error: the sweep's error_rms against the reference cell (the same size and stiffness) at the
  horizon, over the sheet's start diagonal (√2 m);
- cost: wall seconds per simulated second of the cell's run (one thread per worker; two workers
  on two cores share the machine, so costs carry that noise — speed_vs_error times CPU seconds
  with repeats and is the finer measure).

A family's cost at 1 % is its cheapest cell with error ≤ 1 %; the winner of a (size, stiffness)
pair is the cheaper of explicit and the best implicit family. Unlike speed_vs_error, the ladder is
fixed (no adaptive stop), explicit runs only at its default step, and the reference is not checked
for convergence: this is the sweep-engine version of the map, cheap to extend to new axes.
Writes crossover_sweep.json and crossover_sweep.png (speed_vs_error writes crossover.png).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .common import arguments, machine_info, save

HERE = Path(__file__).resolve().parent
DIAGONAL = math.sqrt(2.0)  # m: the 1 m sheet's start diagonal
THRESHOLD = 0.01


def family(label: str) -> str:
    return label.split(",")[0]


def main(argv=None):
    from yore.sweep import load_sweep, run

    args = arguments(__doc__, argv, extra=lambda p: p.add_argument(
        "--workers", type=int, default=None, help="Dask workers (default: the cores)"))
    sweep = load_sweep(HERE / ("crossover_quick.toml" if args.quick else "crossover.toml"))
    folder = Path(args.out) / "sweeps" / "crossover"
    results = run(sweep, folder, workers=args.workers, overwrite=True, quiet=True)
    data = results.dataset()
    rows, summary = [], []
    for i, size in enumerate(int(v) for v in data["mesh.nx"].values):
        for j, k in enumerate(float(v) for v in data["material.stretch_stiffness"].values):
            best = {}
            for m, label in enumerate(str(v) for v in data["method"].values):
                cell = data.isel(size=i, stiffness=j, method=m)
                status = str(cell["status"].values)
                error = float(cell["error_rms"].values) / DIAGONAL
                cost = float(cell["wall_seconds_per_simulated_second"].values)
                dt = float(cell["dt"].values)
                row = {"size": size, "stiffness": k, "method": label, "family": family(label),
                       "dt": dt, "status": status,
                       "error": error if math.isfinite(error) else None,
                       "cost": cost if math.isfinite(cost) else None,
                       "iterations": _number(cell, "newton_iterations", "iterations")}
                rows.append(row)
                if label == "reference" or status != "done" or not math.isfinite(error) \
                        or error > THRESHOLD:
                    continue
                name = row["family"]
                if name not in best or cost < best[name]["cost"]:
                    best[name] = row
            explicit = best.get("explicit")
            implicit = min((r for n, r in best.items() if n != "explicit"),
                           key=lambda r: r["cost"], default=None)
            ratio = (implicit["cost"] / explicit["cost"]) if explicit and implicit else None
            winner = (None if ratio is None else "explicit" if ratio > 1.0
                      else implicit["method"])
            summary.append({"size": size, "stiffness": k,
                            "explicit_cost": explicit["cost"] if explicit else None,
                            "best_implicit": implicit["method"] if implicit else None,
                            "best_implicit_cost": implicit["cost"] if implicit else None,
                            "implicit_over_explicit": ratio, "winner": winner})
            print(f"{size:4d}² k={k:8g}: explicit "
                  f"{explicit['cost'] if explicit else float('nan'):.3g} s/s, best implicit "
                  f"{implicit['method'] if implicit else '–'} "
                  f"{implicit['cost'] if implicit else float('nan'):.3g} s/s -> {winner}")
    payload = {"benchmark": "crossover_sweep", "machine": machine_info(), "quick": args.quick,
               "threshold": THRESHOLD, "horizon_seconds": float(data["time"].max()),
               "sweep": folder.as_posix(), "cells": sweep.cell_count,
               "statuses": results.counts(), "rows": rows, "summary": summary}
    save(args.out, "crossover_sweep", payload, lambda path: plot(payload, path))
    return payload


def _number(cell, *names):
    for name in names:
        if name in cell and math.isfinite(float(cell[name].values)):
            return float(cell[name].values)
    return None


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    sizes = sorted({r["size"] for r in payload["summary"]})
    ks = sorted({r["stiffness"] for r in payload["summary"]})
    grid = np.full((len(sizes), len(ks)), np.nan)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11.0, 4.2))
    for r in payload["summary"]:
        if r["implicit_over_explicit"] is not None:
            grid[sizes.index(r["size"]), ks.index(r["stiffness"])] = r["implicit_over_explicit"]
    image = left.imshow(np.ma.masked_invalid(grid), origin="lower", cmap="coolwarm",
                        norm=LogNorm(0.1, 10.0), aspect="auto")
    for r in payload["summary"]:
        text = "–" if r["winner"] is None else ("explicit" if r["winner"] == "explicit"
                                                 else r["winner"].replace(", ", "\n"))
        left.text(ks.index(r["stiffness"]), sizes.index(r["size"]), text, ha="center",
                  va="center", fontsize=7)
    left.set_xticks(range(len(ks)), [f"{k:g}" for k in ks])
    left.set_yticks(range(len(sizes)), [f"{n}²" for n in sizes])
    left.set_xlabel("stiffness (N/m, bending equal)")
    left.set_ylabel("sheet (vertices)")
    left.set_title(f"cheapest implicit / explicit cost at {payload['threshold']:.0%} error",
                   fontsize=9)
    fig.colorbar(image, ax=left)
    for family in dict.fromkeys(r["family"] for r in payload["rows"] if r["family"] != "reference"):
        points = [(r["cost"], r["error"]) for r in payload["rows"]
                  if r["family"] == family and r["size"] == sizes[-1] and r["cost"]
                  and r["error"] and r["stiffness"] == ks[-1]]
        if points:
            right.plot(*zip(*sorted(points)), "o-", label=family, ms=4)
    right.axhline(payload["threshold"], color="k", lw=0.8, ls="--")
    right.set_xscale("log")
    right.set_yscale("log")
    right.set_xlabel("wall seconds per simulated second")
    right.set_ylabel("error / diagonal at the horizon")
    right.set_title(f"{sizes[-1]}², k = {ks[-1]:g} N/m", fontsize=9)
    right.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
