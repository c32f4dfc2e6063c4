"""Shared helpers of the benchmarks: machine facts, timing, output."""

from __future__ import annotations

import json
import os
import platform
import statistics
import time
from pathlib import Path

import yore


def machine_info() -> dict:
    """CPU, cores, threads, library versions and the BLAS the process loaded."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    blas = sorted(
        {
            line.split()[-1]
            for line in _maps()
            if "blas" in line.lower() and line.split()[-1].startswith("/")
        }
    )
    return {
        "cpu": cpu,
        "logical_cores": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "yore": yore.build_info(),
        "blas_loaded": blas,
        # the kernels CHOLMOD's BLAS runs and who chose them (yore.blas): "SkylakeX", "yore"
        "blas_kernels": yore.blas.report(),
        "thread_environment": {
            name: os.environ.get(name) for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
        },
    }


def _maps():
    try:
        with open("/proc/self/maps") as f:
            return f.readlines()
    except OSError:
        return []


def median_seconds(run, repeats: int, warmup: int = 1) -> dict:
    """Median, min and max wall time of `run()` over `repeats` runs after `warmup` runs."""
    for _ in range(warmup):
        run()
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        samples.append(time.perf_counter() - start)
    return {
        "median": statistics.median(samples),
        "min": min(samples),
        "max": max(samples),
        "repeats": repeats,
    }


def fresh_process(module: str, args, env=None, package_path=None):
    """Runs ``python -m module *args`` from the repository in a fresh process on one BLAS and one
    OpenMP thread (plus `env`), importing yore from `package_path` (a folder holding another
    build's package) when given; returns the JSON its last line of output prints."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    environment = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", **(env or {})}
    if package_path is not None:
        environment["PYTHONPATH"] = os.pathsep.join([str(Path(package_path).resolve()), str(root)])
    done = subprocess.run(
        [sys.executable, "-m", module, *map(str, args)],
        env=environment,
        capture_output=True,
        text=True,
        check=True,
        cwd=root,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def arguments(doc: str, argv=None, extra=None):
    """The benchmarks' command line: --out DIR (default bench-results) and --quick, plus
    whatever `extra(parser)` adds."""
    import argparse

    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", default="bench-results", type=Path)
    parser.add_argument("--quick", action="store_true", help="small sizes, few repeats")
    if extra is not None:
        extra(parser)
    return parser.parse_args(argv)


def save(out: Path, name: str, payload: dict, draw) -> None:
    """Writes out/name.json and out/name.png (draw(path) makes the picture) and says so."""
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / f"{name}.json", payload)
    draw(out / f"{name}.png")
    print(f"wrote {out / f'{name}.json'} and {out / f'{name}.png'}")


def write_json(path: Path, payload: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=2, default=float) + "\n")


def grid_cloth(n: int) -> "yore.Cloth":
    """The benchmarks' cloth: an n × n-vertex, 1 m square with the scenes' material (200 N/m
    structural and bending springs, damping, drag, 0.1 kg), fixed at two corners."""
    V, F = yore.grid_mesh(n, n)
    cloth = yore.Cloth(
        V,
        F,
        masses=0.1 / (n * n),
        stretch_stiffness=200.0,
        bend_stiffness=200.0,
        damping=0.02,
        drag=0.3,
    )
    cloth.fix([0, n - 1])
    return cloth


def explicit_step_seconds(n: int, target_seconds: float, repeats: int) -> dict:
    """Median wall time of one explicit step on grid_cloth(n), timed in batches."""
    sim = yore.Simulation(grid_cloth(n))
    probe = median_seconds(lambda: sim.step(5, progress=False), repeats=1, warmup=1)
    steps = max(1, int(target_seconds / (probe["median"] / 5)))
    timing = median_seconds(lambda: sim.step(steps, progress=False), repeats=repeats)
    return {
        key: (value / steps if key != "repeats" else value) for key, value in timing.items()
    } | {"steps_per_batch": steps}


def grouped_bars(axes, rows, group, series, metrics):
    """Bar charts of rows grouped along x by row[group], one bar per row[series] in each
    group, one axis per metric (axes[k] shows row[metrics[k]]); returns the x positions and
    the group values (in first-seen order), for the caller's tick labels."""
    import numpy as np

    groups = list(dict.fromkeys(r[group] for r in rows))
    names = list(dict.fromkeys(r[series] for r in rows))
    x = np.arange(len(groups))
    width = 0.8 / len(names)
    for k, name in enumerate(names):
        chosen = [next(r for r in rows if r[group] == g and r[series] == name) for g in groups]
        offset = (k - (len(names) - 1) / 2) * width
        for ax, metric in zip(axes, metrics):
            ax.bar(x + offset, [r[metric] for r in chosen], width, label=name)
    return x, groups
