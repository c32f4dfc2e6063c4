"""benchmarks/long_horizon.py: its measures against hand computations and analytic cases, its
floor-gated verdicts, its journal (a cell stopped part-way resumes), its bad-input errors, and a
smoke run of --quick that writes its JSON, picture and sweep records.

As in test_benchmarks.py, no assertion depends on wall time: timings are checked for their type,
and the journal test runs on a counting clock so which runs a cell asks for is fixed."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_benchmarks import _journal_cell, _same_runs, crossover_row, is_timing

from benchmarks import long_horizon as lh

ROOT = Path(__file__).resolve().parent.parent


def test_relative_l2_is_the_norm_of_the_difference_over_the_norm_of_the_reference():
    # ‖(1, 2, 3) − (1, 1, 1)‖ = √5, ‖(1, 1, 1)‖ = √3
    assert math.isclose(lh.relative_l2([1.0, 2.0, 3.0], [1.0, 1.0, 1.0]), math.sqrt(5 / 3))
    # normalised by another history (the total energy's, by the kinetic energy): √5 / √12
    assert math.isclose(
        lh.relative_l2([1.0, 2.0, 3.0], [1.0, 1.0, 1.0], norm_of=[2.0] * 3), math.sqrt(5 / 12)
    )
    assert lh.relative_l2([0.5, -2.0], [0.5, -2.0]) == 0.0


def fake_run(positions, masses, kinetic, total, stride=1):
    """A `history` result of the given positions (k×n×3) and energies (k), sampled every
    `stride` grid points from t = 0."""
    points = np.arange(len(kinetic)) * stride
    zeros = np.zeros(len(kinetic))
    table = np.column_stack(
        [points, kinetic, zeros, zeros, zeros, total, lh.centroid(masses, positions)]
    )
    return {"snapshots": [np.asarray(positions, float), table], "cpu_seconds": 1.0}


def test_a_rigidly_translated_copy_is_off_by_exactly_its_offset():
    rng = np.random.default_rng(7)
    samples, vertices = 33, 20
    positions = rng.standard_normal((samples, vertices, 3))
    masses = rng.uniform(0.5, 2.0, vertices)
    kinetic = np.linspace(0.0, 1.0, samples) ** 2
    total = -0.1 * np.linspace(0.0, 1.0, samples)
    reference = fake_run(positions, masses, kinetic, total)
    offset = np.array([0.03, -0.04, 0.0])  # 5 cm
    moved = fake_run(positions + offset, masses, kinetic, total)
    scales = {"sheet_size": 1.0, "diagonal": math.sqrt(2.0)}
    found = lh.run_measures(moved, reference, scales, until=samples / lh.GRID_RATE)
    # the centroid of a translated copy moves by the offset; every vertex is the offset away
    assert math.isclose(found["centroid_path"], 0.05, rel_tol=1e-12)
    assert math.isclose(found["trajectory"], 0.05 / math.sqrt(2.0), rel_tol=1e-12)
    assert found["kinetic_energy_history"] == found["total_energy_history"] == 0.0
    assert found["energy_retained"] == 0.0
    assert found["kinetic_energy_retained_at_end"] == 1.0
    # the centroid measure is the largest distance over the run (here the offset grows)
    growing = positions + np.linspace(0.0, 1.0, samples)[:, None, None] * offset
    found = lh.run_measures(
        fake_run(growing, masses, kinetic, total), reference, scales, until=0.25
    )
    assert math.isclose(found["centroid_path"], 0.05, rel_tol=1e-12)
    # the trajectory only up to `until`: 16 grid intervals of 32
    assert math.isclose(found["trajectory"], 0.5 * 0.05 / math.sqrt(2.0), rel_tol=1e-12)


def test_a_run_sampled_every_second_point_is_compared_at_its_own_points():
    # the 1/32 s rung has no state between its steps: the reference is read at its points
    # only, and its errors at the odd points (which the run never visits) do not count
    samples, vertices = 65, 4
    masses = np.ones(vertices)
    positions = np.zeros((samples, vertices, 3))
    kinetic = 1.0 + np.arange(samples) % 2  # the reference: 1 at even points, 2 at odd ones
    reference = fake_run(positions, masses, kinetic, -kinetic)
    coarse = fake_run(positions[::2], masses, np.ones(33), -np.ones(33), stride=2)
    found = lh.run_measures(coarse, reference, {"sheet_size": 1.0, "diagonal": 1.0}, until=1.0)
    assert found["kinetic_energy_history"] == 0.0 and found["total_energy_history"] == 0.0
    # energy retained: the mean over the last 0.25 s, at the run's points (9 of them)
    halved = fake_run(positions[::2], masses, 0.5 * np.ones(33), -np.ones(33), stride=2)
    found = lh.run_measures(halved, reference, {"sheet_size": 1.0, "diagonal": 1.0}, until=1.0)
    assert math.isclose(found["energy_retained"], 0.5)
    assert math.isclose(found["kinetic_energy_history"], 0.5)


def test_the_predictability_time_is_the_last_sample_before_the_references_part():
    samples, vertices = 10, 3
    masses = np.ones(vertices)
    base = np.zeros((samples, vertices, 3))
    # every vertex moved along x by 1e-4 × 2^i of the diagonal at sample i: beyond 1e-3 at i = 4
    diagonal = math.sqrt(2.0)
    moved = base + (1e-4 * diagonal * 2.0 ** np.arange(samples))[:, None, None] * [1, 0, 0]
    energy = np.ones(samples)
    until, parted, distances = lh.predictability_time(
        fake_run(moved, masses, energy, energy), fake_run(base, masses, energy, energy), diagonal
    )
    assert parted and until == 3 / lh.GRID_RATE
    assert np.allclose(distances, 1e-4 * 2.0 ** np.arange(samples))
    # references that never part: the whole run
    until, parted, _ = lh.predictability_time(
        fake_run(base, masses, energy, energy), fake_run(base, masses, energy, energy), diagonal
    )
    assert not parted and until == (samples - 1) / lh.GRID_RATE


def verdict_rows():
    """Explicit at its limit (cost 10) and two implicit runs: BE off by 4 % (cost 2), BDF2 by
    0.5 % (cost 4), in every measure."""
    rows = []
    for method, error, cost in (
        ("explicit", 1e-4, 10.0),
        ("implicit", 0.04, 2.0),
        ("bdf2", 0.005, 4.0),
    ):
        row = crossover_row(method, error, cost)
        row.update({measure: error for measure in lh.MEASURES})
        rows.append(row)
    return rows


def test_a_threshold_is_judged_only_where_the_floor_is_below_a_third_of_it():
    rows = verdict_rows()
    families = ["explicit", "implicit", "bdf2"]
    measure = "kinetic_energy_history"
    # a floor of a third of 5 % or more: not judged, and no winner named
    for floor in (0.05 / 3, 0.02):
        verdict = lh.judge(rows, families, rows[0], measure, 0.05, floor)
        assert verdict["judged"] is False and verdict["floor"] == floor
        assert "winner" not in verdict and "implicit_over_explicit_cost" not in verdict
    # below it: the cheapest implicit run that meets 5 % (BE, 2 of explicit's 10)
    verdict = lh.judge(rows, families, rows[0], measure, 0.05, 0.0166)
    assert verdict["judged"] and verdict["winner"] == "implicit"
    assert math.isclose(verdict["implicit_over_explicit_cost"], 0.2)
    assert verdict["best_implicit"][measure] == 0.04 and verdict["explicit_meets"]
    # at 1 % only BDF2 meets it
    verdict = lh.judge(rows, families, rows[0], measure, 0.01, 1e-3)
    assert verdict["best_implicit"]["method"] == "bdf2"
    assert math.isclose(verdict["implicit_over_explicit_cost"], 0.4)
    assert "none" in verdict["families"]["implicit"]
    # a cell's summary gates each (measure, threshold) on that measure's own floor
    floors = {m: {"floor": 1e-3} for m in lh.MEASURES} | {"trajectory": {"floor": 5e-3}}
    cell = lh.summarize({"floors": floors}, rows, families, [0.05, 0.01])
    assert cell["verdicts"]["trajectory"]["at_0.05"]["judged"]
    assert not cell["verdicts"]["trajectory"]["at_0.01"]["judged"]
    assert cell["verdicts"]["centroid_path"]["at_0.01"]["judged"]
    assert cell["explicit"]["cost_seconds_per_simulated_second"] == 10.0


class CountedRuns:
    """Replaces `history` with one that counts the runs it starts and, from `stop_at` runs on,
    raises KeyboardInterrupt instead (a session that ends in the middle of a cell)."""

    def __init__(self, monkeypatch):
        self.real, self.count, self.stop_at = lh.history, 0, None
        monkeypatch.setattr(lh, "history", self)

    def __call__(self, *args, **kwargs):
        if self.count == self.stop_at:
            raise KeyboardInterrupt
        self.count += 1
        return self.real(*args, **kwargs)


def test_a_long_horizon_cell_stopped_part_way_replays_its_finished_runs(tmp_path, monkeypatch):
    crossover, cell, make, families, settings = _journal_cell(monkeypatch)
    monkeypatch.setattr(lh, "time", crossover.time)  # the same counting clock
    settings = dict(settings, thresholds=list(lh.THRESHOLDS))
    runs = CountedRuns(monkeypatch)

    def measure(journal=None):
        return lh.measure_cell(cell, make, families, settings, lambda s: None, journal)

    whole, _ = measure()
    total = runs.count
    # three references, explicit at its limit, the BE ladder and the repeats
    assert total >= 7 and [r["method"] for r in whole[:4]] == [
        "reference",
        "reference, perturbed start",
        "reference, quarter step",
        "explicit",
    ]
    # the same cell, stopped by an interrupt in its sixth run, then resumed on its journal
    folder = tmp_path / "journal" / "cell"
    runs.count, runs.stop_at = 0, 5
    with pytest.raises(KeyboardInterrupt):
        measure(crossover.Journal(folder, print))
    assert len(list(folder.glob("run-*.npz"))) == 5  # the five runs that ended, arrays kept
    runs.count, runs.stop_at = 0, None
    journal = crossover.Journal(folder, print)
    resumed, info = measure(journal)
    assert runs.count == total - 5  # only the runs not finished before ran again
    assert journal.replayed == len(info["stability_trials"]) + 5 == info["replayed_runs"]
    _same_runs(resumed, whole)
    for name in lh.MEASURES:  # the replayed arrays give the same measures
        assert [r.get(name) for r in resumed] == [r.get(name) for r in whole]
    # a third pass replays everything: nothing runs, the CPU seconds are those measured
    runs.count = 0
    again, _ = measure(crossover.Journal(folder, print))
    assert runs.count == 0
    assert [r.get("cpu_seconds_samples") for r in again] == [
        r.get("cpu_seconds_samples") for r in resumed
    ]


BAD_INPUT = [
    ["--horizon", "0"],
    ["--horizon", "-2"],
    ["--horizon", "nan"],
    ["--horizon", "inf"],
    ["--horizon", "0.3"],
    ["--horizon-at", "32=0"],
    ["--horizon-at", "3=2"],
    ["--thresholds", "0"],
    ["--thresholds", "1"],
    ["--thresholds", "0.05", "1.5"],
    ["--families", "explicit", "leapfrog"],
    ["--sizes", "3"],
    ["--sizes", "32", "two"],
    ["--repeats", "0"],
    ["--merge", "no-such-run/long_horizon.json"],
]


@pytest.mark.parametrize("argv", BAD_INPUT, ids=" ".join)
def test_bad_input_is_one_error_line_and_exit_code_2(argv, tmp_path, capsys):
    with pytest.raises(SystemExit) as stopped:
        lh.main(["--out", str(tmp_path), *argv])
    assert stopped.value.code == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1 and err.startswith("yore: error: ")
    assert not (tmp_path / "sweeps").exists()  # nothing ran


def test_bad_input_from_the_command_line(tmp_path):
    # a real process: its exit status and its stderr; --resume of a folder with no run too
    for argv in (["--thresholds", "1.5"], ["--resume"]):
        result = subprocess.run(
            [sys.executable, "-m", "benchmarks.long_horizon", "--out", str(tmp_path), *argv],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert result.returncode == 2, result.stderr
        (line,) = result.stderr.splitlines()
        assert line.startswith("yore: error: ")
    assert "no scene.toml" in line


@pytest.mark.slow  # a Dask cluster and a benchmark, if a small one
def test_the_quick_run_writes_its_measures_picture_and_sweep(tmp_path):
    pytest.importorskip("matplotlib")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "benchmarks.long_horizon",
            "--out",
            str(tmp_path),
            "--quick",
            "--workers",
            "1",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "long_horizon.png").read_bytes()[:4] == b"\x89PNG"
    data = json.loads((tmp_path / "long_horizon.json").read_text())
    assert data["benchmark"] == "long_horizon" and data["quick"]
    assert list(data["measures"]) == list(lh.MEASURES)
    assert data["thresholds"] == list(lh.THRESHOLDS) and data["statuses"] == {"done": 1}
    assert set(data["families"]) == set(lh.QUICK_FAMILIES)
    folder = tmp_path / "sweeps" / "long_horizon"
    assert (folder / "results.nc").is_file() and len(list((folder / "cells").glob("*.json"))) == 1
    assert not any((folder / "journal").iterdir())  # a recorded cell's journal is removed
    (cell,) = data["summary"]["cells"]
    assert cell["size"] == 10 and cell["horizon"] == 0.5
    assert 0.0 < cell["predictability_time"] <= cell["horizon"]
    methods = [r["method"] for r in data["rows"]]
    assert methods[:4] == [
        "reference",
        "reference, perturbed start",
        "reference, quarter step",
        "explicit",
    ]
    assert {r["dt"] for r in data["rows"] if r["method"] == "implicit"} == {
        1 / rate for rate in lh.QUICK_RATES
    }
    for row in data["rows"]:
        # every run sampled at least every 1/32 s on the 1/64 s grid, from 0 to T
        assert row["sample_seconds"] in (1 / 64, 1 / 32)
        assert len(row["kinetic_energy"]) == round(0.5 / row["sample_seconds"]) + 1
        assert math.isclose(row["steps"] * row["dt"], 0.5)
        assert all(row[m] >= 0.0 for m in lh.MEASURES) and is_timing(row["cpu_seconds"])
        assert row["repeats"] == len(row["cpu_seconds_samples"]) in (1, 3)
    assert data["rows"][0]["kinetic_energy_history"] == 0.0
    explicit = data["rows"][3]
    assert explicit["at_limit"] and explicit["repeats"] == 3
    assert explicit["dt"] <= cell["trial_limit_dt"]
    for measure in lh.MEASURES:
        floors = cell["floors"][measure]
        assert floors["floor"] == max(floors["quarter_step"], floors["perturbed_start"])
        for threshold in lh.THRESHOLDS:
            verdict = cell["verdicts"][measure][f"at_{threshold:g}"]
            assert verdict["judged"] == (floors["floor"] < threshold / 3)
            if "implicit_over_explicit_cost" in verdict:
                best = verdict["best_implicit"]
                assert best[measure] <= threshold and math.isclose(
                    verdict["implicit_over_explicit_cost"],
                    best["cost_seconds_per_simulated_second"]
                    / explicit["cost_seconds_per_simulated_second"],
                )


@pytest.mark.slow  # two small benchmark runs on Dask
def test_a_merge_joins_the_families_only_the_earlier_run_has(tmp_path):
    pytest.importorskip("matplotlib")

    def quick(out, *argv):
        return subprocess.run(
            [
                sys.executable,
                "-m",
                "benchmarks.long_horizon",
                "--out",
                str(out),
                "--quick",
                "--workers",
                "1",
                *argv,
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=600,
        )

    first = quick(tmp_path / "a", "--families", "implicit")
    assert first.returncode == 0, first.stderr
    earlier = tmp_path / "a" / "long_horizon.json"
    second = quick(tmp_path / "b", "--families", "bdf2 auto 1e-2", "--merge", str(earlier))
    assert second.returncode == 0, second.stderr
    data = json.loads((tmp_path / "b" / "long_horizon.json").read_text())
    # the union, this run's first; the earlier-only family keeps its options
    assert data["families"] == ["explicit", "bdf2 auto 1e-2", "implicit"]
    assert data["family_options"]["implicit"] == lh.FAMILIES["implicit"]
    (cell,) = data["summary"]["cells"]  # the same cell in both: this run's, which lacks one
    assert cell["families_missing"] == ["implicit"]
    assert {r["method"] for r in data["rows"]} >= {"bdf2 auto 1e-2"}
    assert "implicit" not in {r["method"] for r in data["rows"]}
    (entry,) = cell["at_tolerance"]  # the row at tolerance, read off
    assert entry["family"] == "bdf2 auto 1e-2" and entry["internal_steps"] > 0
    # a family both ran, with other options, cannot merge
    payload = json.loads(earlier.read_text())
    payload["family_resolved_options"]["implicit"]["newton_tol"] = 1.0
    earlier.write_text(json.dumps(payload))
    third = quick(tmp_path / "c", "--families", "implicit", "--merge", str(earlier))
    assert third.returncode == 2
    assert "with other options" in third.stderr and "implicit" in third.stderr
