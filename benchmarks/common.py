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
    blas = sorted({line.split()[-1] for line in _maps() if "blas" in line.lower()
                   and line.split()[-1].startswith("/")})
    return {
        "cpu": cpu,
        "logical_cores": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "yore": yore.build_info(),
        "blas_loaded": blas,
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
    return {"median": statistics.median(samples), "min": min(samples), "max": max(samples),
            "repeats": repeats}


def write_json(path: Path, payload: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=2, default=float) + "\n")
