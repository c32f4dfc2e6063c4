"""What a stroke's rebuild really costs: the paper's reason for explicit integration, measured.

    python -m benchmarks.rebuild_cost [--out bench-results] [--quick]

Grid cloths from 32² to 256² vertices and the rotating cylinder, with the AMD and METIS
orderings: one explicit step; one implicit (linearized backward-Euler) step by phase; the
implicit step right after a stroke, which re-analyses (its analysis time is the rebuild); the
ratios analyze/factorize and analyze/explicit-step; nnz(L), flops and the factorization's
GFlop/s beside numpy's dense matrix-multiply GFlop/s measured in the same run. Medians of
repeated runs (each repeat is a new stroke). Local-global per rebuild strategy and quasi-Newton
(whose stroke rebuilds only the scalar matrix): the extra cost of a stroke in ordinary steps.
Writes rebuild_cost.json and rebuild_cost.png.
"""

from __future__ import annotations

import math
import statistics

import numpy as np

import yore

from .common import arguments, grid_cloth, machine_info, median_seconds, save
from .implicit_step import dense_gflops, phase_deltas


def step(integrator):
    """Implicit: 1/60 s; explicit: the default below its stability limit."""
    return None if integrator == "explicit" else 1.0 / 60.0


def grid_case(n):
    def make(integrator, **options):
        return yore.Simulation(grid_cloth(n), integrator=integrator, dt=step(integrator), **options)

    def stroke(sim, k):
        # a straight stroke across the cloth, a little lower each time
        y = 0.8 - 0.6 * (k + 0.5) / 8
        return sim.stroke([[0.02, y + 0.013, 0.0], [0.98, y - 0.017, 0.0]])

    return make, stroke


def cylinder_case(rings, segments):
    def make(integrator, **options):
        return yore.scenes.rotating_cylinder(
            rings=rings, segments=segments, integrator=integrator, dt=step(integrator), **options
        )

    def stroke(sim, k):
        X = sim.cloth.positions
        y = X[:, 1].min() + (0.15 + 0.08 * k) * np.ptp(X[:, 1])
        r = float(np.median(np.hypot(X[:, 0], X[:, 2])))
        angles = np.linspace(0.0, 2.0 * math.pi, 4 * segments + 1) + 0.013 * k
        return sim.stroke(
            np.column_stack([r * np.cos(angles), np.full_like(angles, y), r * np.sin(angles)])
        )

    return make, stroke


def explicit_seconds(make, target_seconds, repeats):
    sim = make("explicit")
    probe = median_seconds(lambda: sim.step(5, progress=False), repeats=1, warmup=1)
    steps = max(1, int(target_seconds / (probe["median"] / 5)))
    return (
        median_seconds(lambda: sim.step(steps, progress=False), repeats=repeats)["median"] / steps
    )


def dense_supernode_gflops(columns, rows, repeats=5):
    """GFlop/s of numpy's dense kernels on one supernode's shape: the Cholesky of its
    columns × columns block, the solve for the rows × columns block below it and the
    rows × rows update it sends on (flops as each kernel does them: k³/3, 2k³/3 + 2k²m for the
    LU solve, 2km² for the multiply), median of repeats. What a factorization whose flops sit
    in supernodes of this shape can reach at best."""
    k, m = max(1, int(columns)), max(1, int(rows))
    rng = np.random.default_rng(0)
    block = rng.standard_normal((k, k))
    block = block @ block.T + k * np.eye(k)
    below = rng.standard_normal((m, k))

    def kernel():
        factor = np.linalg.cholesky(block)
        panel = np.linalg.solve(factor, below.T).T
        return panel @ panel.T

    timing = median_seconds(kernel, repeats=repeats, warmup=1)
    flops = k**3 / 3 + 2 * k**3 / 3 + 2 * k * k * m + 2 * k * m * m
    return flops / timing["median"] / 1e9


