"""Before and after a change: this build of yore against another, in fresh processes that
alternate, on the same grid cloths.

    python -m benchmarks.build_ab --baseline PATH [--label TEXT] [--rounds 5] [--sizes 32 64 128 256]

PATH is a folder holding another build's installed ``yore`` package (copy
``site-packages/yore`` before the change). Each round runs one process of each build, in
alternating order, so both meet the same machine; each process measures, on every size, what
``benchmarks.factorization`` measures in one process (one thread, the kernels yore chooses, the
automatic ordering): the linearized step's numeric factorization and symbolic analysis, one
Newton iteration, and one explicit step. Reported are each build's medians over the rounds and
this build's over the baseline's. A shared machine's noise moves single runs by tens of per
cent; the alternation and the medians are what make a before/after figure worth quoting.

Writes build_ab.json and build_ab.png.
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import yore

from .common import arguments, fresh_process, machine_info, save
from .factorization import cpu_per_explicit_step, cpu_per_newton_iteration, measure_factorization

MEASURES = (
    "factorize_seconds",
    "analyze_seconds",
    "newton_iteration_cpu_seconds",
    "explicit_cpu_seconds",
)


def worker(sizes, repeats) -> dict:
    """One process's measures on every size."""
    yore.set_num_threads(1)
    rows = []
    for n in sizes:
        factor = measure_factorization(n, "auto", 1.0, repeats)
        rows.append(
            {
                "grid": n,
                "factorize_seconds": factor["factorize_seconds"],
                "analyze_seconds": factor["analyze_seconds"],
                "newton_iteration_cpu_seconds": cpu_per_newton_iteration(n, "auto", repeats),
                "explicit_cpu_seconds": cpu_per_explicit_step(n, repeats),
            }
        )
    return {"blas_kernel": yore.blas.report()["kernel"], "rows": rows}


def run_process(sizes, quick, package_path=None) -> dict:
    args = ["--worker", "--sizes", *sizes] + (["--quick"] if quick else [])
    return fresh_process("benchmarks.build_ab", args, package_path=package_path)


def summary(this_runs, baseline_runs) -> list:
    """Per size: both builds' medians over the rounds and this build's over the baseline's."""
    out = []
    for k, row in enumerate(this_runs[0]["rows"]):
        entry = {"grid": row["grid"]}
        for measure in MEASURES:
            this = statistics.median(run["rows"][k][measure] for run in this_runs)
            base = statistics.median(run["rows"][k][measure] for run in baseline_runs)
            entry[measure] = {"this": this, "baseline": base, "ratio": this / base}
        out.append(entry)
    return out


def plot(payload, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = payload["rows"]
    fig, ax = plt.subplots(figsize=(7, 3.6))
    width = 0.8 / len(MEASURES)
    for j, measure in enumerate(MEASURES):
        ax.bar(
            [i + j * width for i in range(len(rows))],
            [r[measure]["ratio"] for r in rows],
            width,
            label=measure.replace("_cpu_seconds", "").replace("_seconds", "").replace("_", " "),
        )
    ax.axhline(1.0, color="black", linewidth=0.8)
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(rows))])
    ax.set_xticklabels([f"{r['grid']}²" for r in rows])
    ax.set_ylabel("this build / baseline (median)")
    ax.set_title(f"against {payload['baseline_label']}", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> dict:
    def extra(parser):
        parser.add_argument("--baseline", metavar="PATH", help="folder holding the other build")
        parser.add_argument("--label", default="", help="what the baseline build is")
        parser.add_argument("--rounds", type=int, default=5, help="processes per build")
        parser.add_argument("--sizes", type=int, nargs="*", help="grid sizes (vertices per side)")
        parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)

    args = arguments(__doc__, argv, extra)
    sizes = args.sizes or ([8, 12] if args.quick else [32, 64, 128, 256])
    if args.worker:
        print(json.dumps(worker(sizes, 3 if args.quick else 5)))
        return {}
    if not args.baseline:
        raise SystemExit("build_ab: --baseline PATH is required (a folder holding yore)")
    this_runs, baseline_runs = [], []
    for round_number in range(args.rounds):
        order = [(this_runs, None), (baseline_runs, args.baseline)]
        for store, path in order if round_number % 2 == 0 else order[::-1]:
            store.append(run_process(sizes, args.quick, path))
        print(f"round {round_number + 1} of {args.rounds} done", flush=True)
    payload = {
        "benchmark": "build_ab",
        "machine": machine_info(),
        "quick": args.quick,
        "baseline_label": args.label or str(args.baseline),
        "rounds": args.rounds,
        "rows": summary(this_runs, baseline_runs),
        "this_runs": this_runs,
        "baseline_runs": baseline_runs,
    }
    save(args.out, "build_ab", payload, lambda path: plot(payload, path))
    for r in payload["rows"]:
        print(
            f"{r['grid']:>4}²: "
            + ", ".join(
                f"{m.replace('_seconds', '')} {1e3 * r[m]['this']:.2f} / "
                f"{1e3 * r[m]['baseline']:.2f} ms = {r[m]['ratio']:.2f}"
                for m in MEASURES
            )
        )
    return payload


if __name__ == "__main__":
    main()
