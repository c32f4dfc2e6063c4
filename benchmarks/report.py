"""Writes the results pages of the documentation from the JSON in bench-results/ (run by
`make bench`), so the words there are the numbers the benchmarks wrote: one page per benchmark
in docs/results/ (each opens with where its numbers come from, so it reads alone) and their
index in docs/results.md.

    python -m benchmarks.report [--results bench-results] [--page docs/results.md]

Only the part of the index page between the markers START and END is rewritten; the prose
around it is the page's own. The folder of pages is named after the index page and rewritten
whole. Pictures are linked relative to the pages, so they resolve in the Sphinx build and on a
code host alike. `--readme` is the former name of `--page` and still works. Quick runs (make
bench-quick) are refused: the pages show full-size results only.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from .crossover import REFERENCE_FRACTION, finding, stiffest_judged_text, summary_table
from .schema import SCHEMAS, check

START, END = "<!-- results:start -->", "<!-- results:end -->"


def load(results: Path) -> dict:
    data = {}
    for name in SCHEMAS:
        payload = json.loads((results / f"{name}.json").read_text())
        check(payload)
        if payload.get("quick"):
            raise SystemExit(f"{name}.json comes from a quick run; run `make bench` first")
        data[name] = payload
    return data


def duration(seconds: float) -> str:
    """A wall time in ms below a second, in s above."""
    return f"{seconds:.3g} s" if seconds >= 1.0 else f"{1e3 * seconds:.3g} ms"


def verdict(met: bool) -> str:
    return "**met**" if met else "**missed**"


def crossover_section(crossover: dict, images: str) -> list:
    """The crossover's lines: the map, one line per cell, the crossover stiffness per row, the
    issue's targets and one sentence on who wins where and why (all from crossover.json).
    ``images``: the folder of the PNG files as the page links it."""
    settings = crossover["settings"]
    out = [
        "## The crossover",
        "",
        f"![crossover map]({images}/crossover.png)",
        "",
        f"`benchmarks/crossover.py` on the `yore.sweep` engine ({crossover['cells']} cells, one "
        "Dask task each: "
        + ", ".join(f"{n} {s}" for s, n in crossover["statuses"].items())
        + "). Error: RMS vertex distance to a converged symplectic-Euler reference at T/2 and "
        "at T (the larger) over the sheet's start diagonal; cost: CPU seconds of the stepping "
        "per simulated second on one thread (the task's thread clock; medians of "
        f"{settings['repeats']} runs for every run that could be its family's cheapest); "
        "explicit at its largest stable step, found by bisection. An error threshold is "
        "judged only in cells whose reference converged to a tenth of it ("
        + ", ".join(
            f"{REFERENCE_FRACTION * t:g} for {100 * t:g} %" for t in crossover["thresholds"]
        )
        + "). Families: "
        f"{', '.join(crossover['families'])}"
        + (
            f" (not in this build: {'; '.join(crossover['families_unavailable'])})"
            if crossover["families_unavailable"]
            else ""
        )
        + ".",
        "",
    ]
    from .crossover import BENDING_ROWS, SIZES, STIFFNESSES

    full = (list(SIZES), [float(k) for k in STIFFNESSES], list(BENDING_ROWS))
    ran = (settings["sizes"], [float(k) for k in settings["stiffness"]], settings["bending"])
    if ran != full:
        out += [
            f"Only part of the grid ran: sizes {', '.join(f'{n}²' for n in ran[0])}; "
            f"stiffness {', '.join(f'{k:g}' for k in ran[1])} N/m; bending "
            f"{', '.join(ran[2])}; a run's CPU cap {settings['max_run_seconds']:g} s. The "
            f"full grid ({len(SIZES)} sizes × {len(STIFFNESSES)} stiffnesses × "
            f"{len(BENDING_ROWS)} bending rows) has not run here.",
            "",
        ]
    out += summary_table(crossover)
    dropped = {}  # (family, why) → the cells that left it out
    for c in crossover["summary"]["cells"]:
        for name, why in c.get("families_dropped", {}).items():
            dropped.setdefault((name, why.split(": ", 1)[-1]), []).append(
                f"{c['size']}² k = {c['stretch_stiffness']:g} {c['bending']}"
            )
    if dropped:
        out += [
            "",
            "Families left out of cells merged from an earlier run, which ran them with "
            "other options than today's or not at all (a number is kept only with the options "
            "it ran with): "
            + "; ".join(
                f"{name} ({why}) in {', '.join(sorted(cells))}"
                for (name, why), cells in sorted(dropped.items())
            )
            + ".",
        ]
    crossing = crossover["summary"]["crossovers"]
    if crossing:
        out += [
            "",
            "Crossover stiffness (implicit / explicit cost at 1 % crosses 1): "
            + "; ".join(
                f"{x['size']}², {x['bending']} bending: "
                + (
                    f"{x['crossover_stiffness']:.2g} N/m"
                    if x["crossover_stiffness"]
                    else x.get("bound", "no data")
                )
                for x in crossing
            )
            + ".",
        ]
    out += ["", "Targets (cheapest implicit over cheapest explicit cost):", ""]
    for g in crossover["summary"]["targets"]:
        head = (
            f"- {g['target']}, goal {'<' if g['goal_ratio'] == 1.0 else '≤'} {g['goal_ratio']:g}: "
        )
        if g["ratio"] is None:
            out.append(
                head
                + ("**missed**" if g["measured"] else "**not measured**")
                + " ("
                + "; ".join(f"{c['bending']}: {c['why']}" for c in g["cells"] if c.get("why"))
                + stiffest_judged_text(g)
                + ")"
            )
            continue
        best = g["best"]
        out.append(
            head + verdict(g["met"]) + f" ({g['ratio']:.2f}, {best['bending']} bending; "
            f"{best['implicit']['method']} {best['implicit']['steps']} steps × "
            f"{duration(best['implicit']['cpu_per_step'])} against explicit's "
            f"{best['explicit']['steps']} × {duration(best['explicit']['cpu_per_step'])})"
        )
    out += ["", finding(crossover)]
    return out


def _cell_name(c):
    return f"{c['size']}² k = {c['stretch_stiffness']:g} {c['bending']}"


def _long_horizon_verdict(cell, measure, threshold, detail=True):
    """A cell's verdict at (measure, threshold) as a table entry: the cheapest implicit run over
    explicit's cost, "not judged" (with the floor) where the floor forbids, or why not."""
    if cell.get("status") != "done":
        return f"{cell.get('status')}" + (f": {cell['skipped']}" if cell.get("skipped") else "")
    verdict = cell.get("verdicts", {}).get(measure, {}).get(f"at_{threshold:g}")
    if verdict is None:
        return "no verdict (no floors or no stable explicit run)"
    if not verdict["judged"]:
        return f"not judged (floor {verdict['floor']:.1e})"
    if "implicit_over_explicit_cost" in verdict:
        best = verdict["best_implicit"]
        ratio = verdict["implicit_over_explicit_cost"]
        return (f"**{ratio:.2f}**" if ratio < 1 else f"{ratio:.2f}") + (
            f" ({best['method']} {best['dt']:.3g} s)" if detail else ""
        )
    return "explicit (no implicit run met it)"