def measure(name, make, stroke, ordering, repeats, explicit):
    sim = make("implicit", linearized=True, ordering=ordering)
    sim.step(1, progress=False)
    steady = [phase_deltas(sim, lambda: sim.step(1, progress=False)) for _ in range(repeats)]
    after_stroke, reports = [], []
    for k in range(repeats):
        reports.append(stroke(sim, k))
        after_stroke.append(phase_deltas(sim, lambda: sim.step(1, progress=False)))
    counters = sim.stats["counters"]

    def median(samples, key):
        return statistics.median(sample[key] for sample in samples)

    row = {
        "case": name,
        "ordering_requested": ordering,
        "ordering_used": counters["ordering"],
        "vertices": sim.cloth.vertex_count,
        "dofs": counters["dofs"],
        "factor_nonzeros": counters["factor_nonzeros"],
        "factor_flops": counters["factor_flops"],
        "explicit_step_seconds": explicit,
        "implicit_step_seconds": median(steady, "wall_seconds"),
        "assemble_seconds": median(steady, "assemble_seconds"),
        "factorize_seconds": median(steady, "factorize_seconds"),
        "solve_seconds": median(steady, "solve_seconds"),
        "analyze_seconds": median(after_stroke, "analyze_seconds"),
        "step_after_stroke_seconds": median(after_stroke, "wall_seconds"),
        "stroke_faces_split": statistics.median(r.faces_split for r in reports),
        "stroke_locate_seconds": statistics.median(r.locate_seconds for r in reports),
        "stroke_subdivide_seconds": statistics.median(r.subdivide_seconds for r in reports),
        "analyses": counters["analyses"],
        "repeats": repeats,
    }
    row["analyze_over_factorize"] = row["analyze_seconds"] / row["factorize_seconds"]
    row["analyze_over_implicit_step"] = row["analyze_seconds"] / row["implicit_step_seconds"]
    row["analyze_over_explicit_step"] = row["analyze_seconds"] / explicit
    row["step_after_stroke_over_step"] = (
        row["step_after_stroke_seconds"] / row["implicit_step_seconds"]
    )
    row["factorize_gflops"] = row["factor_flops"] / row["factorize_seconds"] / 1e9
    row["supernode_median_columns"] = counters["supernode_median_columns"]
    row["supernode_median_rows"] = counters["supernode_median_rows"]
    row["dense_at_supernode_gflops"] = dense_supernode_gflops(
        row["supernode_median_columns"], row["supernode_median_rows"]
    )
    return row


STRATEGIES = ("fresh", "reuse-ordering", "stale-pcg")


def measure_local_global(name, make, stroke, repeats, after_steps=10):
    """Ordinary local-global step, and the extra time a stroke causes over the next steps, per
    rebuild strategy, in ordinary steps."""
    rows = []
    for strategy in STRATEGIES:
        # the configuration these rows have always measured (and the 64² target is set for):
        # 10 plain iterations per step, no convergence test
        sim = make(
            "local-global", rebuild=strategy, iterations=10, acceleration="none", tolerance=0.0
        )
        sim.step(2, progress=False)
        ordinary = statistics.median(
            phase_deltas(sim, lambda: sim.step(1, progress=False))["wall_seconds"]
            for _ in range(repeats)
        )
        extras = []
        for k in range(repeats):
            stroke(sim, k)
            spent = sum(
                phase_deltas(sim, lambda: sim.step(1, progress=False))["wall_seconds"]
                for _ in range(after_steps)
            )
            extras.append(spent - after_steps * ordinary)
        counters = sim.stats["counters"]
        rows.append(
            {
                "case": name,
                "strategy": strategy,
                "ordinary_step_seconds": ordinary,
                "rebuild_extra_seconds": statistics.median(extras),
                "rebuild_in_ordinary_steps": statistics.median(extras) / ordinary,
                "steps_observed_after_stroke": after_steps,
                "stale_solves": counters["stale_solves"],
                "factorizations": counters["factorizations"],
                "dofs": counters["dofs"],
            }
        )
        r = rows[-1]
        print(
            f"{name:16s} local-global {strategy:15s} step {1e3 * ordinary:8.2f} ms, rebuild "
            f"{r['rebuild_in_ordinary_steps']:6.1f} ordinary steps"
        )
    return rows


