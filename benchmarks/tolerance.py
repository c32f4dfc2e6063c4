"""Rows "at tolerance" (issue 40, item 4): the error-controlled integrators at rtol 1e-2, 1e-3
and 1e-4 as families of the crossover and of the long-horizon benchmark, and what is read off
them in each cell.

A row at tolerance is one run whose steps its tolerance chooses; its `dt` is the output interval
(1/64 s). Per cell and method (yore's own TR-BDF2 and BDF2 with dt="auto", and CVODE), for each
tolerance, `at_tolerance` reports:
- the achieved error (the benchmark's own: the crossover's trajectory error, the long horizon's
  kinetic-energy history) beside the reference's floor;
- the log–log slope of the error against rtol from the next looser tolerance, judged only where
  both errors are above SLOPE_FLOOR times the floor (below that the floor, not the tolerance,
  sets the error);
- internal steps, factorizations and Newton iterations per internal step, CPU per internal step;
- its cost over explicit's at the limit, and over the cheapest fixed-step implicit run of the same
  cell (same task, same clock) that is at least as accurate, with that run's factorizations and
  CPU per step: "at equal achieved error".
"""

from __future__ import annotations

import math

#: tolerance names and values: atol = rtol / 10 m (benchmarks.error_control's setting)
TOLERANCES = {"1e-2": 1e-2, "1e-3": 1e-3, "1e-4": 1e-4}
#: method → the options its rows share (each row adds rtol and atol)
METHODS = {
    "tr-bdf2 auto": {"integrator": "tr-bdf2", "adaptive": True},
    "bdf2 auto": {"integrator": "bdf2", "adaptive": True},
    "cvode": {"integrator": "cvode"},
}
SLOPE_FLOOR = 3.0  # a slope is judged where both errors exceed this × the floor
OUTPUT_RATE = 64  # output intervals per simulated second (dt of a row at tolerance)


def family_name(method, tolerance, label=None):
    """The display name of one row: "tr-bdf2 auto 1e-3" (label maps the method's name)."""
    return f"{(label or {}).get(method, method)} {tolerance}"


def families(label=None, methods=None):
    """{display name: yore.Simulation options} of every row at tolerance."""
    return {
        family_name(m, name, label): {**METHODS[m], "rtol": rtol, "atol": rtol / 10}
        for m in (methods or METHODS)
        for name, rtol in TOLERANCES.items()
    }


def groups(label=None, methods=None):
    """{method: ((display name, rtol), ...)}, loosest tolerance first."""
    return {
        m: tuple((family_name(m, name, label), rtol) for name, rtol in TOLERANCES.items())
        for m in (methods or METHODS)
    }


def is_error_controlled(options):
    """Whether a family's steps are chosen by a tolerance (one run, dt = output interval)."""
    return bool(options.get("adaptive")) or options.get("integrator") in ("cvode", "arkode")


def internal_steps(sim):
    """The steps a run took: SUNDIALS' internal steps, else yore's own step count."""
    counters = sim.stats["counters"]
    if "internal_steps" in counters:
        return int(counters["internal_steps"])
    return int(sim.stats["steps"])


def _usable(row):
    return "error" in row and not row.get("unstable") and not row.get("flagged")