def long_horizon_section(payload: dict, images: str) -> list:
    """The long horizon's lines (from long_horizon.json): the map of the ladder's measure at the
    largest threshold, one table per measure (verdicts at each threshold, "not judged" where
    the floor forbids), the per-run table of one cell, the summary lines."""
    from .long_horizon import FLOOR_FRACTION, LADDER_MEASURE, key

    settings, thresholds = payload["settings"], payload["thresholds"]
    cells = sorted(payload["summary"]["cells"], key=key)
    out = [
        "## The long horizon",
        "",
        f"![long horizon]({images}/long_horizon.png)",
        "",
        f"`benchmarks/long_horizon.py` on the `yore.sweep` engine ({len(cells)} "
        f"cell{'s' if len(cells) != 1 else ''}: "
        + ", ".join(f"{n} {s}" for s, n in payload["statuses"].items())
        + "): the "
        "crossover's sheets over T = "
        + f"{settings['horizon']:g} s"
        + "".join(f" ({n}²: {t:g} s)" for n, t in settings["horizon_at"])
        + ", sampled every 1/64 s. Measures, each against explicit at half its limit: "
        + "; ".join(f"{m.replace('_', ' ')}: {text}" for m, text in payload["measures"].items())
        + f". A threshold is judged only where the measure's floor (the larger of explicit at "
        "a quarter of its limit and the reference from a start moved by round-off, each "
        f"against the reference) is below {FLOOR_FRACTION:.2g} of it. Cost: CPU seconds of the "
        "stepping per simulated second, one thread, explicit at its bisected limit as the "
        "denominator; ratios below 1 (bold) are implicit wins. Families: "
        + ", ".join(payload["families"])
        + (
            f" (not in this build: {'; '.join(payload['families_unavailable'])})"
            if payload.get("families_unavailable")
            else ""
        )
        + ".",
        "",
    ]
    from .long_horizon import BENDING_ROWS, SIZES, STIFFNESSES

    full = (list(SIZES), [float(k) for k in STIFFNESSES], list(BENDING_ROWS))
    ran = (
        list(settings["sizes"]),
        [float(k) for k in settings["stiffness"]],
        list(settings["bending"]),
    )
    if ran != full:
        out += [
            f"Only part of the grid ran: sizes {', '.join(f'{n}²' for n in ran[0])}; "
            f"stiffness {', '.join(f'{k:g}' for k in ran[1])} N/m; bending "
            f"{', '.join(ran[2])}. The full grid ({len(SIZES)} sizes × {len(STIFFNESSES)} "
            f"stiffnesses × {len(BENDING_ROWS)} bending rows) has not run here.",
            "",
        ]
    # the map: rows (bending, size), columns stiffness, at the largest threshold
    top = max(thresholds)
    rows = sorted({(c["bending"], c["size"]) for c in cells})
    stiffnesses = sorted({c["stretch_stiffness"] for c in cells})
    out += [
        f"Map: {LADDER_MEASURE.replace('_', ' ')} within {100 * top:g} %, cheapest implicit "
        "over explicit.",
        "",
        "| sheet | " + " | ".join(f"k = {k:g}" for k in stiffnesses) + " |",
        "|---|" + "---|" * len(stiffnesses),
    ]
    for bending, size in rows:
        entries = []
        for k in stiffnesses:
            cell = next((c for c in cells if key(c) == (size, k, bending)), None)
            entries.append(
                "–" if cell is None else _long_horizon_verdict(cell, LADDER_MEASURE, top)
            )
        out.append(f"| {size}² {bending} | " + " | ".join(entries) + " |")
    for measure, text in payload["measures"].items():
        out += [
            "",
            f"### {measure.replace('_', ' ').capitalize()}",
            "",
            f"{text}.",
            "",
            "| cell | T | floor | "
            + " | ".join(f"within {100 * t:g} %" for t in thresholds)
            + " |",
            "|---|---|---|" + "---|" * len(thresholds),
        ]
        for c in cells:
            floor = (c.get("floors") or {}).get(measure, {}).get("floor")
            out.append(
                f"| {_cell_name(c)} | {c['horizon']:g} s | "
                + ("–" if floor is None else f"{floor:.1e}")
                + " | "
                + " | ".join(_long_horizon_verdict(c, measure, t) for t in thresholds)
                + " |"
            )
    # the per-run table of one cell: 64² k = 2e5 equal where it ran, else the one with most runs
    done = [c for c in cells if c.get("status") == "done"]
    if done:
        counts = {key(c): sum(key(r) == key(c) for r in payload["rows"]) for c in done}
        shown = next(
            (c for c in done if key(c) == (64, 2e5, "equal")),
            max(done, key=lambda c: counts[key(c)]),
        )
        measures = list(payload["measures"])
        out += [
            "",
            f"### Every run of {_cell_name(shown)}",
            "",
            f"Predictability time {shown.get('predictability_time', float('nan')):g} s"
            + (
                ""
                if shown.get("predictability_reached")
                else " (the references never parted: the whole run)"
            )
            + "; explicit's trial limit "
            f"{shown.get('trial_limit_dt', float('nan')):.3g} s. CPU s/s: medians of the "
            "repeats given.",
            "",
            "| run | dt (s) | "
            + " | ".join(m.replace("_", " ") for m in measures)
            + " | CPU s/s (repeats) | Newton per step |",
            "|---|---|" + "---|" * (len(measures) + 2),
        ]
        for r in payload["rows"]:
            if key(r) != key(shown):
                continue
            head = (
                f"| {r['method']}"
                + (" at its limit" if r.get("at_limit") else "")
                + f" | {r['dt']:.3g} | "
            )
            if r["diverged"] or r["aborted"]:
                why = "diverged" if r["diverged"] else f"aborted: {r['aborted']}"
                out.append(head + " | ".join([why] + [""] * (len(measures) + 1)) + " |")
                continue
            cost = r.get("cost_seconds_per_simulated_second")
            out.append(
                head
                + " | ".join(f"{r[m]:.2e}" for m in measures)
                + " | "
                + (
                    "–"
                    if cost is None or r["method"].startswith("reference")
                    else f"{cost:.3g} ({r.get('repeats', 1)})"
                )
                + " | "
                + (
                    f"{r['iterations'] / (r.get('internal_steps') or r['steps']):.2f}"
                    if r["method"]
                    not in (
                        "explicit",
                        "reference",
                        "reference, perturbed start",
                        "reference, quarter step",
                    )
                    and "iterations" in r
                    else "–"
                )
                + (f" ({r['unconverged_steps']} unconverged)" if r.get("unconverged_steps") else "")
                + " |"
            )
    out += [""] + [f"- {line}" for line in payload["summary"]["lines"]]
    return out


