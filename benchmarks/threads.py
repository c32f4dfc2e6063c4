"""Threads: the default thread count against one thread, on an idle machine and on one where
another process burns a core.

    python -m benchmarks.threads [--out bench-results] [--quick] [--env NAME=VALUE ...]

Cells: the demo scene's cloth (`yore demo`, 21² explicit, stepped from rest), a 128² grid cloth
(benchmarks.common.grid_cloth, explicit) and a 64² grid cloth with linearized backward Euler
(its parallelism is OpenBLAS's, inside CHOLMOD), each idle and busy. Busy: a CPU-burning
process pinned (sched_setaffinity) to the last core, killed afterwards. Each measurement runs in
a fresh process, as a user's run does: "one thread" calls yore.set_num_threads(1), "default"
sets nothing. The thread variables (OMP_NUM_THREADS, OMP_WAIT_POLICY, GOMP_SPINCOUNT,
OPENBLAS_NUM_THREADS) are removed from those processes' environment, so the default is yore's;
--env puts one back for the default runs (to compare wait policies). The two modes alternate,
repeats times; medians per mode; the ratio default / one thread per cell. Target: at most 1.2 in
every cell. Writes threads.json, threads.png.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time

from .common import arguments, grid_cloth, machine_info, save

TARGET_RATIO = 1.2
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "OPENBLAS_NUM_THREADS")
# scene → (steps per measurement at full size, at --quick size)
SCENES = {"demo": (20000, 2000), "grid128": (400, 40), "grid64-implicit": (12, 3)}
QUICK_GRID = {"grid128": 32, "grid64-implicit": 16}  # smaller cloths for --quick


def build(scene: str, quick: bool):
    """The Simulation of a cell."""
    import yore

    if scene == "demo":
        from pathlib import Path

        from yore.cli import demo_scene_text
        from yore.runs import load_scene

        sim, _ = load_scene(Path("hanging.toml"), text=demo_scene_text()).build()
        return sim
    n = QUICK_GRID[scene] if quick else int(scene[4:].split("-")[0])
    if scene.endswith("implicit"):
        return yore.Simulation(grid_cloth(n), integrator="implicit", dt=1 / 60, linearized=True)
    return yore.Simulation(grid_cloth(n))


def worker(scene: str, mode: str, quick: bool) -> dict:
    """One measurement in this (fresh) process: wall seconds per step of `steps` steps after a
    warm-up, and the threads the simulation reports."""
    import yore

    if mode == "one":
        yore.set_num_threads(1)
    sim = build(scene, quick)
    steps = SCENES[scene][1 if quick else 0]
    sim.step(max(1, steps // 10), progress=False)  # warm-up: thread pool, caches, analysis
    start = time.perf_counter()
    sim.step(steps, progress=False)
    seconds = time.perf_counter() - start
    return {"step_seconds": seconds / steps, "steps": steps, "threads": sim.stats["threads"]}


def run_worker(scene: str, mode: str, quick: bool, env_extra: dict) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
    if mode == "default":
        env.update(env_extra)
    command = [sys.executable, "-m", "benchmarks.threads", "--worker", scene, mode]
    if quick:
        command.append("--quick")
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    if result.returncode != 0:
        raise RuntimeError(f"worker {scene} {mode} failed:\n{result.stderr}")
    return json.loads(result.stdout.strip().splitlines()[-1])


class Burner:
    """A process spinning on the last core while the `with` block runs."""

    def __enter__(self):
        core = max(os.sched_getaffinity(0))
        self.core = core
        self.process = subprocess.Popen(
            [
                sys.executable,
                "-c",
                f"import os\nos.sched_setaffinity(0, {{{core}}})\nwhile True:\n    pass\n",
            ]
        )
        time.sleep(0.2)  # let it start spinning
        return self

    def __exit__(self, *exc):
        self.process.kill()
        self.process.wait()


def measure(quick: bool, repeats: int, env_extra: dict) -> tuple[list, list]:
    rows, cells = [], []
    for load in ("idle", "busy"):
        for scene in SCENES:
            samples = {"one": [], "default": []}
            used = {}
            burner = Burner() if load == "busy" else None
            if burner:
                burner.__enter__()
            try:
                for r in range(repeats):
                    for mode in ("one", "default") if r % 2 == 0 else ("default", "one"):
                        out = run_worker(scene, mode, quick, env_extra)
                        samples[mode].append(out["step_seconds"])
                        used[mode] = out["threads"]
            finally:
                if burner:
                    burner.__exit__(None, None, None)
            for mode, values in samples.items():
                rows.append(
                    {
                        "scene": scene,
                        "load": load,
                        "mode": mode,
                        "threads_configured": used[mode]["configured"],
                        "threads_used": used[mode],
                        "step_seconds_median": statistics.median(values),
                        "step_seconds_min": min(values),
                        "step_seconds_max": max(values),
                        "repeats": len(values),
                    }
                )
            ratio = statistics.median(samples["default"]) / statistics.median(samples["one"])
            cells.append(
                {
                    "scene": scene,
                    "load": load,
                    "default_over_one_thread": ratio,
                    "met": ratio <= TARGET_RATIO,
                }
            )
            print(
                f"{load:5s} {scene:16s} one thread {1e3 * statistics.median(samples['one']):8.3f}"
                f" ms  default ({used['default']['configured']} configured) "
                f"{1e3 * statistics.median(samples['default']):8.3f} ms  ratio {ratio:.2f}"
            )
    return rows, cells


def plot(rows, cells, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    labels = [f"{c['scene']}\n{c['load']}" for c in cells]
    for offset, mode, color in ((-0.2, "one", "tab:gray"), (0.2, "default", "tab:blue")):
        values = [
            next(
                r["step_seconds_median"]
                for r in rows
                if r["scene"] == c["scene"] and r["load"] == c["load"] and r["mode"] == mode
            )
            / next(
                r["step_seconds_median"]
                for r in rows
                if r["scene"] == c["scene"] and r["load"] == c["load"] and r["mode"] == "one"
            )
            for c in cells
        ]
        ax.bar(
            [i + offset for i in range(len(cells))],
            values,
            width=0.4,
            color=color,
            label="one thread" if mode == "one" else "default",
        )
    ax.axhline(TARGET_RATIO, color="tab:red", linestyle="--", label=f"target {TARGET_RATIO}×")
    ax.set_xticks(range(len(cells)))
    ax.set_xticklabels(labels, fontsize=8)
    ax.set_ylabel("time per step / one thread's (median)")
    ax.set_title("yore: default threads against one thread")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    if argv is None and len(sys.argv) > 1 and sys.argv[1] == "--worker":
        scene, mode = sys.argv[2], sys.argv[3]
        print(json.dumps(worker(scene, mode, "--quick" in sys.argv[4:])))
        return None

    def extra(parser):
        parser.add_argument(
            "--env",
            action="append",
            default=[],
            metavar="NAME=VALUE",
            help="a thread variable for the default runs (repeatable)",
        )
        parser.add_argument("--repeats", type=int, default=None)

    args = arguments(__doc__, argv, extra)
    env_extra = dict(item.split("=", 1) for item in args.env)
    repeats = args.repeats or (1 if args.quick else 7)
    rows, cells = measure(args.quick, repeats, env_extra)
    payload = {
        "benchmark": "threads",
        "machine": machine_info(),
        "quick": args.quick,
        "target_ratio": TARGET_RATIO,
        "target_met": all(c["met"] for c in cells),
        "default_environment": env_extra,
        "rows": rows,
        "cells": cells,
    }
    save(args.out, "threads", payload, lambda path: plot(rows, cells, path))
    print(
        f"target: default at most {TARGET_RATIO}× one thread in every cell — "
        f"{'met' if payload['target_met'] else 'missed'}"
    )
    return payload


if __name__ == "__main__":
    main()