def measure_quasi_newton(name, make, stroke, repeats):
    """Quasi-Newton at its defaults: an ordinary step, and what a stroke makes it rebuild (the
    scalar matrix's analysis and factorization, the only work a stroke adds), in ordinary
    steps and in iterations."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # steps at the cap are counted below
        sim = make("quasi-newton")
        sim.step(2, progress=False)
        steady = [phase_deltas(sim, lambda: sim.step(1, progress=False)) for _ in range(repeats)]
        iterations_before = sim.stats["counters"]["newton_iterations"]
        steps_before = sim.stats["steps"]
        rebuilds = []
        for k in range(repeats):
            stroke(sim, k)
            after = phase_deltas(sim, lambda: sim.step(1, progress=False))
            rebuilds.append(after["analyze_seconds"] + after["factorize_seconds"])
    counters = sim.stats["counters"]
    ordinary = statistics.median(d["wall_seconds"] for d in steady)
    per_iteration = ordinary / max(
        1.0,
        (counters["newton_iterations"] - iterations_before) / (sim.stats["steps"] - steps_before),
    )
    rebuild = statistics.median(rebuilds)
    row = {
        "case": name,
        "ordinary_step_seconds": ordinary,
        "seconds_per_iteration": per_iteration,
        "rebuild_seconds": rebuild,
        "rebuild_in_ordinary_steps": rebuild / ordinary,
        "rebuild_in_iterations": rebuild / per_iteration,
        "iterations_per_step": counters["newton_iterations"] / sim.stats["steps"],
        "unconverged_steps": counters["unconverged_steps"],
        "steps": sim.stats["steps"],
        "analyses": counters["analyses"],
        "factorizations": counters["factorizations"],
        "factor_nonzeros": counters["factor_nonzeros"],
        "dofs": counters["dofs"],
    }
    print(
        f"{name:16s} quasi-newton step {1e3 * ordinary:8.2f} ms "
        f"({row['iterations_per_step']:.0f} it, {1e3 * per_iteration:.3f} ms/it), rebuild "
        f"{1e3 * rebuild:.2f} ms = {row['rebuild_in_ordinary_steps']:.3f} ordinary steps"
    )
    return row


def main(argv=None):
    args = arguments(__doc__, argv)
    repeats = 3 if args.quick else 5
    cases = [
        (f"grid {n}²", *grid_case(n)) for n in ((16, 32) if args.quick else (32, 64, 128, 256))
    ] + [
        (
            "cylinder 32×32" if args.quick else "cylinder 64×64",
            *cylinder_case(*((32, 32) if args.quick else (64, 64))),
        )
    ]
    dense = dense_gflops(size=500 if args.quick else 2000)
    rows = []
    for name, make, stroke in cases:
        explicit = explicit_seconds(make, 0.02 if args.quick else 0.2, repeats)
        for ordering in ("amd", "metis"):
            row = measure(name, make, stroke, ordering, repeats, explicit)
            row["dense_gflops"] = dense
            row["factorize_fraction_of_dense"] = row["factorize_gflops"] / dense
            row["dense_at_supernode_fraction_of_dense"] = row["dense_at_supernode_gflops"] / dense
            rows.append(row)
            print(
                f"{name:16s} {ordering:6s} dofs {row['dofs']:7d} explicit "
                f"{1e3 * explicit:8.3f} ms  implicit {1e3 * row['implicit_step_seconds']:9.2f} ms"
                f"  analyze {1e3 * row['analyze_seconds']:8.2f} ms  after stroke "
                f"{1e3 * row['step_after_stroke_seconds']:9.2f} ms  analyze/factorize "
                f"{row['analyze_over_factorize']:.2f}  analyze/explicit "
                f"{row['analyze_over_explicit_step']:.0f}  {row['factorize_gflops']:.1f} GF/s"
            )
    local_global = []
    for name, make, stroke in cases:
        local_global += measure_local_global(name, make, stroke, repeats)
    quasi_newton = [
        measure_quasi_newton(name, make, stroke, repeats) for name, make, stroke in cases
    ]
    payload = {
        "benchmark": "rebuild_cost",
        "machine": machine_info(),
        "quick": args.quick,
        "dense_matmul_gflops": dense,
        "rows": rows,
        "local_global": local_global,
        "quasi_newton": quasi_newton,
        "targets": {
            "analyze_over_implicit_step_at_most": 1.0,
            "local_global_rebuild_in_steps_at_most_128": 10.0,
            "local_global_step_seconds_at_most_64": 0.005,
        },
    }
    save(args.out, "rebuild_cost", payload, lambda path: plot(rows, path))
    print(f"dense matmul (numpy, same run): {dense:.1f} GFlop/s")
    return payload


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ordering, marker in (("amd", "o"), ("metis", "s")):
        sel = [r for r in rows if r["ordering_requested"] == ordering]
        labels = [r["case"] for r in sel]
        x = np.arange(len(sel))
        axes[0].semilogy(
            x,
            [r["analyze_over_explicit_step"] for r in sel],
            marker=marker,
            label=f"analysis / explicit step ({ordering})",
        )
        axes[0].semilogy(
            x,
            [r["analyze_over_implicit_step"] for r in sel],
            marker=marker,
            linestyle="--",
            label=f"analysis / implicit step ({ordering})",
        )
        axes[0].set_xticks(x, labels, rotation=20, fontsize=8)
        axes[1].plot(
            x, [r["step_after_stroke_over_step"] for r in sel], marker=marker, label=f"{ordering}"
        )
        axes[1].set_xticks(x, labels, rotation=20, fontsize=8)
    axes[0].axhline(1.0, color="k", linewidth=0.8)
    axes[0].set_title("the rebuild (symbolic analysis) after a stroke")
    axes[0].set_ylabel("ratio")
    axes[0].legend(fontsize=7)
    axes[0].grid(True, which="both", alpha=0.3)
    axes[1].set_title("implicit step right after a stroke / ordinary implicit step")
    axes[1].legend(fontsize=7)
    axes[1].grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