def numerical_damping_section(payload: dict, images: str) -> list:
    """The numerical-damping lines (from numerical_damping.json): one linear mode against each
    scheme's analytic amplification, and the energy the swinging sheet keeps."""
    chain = payload["chain"]
    out = [
        "## Numerical damping",
        "",
        f"![numerical damping]({images}/numerical_damping.png)",
        "",
        "`benchmarks/numerical_damping.py`, one thread. **One linear mode**: a straight "
        f"chain of {chain['free_masses']} free masses (explicit: "
        f"{chain['explicit_free_masses']}, so that its highest mode stays stable) between two "
        "fixed ends, no damping, drag or gravity, started from rest in its lowest "
        "longitudinal mode, which moves exactly linearly; Newton tight "
        f"(newton_tol {chain['newton']['newton_tol']:g}, truncation_fraction "
        f"{chain['newton']['truncation_fraction']:g}). Measured: the principal root of the "
        "linear recurrence fitted to the mode's sampled (ωq, p) (matrix pencil); analytic: "
        "the principal eigenvalue of each scheme's one-step matrix for ẍ = −ω²x, computed "
        "independently in numpy. Energy kept per period: decay^(2 · 2π/ωh); period "
        "elongation: ωh / arg λ − 1."
        + (
            f" Not in this build: {'; '.join(payload['integrators_unavailable'])}."
            if payload["integrators_unavailable"]
            else ""
        ),
        "",
        "| integrator | ρ∞ | ωh | steps per period | decay per step | analytic | relative "
        "difference | energy kept per period | period elongation |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in payload["rows"]:
        out.append(
            f"| {r['integrator']} | "
            + ("–" if r["rho_infinity"] is None else f"{r['rho_infinity']:g}")
            + f" | {r['omega_h']:.3g} | {r['steps_per_period']:.3g} | "
            f"{r['decay_per_step']:.9f} | {r['analytic_decay_per_step']:.9f} | "
            f"{r['relative_difference']:.1e} | {r['energy_kept_per_period']:.4g} | "
            f"{r['period_elongation']:.3g} |"
        )
    worst = max(abs(r["relative_difference"]) for r in payload["rows"])
    out += ["", f"Largest relative difference between measured and analytic decay: {worst:.1e}."]
    settings = payload["sheet_settings"]
    references = {ref["size"]: ref for ref in payload["sheet_references"]}
    out += [
        "",
        "**The swinging sheet's energy kept**: the crossover's sheet (pin spacing 1 m, "
        f"0.1 kg, k = {settings['stretch_stiffness']:g} N/m, bending {settings['bending']}) "
        "let go from flat; the reference is explicit at half its bisected limit ("
        + ", ".join(f"{n}²: {ref['reference_dt']:.3g} s" for n, ref in references.items())
        + "). Kept at t: the run's mean kinetic energy over t ± "
        f"{settings['window']:g} s over the reference's; history: the kinetic-energy "
        f"history's relative L2 over [0, {settings['history_until']:g}] s; centroid: the "
        "largest centroid distance over the sheet's size; CPU seconds of the stepping per "
        "simulated second (one run). Explicit at its limit shows the measures' floor on "
        "this chaotic sheet. Families at yore's defaults"
        + (
            f" (not in this build: {'; '.join(payload['sheet_families_unavailable'])})"
            if payload["sheet_families_unavailable"]
            else ""
        )
        + ".",
        "",
        "| sheet | family | dt (s) | kept at "
        + " | kept at ".join(f"{t:g} s" for t in settings["times"])
        + " | KE history | centroid | CPU s/s | Newton per step |",
        "|---|---|---|" + "---|" * len(settings["times"]) + "---|---|---|---|",
    ]
    aliases = {}  # a family measured once for several names that resolve alike
    for name, kept in payload.get("sheet_families_merged", {}).items():
        aliases.setdefault(kept, []).append(name)
    for r in payload["sheet_rows"]:
        family = " = ".join([r["family"], *aliases.get(r["family"], [])])
        head = f"| {r['size']}² | {family} | {r['dt']:.3g} | "
        if "kinetic_energy_history" not in r:
            why = "diverged" if r["diverged"] else f"aborted: {r['aborted']}"
            out.append(head + " | ".join([why] + [""] * (len(settings["times"]) + 3)) + " |")
            continue
        out.append(
            head
            + " | ".join(f"{r[f'kinetic_energy_kept_at_{t:g}s']:.3g}" for t in settings["times"])
            + f" | {r['kinetic_energy_history']:.3g} | {r['centroid_path']:.3g} | "
            f"{r['cost_seconds_per_simulated_second']:.3g} | "
            + ("–" if r["integrator"] == "explicit" else f"{r['newton_iterations_per_step']:.2f}")
            + (f" ({r['unconverged_steps']} unconverged)" if r.get("unconverged_steps") else "")
            + " |"
        )
    out += [""] + [f"- {line}" for line in payload["summary"]["lines"]]
    return out


def error_control_section(payload: dict, images: str) -> list:
    """The error-control lines (from error_control.json): each family's error at T against
    its CPU time, per cell, with what the error-controlled rows cost at equal error."""

    def number(value, form="{:.3g}"):
        return "–" if value is None else form.format(value)

    out = [
        "## Tolerance in, steps out",
        "",
        f"![error control]({images}/error_control.png)",
        "",
        "`benchmarks/error_control.py`, one thread: the crossover's sheet (flat start, "
        "bending as stiff as stretching) over its first "
        f"{payload['horizon']} s; error = the crossover's (RMS distance from explicit at "
        "half its step, at T/2 and T, over the diagonal); "
        + ", ".join(
            f.replace(" auto", ' with dt="auto"')
            for f in payload.get("families", ["cvode", "arkode", "tr-bdf2 auto"])
        )
        + " at rtol 1e-2, 1e-3, 1e-4 (atol = rtol/10 m), against bdf2's fixed steps and "
        "explicit. "
        '"factorizations / step" is per internal step; "× bdf2" is the CPU time over the '
        "cheapest bdf2 run at least as accurate (– when none is).",
        "",
    ]
    for cell in payload["cells"]:
        judged = [t for t, v in cell["verdicts"].items() if v["judged"]]
        cheapest = (
            "; ".join(
                f"at {float(t):.1%}: "
                + ", ".join(
                    f"{name} {v['cpu_seconds']:.3g} s"
                    for name, v in sorted(
                        cell["verdicts"][t]["cheapest"].items(), key=lambda kv: kv[1]["cpu_seconds"]
                    )
                )
                for t in judged
            )
            or "no threshold judged (the floor is too high)"
        )
        out += [
            f"**{cell['size']}², k = {cell['stiffness']:g} N/m** (floor "
            f"{cell['floor']:.2g}; cheapest {cheapest})",
            "",
            "| run | error | CPU s | steps | factorizations / step | slope vs rtol "
            "| × bdf2 | × explicit |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for r in payload["rows"]:
            if (r["size"], r["stiffness"]) != (cell["size"], cell["stiffness"]):
                continue
            name = (
                f"{r['integrator']} rtol {r['rtol']:g}"
                if "rtol" in r
                else f"{r['integrator']} dt {r['dt']:.3g} s"
            )
            if r.get("failure"):
                out.append(f"| {name} | failed: {r['failure'][:80]} | | | | | | |")
                continue
            out.append(
                f"| {name} | {number(r['error'])} | {number(r['cpu_seconds'])} | "
                f"{r.get('internal_steps', '–')} | "
                f"{number(r.get('factorizations_per_step'), '{:.2f}')} | "
                f"{number(r.get('slope'), '{:.2f}')} | "
                f"{number(r.get('cpu_over_bdf2'), '{:.2f}')} | "
                f"{number(r.get('cpu_over_explicit'), '{:.2f}')} |"
            )
        out.append("")
    return out


TOLERANCE_CROSSOVER = Path("crossover-tolerance") / "crossover.json"  # under the results


def at_tolerance_section(crossover: dict | None, long_horizon: dict) -> list:
    """The rows at tolerance (issue 40, item 4) of the crossover (a part of its grid run with
    them, in crossover-tolerance/) and of the long horizon: one table each, and per method the
    slope against rtol, factorizations per step and cost at equal achieved error."""
    from . import tolerance
    from .long_horizon import key

    out = [
        "## At tolerance",
        "",
        "The error-controlled rows as families of the crossover and of the long horizon "
        '(`benchmarks/tolerance.py`): TR-BDF2 and BDF2 with `dt="auto"` and CVODE at rtol '
        "1e-2, 1e-3, 1e-4 (atol = rtol/10 m), one run each, in the same task as the "
        "fixed-step rows and explicit. Error: the benchmark's own (the crossover's trajectory "
        "error at T/2 and T; the long horizon's kinetic-energy history), beside the floor of "
        "its reference. The slope of error against rtol is judged where both errors are "
        f'above {tolerance.SLOPE_FLOOR:g} times the floor; "per step" is per internal step; '
        '"× cheapest fixed step as accurate" is the CPU time over the cheapest fixed-step '
        "implicit run of the cell with an error at most as large (– when none is). In the "
        "crossover the rows write output at T/2 and T only; in the long horizon every 1/64 s "
        "(the sampling grid), which caps their steps at 1/64 s.",
        "",
    ]
    lines = []

    def block(title, what, cells, name_of):
        """One benchmark's table and summary lines, from its cells with rows at tolerance."""
        named = [(name_of(c), c["stretch_stiffness"], c["at_tolerance"]) for c in cells]
        out.extend(
            [f"**{title}** ({len(cells)} cell{'s' * (len(cells) != 1)}, {what}):", ""]
            + tolerance.TABLE_HEAD
        )
        for name, _, entries in named:
            out.extend(tolerance.table(entries, name))
        out.append("")
        lines.extend(
            tolerance.summary_lines(
                named,
                title,
                [
                    (name, c["stretch_stiffness"], c.get("at_tolerance_verdicts", []))
                    for (name, _, _), c in zip(named, cells)
                ],
            )
        )

    if crossover is None:
        out += ["The crossover has not run with these rows here.", ""]
    else:
        block(
            "Crossover",
            "short horizon",
            [c for c in crossover["summary"]["cells"] if c.get("at_tolerance")],
            lambda c: f"{c['size']}² k = {c['stretch_stiffness']:g} {c['bending']}",
        )
    cells = sorted((c for c in long_horizon["summary"]["cells"] if c.get("at_tolerance")), key=key)
    if cells:
        block("Long horizon", "kinetic-energy history", cells, _cell_name)
    else:
        out += ["The long horizon has no cell with these rows yet.", ""]
    return out + [f"- {line}" for line in lines]


def vibration_floor_section(payload: dict, images: str) -> list:
    """Why the errors do not follow the tolerance: every family's error against its mean step
    beside the explicit stable step (from vibration_floor.json)."""
    out = [
        "### Why the error does not follow the tolerance on the stiff sheets",
        "",
        f"![vibration floor]({images}/vibration_floor.png)",
        "",
        "`benchmarks/vibration_floor.py`, one thread: the crossover's sheet (bending equal) "
        f"over {payload['horizon']} s, the RMS distance at T over the diagonal against "
        "explicit at a sixteenth of its stable step; tr-bdf2 at fixed steps with Newton solved "
        "tight, so neither Newton's stop nor a controller is in its error. Slopes are "
        "log–log, from the row above.",
        "",
        "| cell | row | error | internal steps | mean step / stable step | slope vs step "
        "| slope vs rtol |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in payload["rows"]:
        name = f"{r['size']}² k = {r['stiffness']:g}"
        setting = (
            f"dt = stable / {r['setting']:g}"
            if r["family"] == "explicit"
            else f"dt = {r['setting']:.3g} s"
            if "fixed" in r["family"]
            else f"rtol {r['setting']:g}"
        )
        if "error" not in r:
            out.append(
                f"| {name} | {r['family']}, {setting} | failed: "
                f"{str(r.get('failure'))[:60]} | | | | |"
            )
            continue
        if r.get("unconverged_steps"):
            setting += f" ({r['unconverged_steps']} steps at Newton's iteration cap)"
        out.append(
            f"| {name} | {r['family']}, {setting} | {r['error']:.2e} | "
            f"{r['internal_steps']} | {r['mean_step_over_stable_dt']:.3g} | "
            + (f"{r['slope_vs_step']:.2f}" if "slope_vs_step" in r else "–")
            + " | "
            + (f"{r['slope_vs_rtol']:.2f}" if "slope_vs_rtol" in r else "–")
            + " |"
        )
    return out


def bending_consistency_section(payload: dict, images: str) -> list:
    """The cylinder test of both bending energies on every mesh kind and size, and the fitted
    energy's cost in an implicit step (bending_consistency.json)."""
    summary = payload["summary"]
    out = [
        "## Bending on any mesh",
        "",
        f"![bending consistency]({images}/bending_consistency.png)",
        "",
        "`benchmarks/bending_consistency.py`, one thread: a 1 m × 0.5 m sheet rolled "
        f"isometrically onto a cylinder of radius {payload['radius']:g} m, its bending energy "
        'over the continuum\'s ½ B A / R², for `bending="quadratic"` (fitted vertex '
        'Hessians) and `bending="hinge"` (Bergou et al. 2006); target: within '
        f"{100 * summary['target']:g} % on every mesh kind and size.",
        "",
        "| mesh | longest edge (m) | vertices | quadratic | hinge | Q entries a row "
        "(quadratic / hinge) |",
        "|---|---|---|---|---|---|",
    ]
    for r in payload["rows"]:
        out.append(
            f"| {r['kind']} | {r['edge_length']:g} | {r['vertices']} | "
            f"{r['quadratic']['ratio']:.4f} | {r['hinge']['ratio']:.4f} | "
            f"{r['quadratic']['entries_per_row']:.1f} / "
            f"{r['hinge']['entries_per_row']:.1f} |"
        )
    for model in ("quadratic", "hinge"):
        s = summary[model]
        out += [
            "",
            f"`{model}`: largest error {100 * s['largest_error']:.2f} % "
            f"({s['worst']['kind']}, edge {s['worst']['edge_length']:g} m): "
            f"{verdict(s['within_target'])}.",
        ]
    for c in summary["cost"]:
        out += [
            "",
            f"Cost on `hanging_cloth` {c['resolution']}² (TR-BDF2, 1/64 s, B = "
            f"{payload['bending_modulus']:g} N·m): a step with the fitted energy costs "
            f"{c['step_quadratic_over_hinge']:.2f}× the hinge energy's, a Newton iteration "
            f"{c['iteration_quadratic_over_hinge']:.2f}×, with "
            f"{c['factor_nonzeros_quadratic_over_hinge']:.2f}× the factor's non-zeros.",
        ]
    return out


def interpolation_bending_section(payload: dict, images: str) -> list:
    """What the mesh adds to a wrinkle's membrane energy per mesh kind, strain and direction
    (interpolation_bending.json)."""
    settings = payload["settings"]
    out = [
        "## What the mesh adds to a wrinkle",
        "",
        f"![interpolation bending]({images}/interpolation_bending.png)",
        "",
        "`benchmarks/interpolation_bending.py`, from the library's own membrane energy: a "
        f"{settings['side']:g} m square (longest edge {settings['edge_length']:g} m) turned "
        "0°–90° under a fixed load, a wrinkle along x of "
        f"{settings['points_per_wavelength']} mean edges. Tension leak: stretched 10 % along "
        "x, the energy the continuum does not have, as B_art = c_leak h² S_xx. Compression "
        "deficit: shortened 1 % along y, the fraction d = c_comp (k h)² of ½ S_yy ∫ z_y² "
        "the mesh does not charge. The whole sheet counts, its edges included.",
        "",
        "| mesh | strain | c_leak, smallest–largest over the angles | c_comp |",
        "|---|---|---|---|",
    ]
    for name, s in payload["summary"].items():
        mesh, strain = name.split(", ")
        out.append(
            f"| {mesh} | {strain} | {s['c_leak_smallest']:.2g}–{s['c_leak_largest']:.2g}"
            f" | {s['c_compression_mean']:.3f} |"
        )
    return out


def wrinkles_section(payload: dict, images: str) -> list:
    """The stretched sheet (springs and membrane) and the stroke against the mesh (from
    wrinkles.json)."""
    settings = payload["settings"]
    base = settings["bases"]["membrane"]
    out = [
        "## Wrinkles: physics or mesh",
        "",
        f"![wrinkles]({images}/wrinkles.png)",
        "",
        "`benchmarks/wrinkles.py`, one thread: `yore.scenes.stretched_sheet` (Cerda & "
        f"Mahadevan's setting) {base['length']:g} m × {base['width']:g} m, clamped along its "
        f"short edges and stretched {100 * base['strain']:g} %, on a pattern mesh (an "
        "equilateral lattice inside, CGAL along the edges) "
        "(base runs: "
        + "; ".join(
            f"{model} B = {b['bending_modulus']:g} N·m, longest edge {b['edge_length']:g} m"
            for model, b in settings["bases"].items()
        )
        + "), "
        f"quadratic bending B, Y = {settings['young']:g} N/m (the membrane's; the springs' "
        f"stiffness), ν = {settings['poisson']:g} (membrane), relaxed by `settle` with its "
        "saddle test from the flat state plus "
        f"{settings['noise']:g} m of noise. λ: the FFT peak of the mid-length cross-section; "
        "predicted: (2π L)^½ (4 B / (Y γ))^¼ with the model's own Y (the lattice's under an "
        "affine strain). Flat-state stable: the flat stretched state's true Hessian is "
        "positive definite; compression: the membrane's largest S_yy there over the middle "
        "fifth of the length (N/m).",
        "",
        "Since issue 52 also per run: the mesh (pattern, CGAL's Delaunay mesh throughout, "
        "or a grid aligned with the sheet), the membrane's strain (the faces', the default, "
        "or smoothed) and seed, the bending modulus the mesh realises (its cylinder test) over B, "
        "the interpolation's artificial modulus B_art over B (the run's tension charging a "
        "wrinkle's spurious slope along the length: the library's own energy on the run's "
        "mesh under a uniform tension, scaled to the measured one), beside it the "
        "flat-state probe (the same under the flat state's stress, which also charges the "
        "compression deficit, an error proportional to B that 8 points a wavelength bound; "
        "for the membrane as built and with the faces' constant strain), and whether the "
        "row is judged (wrinkled, no zigzag, ≥ 8 points per wavelength, |B_art| ≤ 0.1 B); "
        "exponents are fitted on judged rows only, each value of the varied parameter on "
        "its finest judged mesh.",
        "",
        "| run | model | mesh, strain, seed | B (N·m) | L (m) | γ | mean edge (m) | λ (m) | "
        "predicted (m) | λ / edge | amplitude (m) | flat state stable | compression | "
        "realised B / B | B_art / B | flat-state probe / B | probe / B, faces' strain | "
        "judged | CPU s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in payload["rows"]:
        wavelength = "flat" if r["wavelength"] is None else f"{r['wavelength']:.4f}"
        ratio = "–" if r["wavelength"] is None else f"{r['wavelength'] / r['mean_edge']:.1f}"
        if r["zigzag"]:
            ratio += " (zigzag)"
        compression = (
            "–" if r.get("flat_state_compression") is None else f"{r['flat_state_compression']:.1f}"
        )
        realised = (
            "–"
            if r.get("realized_bending") is None
            else f"{r['realized_bending'] / r['bending_modulus']:.3f}"
        )
        artificial = (
            "–"
            if r.get("artificial_bending") is None
            else f"{r['artificial_bending'] / r['bending_modulus']:.3g}"
        )
        remedy = (
            "–"
            if r.get("artificial_bending_faces") is None
            else f"{r['artificial_bending_faces'] / r['bending_modulus']:.2g}"
        )
        probe = (
            "–"
            if r.get("flat_state_probe_bending") is None
            else f"{r['flat_state_probe_bending'] / r['bending_modulus']:.2g}"
        )
        judged = "–" if "judged" not in r else ("yes" if r["judged"] else "no")
        strain = f"{r['membrane_strain']}, " if r.get("membrane_strain") else ""
        out.append(
            f"| {r['label']} | {r['model']} | {r.get('mesh', 'pattern')}, {strain}"
            f"{r.get('seed', 0)} | {r['bending_modulus']:g} | "
            f"{r['length']:g} | {r['strain']:g} | {r['mean_edge']:.4f} | {wavelength} | "
            f"{r['predicted_wavelength']:.4f} | {ratio} | {r['amplitude']:.2e} | "
            f"{r['flat_state_stable']} | {compression} | {realised} | {artificial} | "
            f"{probe} | {remedy} | {judged} | {r['cpu_seconds']:.0f} |"
        )
    summary = payload["summary"]
    out += [
        "",
        "| model | wrinkled runs | zigzags | exponent in B (¼) | in L (½) | in γ (−¼) | "
        "λ / predicted | λ change, two finest meshes |",
        "|---|---|---|---|---|---|---|---|",
    ]

    def number(value, digits=2):
        return "–" if value is None else f"{value:.{digits}f}"

    for model in [
        key for key, value in summary.items() if isinstance(value, dict) and "exponents" in value
    ]:
        m = summary[model]
        ratios = m["ratio_to_prediction"]
        spread = f"{min(ratios):.2f}–{max(ratios):.2f}" if ratios else "–"
        out.append(
            f"| {model} | {m['wrinkled']} of {m['runs']} | {m['zigzags']} | "
            f"{number(m['exponents']['bending_modulus'])} | "
            f"{number(m['exponents']['length'])} | {number(m['exponents']['strain'])} | "
            f"{spread} | {number(m['finest_meshes_change'], 3)} |"
        )
    threshold = summary["springs_threshold"]
    if threshold:
        out += [
            "",
            "The spring lattice against B, per mesh (largest B that wrinkled, smallest "
            "that stayed flat): "
            + "; ".join(
                f"mean edge {t['mean_edge']:.4f} m: wrinkled up to "
                f"{number(t['wrinkled_up_to'], 6) if t['wrinkled_up_to'] else 'none'}, flat "
                f"from {t['flat_from'] if t['flat_from'] is not None else 'none'}"
                for t in threshold.values()
            )
            + ".",
        ]
    strokes = payload["strokes"]
    if strokes:
        out += [
            "",
            "The hanging-cloth stroke (v = 0.8, u 0.2–0.8) against the mesh:",
            "",
            "| model | vertices per side | faces split | wrinkle measure (m) | fold depth (m) "
            "| CPU s |",
            "|---|---|---|---|---|---|",
        ]
        for s in strokes:
            out.append(
                f"| {s['model']} | {s['resolution']} | {s['faces_split']} | "
                f"{s['wrinkle_measure']:.3e} | {s['fold_depth']:.3e} | "
                f"{s['cpu_seconds']:.0f} |"
            )
        for model, change in summary["stroke"].items():
            out.append("")
            out.append(
                f"{model}: between the two finest meshes the wrinkle measure changes by "
                f"{100 * change['wrinkle_measure_change']:.0f} %, the fold depth by "
                f"{100 * change['fold_depth_change']:.0f} % (target: < 10 % for one "
                "model)."
            )
    return out + band_lines(payload)


def band_lines(payload: dict) -> list:
    """The band strokes in physical units (issue 52) against the mesh: the seeds' means."""
    means = payload.get("band_means") or []
    if not means:
        return []
    settings = payload["band_settings"]
    start = settings["start"]
    bands = payload["band_strokes"]

    def shown(m, key, scale=1e3):
        error = m.get(key + "_error")
        value = f"{scale * m[key]:.2f}"
        return value if error is None else f"{value} ± {scale * error:.2f}"

    out = [
        "",
        f"The band stroke in physical units (issue 52): the hanging cloth (membrane, fitted "
        f"bending B) settled on a {start['resolution']}² {start['mesh']}, that shape carried "
        "to each mesh by its material coordinates and settled there; stroked along v = "
        f"{settings['v']:g} from u = {settings['u'][0]:g} to {settings['u'][1]:g} with a band "
        f"{settings['width']:g} m wide grown {settings['growth']} × {settings['expansion']:g} "
        f"(spring weights: {settings['weights']}), the band refined (1→4 passes) to edges of "
        f"at most {1e3 * settings['edge']:g} mm; displaced by {settings['noise']:g} m of "
        f"seeded noise ({len(settings['seeds'])} seeds) and settled again. Measured on the "
        f"same material points every {1e3 * settings['sample']:g} mm on every mesh, over the "
        "band: the fold depth and RMS (the range, and the RMS about its mean, of the stroke's "
        "displacement along the settled surface's normals), the wrinkle measure (RMS height "
        f"over the surface Gaussian-smoothed with σ = {settings['reach'] / 3:g} m) and the "
        "wrinkles' wavelength along the band's centre line; the seeds' mean ± its standard "
        "error:",
        "",
        "| B (N·m) | mesh | vertices a side | passes | band edge (mm) | vertices | "
        "fold depth (mm) | fold RMS (mm) | wrinkle measure (mm) | wavelength (mm) | "
        "rest area added (cm²) | CPU s a seed | states: fold RMS (mm) × seeds |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    outcomes = {
        (o["bending_modulus"], o["mesh"], o["resolution"]): o["states"]
        for o in payload.get("band_outcomes") or []
    }
    for m in means:
        mine = [
            b
            for b in bands
            if (b["bending_modulus"], b["mesh"], b["resolution"])
            == (m["bending_modulus"], m["mesh"], m["resolution"])
        ]
        out.append(
            f"| {m['bending_modulus']:g} | {m['mesh']} | {m['resolution']} | "
            f"{mine[0]['refine']} | {1e3 * mine[0]['band_edge']:.2f} | {m['vertices']:.0f} | "
            f"{shown(m, 'fold_depth')} | {shown(m, 'fold_rms')} | "
            f"{shown(m, 'wrinkle_measure')} | {1e3 * m['wrinkle_wavelength']:.0f} | "
            f"{1e4 * m['rest_area_added']:.1f} | {m['cpu_seconds']:.0f} | "
            + ", ".join(
                f"{1e3 * c['fold_rms']:.2f} × {len(c['seeds'])}"
                for c in outcomes.get((m["bending_modulus"], m["mesh"], m["resolution"]), [])
            )
            + " |"
        )
    for key, change in payload["summary"].get("band_strokes", {}).items():
        out.append("")
        parts = []
        for name in ("fold_depth", "fold_rms", "wrinkle_measure", "rest_area_added"):
            if name + "_change" not in change:
                continue
            error = change.get(name + "_change_error")
            parts.append(
                f"{name.replace('_', ' ')} {100 * change[name + '_change']:.1f} %"
                + ("" if error is None else f" (± {100 * error:.1f})")
            )
        line = (
            f"{key}, {change['resolutions'][0]} → {change['resolutions'][1]} a side, seed "
            "means: " + ", ".join(parts) + " (target: < 5 %)"
        )
        if "states" in change:
            line += (
                f"; states found {change['states'][0]} and {change['states'][1]}, the finer "
                f"mesh's commonest ({change['commonest_state_seeds'][1]} seeds) against the "
                "coarser's nearest: "
                + ", ".join(
                    f"{name.replace('_', ' ')} {100 * change[name + '_state_change']:.1f} %"
                    for name in ("fold_depth", "fold_rms", "wrinkle_measure")
                )
            )
        out.append(line + ".")
    return out


def factorization_section(payload: dict, images: str) -> list:
    """The factorization against DGEMM, the orderings, and the BLAS kernels."""
    kernel = payload["machine"]["yore"].get("blas_kernel", "?")
    out = [
        "",
        "## The factorization and the BLAS kernels",
        "",
        f"![factorization]({images}/factorization.png)",
        "",
        f"From `factorization` (one thread, {kernel} kernels; DGEMM of the BLAS CHOLMOD calls: "
        f"{payload['dgemm_gflops']:.1f} GFlop/s in the same run). The linearized step's "
        "matrix on grid cloths, CHOLMOD's own supernode amalgamation:",
        "",
        "| grid | ordering | nnz(L) | GFlop | analysis | factorization | GFlop/s | of DGEMM |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in payload["rows"]:
        if r["supernode_relaxation"] != 1.0 or r["blas_threads"] != 1:
            continue
        out.append(
            f"| {r['grid']}² | {r['ordering_used']} | {r['factor_nonzeros']:.3g} | "
            f"{r['factor_flops'] / 1e9:.3f} | {duration(r['analyze_seconds'])} | "
            f"{duration(r['factorize_seconds'])} | {r['factorize_gflops']:.1f} | "
            f"{r['factorize_fraction_of_dgemm']:.0%} |"
        )
    target = payload["targets"]["factorize_fraction_of_dgemm_at_least"]
    judged = [
        r
        for r in payload["rows"]
        if r["grid"] in payload["targets"]["at_grids"]
        and r["supernode_relaxation"] == 1.0
        and r["blas_threads"] == 1
    ]
    if judged:
        best = {
            g: max(r["factorize_fraction_of_dgemm"] for r in judged if r["grid"] == g)
            for g in sorted({r["grid"] for r in judged})
        }
        out += [
            "",
            "Best rate per judged grid (target ≥ "
            f"{target:.0%}): "
            + ", ".join(f"{g}² {f:.0%} ({verdict(f >= target)})" for g, f in best.items())
            + ".",
        ]
    if payload["kernels"]:
        out += [
            "",
            "OpenBLAS's kernels, one fresh process each (`OPENBLAS_CORETYPE`): DGEMM "
            "(n = 1200) and one Newton iteration in explicit steps of the same process:",
            "",
            "| kernels | DGEMM GFlop/s | "
            + " | ".join(f"{r['grid']}² {r['ordering']}" for r in payload["kernels"][0]["rows"])
            + " |",
            "|---|---|" + "---|" * len(payload["kernels"][0]["rows"]),
        ]
        for k in payload["kernels"]:
            out.append(
                f"| {k['kernel']} | {k['dgemm_gflops']:.1f} | "
                + " | ".join(f"{r['iteration_over_explicit']:.0f}" for r in k["rows"])
                + " |"
            )
        goals = payload["targets"]["newton_iteration_new_over_old_at_most"]
        out += [""] + [
            f"{s['grid']}²: a Newton iteration with {s['new_kernel']} and the "
            f"automatic ordering costs {s['new_over_old']:.2f} of one with Prescott and "
            f"AMD (target ≤ {goals[str(s['grid'])]}: "
            f"{verdict(s['new_over_old'] <= goals[str(s['grid'])])})."
            for s in payload["kernel_summary"]
            if str(s["grid"]) in goals
        ]
        baseline = payload.get("baseline")
        out += [""] + [
            f"{s['grid']}²: against Prescott and AMD on {baseline['label']}, a Newton "
            f"iteration of this build with {s['new_kernel']} and the automatic ordering costs "
            f"{s['new_over_baseline']:.2f} (target ≤ {goals[str(s['grid'])]}: "
            f"{verdict(s['new_over_baseline'] <= goals[str(s['grid'])])}); on the same kernels, "
            "this build over that one: "
            + ", ".join(f"{k} {v:.2f}" for k, v in s["same_kernel"].items())
            + "."
            for s in payload.get("baseline_summary") or []
            if str(s["grid"]) in goals and "new_over_baseline" in s
        ]
    return out


def rebuild_cost_section(data: dict, images: str) -> list:
    """What a stroke's rebuild costs (rebuild_cost.json), with implicit_step's phases."""
    out = []
    rebuild = data["rebuild_cost"]
    out += [
        "",
        "## What a stroke's rebuild costs",
        "",
        f"![rebuild cost]({images}/rebuild_cost.png)",
        "",
        "| case | ordering | unknowns | explicit step | implicit step | analysis (the "
        "rebuild) | step after a stroke | analysis / implicit step | analysis / explicit step "
        "| factorization GFlop/s (% of dense) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rebuild["rows"]:
        out.append(
            f"| {r['case']} | {r['ordering_used']} | {r['dofs']} | "
            f"{duration(r['explicit_step_seconds'])} | "
            f"{duration(r['implicit_step_seconds'])} | {duration(r['analyze_seconds'])}"
            f" | {duration(r['step_after_stroke_seconds'])} | "
            f"{r['analyze_over_implicit_step']:.2f} | {r['analyze_over_explicit_step']:.0f} | "
            f"{r['factorize_gflops']:.1f} ({100 * r['factorize_fraction_of_dense']:.0f} %) |"
        )
    worst = max(r["analyze_over_implicit_step"] for r in rebuild["rows"])
    out += [
        "",
        f"Dense reference: numpy's 2000×2000 multiply, {rebuild['dense_matmul_gflops']:.1f} "
        "GFlop/s in the same run. Target: the symbolic re-analysis after a stroke costs no more "
        f"than one implicit step — {verdict(worst <= 1.0)} (at most {worst:.2f} of a step). "
        "Against explicit stepping the same rebuild is "
        f"{min(r['analyze_over_explicit_step'] for r in rebuild['rows']):.0f}–"
        f"{max(r['analyze_over_explicit_step'] for r in rebuild['rows']):.0f} explicit steps.",
    ]

    shaped = [r for r in rebuild["rows"] if r.get("dense_at_supernode_gflops")]
    if shaped:
        out += [
            "",
            "What bounds the factorization's rate: half of its flops are in supernodes "
            "(dense column blocks) no wider than the flop-weighted median below, and numpy's "
            "dense kernels on one supernode of that shape (Cholesky, solve below it, update) "
            "run at the rate given, in the same run:",
            "",
            "| case | ordering | median supernode: columns × rows below | dense kernels at "
            "that shape, GFlop/s (% of the big multiply) | factorization, % of that |",
            "|---|---|---|---|---|",
        ]
        for r in shaped:
            out.append(
                f"| {r['case']} | {r['ordering_used']} | "
                f"{r['supernode_median_columns']:.0f} × {r['supernode_median_rows']:.0f} | "
                f"{r['dense_at_supernode_gflops']:.1f} "
                f"({100 * r['dense_at_supernode_fraction_of_dense']:.0f} %) | "
                f"{100 * r['factorize_gflops'] / r['dense_at_supernode_gflops']:.0f} % |"
            )

    lg = rebuild.get("local_global", [])
    if lg:
        out += [
            "",
            "Prefactored local-global (10 iterations per step), where the matrix is factored "
            "once and a stroke's rebuild is the whole extra cost — extra time over the 10 "
            "steps after a stroke, in ordinary steps:",
            "",
            "| case | ordinary step | fresh | reuse-ordering | stale-pcg |",
            "|---|---|---|---|---|",
        ]
        for case in dict.fromkeys(r["case"] for r in lg):
            sel = {r["strategy"]: r for r in lg if r["case"] == case}
            out.append(
                f"| {case} | {duration(sel['fresh']['ordinary_step_seconds'])} | "
                + " | ".join(
                    f"{sel[k]['rebuild_in_ordinary_steps']:.1f}"
                    for k in ("fresh", "reuse-ordering", "stale-pcg")
                )
                + " |"
            )
        at128 = [r for r in lg if r["case"] == "grid 128²"]
        at64 = [r for r in lg if r["case"] == "grid 64²"]
        if at128 and at64:
            best = min(r["rebuild_in_ordinary_steps"] for r in at128)
            step64 = min(r["ordinary_step_seconds"] for r in at64)
            out += [
                "",
                f"Targets: a rebuild under 10 ordinary steps at 128² — {verdict(best < 10)} "
                f"(best strategy {best:.1f}); a local-global step at 64² under 5 ms — "
                f"{verdict(step64 < 0.005)} ({1e3 * step64:.1f} ms).",
            ]

    qn = rebuild.get("quasi_newton", [])
    if qn:
        out += [
            "",
            "Quasi-Newton at its defaults: a stroke re-analyses and refactors only the "
            "scalar matrix (n×n); its cost in ordinary steps and in L-BFGS iterations:",
            "",
            "| case | ordinary step | iterations per step | per iteration | rebuild | "
            "rebuild in steps | rebuild in iterations |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in qn:
            out.append(
                f"| {r['case']} | {duration(r['ordinary_step_seconds'])} | "
                f"{r['iterations_per_step']:.0f} | {duration(r['seconds_per_iteration'])} | "
                f"{duration(r['rebuild_seconds'])} | {r['rebuild_in_ordinary_steps']:.3f} | "
                f"{r['rebuild_in_iterations']:.1f} |"
            )

    imp = data["implicit_step"]
    big = [r for r in imp["rows"] if r["grid"] >= 128]
    out += [
        "",
        "From `implicit_step` (linearized step by phase, AMD and METIS): a linearized step "
        f"costs {min(r['step_over_factorize'] for r in imp['rows']):.2f}–"
        f"{max(r['step_over_factorize'] for r in imp['rows']):.2f} × one factorization "
        f"(target ≤ 1.5: {verdict(max(r['step_over_factorize'] for r in imp['rows']) <= 1.5)}); "
        f"an analysis {min(r['analyze_over_factorize'] for r in imp['rows']):.2f}–"
        f"{max(r['analyze_over_factorize'] for r in imp['rows']):.2f} of one (target ≤ 1: "
        f"{verdict(max(r['analyze_over_factorize'] for r in imp['rows']) <= 1)}); at 128² and "
        f"above the factorization reaches {min(r['factorize_fraction_of_dense'] for r in big):.0%}–"
        f"{max(r['factorize_fraction_of_dense'] for r in big):.0%} of the dense multiply rate "
        f"(target ≥ 30 %: {verdict(min(r['factorize_fraction_of_dense'] for r in big) >= 0.3)})."
        if big
        else "",
    ]
    for r in imp.get("iterations", []):
        if r["grid"] == 64:
            out += [
                "",
                f"One quasi-Newton iteration at 64² costs {r['quasi_over_newton']:.3f} of a "
                f"Newton iteration ({duration(r['quasi_newton_iteration_seconds'])} against "
                f"{duration(r['newton_iteration_seconds'])}; target ≤ 0.1: "
                f"{verdict(r['quasi_over_newton'] <= 0.1)}).",
            ]

    return out


def scaling_section(data: dict, images: str) -> list:
    """The step costs' slopes against the vertex count (scaling.json)."""
    out = []
    scaling = data["scaling"]
    out += [
        "",
        "## Scaling",
        "",
        f"![scaling]({images}/scaling.png)",
        "",
        "Fitted slopes of step cost against vertices (log-log): "
        + ", ".join(f"{k.replace('_', ' ')} {v:.2f}" for k, v in scaling["slopes"].items())
        + ".",
    ]
    return out


def newton_projection_section(data: dict, images: str) -> list:
    """Newton's iterations per Hessian projection (newton_projection.json)."""
    out = []
    newton = data["newton_projection"]
    out += [
        "",
        "## Newton: Hessian projections",
        "",
        f"![Newton iterations]({images}/newton_projection.png)",
        "",
        "Iterations per step (median / mean / max), rejected factorizations per step, steps "
        "at max_newton, CPU s per simulated s; deviation from a tight run / cloth size (on "
        "the buckling scenes mostly the creases settling differently) and the step's own "
        "deviation (the largest over every 10th step, each also solved tight from the same "
        "state).",
        "",
        "| scene | projection | iterations | rejected/step | at max_newton | CPU s/s "
        "| deviation | one step |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in newton["rows"]:
        out.append(
            f"| {r['scene']} | {r['projection']} | {r['median_iterations']:.0f} / "
            f"{r['mean_iterations']:.1f} / {r['max_iterations']} | "
            f"{r['rejected_per_step']:.2f} | {r['unconverged_steps']} | "
            f"{r['cpu_seconds_per_simulated_second']:.1f} | {r['deviation']:.1e} | "
            + (f"{r['step_deviation']:.1e}" if r.get("step_deviation") is not None else "–")
            + (
                f" ({r['step_deviation_over_truncation']:.2f} of its truncation error) |"
                if r.get("step_deviation_over_truncation") is not None
                else " |"
            )
        )
    out += [
        "",
        "Target on the first scene (median <= 5, <= 0.5 rejected/step, none at max_newton, "
        "each probed step within its truncation error of the tight solve): "
        + ", ".join(
            f"{p} {'**met**' if met else '**missed**'}" for p, met in newton["target_met"].items()
        )
        + ".",
    ]
    return out


def factor_reuse_section(data: dict, images: str) -> list:
    """Newton with a kept factor on the stiff sheets (factor_reuse.json)."""
    out = []
    reuse = data["factor_reuse"]
    out += [
        "",
        "## Newton: factor reuse on stiff sheets",
        "",
        f"![factor reuse]({images}/factor_reuse.png)",
        "",
        f"Stiff sheet (k = {reuse['stretch_stiffness']:g} N/m, bending equal, pinned 1 m "
        "apart), BDF2 at 1/60 s, one thread. Per step: Newton iterations, fresh "
        "factorizations, factor reuses (Newton systems solved by CG on the kept factor), "
        "thrown-away factorizations; CPU s per simulated s; largest vertex distance from the "
        "default run's end state over the cloth's size.",
        "",
        "| size | variant | iterations | fresh | reused | thrown away | capped steps | "
        "CPU s/s | from default |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in reuse["rows"]:
        out.append(
            f"| {r['resolution']}² | {r['variant']} | {r['newton_per_step']:.1f} | "
            f"{r['fresh_factorizations_per_step']:.1f} | "
            f"{r['factor_reuses_per_step']:.1f} | {r['thrown_away_per_step']:.1f} | "
            f"{r['unconverged_steps']} | {r['cpu_seconds_per_simulated_second']:.1f}"
            + (
                f" (CPU cap: {r['steps']} of {r['planned_steps']} steps)"
                if r.get("stopped_by_cpu_cap")
                else ""
            )
            + " | "
            + (
                f"{r['deviation_from_default']:.1e} |"
                if r["deviation_from_default"] is not None
                else "– |"
            )
        )
    ran = sorted({r["resolution"] for r in reuse["rows"]})
    if not reuse["quick"] and ran != [64, 128]:
        out += [
            "",
            "Only " + ", ".join(f"{n}²" for n in ran) + " ran this time "
            "(`--sizes`); the full benchmark also runs 128².",
        ]
    priced = [
        r
        for r in reuse["rows"]
        if "factorization_ms" in r and r["variant"].startswith("default (") and r["solve_ms"] > 0
    ]
    if priced:
        out += [
            "",
            "What a reuse has to beat (default rows, no CG): one factorization costs "
            + ", ".join(
                f"{r['factorization_ms']:.3g} ms at {r['resolution']}² (as much as "
                f"{r['factorization_ms'] / r['solve_ms']:.1f} solves with its factor)"
                for r in priced
            )
            + "; a CG iteration on a kept factor is one solve and one product with the "
            "matrix.",
        ]
    failing = [
        r
        for r in reuse["rows"]
        if "lagged_failures_per_step" in r and "lagged factor" in r["variant"]
    ]
    if failing:
        # (steihaug's CG iterations are its trust-region solver's, not counted here)
        out += [
            "",
            "Failed CG runs on the kept factor per step (and the lagged CG's iterations "
            "per step, where the clamp runs it): "
            + ", ".join(
                f"{r['resolution']}² {r['variant']} {r['lagged_failures_per_step']:.2f}"
                + (
                    ""
                    if "steihaug" in r["variant"]
                    else f" ({r['lagged_cg_iterations_per_step']:.1f})"
                )
                for r in failing
            )
            + ".",
        ]
    lagged = [r for r in reuse["rows"] if "cpu_over_unlagged" in r]
    if lagged:
        out += [
            "",
            "The lagged factor's CPU time over the same setting without it: "
            + ", ".join(
                f"{r['resolution']}² {r['variant']} {r['cpu_over_unlagged']:.2f}×" for r in lagged
            )
            + ".",
        ]
    return out


def newton_stop_section(data: dict, images: str) -> list:
    """Where Newton stops on the stiff sheet (newton_stop.json)."""
    out = []
    stop = data["newton_stop"]
    out += [
        "",
        "## Newton: where it stops on the stiff sheet",
        "",
        f"![Newton's stop]({images}/newton_stop.png)",
        "",
        f"{stop['resolution']}² stiff sheet (k = {stop['stretch_stiffness']:g} N/m, bending "
        f"equal, pinned 1 m apart), {stop['rows'][0]['steps']} steps of 1/60 s, one thread. "
        "`truncation_fraction` 0 is the residual test alone (the tight run); "
        f"{stop['default_fraction']:g} is the default. Error: the largest vertex distance "
        "from explicit at a quarter of its stable-step estimate, over the cloth's size, at "
        f"T/3, 2T/3 and T (the reference is {stop['reference_check']:.1e} of the size from "
        "explicit at half that step); from tight: the same distance from the tight run.",
        "",
        "| integrator | truncation_fraction | iterations mean / median / max | thrown away | "
        "capped steps | CPU s/s | error | RMS error | from tight (of its error) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in stop["rows"]:
        out.append(
            f"| {r['integrator']} | {r['truncation_fraction']:g}"
            + (" (default)" if r["default"] else "")
            + f" | {r['mean_iterations']:.2f} / {r['median_iterations']:g} / "
            f"{r['max_iterations']} | {r['thrown_away_per_step']:.2f} | "
            f"{r['unconverged_steps']} | {r['cpu_seconds_per_simulated_second']:.2f} | "
            f"{r['error']:.2e} | {r['rms_error']:.2e} | {r['from_tight']:.2e} "
            f"({r['from_tight_over_tight_error']:.2f}) |"
        )
    goal = stop["goal"]
    out += [
        "",
        f"Goal for the default (mean and median at most {goal['mean_iterations']:g} "
        f"iterations per step, at most {goal['thrown_away_per_step']:g} thrown-away "
        "factorizations per step, no step at max_newton): "
        + ", ".join(
            f"{name} {'**met**' if met else '**missed**'}" for name, met in stop["goal_met"].items()
        )
        + ".",
    ]
    return out


def sensitivity_section(data: dict, images: str) -> list:
    """How far round-off alone moves the crossover's sheets (sensitivity.json)."""
    out = []
    sens = data["sensitivity"]
    small, large = (f"{e:g}" for e in sens["epsilons"])
    tenth = {f"{t:g}": sens["reference_fraction"] * t for t in sens["thresholds"]}

    def cell(c):
        return f"{c['size']}² {c['bending']} {c['stretch_stiffness']:g} N/m"

    def side(e, least=None):
        if e is None:
            return "none within t − u" + ("" if least is None else f" (least error {least:.2e})")
        return f"{e['method']} at {e['dt']:.3g} s ({e['error']:.2e})"

    out += [
        "",
        "## How sensitive the crossover's sheets are",
        "",
        f"![sensitivity]({images}/sensitivity.png)",
        "",
        "Explicit at each crossover cell's coarsest reference step, from the cell's start "
        f"and from starts whose free vertices moved by {small} m and {large} m; the "
        "distance is the crossover's (RMS over the size, the larger of T/2 and T). Growth: "
        f"the distance at {large} m over that at {small} m (linear response: "
        f"{float(large) / float(small):.0e}). The floor (the distance at {small} m) must be "
        "at most a tenth of a threshold for any run to be judged against it, as the "
        "crossover asks of its references.",
        "",
        "| cell | reference's last difference | floor | at " + large + " m | growth | "
        "judgeable at " + " / ".join(f"{float(t) * 100:g} %" for t in tenth) + " |",
        "|---|---|---|---|---|---|",
    ]
    for r in sorted(sens["rows"], key=lambda r: (r["bending"], r["size"], r["stretch_stiffness"])):
        reference = (
            "—"
            if r["reference_error"] is None
            else f"{r['reference_error']:.1e}" + ("" if r["reference_converged"] else " (stalled)")
        )
        out.append(
            f"| {cell(r)} | {reference} "
            f"| {r['floor']:.1e} | {r['distance_' + large]:.1e} | {r['growth']:.3g} | "
            + " / ".join("yes" if r["judgeable"][t] else "**no**" for t in tenth)
            + " |"
        )
    for t, bound in tenth.items():
        lucky = [
            r
            for r in sens["rows"]
            if r["reference_error"] is not None
            and r["reference_error"] <= bound
            and not r["judgeable"][t]
        ]
        if lucky:
            out += [
                "",
                f"Judged at {float(t) * 100:g} % by the crossover's rule (its "
                "reference's last difference within a tenth of it) though the sheet moves "
                "more than that for a start moved by round-off: "
                + "; ".join(
                    f"{cell(r)} (reference {r['reference_error']:.1e}, floor {r['floor']:.1e})"
                    for r in lucky
                )
                + ".",
            ]
    if sens["floor_aware"]:
        out += [
            "",
            "Floor-aware verdicts, beside the crossover's and not in it: where its rule "
            "leaves a threshold out or judges it on a floor above a tenth of it, every "
            "error is charged the reference's own uncertainty u = max(its last difference, "
            "the floor), and a run meets t when error + u ≤ t.",
            "",
            "| cell | threshold | u | cheapest implicit (error) | explicit (error) | "
            "implicit / explicit |",
            "|---|---|---|---|---|---|",
        ]
        for v in sens["floor_aware"]:
            ratio = "—" if v["ratio"] is None else f"**{v['ratio']:.2f}**"
            out.append(
                f"| {cell(v)} | {v['threshold'] * 100:g} % | {v['allowance']:.1e} | "
                f"{side(v['implicit'], v['least_implicit_error'])} | "
                f"{side(v['explicit'])} | {ratio} |"
            )
    if sens["left_out"]:
        out += [
            "",
            "Not measured: "
            + "; ".join(f"{cell(c)} ({c['reason']})" for c in sens["left_out"])
            + ".",
        ]
    return out


def stability_section(data: dict, images: str) -> list:
    """The stability map (stability_map.json)."""
    out = []
    stability = data["stability_map"]
    out += [
        "",
        "## Stability",
        "",
        f"![stability map]({images}/stability_map.png)",
        "",
        "A sweep (`benchmarks/stability_map.toml`, run through `yore sweep`; the figure "
        "comes from its Dataset): "
        f"{stability['steps']} undamped steps per cell; cells stable / energy gain / diverged "
        "per integrator: "
        + "; ".join(
            f"{name} {sum(r['state'] == 'stable' for r in rows)}/"
            f"{sum(r['state'] == 'energy gain' for r in rows)}/"
            f"{sum(r['state'] == 'diverged' for r in rows)}"
            for name in dict.fromkeys(r["integrator"] for r in stability["rows"])
            for rows in [[r for r in stability["rows"] if r["integrator"] == name]]
        )
        + ".",
    ]
    return out


def explicit_step_section(data: dict, images: str) -> list:
    """The explicit step against the memory-bandwidth bound (explicit_step.json)."""
    out = []
    explicit = data["explicit_step"]
    out += [
        "",
        "## Explicit step",
        "",
        f"![explicit step]({images}/explicit_step.png)",
        "",
        "| grid | springs | threads | ms per step | × memory-bandwidth bound |",
        "|---|---|---|---|---|",
    ]
    for r in explicit["rows"]:
        out.append(
            f"| {r['grid']}² | {r['springs']} | {r['threads']} | "
            f"{1e3 * r['step_seconds_median']:.3g} | {r['over_bandwidth_bound']:.2f} |"
        )
    largest = max(r["grid"] for r in explicit["rows"])
    best = min(r["over_bandwidth_bound"] for r in explicit["rows"] if r["grid"] == largest)
    out += [
        "",
        "Bound: the step's least memory traffic (every array touched once) over the "
        "STREAM-triad bandwidth measured in the same run with as many threads ("
        + ", ".join(
            f"{k} thread{'s' if int(k) > 1 else ''}: {v / 1e9:.1f} GB/s"
            for k, v in explicit.get("stream_bandwidth_by_threads", {}).items()
        )
        + "). Target: within 2× "
        f"of the bound at the largest size ({largest}²) — {verdict(best <= 2.0)} "
        f"({best:.2f}×)."
        + (" Below 1, the cloth's arrays still fit in the caches." if best < 1.0 else ""),
    ]
    return out


def threads_section(data: dict, images: str) -> list:
    """The default threads against one (threads.json)."""
    out = []
    threads = data["threads"]
    out += [
        "",
        "## Threads",
        "",
        f"![threads]({images}/threads.png)",
        "",
        f"Default threads against one thread on {threads['machine']['cpu']} "
        f"({threads['machine']['logical_cores']} logical cores), each run a fresh process "
        "(medians; busy: a process burning the last core):",
        "",
        "| cell | one thread | default | default / one |",
        "|---|---|---|---|",
    ]
    for cell in threads["cells"]:
        modes = {
            r["mode"]: r
            for r in threads["rows"]
            if r["scene"] == cell["scene"] and r["load"] == cell["load"]
        }
        out.append(
            f"| {cell['scene']}, {cell['load']} | "
            f"{duration(modes['one']['step_seconds_median'])} | "
            f"{duration(modes['default']['step_seconds_median'])} | "
            f"{cell['default_over_one_thread']:.2f} |"
        )
    out += [
        "",
        f"Target: the default at most {threads['target_ratio']}× one thread in every "
        f"cell — {verdict(threads['target_met'])}.",
    ]
    return out


def pictures_section(data: dict, images: str) -> list:
    """Pictures' render times (pictures.json)."""
    out = []
    pictures = data["pictures"]
    out += [
        "",
        "## Pictures",
        "",
        f"![pictures]({images}/pictures.png)",
        "",
        f"{pictures['renderer']} on the CPU (Mesa llvmpipe), one picture with a colour map, "
        "colour bar and stroke (median of "
        f"{pictures['rows'][0]['repeats']}); starting polyscope in a fresh process "
        f"{pictures['start_seconds_median']:.2f} s, the viewer's pick of a pixel "
        f"{1e3 * pictures['pick_seconds_median']:.1f} ms.",
        "",
        "| size | vertices | "
        + " | ".join(f"×{f}" for f in sorted({r["factor"] for r in pictures["rows"]}))
        + " |",
        "|---|---|" + "---|" * len({r["factor"] for r in pictures["rows"]}),
    ]
    for key in dict.fromkeys((r["width"], r["height"], r["vertices"]) for r in pictures["rows"]):
        cells = {
            r["factor"]: r
            for r in pictures["rows"]
            if (r["width"], r["height"], r["vertices"]) == key
        }
        out.append(
            f"| {key[0]}×{key[1]} | {key[2]} | "
            + " | ".join(
                duration(cells[f]["render_seconds_median"]) if f in cells else "– (too large)"
                for f in sorted({r["factor"] for r in pictures["rows"]})
            )
            + " |"
        )
    return out


def machine_line(data: dict, results: Path) -> list:
    """The line every results page opens with: where its numbers come from."""
    machine = data["explicit_step"]["machine"]
    blas = ", ".join(p.rsplit("/", 1)[-1] for p in machine["blas_loaded"]) or "unknown"
    return [
        f"Regenerated by `make bench` from `{results}/*.json` (each benchmark's machine is "
        f"in its JSON; most ran on): {machine['cpu']}, {machine['logical_cores']} logical "
        f"cores, yore threads {machine['yore']['threads']}, BLAS {blas}, OPENBLAS_NUM_THREADS="
        f"{machine['thread_environment'].get('OPENBLAS_NUM_THREADS')}. Medians of repeated "
        "runs; ratios measured in one run.",
        "",
    ]


def _at_tolerance_page(data, images, results):
    extra = Path(results) / TOLERANCE_CROSSOVER
    crossover = json.loads(extra.read_text()) if extra.is_file() else None
    return (
        at_tolerance_section(crossover, data["long_horizon"])
        + [""]
        + vibration_floor_section(data["vibration_floor"], images)
    )


def build_ab_section(payload: dict, images: str) -> list:
    """This build against another, fresh processes alternating (build_ab.json)."""
    out = [
        "",
        "## Before and after: this build against another",
        "",
        f"![build_ab]({images}/build_ab.png)",
        "",
        f"From `build_ab`: against {payload['baseline_label']}, {payload['rounds']} fresh "
        "processes of each build in alternating order, one thread, the automatic ordering; "
        "medians, and this build's over the baseline's:",
        "",
        "| grid | factorization | analysis | Newton iteration | explicit step |",
        "|---|---|---|---|---|",
    ]
    keys = (
        "factorize_seconds",
        "analyze_seconds",
        "newton_iteration_cpu_seconds",
        "explicit_cpu_seconds",
    )
    for r in payload["rows"]:
        out.append(
            f"| {r['grid']}² | "
            + " | ".join(
                f"{duration(r[k]['this'])} / {duration(r[k]['baseline'])} = {r[k]['ratio']:.2f}"
                for k in keys
            )
            + " |"
        )
    return out


def _rebuild_page(data, images, results):
    return (
        rebuild_cost_section(data, images)
        + [""]
        + factorization_section(data["factorization"], images)
        + [""]
        + build_ab_section(data["build_ab"], images)
    )


#: The results pages, in the index's order: (file name under docs/results/, the lines of its
#: body from (data, images, results)). Each page opens with its "## " heading, made its title.
PAGES = (
    ("crossover", lambda d, i, r: crossover_section(d["crossover"], i)),
    ("sensitivity", lambda d, i, r: sensitivity_section(d, i)),
    ("long-horizon", lambda d, i, r: long_horizon_section(d["long_horizon"], i)),
    ("numerical-damping", lambda d, i, r: numerical_damping_section(d["numerical_damping"], i)),
    ("error-control", lambda d, i, r: error_control_section(d["error_control"], i)),
    ("at-tolerance", _at_tolerance_page),
    ("wrinkles", lambda d, i, r: wrinkles_section(d["wrinkles"], i) if "wrinkles" in d else []),
    (
        "interpolation-bending",
        lambda d, i, r: interpolation_bending_section(d["interpolation_bending"], i),
    ),
    (
        "bending-consistency",
        lambda d, i, r: bending_consistency_section(d["bending_consistency"], i),
    ),
    ("rebuild-cost", _rebuild_page),
    ("scaling", lambda d, i, r: scaling_section(d, i)),
    ("newton-projection", lambda d, i, r: newton_projection_section(d, i)),
    ("factor-reuse", lambda d, i, r: factor_reuse_section(d, i)),
    ("newton-stop", lambda d, i, r: newton_stop_section(d, i)),
    ("stability", lambda d, i, r: stability_section(d, i)),
    ("explicit-step", lambda d, i, r: explicit_step_section(d, i)),
    ("threads", lambda d, i, r: threads_section(d, i)),
    ("pictures", lambda d, i, r: pictures_section(d, i)),
)


def as_page(lines: list) -> tuple:
    """(title, page text) of a section: its first "## " heading becomes the page's title and
    every deeper heading moves up one level, so the page reads alone."""
    lines = [line for line in lines if line is not None]
    while lines and not lines[0].strip():
        lines.pop(0)
    title = lines[0][3:].strip()
    rest = [line[1:] if line.startswith("###") else line for line in lines[1:]]
    return title, "\n".join([f"# {title}"] + rest).rstrip() + "\n"


def pages(data: dict, results: Path, images: str) -> list:
    """[(file stem, title, Markdown text)] of every results page with a body; ``images`` is the
    folder of the PNG files as the pages (in docs/results/) link it."""
    out = []
    for stem, build in PAGES:
        lines = build(data, images, results)
        if not any(line and line.strip() for line in lines):
            continue
        title, text = as_page(lines)
        head, body = text.split("\n", 1)
        out.append((stem, title, f"{head}\n\n" + "\n".join(machine_line(data, results)) + body))
    return out


def index(listed: list) -> str:
    """The generated block of docs/results.md: a link to every page (and Sphinx's toctree)."""
    links = [f"- [{title}](results/{stem}.md)" for stem, title, _ in listed]
    tree = ["```{toctree}", ":hidden:", ""] + [f"results/{stem}" for stem, _, _ in listed]
    return "\n".join(
        ["One page per benchmark, each readable alone:", ""] + links + [""] + tree + ["```"]
    )


def section(data: dict, results: Path, images: str | None = None) -> str:
    """Every results page's body in one text (the pages' order), from the benchmarks' JSON
    (``load``); ``results`` is the folder named in the text, ``images`` the folder of the PNG
    files as the text links it (default: ``results``)."""
    images = str(results) if images is None else images
    out = machine_line(data, results)
    for _, build in PAGES:
        lines = build(data, images, results)
        if any(line and line.strip() for line in lines):
            out += [""] + lines
    return "\n".join(line for line in out if line is not None)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--results",
        default="bench-results",
        type=Path,
        help="the folder of the benchmarks' JSON and PNG files",
    )
    parser.add_argument(
        "--page",
        "--readme",
        dest="page",
        default=Path("docs/results.md"),
        type=Path,
        help=f"the Markdown page whose {START} … {END} block is "
        "rewritten with the index; the pages go into the folder beside it named "
        "after it (docs/results/; --readme: the option's former name)",
    )
    args = parser.parse_args(argv)
    text = args.page.read_text()
    if START not in text or END not in text:
        raise SystemExit(f"{args.page} has no {START} … {END} block")
    before, rest = text.split(START, 1)
    after = rest.split(END, 1)[1]
    folder = args.page.parent / args.page.stem
    images = Path(os.path.relpath(args.results.resolve(), folder.resolve())).as_posix()
    listed = pages(load(args.results), args.results, images)
    folder.mkdir(exist_ok=True)
    for stale in set(folder.glob("*.md")) - {folder / f"{stem}.md" for stem, _, _ in listed}:
        stale.unlink()
    for stem, _, page in listed:
        (folder / f"{stem}.md").write_text(page, encoding="utf-8")
    args.page.write_text(f"{before}{START}\n{index(listed)}\n{END}{after}")
    print(f"updated the results in {args.page} and {len(listed)} pages in {folder}")


if __name__ == "__main__":
    main()