def at_tolerance(rows, floor, explicit_cost, fixed, groups_):
    """One entry per row at tolerance of one cell (see the module's docstring). rows: the
    cell's run rows (method, error, cpu_seconds, cost_seconds_per_simulated_second, steps,
    factorizations, iterations, horizon; internal_steps where recorded); floor: the
    reference's floor of that error; explicit_cost: explicit's CPU s per simulated s at its
    limit; fixed: the names of the fixed-step implicit families."""
    cost = "cost_seconds_per_simulated_second"
    fixed_rows = [r for r in rows if r["method"] in fixed and _usable(r)]
    out = []
    for method, members in groups_.items():
        previous = None
        for family, rtol in members:
            r = next((r for r in rows if r["method"] == family), None)
            if r is None:
                continue
            entry = {"method": method, "family": family, "rtol": rtol, "floor": floor}
            if "error" not in r:
                entry["failed"] = (
                    "diverged" if r.get("diverged") else r.get("aborted") or "no error measured"
                )
                out.append(entry)
                previous = None
                continue
            # a row recorded before internal steps were has none: no per-step figures
            steps = r.get("internal_steps")
            per = (lambda value: value / max(int(steps), 1)) if steps else (lambda value: None)
            entry.update(
                error=r["error"],
                internal_steps=steps,
                mean_dt=per(r["horizon"]),
                factorizations_per_step=per(r["factorizations"]),
                iterations_per_step=per(r["iterations"]),
                cpu_per_step=per(r["cpu_seconds"]),
                cost=r[cost],
                repeats=r.get("repeats", 1),
                flagged=bool(r.get("flagged")),
                cost_over_explicit=(r[cost] / explicit_cost if explicit_cost else None),
            )
            counters = r.get("counters") or {}
            rejected = counters.get("rejected_steps", counters.get("error_test_failures"))
            if rejected is not None:
                entry["rejected_steps"] = int(rejected)
            as_good = [f for f in fixed_rows if f["error"] <= r["error"]]
            if as_good:
                best = min(as_good, key=lambda f: f[cost])
                entry.update(
                    fixed=best["method"],
                    fixed_dt=best["dt"],
                    fixed_error=best["error"],
                    cost_over_fixed=r[cost] / best[cost],
                    fixed_factorizations_per_step=best["factorizations"] / best["steps"],
                    fixed_cpu_per_step=best["cpu_seconds"] / best["steps"],
                )
            if (
                previous is not None
                and floor is not None
                and min(previous["error"], r["error"]) > SLOPE_FLOOR * floor
            ):
                entry["slope"] = math.log10(previous["error"] / r["error"]) / math.log10(
                    previous["rtol"] / rtol
                )
            out.append(entry)
            previous = entry
    return out


def at_thresholds(rows, thresholds, fixed, controlled):
    """Per judged threshold: the cheapest error-controlled run and the cheapest fixed-step
    implicit run meeting it, and the ratio of their costs (the issue's "≤ 1.2×, ≤ 0.5× in half
    the cells"). thresholds: the judged ones; fixed, controlled: family names."""
    cost = "cost_seconds_per_simulated_second"
    out = []
    for threshold in thresholds:

        def cheapest(names):
            meeting = [
                r for r in rows if r["method"] in names and _usable(r) and r["error"] <= threshold
            ]
            return min(meeting, key=lambda r: r[cost], default=None)

        mine, theirs = cheapest(controlled), cheapest(fixed)
        entry = {"threshold": threshold}
        for side, r in (("controlled", mine), ("fixed", theirs)):
            if r is not None:
                entry[side] = {
                    "method": r["method"],
                    "dt": r["dt"],
                    "error": r["error"],
                    "cost": r[cost],
                }
        if mine is not None and theirs is not None:
            entry["controlled_over_fixed"] = mine[cost] / theirs[cost]
        out.append(entry)
    return out


def slopes(entries):
    """Every judged slope of a list of at_tolerance entries (for the summary)."""
    return [e["slope"] for e in entries if "slope" in e]


def table(entries, cell_name):
    """Markdown rows of one cell's entries (for the Results page)."""

    def number(value, form="{:.3g}"):
        return "–" if value is None else form.format(value)

    lines = []
    for e in entries:
        head = f"| {cell_name} | {e['family']} |"
        if "failed" in e:
            lines.append(head + f" failed: {str(e['failed'])[:70]} |" + " |" * 7)  # 10 columns
            continue
        fixed = (
            "–"
            if "fixed" not in e
            else f"{e['cost_over_fixed']:.2f} ({e['fixed']} {e['fixed_dt']:.3g} s, "
            f"{e['fixed_factorizations_per_step']:.1f} fact./step)"
        )
        cpu_ms = None if e["cpu_per_step"] is None else 1e3 * e["cpu_per_step"]
        lines.append(
            head + f" {e['error']:.2e} (floor {number(e['floor'], '{:.1e}')}) | "
            f"{number(e.get('slope'), '{:.2f}')} | "
            f"{number(e['internal_steps'], '{}')} | "
            f"{number(e['factorizations_per_step'], '{:.2f}')} | "
            f"{number(e['iterations_per_step'], '{:.1f}')} | {number(cpu_ms)} | "
            f"{number(e['cost_over_explicit'], '{:.2f}')} | {fixed} |"
        )
    return lines


