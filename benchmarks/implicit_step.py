"""What an implicit step costs, phase by phase, against an explicit step and a symbolic analysis.

    python -m benchmarks.implicit_step [--out bench-results] [--quick] [--sizes 32 64 ...]

For grid cloths of n × n vertices (structural + bending springs) and the AMD and METIS orderings:
one explicit step; one linearized implicit step split into assemble / factorize / solve; one
symbolic analysis (after a change of topology); nnz(L) and the factorization's flops and
GFlop/s beside the dense matrix-multiply GFlop/s of numpy measured in the same run; one Newton
iteration against one quasi-Newton iteration at the defaults. Medians of repeated runs; writes
implicit_step.json and implicit_step.png.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

import yore

from .common import arguments, explicit_step_seconds, grid_cloth, machine_info, median_seconds, save

PHASES = ("assemble_seconds", "analyze_seconds", "factorize_seconds", "solve_seconds")


def dense_gflops(size: int = 2000, repeats: int = 3) -> float:
    """GFlop/s of numpy's dense matrix multiply (2 n³ flops), median of repeats."""
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((size, size)), rng.standard_normal((size, size))
    timing = median_seconds(lambda: a @ b, repeats=repeats)
    return 2.0 * size**3 / timing["median"] / 1e9


def phase_deltas(sim, action) -> dict:
    """Wall time per phase spent by action(), and its total wall time."""
    before = sim.stats["phases"]
    start = time.perf_counter()
    action()
    wall = time.perf_counter() - start
    after = sim.stats["phases"]
    deltas = {phase: after[phase] - before[phase] for phase in PHASES}
    deltas["wall_seconds"] = wall
    return deltas


