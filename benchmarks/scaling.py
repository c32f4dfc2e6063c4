"""Scaling: cost of a step against the number of vertices, explicit and implicit, log-log with
fitted slopes.

    python -m benchmarks.scaling [--out bench-results] [--quick]

Grid cloths of n × n vertices (benchmarks.common.grid_cloth). Explicit: median of batches of
steps. Implicit: one linearized backward-Euler step (one factorization) and one Newton step
(median over steps of a falling cloth), both with CHOLMOD (AMD). Slopes are least-squares fits
of log(cost) against log(vertices) over the sizes measured. Writes scaling.json, scaling.png.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

import yore

from .common import arguments, explicit_step_seconds, grid_cloth, machine_info, save


def implicit_step_seconds(n, repeats, **options):
    sim = yore.Simulation(grid_cloth(n), integrator="implicit", dt=1 / 60, **options)
    sim.step(1, progress=False)  # analysis and warm-up
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        sim.step(1, progress=False)
        samples.append(time.perf_counter() - start)
    stats = sim.stats
    return statistics.median(samples), stats["counters"]["newton_iterations"] / stats["steps"]


def slope(vertices, seconds):
    return float(np.polyfit(np.log(vertices), np.log(seconds), 1)[0])


def main(argv=None):
    args = arguments(__doc__, argv)
    sizes = [8, 16, 32] if args.quick else [16, 32, 64, 128, 256]
    repeats = 3 if args.quick else 5
    rows = []
    for n in sizes:
        explicit = explicit_step_seconds(n, 0.02 if args.quick else 0.2, repeats)["median"]
        linearized, _ = implicit_step_seconds(n, repeats, linearized=True)
        newton_sizes_limit = 64 if args.quick else 128  # Newton at 256² takes minutes per step
        newton, iterations = (
            implicit_step_seconds(n, repeats) if n <= newton_sizes_limit else (None, None)
        )
        rows.append(
            {
                "grid": n,
                "vertices": n * n,
                "explicit_step_seconds": explicit,
                "implicit_linearized_step_seconds": linearized,
                "implicit_newton_step_seconds": newton,
                "newton_iterations_per_step": iterations,
            }
        )
        print(
            f"{n:>4}² explicit {1e3 * explicit:9.3f} ms  linearized {1e3 * linearized:9.2f} ms"
            + (f"  Newton {1e3 * newton:9.2f} ms ({iterations:.1f} it)" if newton else "")
        )
    vertices = [r["vertices"] for r in rows]
    slopes = {
        "explicit": slope(vertices, [r["explicit_step_seconds"] for r in rows]),
        "implicit_linearized": slope(
            vertices, [r["implicit_linearized_step_seconds"] for r in rows]
        ),
    }
    newton_rows = [r for r in rows if r["implicit_newton_step_seconds"]]
    if len(newton_rows) >= 2:
        slopes["implicit_newton"] = slope(
            [r["vertices"] for r in newton_rows],
            [r["implicit_newton_step_seconds"] for r in newton_rows],
        )
    payload = {
        "benchmark": "scaling",
        "machine": machine_info(),
        "quick": args.quick,
        "rows": rows,
        "slopes": slopes,
    }
    save(args.out, "scaling", payload, lambda path: plot(rows, slopes, path))
    print("fitted slopes (cost ∝ vertices^slope):", {k: round(v, 2) for k, v in slopes.items()})
    return payload


def plot(rows, slopes, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.2))
    for key, label, name in (
        ("explicit_step_seconds", "explicit step", "explicit"),
        ("implicit_linearized_step_seconds", "implicit, linearized", "implicit_linearized"),
        ("implicit_newton_step_seconds", "implicit, Newton", "implicit_newton"),
    ):
        sel = [r for r in rows if r[key]]
        if sel and name in slopes:
            ax.loglog(
                [r["vertices"] for r in sel],
                [1e3 * r[key] for r in sel],
                "o-",
                label=f"{label} (slope {slopes[name]:.2f})",
            )
    ax.set_xlabel("vertices")
    ax.set_ylabel("ms per step (median)")
    ax.set_title("yore: step cost against size")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
