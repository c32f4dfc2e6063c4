"""CHOLMOD's factorization against the dense rate of the same BLAS, orderings, supernodes,
threads, and the BLAS kernels.

    python -m benchmarks.factorization [--out bench-results] [--quick] [--sizes 32 64 128 256]

Part 1, in this process (the kernels yore chose, one thread): DGEMM of the ``libblas.so.3`` that
CHOLMOD calls (through ctypes: the same library, kernels and thread setting), then for each
grid cloth and each ordering (AMD, METIS, CHOLMOD's nested dissection) and supernode relaxation
(0, 1 = CHOLMOD's, 3): the symbolic analysis, the numeric factorization (medians of repeats;
a linearized implicit step split by phase), nnz(L), flops, GFlop/s and that rate over DGEMM's;
then the default ordering with two BLAS threads, beside DGEMM with two.

Part 2, one fresh process per OpenBLAS kernel the CPU runs (``OPENBLAS_CORETYPE`` = SkylakeX,
Haswell, Sandybridge, Prescott: the last is what Debian's OpenBLAS 0.3.21 picks on an Emerald
Rapids Xeon): DGEMM, and the CPU time of one Newton iteration over one explicit step (the same
process, one thread), with the old default ordering (AMD) and the new one (auto). With
``--baseline PATH``, every kernel again on another build of yore (a folder holding its installed
package, e.g. a copy made before a change to the factorization): this build's default over that
build's Prescott and AMD, and this build over that one kernel by kernel, each a Newton iteration
in explicit steps of its own process.

Writes factorization.json and factorization.png.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import math
import statistics
import time
from pathlib import Path

import numpy as np

import yore

from .common import arguments, fresh_process, grid_cloth, machine_info, save
from .implicit_step import phase_deltas

ORDERINGS = ("amd", "metis", "nesdis")
RELAXATIONS = (0.0, 1.0, 3.0)
KERNELS = ("SkylakeX", "Haswell", "Sandybridge", "Prescott")


def blas_dgemm_gflops(size: int, repeats: int) -> float:
    """GFlop/s (2 n³ flops, median of repeats) of the DGEMM in the libblas.so.3 CHOLMOD calls."""
    library = ctypes.CDLL("libblas.so.3")
    rng = np.random.default_rng(0)
    a, b = (np.asfortranarray(rng.standard_normal((size, size))) for _ in range(2))
    c = np.zeros((size, size), order="F")
    n, one, zero, plain = (
        ctypes.c_int(size),
        ctypes.c_double(1.0),
        ctypes.c_double(0.0),
        ctypes.c_char(b"N"),
    )

    def pointer(array):
        return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))

    def multiply():
        library.dgemm_(
            ctypes.byref(plain),
            ctypes.byref(plain),
            ctypes.byref(n),
            ctypes.byref(n),
            ctypes.byref(n),
            ctypes.byref(one),
            pointer(a),
            ctypes.byref(n),
            pointer(b),
            ctypes.byref(n),
            ctypes.byref(zero),
            pointer(c),
            ctypes.byref(n),
        )

    multiply()  # warm-up (and OpenBLAS's buffers)
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        multiply()
        samples.append(time.perf_counter() - start)
    if not np.allclose(c[:8, :8], a[:8] @ b[:, :8]):
        raise RuntimeError("the BLAS's DGEMM disagrees with numpy's product")
    return 2.0 * size**3 / statistics.median(samples) / 1e9


def measure_factorization(n: int, ordering: str, relaxation: float, repeats: int) -> dict:
    """Analysis and numeric factorization of the linearized implicit step's matrix on the
    benchmarks' n × n grid cloth (medians)."""
    cloth = grid_cloth(n)
    sim = yore.Simulation(
        cloth,
        integrator="implicit",
        linearized=True,
        ordering=ordering,
        supernode_relaxation=relaxation,
        dt=1.0 / 60.0,
    )
    sim.step(1, progress=False)
    steady = [phase_deltas(sim, lambda: sim.step(1, progress=False)) for _ in range(repeats)]
    counters = sim.stats["counters"]  # of the analysis the steady factorizations used
    analyses = []
    for k in range(max(2, repeats // 2)):
        cloth.fix([n * (n // 2) + n // 2 + k])  # a change of topology: the next step re-analyses
        analyses.append(phase_deltas(sim, lambda: sim.step(1, progress=False))["analyze_seconds"])
    factorize = statistics.median(s["factorize_seconds"] for s in steady)
    return {
        "grid": n,
        "dofs": counters["dofs"],
        "ordering_requested": ordering,
        "ordering_used": counters["ordering"],
        "supernode_relaxation": relaxation,
        "factor_nonzeros": counters["factor_nonzeros"],
        "factor_flops": counters["factor_flops"],
        "factorize_seconds": factorize,
        "analyze_seconds": statistics.median(analyses),
        "factorize_gflops": counters["factor_flops"] / factorize / 1e9,
        "repeats": repeats,
    }


def cpu_per_newton_iteration(n: int, ordering: str, repeats: int) -> float:
    """Process CPU seconds of one Newton iteration (steps of 8 capped iterations: assemble,
    factorize, solve, line search) on the grid cloth, median over steps."""
    import warnings

    sim = yore.Simulation(
        grid_cloth(n),
        integrator="implicit",
        dt=1.0 / 64.0,
        ordering=ordering,
        newton_tol=1e-300,
        max_newton=8,
        truncation_fraction=0.0,
    )
    samples = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # every step is at its cap on purpose
        sim.step(1, progress=False)
        for _ in range(repeats):
            before = sim.stats["counters"]["newton_iterations"]
            start = time.process_time()
            sim.step(1, progress=False)
            samples.append(
                (time.process_time() - start)
                / (sim.stats["counters"]["newton_iterations"] - before)
            )
    return statistics.median(samples)


def cpu_per_explicit_step(n: int, repeats: int) -> float:
    """Process CPU seconds of one explicit step on the same cloth, median of batches."""
    sim = yore.Simulation(grid_cloth(n))
    sim.step(20, progress=False)
    start = time.process_time()
    sim.step(20, progress=False)
    batch = max(20, int(0.2 / max(time.process_time() - start, 1e-6) * 20))
    samples = []
    for _ in range(repeats):
        start = time.process_time()
        sim.step(batch, progress=False)
        samples.append((time.process_time() - start) / batch)
    return statistics.median(samples)


def kernel_worker(sizes, repeats) -> dict:
    """Part 2's child: this process's kernels, DGEMM, and Newton iteration over explicit step."""
    yore.set_num_threads(1)
    info = yore.blas.report()
    out = {
        "kernel": info["kernel"],
        "chosen_by": info["chosen_by"],
        "dgemm_gflops": blas_dgemm_gflops(1200, repeats),
        "rows": [],
    }
    for n in sizes:
        explicit = cpu_per_explicit_step(n, repeats)
        for ordering in ("amd", "auto"):
            iteration = cpu_per_newton_iteration(n, ordering, repeats)
            out["rows"].append(
                {
                    "grid": n,
                    "ordering": ordering,
                    "explicit_cpu_seconds": explicit,
                    "newton_iteration_cpu_seconds": iteration,
                    "iteration_over_explicit": iteration / explicit,
                }
            )
    return out


def kernel_process(kernel, sizes, quick, package_path=None) -> dict:
    """One kernel worker in a fresh process on that OpenBLAS kernel; with package_path, the
    yore installed there (another build) instead of this one."""
    args = ["--kernel-worker", "--sizes", *sizes] + (["--quick"] if quick else [])
    return fresh_process(
        "benchmarks.factorization", args, {"OPENBLAS_CORETYPE": kernel}, package_path
    )


def merge_rounds(runs) -> dict:
    """One kernel's runs (fresh processes) as one: medians of DGEMM and of each row's times and
    ratio; the runs themselves under "rounds"."""
    first = runs[0]
    rows = []
    for k, row in enumerate(first["rows"]):
        samples = [run["rows"][k] for run in runs]
        rows.append(
            row
            | {
                key: statistics.median(sample[key] for sample in samples)
                for key in (
                    "explicit_cpu_seconds",
                    "newton_iteration_cpu_seconds",
                    "iteration_over_explicit",
                )
            }
        )
    return {
        "kernel": first["kernel"],
        "chosen_by": first["chosen_by"],
        "dgemm_gflops": statistics.median(run["dgemm_gflops"] for run in runs),
        "rows": rows,
        "rounds": runs,
    }


def run_kernels(sizes, quick, rounds=1, baseline=None) -> tuple:
    """Part 2: one fresh process per kernel the CPU runs, `rounds` times (the kernels forward,
    then backward, ...), each followed by the same kernel on the baseline build (a folder
    holding its package) when given: the two builds meet the same conditions. Returns this
    build's runs and the baseline's (None without one), medians over the rounds."""
    from yore import _cpu

    extensions = set(_cpu.cpu_features().extensions)
    kernels = [k for k in KERNELS if yore.blas.KERNEL_NEEDS[k.lower()] <= extensions]
    raw = {k: [] for k in kernels}
    raw_baseline = {k: [] for k in kernels}
    for round_number in range(rounds):
        for kernel in kernels if round_number % 2 == 0 else kernels[::-1]:
            builds = [(raw, None), (raw_baseline, baseline)] if baseline else [(raw, None)]
            if round_number % 2 == 1:
                builds.reverse()
            for store, path in builds:
                run = kernel_process(kernel, sizes, quick, path)
                store[kernel].append(run)
                print(
                    f"{kernel:>12}{' (baseline)' if path else ''}: DGEMM "
                    f"{run['dgemm_gflops']:.1f} GFlop/s; "
                    + ", ".join(
                        f"{r['grid']}² {r['ordering']} iteration/explicit "
                        f"{r['iteration_over_explicit']:.0f}"
                        for r in run["rows"]
                    ),
                    flush=True,
                )
    runs = [merge_rounds(raw[k]) for k in kernels]
    baseline_runs = [merge_rounds(raw_baseline[k]) for k in kernels] if baseline else None
    return runs, baseline_runs


def kernel_summary(runs) -> list:
    """Per grid: the new default (widest kernel, auto ordering) over the old one on Debian's
    0.3.21 on the issue's Xeon (Prescott, AMD), each as a Newton iteration over an explicit
    step measured in its own process."""
    by_kernel = {run["kernel"]: run for run in runs}
    if "Prescott" not in by_kernel or len(runs) < 2:
        return []
    best = runs[0]
    out = []
    for old in by_kernel["Prescott"]["rows"]:
        if old["ordering"] != "amd":
            continue
        new = next(r for r in best["rows"] if r["grid"] == old["grid"] and r["ordering"] == "auto")
        out.append(
            {
                "grid": old["grid"],
                "new_kernel": best["kernel"],
                "new_over_old": new["iteration_over_explicit"] / old["iteration_over_explicit"],
            }
        )
    return out


def baseline_summary(runs, baseline) -> list:
    """Per grid: this build's default (widest kernel, auto ordering) over another build's
    Prescott and AMD (the issue's default), and this build over that one on each kernel with
    the automatic ordering; each a Newton iteration over an explicit step of its own process."""
    if not runs or not baseline:
        return []
    by_kernel = {run["kernel"]: run for run in baseline["kernels"]}
    out = []
    for new in runs[0]["rows"]:
        if new["ordering"] != "auto":
            continue
        row = {"grid": new["grid"], "new_kernel": runs[0]["kernel"]}
        prescott = by_kernel.get("Prescott")
        if prescott is not None:
            old = next(
                r for r in prescott["rows"] if r["grid"] == new["grid"] and r["ordering"] == "amd"
            )
            row["new_over_baseline"] = (
                new["iteration_over_explicit"] / old["iteration_over_explicit"]
            )
        row["same_kernel"] = {}
        for run in runs:
            this = next(
                r for r in run["rows"] if r["grid"] == new["grid"] and r["ordering"] == "auto"
            )
            that = next(
                r
                for r in by_kernel[run["kernel"]]["rows"]
                if r["grid"] == new["grid"] and r["ordering"] == "auto"
            )
            row["same_kernel"][run["kernel"]] = (
                this["iteration_over_explicit"] / that["iteration_over_explicit"]
            )
        out.append(row)
    return out


def plot(payload, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, dense = payload["rows"], payload["dgemm_gflops"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.3))
    for ordering, marker in zip(ORDERINGS, "osd"):
        chosen = [
            r
            for r in rows
            if r["ordering_requested"] == ordering
            and r["supernode_relaxation"] == 1.0
            and r["blas_threads"] == 1
        ]
        grids = [r["grid"] for r in chosen]
        axes[0].plot(grids, [r["factorize_gflops"] for r in chosen], marker=marker, label=ordering)
        axes[1].loglog(
            grids,
            [1e3 * r["factorize_seconds"] for r in chosen],
            marker=marker,
            label=f"factorize ({ordering})",
        )
        axes[1].loglog(
            grids,
            [1e3 * r["analyze_seconds"] for r in chosen],
            marker=marker,
            linestyle=":",
            label=f"analyze ({ordering})",
        )
    axes[0].axhline(dense, color="k", linestyle="--", label="DGEMM (same BLAS)")
    axes[0].axhline(0.4 * dense, color="gray", linestyle=":", label="40 % of DGEMM")
    axes[0].set(
        xlabel="grid (vertices per side)",
        ylabel="GFlop/s",
        xscale="log",
        title=f"factorization rate ({payload['machine']['yore']['blas_kernel']} kernels)",
    )
    axes[1].set(
        xlabel="grid (vertices per side)", ylabel="ms (median)", title="factorization and analysis"
    )
    for ax in axes[:2]:
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    kernels = payload["kernels"]
    if kernels:
        names = [k["kernel"] for k in kernels]
        axes[2].bar(names, [k["dgemm_gflops"] for k in kernels], color="tab:blue")
        axes[2].set_ylabel("DGEMM GFlop/s (n = 1200, one thread)")
        axes[2].set_title("OpenBLAS kernels on this CPU")
        for x, k in enumerate(kernels):
            ratios = [r for r in k["rows"] if r["ordering"] == "auto"]
            axes[2].annotate(
                "\n".join(
                    f"{r['grid']}²: iteration = {r['iteration_over_explicit']:.0f} explicit steps"
                    for r in ratios
                ),
                (x, k["dgemm_gflops"]),
                ha="center",
                va="bottom",
                fontsize=7,
            )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def factorization_rows(sizes, repeats, dense_by_threads) -> list:
    """Part 1's rows: every ordering and relaxation on one thread, the default on two (unless
    dense_by_threads has no two-thread rate)."""
    rows = []
    for n in sizes:
        for ordering in ORDERINGS:
            for relaxation in RELAXATIONS if ordering != "metis" else (1.0,):
                rows.append(
                    measure_factorization(n, ordering, relaxation, repeats) | {"blas_threads": 1}
                )
        if 2 not in dense_by_threads:
            continue
        yore.set_num_threads(2)
        try:
            rows.append(measure_factorization(n, "auto", 1.0, repeats) | {"blas_threads": 2})
        finally:
            yore.set_num_threads(1)
    for row in rows:
        dense = dense_by_threads[row["blas_threads"]]
        row["dgemm_gflops"] = dense
        row["factorize_fraction_of_dgemm"] = row["factorize_gflops"] / dense
    return rows


def main(argv=None) -> dict:
    def extra(parser):
        parser.add_argument("--sizes", type=int, nargs="*", help="grid sizes (vertices per side)")
        parser.add_argument("--kernel-worker", action="store_true", help=argparse.SUPPRESS)
        parser.add_argument(
            "--no-kernels",
            action="store_true",
            help="leave out part 2 (the kernels, in fresh processes)",
        )
        parser.add_argument(
            "--baseline",
            metavar="PATH",
            help="part 2 also runs Prescott and AMD on the yore installed in PATH (a folder "
            "holding another build's package): this build's default over that one",
        )
        parser.add_argument(
            "--kernel-rounds",
            type=int,
            default=1,
            help="part 2's processes per kernel (and build), alternating in order; medians",
        )
        parser.add_argument(
            "--one-thread",
            action="store_true",
            help="leave out the two-thread rows (for a run that has one core to itself while "
            "the other is busy)",
        )
        parser.add_argument(
            "--baseline-label", default="", help="what the --baseline build is (for the report)"
        )

    args = arguments(__doc__, argv, extra)
    sizes = args.sizes or ([12, 16] if args.quick else [32, 64, 128, 256])
    repeats = 3 if args.quick else 5
    if args.kernel_worker:
        print(json.dumps(kernel_worker([n for n in sizes if n <= 128], repeats)))
        return {}
    yore.set_num_threads(1)
    dense = {1: blas_dgemm_gflops(300 if args.quick else 2000, repeats)}
    if not args.one_thread:
        yore.set_num_threads(2)
        dense[2] = blas_dgemm_gflops(300 if args.quick else 2000, repeats)
        yore.set_num_threads(1)
    rows = factorization_rows(sizes, repeats, dense)
    kernel_sizes = [n for n in sizes if n in (64, 128)] or sizes[:1]
    kernels, baseline_runs = (
        ([], None)
        if args.no_kernels
        else run_kernels(kernel_sizes, args.quick, args.kernel_rounds, args.baseline)
    )
    baseline = (
        {"label": args.baseline_label or str(args.baseline), "kernels": baseline_runs}
        if baseline_runs
        else None
    )
    payload = {
        "benchmark": "factorization",
        "machine": machine_info(),
        "quick": args.quick,
        "dgemm_gflops": dense[1],
        "dgemm_gflops_two_threads": dense.get(2),
        "rows": rows,
        "kernels": kernels,
        "kernel_summary": kernel_summary(kernels),
        "baseline": baseline,
        "baseline_summary": baseline_summary(kernels, baseline),
        "targets": {
            "factorize_fraction_of_dgemm_at_least": 0.4,
            "at_grids": [128, 256],
            "newton_iteration_new_over_old_at_most": {"64": 0.5, "128": 0.4},
        },
    }
    save(args.out, "factorization", payload, lambda path: plot(payload, path))
    print(
        f"DGEMM of the BLAS CHOLMOD calls ({payload['machine']['yore']['blas_kernel']}): "
        f"{dense[1]:.1f} GFlop/s, two threads " + (f"{dense[2]:.1f}" if 2 in dense else "not run")
    )
    print(
        f"{'grid':>5} {'order':>7} {'relax':>5} {'thr':>3} {'nnz(L)':>9} {'GFlop':>7} "
        f"{'anal ms':>8} {'fact ms':>8} {'GF/s':>6} {'%DGEMM':>6}"
    )
    for r in rows:
        print(
            f"{r['grid']:>4}² {r['ordering_used']:>7} {r['supernode_relaxation']:>5.0f} "
            f"{r['blas_threads']:>3} {r['factor_nonzeros']:>9.3g} {r['factor_flops'] / 1e9:>7.3f} "
            f"{1e3 * r['analyze_seconds']:>8.1f} {1e3 * r['factorize_seconds']:>8.1f} "
            f"{r['factorize_gflops']:>6.1f} {100 * r['factorize_fraction_of_dgemm']:>5.0f}%"
        )
    for s in payload["kernel_summary"]:
        print(
            f"{s['grid']}²: a Newton iteration (in explicit steps), {s['new_kernel']} + auto "
            f"over Prescott + AMD: {s['new_over_old']:.2f}"
        )
    for s in payload["baseline_summary"]:
        print(
            f"{s['grid']}²: a Newton iteration (in explicit steps), {s['new_kernel']} + auto "
            f"over Prescott + AMD of {baseline['label']}: {s.get('new_over_baseline', math.nan):.2f}; "
            "on the same kernels: " + ", ".join(f"{k} {v:.2f}" for k, v in s["same_kernel"].items())
        )
    return payload


if __name__ == "__main__":
    main()