TABLE_HEAD = [
    "| cell | row | error | slope vs rtol | internal steps | factorizations / step "
    "| Newton / step | CPU ms / step | × explicit | × cheapest fixed step as accurate |",
    "|---|---|---|---|---|---|---|---|---|---|",
]


STIFF = 2e5  # N/m: the stiff sheets of the targets (k ≥ STIFF)


def summary_lines(cells, what, verdicts=()):
    """Sentences over cells [(name, stiffness, entries)] of one benchmark (what: its name):
    the judged slopes, factorizations per internal step on the stiff sheets, and the cost at
    equal achieved error against the cheapest fixed-step run as accurate, per method; then,
    from verdicts [(name, stiffness, at_thresholds entries)], per threshold on the stiff
    sheets, the cheapest error-controlled run over the cheapest fixed-step one."""
    lines = []
    thresholds = sorted({e["threshold"] for _, _, found in verdicts for e in found}, reverse=True)
    for threshold in thresholds:
        found = [
            (name, e)
            for name, k, entries in verdicts
            if k >= STIFF
            for e in entries
            if e["threshold"] == threshold
        ]
        ratios = [
            (name, e["controlled_over_fixed"]) for name, e in found if "controlled_over_fixed" in e
        ]
        if not found:
            continue
        text = (
            f"{what} within {100 * threshold:g} %, stiff sheets (k ≥ {STIFF:g} N/m): "
            f"{len(found)} cells judged"
        )
        if ratios:
            values = [v for _, v in ratios]
            text += (
                f"; the cheapest error-controlled run costs {min(values):.2f}–"
                f"{max(values):.2f} of the cheapest fixed-step implicit run in the "
                f"{len(ratios)} where both met it ({sum(v <= 1.2 for v in values)} at most "
                f"1.2, {sum(v <= 0.5 for v in values)} at most 0.5)"
            )
        missing = [name for name, e in found if "controlled_over_fixed" not in e]
        if missing:
            text += "; not both met it in " + ", ".join(missing)
        lines.append(text + ".")
    methods = list(dict.fromkeys(e["method"] for _, _, entries in cells for e in entries))
    for method in methods:
        mine = [
            (name, k, e) for name, k, entries in cells for e in entries if e["method"] == method
        ]
        done = [(name, k, e) for name, k, e in mine if "failed" not in e]
        failed = len(mine) - len(done)
        found = slopes([e for _, _, e in done])
        stiff = [e for _, k, e in done if k >= STIFF]
        versus = [e["cost_over_fixed"] for e in stiff if "cost_over_fixed" in e]
        text = f"{what}, {method}: {len(done)} of {len(mine)} rows ran" + (
            f" ({failed} diverged or stopped at the CPU cap)" if failed else ""
        )
        text += "; slope of error against rtol " + (
            f"{min(found):.2f}–{max(found):.2f} in the {len(found)} judged"
            if found
            else "judged nowhere (no two consecutive rows both above "
            f"{SLOPE_FLOOR:g} times the floor)"
        )
        if stiff:
            per_step = [
                e["factorizations_per_step"]
                for e in stiff
                if e["factorizations_per_step"] is not None
            ]
            if per_step:
                text += (
                    f"; on the stiff sheets (k ≥ {STIFF:g} N/m) {min(per_step):.2f}–"
                    f"{max(per_step):.2f} factorizations per internal step"
                )
        if versus:
            text += (
                f", {min(versus):.2f}–{max(versus):.2f} of the cheapest fixed-step run as "
                f"accurate ({sum(v <= 1.2 for v in versus)} of {len(versus)} at most 1.2, "
                f"{sum(v <= 0.5 for v in versus)} at most 0.5)"
            )
        elif stiff:
            text += ", no fixed-step run as accurate to compare with"
        lines.append(text + ".")
    return lines
