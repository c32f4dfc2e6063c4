"""The benchmarks still run (at smoke size) and write JSON of the documented shape and a PNG.

No assertion here may depend on wall time (a slope, a ratio, one timing against another or a
bound): on a loaded machine any of them can fail. Timings are checked for their type; counted
quantities (steps, factorizations, sizes) for their values. Timings belong in the reports.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import report, schema

ROOT = Path(__file__).resolve().parent.parent


def run_benchmark(name, out, *args):
    pytest.importorskip("matplotlib")
    result = subprocess.run([sys.executable, "-m", f"benchmarks.{name}", "--out", str(out), *args],
                            cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    assert (out / f"{name}.png").read_bytes()[:4] == b"\x89PNG"
    data = json.loads((out / f"{name}.json").read_text())
    schema.check(data)  # the documented shape
    return data


def is_timing(value):
    """A wall time as the benchmarks write it: a finite float (its value is not checked)."""
    return isinstance(value, float) and math.isfinite(value)


def test_explicit_step_benchmark_smoke(tmp_path):
    data = run_benchmark("explicit_step", tmp_path, "--quick")
    assert data["benchmark"] == "explicit_step"
    assert {"cpu", "logical_cores", "yore", "blas_loaded", "thread_environment"} <= set(data["machine"])
    for row in data["rows"]:
        assert all(is_timing(row[k]) for k in ("step_seconds_min", "step_seconds_median",
                                                "step_seconds_max"))
        assert row["vertices"] == row["grid"] ** 2 and row["springs"] > row["vertices"]


def test_implicit_step_benchmark_smoke(tmp_path):
    data = run_benchmark("implicit_step", tmp_path, "--quick", "--sizes", "6", "8")
    assert data["dense_matmul_gflops"] > 0
    assert {r["ordering_requested"] for r in data["rows"]} == {"amd", "metis"}
    for row in data["rows"]:
        assert row["dofs"] == 3 * (row["vertices"] - 2 - row["analyses"] + 1)  # pins + extra fixes
        for key in ("assemble_seconds", "factorize_seconds", "solve_seconds", "analyze_seconds",
                    "explicit_step_seconds"):
            assert is_timing(row[key]), key
        assert row["factor_flops"] > row["factor_nonzeros"] >= row["dofs"]
    assert [r["grid"] for r in data["iterations"]] == [6, 8]
    for row in data["iterations"]:
        assert is_timing(row["newton_iteration_seconds"])
        assert is_timing(row["quasi_newton_iteration_seconds"])


def test_speed_vs_error_with_every_cell_skipped_still_writes_its_results(tmp_path):
    # a budget of 0 CPU seconds per cell skips them all (predicted from the stability trials,
    # not timed): the JSON says so per cell and the picture says there is nothing to show
    pytest.importorskip("matplotlib")
    result = subprocess.run([sys.executable, "-m", "benchmarks.speed_vs_error", "--out",
                             str(tmp_path), "--quick", "--scenes", "sheet", "--sizes", "6",
                             "--stiffness", "2e3", "--bending", "equal", "--max-cell-seconds",
                             "0", "--no-extend"], cwd=ROOT, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "speed_vs_error.png").read_bytes()[:4] == b"\x89PNG"
    data = json.loads((tmp_path / "speed_vs_error.json").read_text())
    assert data["rows"] == []
    assert data["summary"]["cells"] and all("skipped" in c for c in data["summary"]["cells"])


def test_speed_vs_error_smoke(tmp_path):
    # caps far above any run: which runs exist must not depend on wall time
    data = run_benchmark("speed_vs_error", tmp_path, "--quick", "--repeats", "2",
                         "--max-ratio", "1e9", "--max-run-seconds", "1e9")
    rows = [r for r in data["rows"] if r["method"] != "reference"]
    families = set(data["families"])
    core = {"explicit", "BE linearized", "BE Newton", "BDF2", "local-global"}
    assert core <= families <= core | {"quasi-Newton BE", "quasi-Newton BDF2"}
    assert families | set(data["families_unavailable"]) == core | {"quasi-Newton BE",
                                                                    "quasi-Newton BDF2"}
    assert {r["method"] for r in rows} == families
    assert not any(r["diverged"] or r["aborted"] for r in rows
                   if r["method"] in ("BE Newton", "BDF2"))
    for cell in data["summary"]["cells"]:
        # the stability search bracketed explicit's limit, and the limit run is at or below it
        trials = cell["stability_trials"]
        largest = max(t["dt"] for t in trials if t["stable"])
        assert all(t["dt"] > largest for t in trials if not t["stable"]) and len(trials) >= 2
        assert cell["explicit_limit_dt"] <= largest * (1 + 1e-12)
        if cell["reference_converged"]:
            assert cell["reference_error"] <= data["reference_tolerance"] == 1e-4
            for at in ("at_0.01", "at_0.001"):
                explicit = cell[at]["families"]["explicit"]
                assert "none" in explicit or explicit["error"] <= float(at[3:])
    for r in rows:
        if "error" in r:  # counted quantities; every run covers its cell's horizon
            assert r["steps"] % 2 == 0 and math.isclose(r["steps"] * r["dt"], r["horizon"])
            assert r["iterations_per_step"] >= 1 and is_timing(r["cost_seconds_per_simulated_second"])
            assert r["repeats"] == len(r["cpu_seconds_samples"]) in (1, 2)
            if r["scene"] != "sheet":
                assert r["wrinkle_retention"] > 0
    assert any(r.get("repeats") == 2 for r in rows)
    # BDF2 is second order: halving dt divides its error by more than backward Euler's
    def ratio(method):
        sel = sorted((r for r in rows if r["method"] == method and r["scene"] == "sheet"
                      and r["size"] == 9 and r["bending"] == "equal"
                      and r["stretch_stiffness"] == 2e3), key=lambda r: -r["dt"])
        return sel[0]["error"] / sel[1]["error"]
    assert ratio("BDF2") > ratio("BE Newton")
    assert (tmp_path / "crossover.png").read_bytes()[:4] == b"\x89PNG"


def test_rebuild_cost_smoke(tmp_path):
    data = run_benchmark("rebuild_cost", tmp_path, "--quick")
    for row in data["rows"]:
        assert row["analyses"] == 1 + row["repeats"]  # one per stroke, plus the first
        assert is_timing(row["step_after_stroke_seconds"]) and is_timing(row["analyze_seconds"])
    strategies = {(r["case"], r["strategy"]) for r in data["local_global"]}
    assert {s for _, s in strategies} == {"fresh", "reuse-ordering", "stale-pcg"}
    for row in data["local_global"]:
        assert is_timing(row["ordinary_step_seconds"])
        # every strategy refactored at least once per stroke except stale-pcg, which may still
        # be stepping on the stale factor
        if row["strategy"] != "stale-pcg":
            assert row["factorizations"] >= 1 + 3
    for row in data["quasi_newton"]:
        # one scalar analysis per topology (the first and one per stroke), refactored with it
        assert row["analyses"] == 1 + 3 and row["factorizations"] == 1 + 3
        assert is_timing(row["ordinary_step_seconds"]) and is_timing(row["rebuild_seconds"])


def test_scaling_smoke(tmp_path):
    # the slopes are fitted to wall times: their names and types are checked, not their values
    data = run_benchmark("scaling", tmp_path, "--quick")
    assert set(data["slopes"]) >= {"explicit", "implicit_linearized"}
    assert all(is_timing(slope) for slope in data["slopes"].values())
    assert [r["grid"] for r in data["rows"]] == [8, 16, 32]
    assert all(r["vertices"] == r["grid"] ** 2 for r in data["rows"])
    assert all(r["newton_iterations_per_step"] >= 1 for r in data["rows"])


def test_stability_map_smoke(tmp_path):
    data = run_benchmark("stability_map", tmp_path, "--quick")
    cells = len(data["stiffness_values"]) * len(data["dt_values"])
    for name in ("explicit", "BE Newton"):
        assert sum(r["integrator"] == name for r in data["rows"]) == cells
    # backward Euler with Newton never diverges; explicit does at the largest step
    assert all(r["state"] != "diverged" for r in data["rows"] if r["integrator"] == "BE Newton")
    assert any(r["state"] == "diverged" for r in data["rows"] if r["integrator"] == "explicit")


def test_stable_dt_smoke(tmp_path):
    data = run_benchmark("stable_dt", tmp_path, "--quick")
    assert {r["scene"] for r in data["rows"]} == {"hanging_cloth", "rotating_cylinder"}
    for r in data["rows"]:
        # Gershgorin <= Laplacian bound <= found limit; the default is below the limit
        assert r["gershgorin_dt"] <= r["bound_dt"] * (1 + 1e-12) <= r["found_dt"]
        assert r["default_dt"] < r["found_dt"]


def test_newton_projection_smoke(tmp_path):
    data = run_benchmark("newton_projection", tmp_path, "--quick")
    assert {r["projection"] for r in data["rows"]} == {"clamp", "abs", "exact", "trust-region",
                                                        "shifted"}
    # only the projections that try the exact Hessian can have it rejected
    assert all(r["rejected_per_step"] == 0 for r in data["rows"]
               if r["projection"] not in ("exact", "shifted"))
    assert all(r["median_iterations"] <= r["max_iterations"] <= 50 for r in data["rows"])
    assert all(0.0 <= r["deviation"] < 1.0 for r in data["rows"])
    # the step's own error, probed from the run's states, is finite and below the size
    assert all(0.0 <= r["step_deviation"] < 1.0 for r in data["rows"])
    assert set(data["target_met"]) == {r["projection"] for r in data["rows"]}


def test_threads_benchmark_smoke(tmp_path):
    data = run_benchmark("threads", tmp_path, "--quick")
    scenes = {"demo", "grid128", "grid64-implicit"}
    assert {(c["scene"], c["load"]) for c in data["cells"]} == {
        (s, load) for s in scenes for load in ("idle", "busy")}
    assert len(data["rows"]) == 2 * len(data["cells"])  # one thread and the default, per cell
    assert data["target_ratio"] == 1.2
    assert data["target_met"] == all(c["met"] for c in data["cells"])
    for cell in data["cells"]:
        assert is_timing(cell["default_over_one_thread"])
    for row in data["rows"]:
        assert is_timing(row["step_seconds_median"]) and row["repeats"] == 1
        used = row["threads_used"]
        if row["mode"] == "one":
            assert used["configured"] == 1 and used["blas"] in (0, 1)
            if "last_step" in used:  # explicit: every step ran on one thread
                assert used["last_step"] == 1 and used["parallel_steps"] == 0
        else:
            assert used["configured"] == len(os.sched_getaffinity(0))  # OpenMP's default
            if "last_step" in used:
                assert 1 <= used["last_step"] <= used["configured"]


def test_report_refuses_quick_results_and_writes_full_ones(tmp_path):
    results = tmp_path / "results"
    for name in schema.SCHEMAS:
        run_benchmark(name, results, "--quick", *(["--sizes", "6", "8"]
                                                  if name == "implicit_step" else []))
    readme = tmp_path / "README.md"
    readme.write_text(f"intro\n{report.START}\nold\n{report.END}\nrest\n")
    with pytest.raises(SystemExit, match="quick"):
        report.main(["--results", str(results), "--readme", str(readme)])
    for path in results.glob("*.json"):
        data = json.loads(path.read_text())
        data["quick"] = False
        path.write_text(json.dumps(data))
    report.main(["--results", str(results), "--readme", str(readme)])
    text = readme.read_text()
    assert text.startswith("intro\n") and text.endswith("rest\n") and "old" not in text
    # every number in the section comes from the JSON: spot-check two
    rebuild = json.loads((results / "rebuild_cost.json").read_text())
    assert f"{rebuild['dense_matmul_gflops']:.1f} GFlop/s" in text
    scaling = json.loads((results / "scaling.json").read_text())
    assert f"explicit {scaling['slopes']['explicit']:.2f}" in text


def test_stream_bandwidth_probe_is_plausible():
    import yore

    bandwidth = yore._core.stream_triad_bandwidth(1_000_000, 3)
    # bytes over the best wall time: only its type is checked (its value depends on the load)
    assert is_timing(bandwidth) and bandwidth > 0
    with pytest.raises(ValueError):
        yore._core.stream_triad_bandwidth(0, 3)


def test_pictures_smoke(tmp_path):
    data = run_benchmark("pictures", tmp_path, "--quick")
    cells = {(r["width"], r["height"], r["factor"]) for r in data["rows"]}
    assert cells == {(w, h, f) for w, h in ((320, 240), (640, 480)) for f in (1, 3)}
    assert all(is_timing(r["render_seconds_median"]) for r in data["rows"])
    assert is_timing(data["start_seconds_median"]) and is_timing(data["pick_seconds_median"])


def test_crossover_sweep_smoke(tmp_path):
    data = run_benchmark("crossover_sweep", tmp_path, "--quick")
    # the sweep's Dataset is there, every cell ran, and the reference cells have error 0
    assert (tmp_path / "sweeps" / "crossover" / "results.nc").is_file()
    assert sum(data["statuses"].values()) == data["cells"] == len(data["rows"])
    assert all(r["error"] == 0.0 for r in data["rows"] if r["method"] == "reference")
    assert {r["family"] for r in data["rows"]} == {"explicit", "reference", "BE linearized",
                                                    "BE Newton", "BDF2", "local-global",
                                                    "quasi-Newton"}
    for cell in data["summary"]:
        assert cell["winner"] in (None, "explicit") or cell["winner"].split(",")[0] in {
            "BE linearized", "BE Newton", "BDF2", "local-global", "quasi-Newton"}
