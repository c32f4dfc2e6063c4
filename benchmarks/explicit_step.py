"""Cost of one explicit (symplectic Euler) step against grid size, with 1 and 2 threads.

    python -m benchmarks.explicit_step [--out bench-results] [--quick]

Writes explicit_step.json (raw medians, machine info) and explicit_step.png. Each size is
timed as the median of repeated batches of steps after a warm-up; the thread comparison is a
ratio measured in the same run.
"""

from __future__ import annotations

from pathlib import Path


import yore

from .common import arguments, explicit_step_seconds, grid_cloth, machine_info, save

# Least memory traffic of one explicit step, bytes: every array read or written once.
# Per spring: ends (2 × 4), rest + stiffness + damping (3 × 8), its force written and read back
# (2 × 24), two incidence entries (2 × (4 + 8)). Per vertex: position and velocity read and
# written (4 × 24), mass and inverse mass (2 × 8), force written and read (2 × 24), offset (4).
BYTES_PER_SPRING = 8 + 24 + 48 + 24
BYTES_PER_VERTEX = 96 + 16 + 48 + 4


def stream_bandwidth(elements=20_000_000, repeats=10):
    """Memory bandwidth of the STREAM triad in the core with its current threads, bytes/s (best
    of repeats, as STREAM reports)."""
    return yore._core.stream_triad_bandwidth(elements, repeats)


def measure(sizes, threads_list, target_seconds: float, repeats: int) -> list:
    rows = []
    default_threads = yore.build_info()["threads"]
    for n in sizes:
        for threads in threads_list:
            yore.set_num_threads(threads)
            timing = explicit_step_seconds(n, target_seconds, repeats)
            rows.append(
                {
                    "grid": n,
                    "vertices": n * n,
                    "springs": grid_cloth(n).spring_count,
                    "threads": threads,
                    "steps_per_batch": timing["steps_per_batch"],
                    "step_seconds_median": timing["median"],
                    "step_seconds_min": timing["min"],
                    "step_seconds_max": timing["max"],
                }
            )
    yore.set_num_threads(default_threads)
    return rows


def plot(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for threads in sorted({r["threads"] for r in rows}):
        sel = [r for r in rows if r["threads"] == threads]
        ax.loglog(
            [r["vertices"] for r in sel],
            [1e3 * r["step_seconds_median"] for r in sel],
            "o-",
            label=f"{threads} thread{'s' if threads > 1 else ''}",
        )
    ax.set_xlabel("vertices")
    ax.set_ylabel("ms per explicit step (median)")
    ax.set_title("yore: symplectic Euler step cost")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> None:
    args = arguments(__doc__, argv)
    sizes = [16, 32, 64] if args.quick else [16, 32, 64, 128, 256]
    threads = sorted({1, min(2, yore.build_info()["threads"])} | {yore.build_info()["threads"]})
    rows = measure(
        sizes, threads, target_seconds=0.02 if args.quick else 0.2, repeats=3 if args.quick else 7
    )
    speedups = {}
    for n in sizes:
        one = next(r for r in rows if r["grid"] == n and r["threads"] == 1)
        best = min((r for r in rows if r["grid"] == n), key=lambda r: r["step_seconds_median"])
        speedups[str(n)] = one["step_seconds_median"] / best["step_seconds_median"]
    default_threads = yore.build_info()["threads"]
    bandwidth_by_threads = {}
    for threads in sorted({r["threads"] for r in rows}):
        yore.set_num_threads(threads)
        bandwidth_by_threads[threads] = stream_bandwidth(2_000_000 if args.quick else 20_000_000)
    yore.set_num_threads(default_threads)
    bandwidth = max(bandwidth_by_threads.values())
    for row in rows:
        row["bytes_per_step"] = (
            BYTES_PER_SPRING * row["springs"] + BYTES_PER_VERTEX * row["vertices"]
        )
        bound_bandwidth = bandwidth_by_threads[row["threads"]]
        row["bandwidth_bound_seconds"] = row["bytes_per_step"] / bound_bandwidth
        row["over_bandwidth_bound"] = row["step_seconds_median"] / row["bandwidth_bound_seconds"]
    payload = {
        "benchmark": "explicit_step",
        "machine": machine_info(),
        "quick": args.quick,
        "rows": rows,
        "speedup_best_threads_vs_1": speedups,
        "stream_bandwidth_bytes_per_second": bandwidth,
        "stream_bandwidth_by_threads": {str(k): v for k, v in bandwidth_by_threads.items()},
        "targets": {"over_bandwidth_bound_at_most": 2.0},
    }
    save(args.out, "explicit_step", payload, lambda path: plot(rows, path))
    print(f"{'grid':>6} {'threads':>7} {'ms/step':>10} {'x bound':>8}")
    for r in rows:
        print(
            f"{r['grid']:>5}² {r['threads']:>7} {1e3 * r['step_seconds_median']:>10.4f} "
            f"{r['over_bandwidth_bound']:>8.2f}"
        )
    print(
        "STREAM triad bandwidth (same run): "
        + ", ".join(
            f"{threads} thread(s) {value / 1e9:.1f} GB/s"
            for threads, value in bandwidth_by_threads.items()
        )
    )
    print(
        "speed-up of the best thread count over 1 thread:",
        {k: round(v, 2) for k, v in speedups.items()},
    )


if __name__ == "__main__":
    main()
