"""The rows "at tolerance" of the crossover and the long horizon (benchmarks/tolerance.py):
what a cell reads off them, on rows whose numbers are chosen so every answer is known."""

import math

import pytest

from benchmarks import crossover, long_horizon, tolerance


def run(
    method, error, cpu, steps, internal=None, factorizations=0, iterations=None, dt=0.25, **extra
):
    row = {
        "method": method,
        "error": error,
        "cpu_seconds": cpu,
        "horizon": 0.5,
        "cost_seconds_per_simulated_second": cpu / 0.5,
        "steps": steps,
        "dt": dt,
        "internal_steps": internal,
        "factorizations": factorizations,
        "iterations": iterations if iterations is not None else factorizations,
        "repeats": 1,
    }
    row.update(extra)
    return row


def test_every_row_at_tolerance_is_a_family_of_both_benchmarks_with_atol_a_tenth_of_rtol():
    for names, table in (
        (tolerance.families(), long_horizon.FAMILIES),
        (tolerance.families(crossover.TOLERANCE_LABELS), crossover.FAMILIES),
    ):
        assert len(names) == len(tolerance.METHODS) * len(tolerance.TOLERANCES)
        for name, options in names.items():
            assert table[name] == options
            assert options["atol"] == pytest.approx(options["rtol"] / 10, rel=1e-15)
    assert set(tolerance.families()) <= set(long_horizon.ERROR_CONTROLLED)
    assert set(tolerance.families(crossover.TOLERANCE_LABELS)) <= set(crossover.ERROR_CONTROLLED)
    # the fixed-step families are not error-controlled
    assert "bdf2" not in long_horizon.ERROR_CONTROLLED
    assert "BDF2 default" not in crossover.ERROR_CONTROLLED


def test_slope_per_step_figures_and_the_cheapest_fixed_step_run_as_accurate():
    groups = {"tr-bdf2 auto": (("t 1e-2", 1e-2), ("t 1e-3", 1e-3), ("t 1e-4", 1e-4))}
    rows = [
        run("explicit", 1e-4, 10.0, 1000, at_limit=True),
        # fixed-step rows: the cheaper one is less accurate than every tolerance row
        run("bdf2", 2e-2, 0.5, 16, internal=16, factorizations=48),
        run("bdf2", 1e-3, 4.0, 64, internal=64, factorizations=128),
        run("bdf2", 5e-5, 9.0, 256, internal=256, factorizations=512, flagged=True),
        # error falls tenfold per tolerance, then only threefold (slope log10(3))
        run("t 1e-2", 1e-2, 1.0, 2, internal=20, factorizations=10, iterations=30),
        run("t 1e-3", 1e-3, 2.0, 2, internal=40, factorizations=10, iterations=80),
        run("t 1e-4", 1e-3 / 3, 6.0, 2, internal=200, factorizations=20, iterations=400),
    ]
    entries = tolerance.at_tolerance(rows, 1e-5, explicit_cost=20.0, fixed=["bdf2"], groups_=groups)
    loose, middle, tight = entries
    assert "slope" not in loose
    assert middle["slope"] == pytest.approx(1.0)
    assert tight["slope"] == pytest.approx(math.log10(3))
    assert middle["internal_steps"] == 40
    assert middle["factorizations_per_step"] == pytest.approx(0.25)
    assert middle["iterations_per_step"] == pytest.approx(2.0)
    assert middle["cpu_per_step"] == pytest.approx(0.05)
    assert middle["mean_dt"] == pytest.approx(0.5 / 40)
    assert middle["cost_over_explicit"] == pytest.approx(4.0 / 20.0)
    # as accurate: bdf2 at 1e-3 (4 CPU s); the 5e-5 run is flagged (unconverged), not counted
    assert middle["fixed_error"] == 1e-3
    assert middle["cost_over_fixed"] == pytest.approx(0.5)
    assert middle["fixed_factorizations_per_step"] == pytest.approx(2.0)
    assert loose["cost_over_fixed"] == pytest.approx(1.0 / 4.0)
    assert "fixed" not in tight  # no usable fixed-step run is that accurate


def test_slopes_are_judged_only_above_three_times_the_floor_and_failures_break_the_chain():
    groups = {"cvode": (("c 1e-2", 1e-2), ("c 1e-3", 1e-3), ("c 1e-4", 1e-4))}
    rows = [
        run("c 1e-2", 1e-2, 1.0, 2, internal=10),
        run("c 1e-3", 2.9e-4, 1.0, 2, internal=10),  # within 3 × the floor (1e-4)
        run("c 1e-4", 1e-5, 1.0, 2, internal=10),
    ]
    entries = tolerance.at_tolerance(rows, 1e-4, 1.0, [], groups)
    assert [("slope" in e) for e in entries] == [False, False, False]
    rows[1] = {"method": "c 1e-3", "diverged": True, "aborted": None, "steps": 2}
    entries = tolerance.at_tolerance(rows, 1e-7, 1.0, [], groups)
    assert entries[1]["failed"] == "diverged"
    assert "slope" not in entries[2]  # no slope across a failed row
    assert tolerance.slopes(entries) == []


