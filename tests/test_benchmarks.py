"""The benchmarks still run (at smoke size) and write JSON of the documented shape and a PNG."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def run_benchmark(name, out, *args):
    pytest.importorskip("matplotlib")
    result = subprocess.run([sys.executable, "-m", f"benchmarks.{name}", "--out", str(out), *args],
                            cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    assert (out / f"{name}.png").read_bytes()[:4] == b"\x89PNG"
    return json.loads((out / f"{name}.json").read_text())


def test_explicit_step_benchmark_smoke(tmp_path):
    data = run_benchmark("explicit_step", tmp_path, "--quick")
    assert data["benchmark"] == "explicit_step"
    assert {"cpu", "logical_cores", "yore", "blas_loaded", "thread_environment"} <= set(data["machine"])
    for row in data["rows"]:
        assert row["step_seconds_min"] <= row["step_seconds_median"] <= row["step_seconds_max"]
        assert row["springs"] > row["vertices"]


def test_implicit_step_benchmark_smoke(tmp_path):
    data = run_benchmark("implicit_step", tmp_path, "--quick", "--sizes", "6", "8")
    assert data["dense_matmul_gflops"] > 0
    assert {r["ordering_requested"] for r in data["rows"]} == {"amd", "metis"}
    for row in data["rows"]:
        assert row["dofs"] == 3 * (row["vertices"] - 2 - row["analyses"] + 1)  # pins + extra fixes
        for key in ("assemble_seconds", "factorize_seconds", "solve_seconds", "analyze_seconds",
                    "explicit_step_seconds", "factor_nonzeros", "factor_flops"):
            assert row[key] > 0, key
        assert row["analyze_over_factorize"] == pytest.approx(
            row["analyze_seconds"] / row["factorize_seconds"])