def measure_implicit(n: int, ordering: str, repeats: int) -> dict:
    cloth = grid_cloth(n)
    sim = yore.Simulation(
        cloth, integrator="implicit", linearized=True, ordering=ordering, dt=1.0 / 60.0
    )
    sim.step(1, progress=False)  # warm-up: first analysis and factorization
    steady = [phase_deltas(sim, lambda: sim.step(1, progress=False)) for _ in range(repeats)]
    # A change of topology (one more fixed vertex) before each step: that step re-analyses.
    interior = [n * (n // 2) + n // 2 + k for k in range(repeats)]
    after_change = []
    for vertex in interior:
        cloth.fix([vertex])
        after_change.append(phase_deltas(sim, lambda: sim.step(1, progress=False)))
    counters = sim.stats["counters"]
    median = {key: statistics.median(sample[key] for sample in steady) for key in steady[0]}
    analysis = statistics.median(sample["analyze_seconds"] for sample in after_change)
    return {
        "grid": n,
        "vertices": n * n,
        "dofs": counters["dofs"],
        "ordering_requested": ordering,
        "ordering_used": counters["ordering"],
        "factor_nonzeros": counters["factor_nonzeros"],
        "factor_flops": counters["factor_flops"],
        "step_seconds": median["wall_seconds"],
        "assemble_seconds": median["assemble_seconds"],
        "factorize_seconds": median["factorize_seconds"],
        "solve_seconds": median["solve_seconds"],
        "analyze_seconds": analysis,
        "step_after_topology_change_seconds": statistics.median(
            sample["wall_seconds"] for sample in after_change
        ),
        "analyses": counters["analyses"],
        "repeats": repeats,
    }


def plot(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ordering, marker in (("amd", "o"), ("metis", "s")):
        sel = [r for r in rows if r["ordering_requested"] == ordering]
        if not sel:
            continue
        dofs = [r["dofs"] for r in sel]
        for key, label in (
            ("factorize_seconds", "factorize"),
            ("analyze_seconds", "analyze"),
            ("assemble_seconds", "assemble"),
            ("solve_seconds", "solve"),
        ):
            axes[0].loglog(
                dofs,
                [1e3 * r[key] for r in sel],
                marker=marker,
                linestyle="-",
                label=f"{label} ({ordering})",
            )
    sel = [r for r in rows if r["ordering_requested"] == "amd"]
    axes[0].loglog(
        [r["dofs"] for r in sel],
        [1e3 * r["explicit_step_seconds"] for r in sel],
        "k--",
        label="explicit step",
    )
    axes[0].set_xlabel("unknowns (3 per free vertex)")
    axes[0].set_ylabel("ms (median)")
    axes[0].set_title("implicit step phases vs explicit step")
    axes[0].grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    for ordering, marker in (("amd", "o"), ("metis", "s")):
        sel = [r for r in rows if r["ordering_requested"] == ordering]
        axes[1].semilogx(
            [r["dofs"] for r in sel],
            [r["factorize_gflops"] for r in sel],
            marker=marker,
            label=f"factorization ({ordering})",
        )
    if rows:
        axes[1].axhline(
            rows[0]["dense_gflops"], color="k", linestyle="--", label="numpy dense matmul"
        )
        axes[1].axhline(
            0.3 * rows[0]["dense_gflops"], color="gray", linestyle=":", label="30 % of dense"
        )
    axes[1].set_xlabel("unknowns")
    axes[1].set_ylabel("GFlop/s")
    axes[1].set_title("CHOLMOD factorization rate")
    axes[1].grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def iteration_seconds(n: int, integrator: str, repeats: int) -> dict:
    """Wall time of one iteration of a minimiser at its defaults (Newton: assemble the Hessian,
    factorize, solve, line search; quasi-Newton: gradient, two-loop recursion with one scalar
    solve of three right-hand sides, line search) on the hanging grid, median over repeated
    steps of 8 iterations each (tolerance out of reach, so every step takes exactly 8)."""
    import warnings

    # (Newton's truncation test off: it would end a step before its 8 iterations)
    stop = {"truncation_fraction": 0.0} if integrator in ("implicit", "bdf2") else {}
    sim = yore.Simulation(
        grid_cloth(n), integrator=integrator, dt=1.0 / 60.0, newton_tol=1e-300, max_newton=8, **stop
    )
    samples = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # every step is at its cap on purpose
        sim.step(1, progress=False)  # analysis and first factorization
        for _ in range(repeats):
            before = sim.stats["counters"]["newton_iterations"]
            start = time.perf_counter()
            sim.step(1, progress=False)
            samples.append(
                (time.perf_counter() - start)
                / (sim.stats["counters"]["newton_iterations"] - before)
            )
    return {
        "median": statistics.median(samples),
        "min": min(samples),
        "max": max(samples),
        "repeats": repeats,
    }


def main(argv=None) -> dict:
    def extra(parser):
        parser.add_argument("--sizes", type=int, nargs="*", help="grid sizes (vertices per side)")

    args = arguments(__doc__, argv, extra)
    sizes = args.sizes or ([16, 32] if args.quick else [32, 64, 128, 256])
    repeats = 3 if args.quick else 5
    dense = dense_gflops(size=500 if args.quick else 2000)
    rows = []
    for n in sizes:
        explicit = explicit_step_seconds(n, 0.02 if args.quick else 0.2, repeats)["median"]
        for ordering in ("amd", "metis"):
            row = measure_implicit(n, ordering, repeats)
            row["explicit_step_seconds"] = explicit
            row["factorize_gflops"] = row["factor_flops"] / row["factorize_seconds"] / 1e9
            row["dense_gflops"] = dense
            row["factorize_fraction_of_dense"] = row["factorize_gflops"] / dense
            row["analyze_over_factorize"] = row["analyze_seconds"] / row["factorize_seconds"]
            row["analyze_over_explicit_step"] = row["analyze_seconds"] / explicit
            row["step_over_factorize"] = row["step_seconds"] / row["factorize_seconds"]
            rows.append(row)
    iterations = []
    for n in sizes:
        newton = iteration_seconds(n, "implicit", repeats)
        quasi = iteration_seconds(n, "quasi-newton", repeats)
        iterations.append(
            {
                "grid": n,
                "newton_iteration_seconds": newton["median"],
                "quasi_newton_iteration_seconds": quasi["median"],
                "quasi_over_newton": quasi["median"] / newton["median"],
                "repeats": repeats,
            }
        )
        print(
            f"{n:>4}² one Newton iteration {1e3 * newton['median']:.2f} ms, one quasi-Newton "
            f"iteration {1e3 * quasi['median']:.3f} ms: ratio "
            f"{iterations[-1]['quasi_over_newton']:.3f}"
        )
    payload = {
        "benchmark": "implicit_step",
        "machine": machine_info(),
        "quick": args.quick,
        "dense_matmul_gflops": dense,
        "rows": rows,
        "iterations": iterations,
        "targets": {
            "step_over_factorize_at_most": 1.5,
            "factorize_fraction_of_dense_at_least": 0.3,
            "analyze_over_factorize_at_most": 1.0,
            "quasi_over_newton_iteration_at_64_at_most": 0.1,
        },
    }
    save(args.out, "implicit_step", payload, lambda path: plot(rows, path))
    header = (
        f"{'grid':>5} {'order':>6} {'dofs':>7} {'nnz(L)':>9} {'expl ms':>8} {'asm ms':>7} "
        f"{'fact ms':>8} {'solve ms':>8} {'anal ms':>8} {'step/fact':>9} {'anal/fact':>9} "
        f"{'anal/expl':>9} {'GF/s':>6} {'%dense':>6}"
    )
    print(header)
    for r in rows:
        print(
            f"{r['grid']:>4}² {r['ordering_used']:>6} {r['dofs']:>7} {r['factor_nonzeros']:>9.3g} "
            f"{1e3 * r['explicit_step_seconds']:>8.3f} {1e3 * r['assemble_seconds']:>7.2f} "
            f"{1e3 * r['factorize_seconds']:>8.2f} {1e3 * r['solve_seconds']:>8.2f} "
            f"{1e3 * r['analyze_seconds']:>8.2f} {r['step_over_factorize']:>9.2f} "
            f"{r['analyze_over_factorize']:>9.2f} {r['analyze_over_explicit_step']:>9.1f} "
            f"{r['factorize_gflops']:>6.2f} {100 * r['factorize_fraction_of_dense']:>5.0f}%"
        )
    print(
        f"dense matmul (numpy, same run): {dense:.1f} GFlop/s; BLAS loaded: "
        f"{payload['machine']['blas_loaded']}"
    )
    return payload


if __name__ == "__main__":
    main()