def test_the_table_has_one_line_of_ten_columns_per_row():
    groups = {"bdf2 auto": (("b 1e-2", 1e-2), ("b 1e-3", 1e-3))}
    rows = [
        run("b 1e-2", 1e-2, 1.0, 2, internal=10),
        {"method": "b 1e-3", "diverged": False, "aborted": "CPU cap", "steps": 2},
    ]
    lines = tolerance.table(tolerance.at_tolerance(rows, 1e-6, 2.0, [], groups), "32²")
    head = tolerance.TABLE_HEAD[0].count("|")
    assert len(lines) == 2 and all(line.count("|") == head for line in lines)
    assert "failed: CPU cap" in lines[1]


def test_the_summary_counts_the_stiff_cells_against_the_cheapest_fixed_step_run():
    def entry(method, k_over, cost_over_fixed=None, slope=None, fact=0.5):
        e = {
            "method": method,
            "family": method,
            "rtol": 1e-3,
            "error": 1e-3,
            "factorizations_per_step": fact,
        }
        if cost_over_fixed is not None:
            e["cost_over_fixed"] = cost_over_fixed
        if slope is not None:
            e["slope"] = slope
        return e

    cells = [
        ("a", 2e5, [entry("m", 1, 0.4, fact=0.1), entry("m", 1, 1.1, slope=0.8)]),
        ("b", 2e6, [entry("m", 1, 1.5, slope=1.2, fact=3.0)]),
        ("soft", 2e3, [entry("m", 1, 0.1, fact=9.0)]),  # not stiff: not counted
        ("c", 2e7, [{"method": "m", "family": "m", "rtol": 1e-2, "failed": "diverged"}]),
    ]
    (line,) = tolerance.summary_lines(cells, "X")
    assert "4 of 5 rows ran (1 diverged" in line
    assert "0.80–1.20 in the 2 judged" in line
    assert "0.10–3.00 factorizations per internal step" in line
    assert (
        "0.40–1.50 of the cheapest fixed-step run as accurate (2 of 3 at most 1.2, 1 at most "
        "0.5)" in line
    )


def test_per_threshold_the_cheapest_controlled_run_over_the_cheapest_fixed_step_run():
    rows = [
        run("fixed", 2e-2, 1.0, 8),
        run("fixed", 5e-3, 3.0, 32),
        run("fixed", 8e-4, 9.0, 128),
        run("fixed", 1e-4, 0.5, 128, flagged=True),
        run("auto 1e-2", 6e-3, 1.2, 2),
        run("auto 1e-3", 9e-4, 2.0, 2),
    ]
    loose, tight, tightest = tolerance.at_thresholds(
        rows, [1e-2, 1e-3, 1e-4], ["fixed"], ["auto 1e-2", "auto 1e-3"]
    )
    # 1 %: auto 1e-2 (1.2 s) against fixed at 5e-3 (3 s); 0.1 %: auto 1e-3 (2 s) against 9 s
    assert loose["controlled"]["method"] == "auto 1e-2"
    assert loose["controlled_over_fixed"] == pytest.approx(1.2 / 3.0)
    assert tight["controlled"]["method"] == "auto 1e-3"
    assert tight["controlled_over_fixed"] == pytest.approx(2.0 / 9.0)
    # 0.01 %: only a flagged (unconverged) fixed-step run got there, and it does not count
    assert "controlled" not in tightest and "fixed" not in tightest
    assert "controlled_over_fixed" not in tightest
    verdicts = [("a", 2e5, [loose, tight]), ("b", 2e3, [loose])]
    lines = tolerance.summary_lines([], "X", verdicts)
    assert lines[0].startswith("X within 1 %, stiff sheets (k ≥ 200000 N/m): 1 cells judged")
    assert "0.40–0.40" in lines[0] and "(1 at most 1.2, 1 at most 0.5)" in lines[0]
    assert lines[1].startswith("X within 0.1 %")


def test_a_row_recorded_without_its_internal_steps_has_no_per_step_figures():
    groups = {"tr-bdf2 auto": (("t 1e-4", 1e-4),)}
    rows = [run("t 1e-4", 1e-3, 4.0, 128, internal=None, factorizations=600)]
    (entry,) = tolerance.at_tolerance(rows, 1e-5, 2.0, [], groups)
    assert entry["internal_steps"] is None and entry["factorizations_per_step"] is None
    assert entry["cpu_per_step"] is None and entry["cost_over_explicit"] == pytest.approx(4.0)
    (line,) = tolerance.table([entry], "c")
    assert line.count("| – |") >= 3 and "600" not in line
    (summary,) = tolerance.summary_lines([("c", 2e5, [entry])], "X")
    assert "factorizations" not in summary
