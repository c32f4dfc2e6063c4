"""Writes the README's "Results" section from the JSON in bench-results/ (run by `make bench`),
so the words there are the numbers the benchmarks wrote.

    python -m benchmarks.report [--results bench-results] [--readme README.md]

Quick runs (make bench-quick) are refused: the README shows full-size results only.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

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


def speed_vs_error_section(sve: dict, results: Path) -> list:
    """The crossover benchmark's lines: per sheet cell the cheapest explicit and implicit runs at
    1 % (and the ratio at 0.1 %), the crossover stiffness, the 64² targets, wrinkle retention."""
    out = ["### Speed against error: the crossover", "",
           f"![crossover map]({results}/crossover.png)", "",
           f"![speed against error]({results}/speed_vs_error.png)", "",
           "Error: RMS vertex distance to a converged symplectic-Euler reference at T/2 and T over "
           "the cloth's size; cost: CPU seconds per simulated second on one thread (medians of "
           f"{sve['repeats']} runs for every run that could be its family's cheapest); explicit "
           "at its largest stable step, found by trying. Cells whose reference did not converge "
           f"to {sve['reference_tolerance']:g} are left out. Families: "
           f"{', '.join(sve['families'])}"
           + (f" (not in this build: {', '.join(sve['families_unavailable'])})"
              if sve["families_unavailable"] else "") + ".", "",
           "| cell | T | explicit at 1 % | cheapest implicit at 1 % | implicit / explicit at 1 % "
           "| at 0.1 % |", "|---|---|---|---|---|---|"]

    def run(e):
        if not e or "method" not in e:
            return "none"
        return (f"{e['method']}, dt {e['dt']:.3g} s, {e['cost_seconds_per_simulated_second']:.3g}"
                " s/s" + ("" if e["method"] == "explicit"
                          else f" ({e['iterations_per_step']:.1f} it/step)"))

    for c in sve["summary"]["cells"]:
        name = (f"{c['scene']} {c['size']}², k {c['stretch_stiffness']:g}, bending "
                f"{c['bend_stiffness']:g}")
        if "skipped" in c:
            out.append(f"| {name} | | skipped: {c['skipped']} | | | |")
            continue
        if not c.get("reference_converged"):
            out.append(f"| {name} | {c['horizon']:g} s | reference not converged "
                       f"({c.get('reference_error') or float('nan'):.1e}) | | | |")
            continue
        one, tenth = c["at_0.01"], c["at_0.001"]
        ratios = [f"{a['implicit_over_explicit_cost']:.2f} ({a['winner']})"
                  if "implicit_over_explicit_cost" in a else "—" for a in (one, tenth)]
        out.append(f"| {name} | {c['horizon']:g} s | {run(one['families'].get('explicit'))} | "
                   f"{run(one['best_implicit'])} | {ratios[0]} | {ratios[1]} |")
    crossing = sve["summary"]["crossovers"]
    if crossing:
        out += ["", "Crossover stiffness (implicit / explicit cost at 1 % crosses 1): "
                + "; ".join(f"{x['size']}², bending {x['bending']}: "
                            + (f"{x['crossover_stiffness']:.2g} N/m" if x["crossover_stiffness"]
                               else x.get("bound", "no data")) for x in crossing) + "."]
    for g in sve["summary"]["targets"]:
        head = (f"Target: at 64², k = {g['stretch_stiffness']:g} N/m, the best implicit method "
                f"costs at most {g['goal_ratio']:g} × explicit — ")
        if g.get("ratio") is None:
            out += ["", head + "**not measured**" + (" (no implicit run reached 1 %)"
                                                     if g["measured"] else "") + "."]
            continue
        lim = g["limits"]
        out += ["", head + verdict(g["met"]) + f": {g['ratio']:.2f}"
                + ("" if g["met"] else f", {g['shortfall']:.2f}× short")
                + f". {lim['implicit']['method']}: {lim['implicit']['steps']} steps × "
                f"{lim['implicit']['iterations_per_step']:.1f} iterations × "
                f"{duration(lim['implicit']['cpu_per_iteration'])} per iteration, against "
                f"explicit's {lim['explicit']['steps']} steps × "
                f"{duration(lim['explicit']['cpu_per_step'])}."]
    wrinkles = [c for c in sve["summary"]["cells"] if c["scene"] != "sheet"
                and c.get("reference_converged")]
    for c in wrinkles:
        kept = [f"{e['method']} {e['wrinkle_retention']:.2f}"
                for e in c["at_0.01"]["families"].values() if "wrinkle_retention" in e]
        if kept:
            out += ["", f"Wrinkle retention on {c['scene']} (stroke region's wrinkle measure "
                    "over the reference's), cheapest run of each family at 1 %: "
                    + ", ".join(kept) + "."]
    return out


def section(data: dict, results: Path) -> str:
    machine = data["explicit_step"]["machine"]
    blas = ", ".join(p.rsplit("/", 1)[-1] for p in machine["blas_loaded"]) or "unknown"
    out = [f"Regenerated by `make bench` from `{results}/*.json` (each benchmark's machine is "
           f"in its JSON; most ran on): {machine['cpu']}, {machine['logical_cores']} logical cores, "
           f"yore threads {machine['yore']['threads']}, BLAS {blas}, OPENBLAS_NUM_THREADS="
           f"{machine['thread_environment'].get('OPENBLAS_NUM_THREADS')}. Medians of repeated "
           "runs; ratios measured in one run.", ""]

    # -- speed against error: the crossover ------------------------------------------------------
    out += speed_vs_error_section(data["speed_vs_error"], results)

    # -- rebuild cost ---------------------------------------------------------------------------
    rebuild = data["rebuild_cost"]
    out += ["", "### What a stroke's rebuild costs", "", f"![rebuild cost]({results}/rebuild_cost.png)",
            "", "| case | ordering | unknowns | explicit step | implicit step | analysis (the "
            "rebuild) | step after a stroke | analysis / implicit step | analysis / explicit step "
            "| factorization GFlop/s (% of dense) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rebuild["rows"]:
        out.append(f"| {r['case']} | {r['ordering_used']} | {r['dofs']} | "
                   f"{duration(r['explicit_step_seconds'])} | "
                   f"{duration(r['implicit_step_seconds'])} | {duration(r['analyze_seconds'])}"
                   f" | {duration(r['step_after_stroke_seconds'])} | "
                   f"{r['analyze_over_implicit_step']:.2f} | {r['analyze_over_explicit_step']:.0f} | "
                   f"{r['factorize_gflops']:.1f} ({100 * r['factorize_fraction_of_dense']:.0f} %) |")
    worst = max(r["analyze_over_implicit_step"] for r in rebuild["rows"])
    out += ["", f"Dense reference: numpy's 2000×2000 multiply, {rebuild['dense_matmul_gflops']:.1f} "
            "GFlop/s in the same run. Target: the symbolic re-analysis after a stroke costs no more "
            f"than one implicit step — {verdict(worst <= 1.0)} (at most {worst:.2f} of a step). "
            "Against explicit stepping the same rebuild is "
            f"{min(r['analyze_over_explicit_step'] for r in rebuild['rows']):.0f}–"
            f"{max(r['analyze_over_explicit_step'] for r in rebuild['rows']):.0f} explicit steps."]

    lg = rebuild.get("local_global", [])
    if lg:
        out += ["", "Prefactored local-global (10 iterations per step), where the matrix is factored "
                "once and a stroke's rebuild is the whole extra cost — extra time over the 10 "
                "steps after a stroke, in ordinary steps:", "",
                "| case | ordinary step | fresh | reuse-ordering | stale-pcg |", "|---|---|---|---|---|"]
        for case in dict.fromkeys(r["case"] for r in lg):
            sel = {r["strategy"]: r for r in lg if r["case"] == case}
            out.append(f"| {case} | {duration(sel['fresh']['ordinary_step_seconds'])} | "
                       + " | ".join(f"{sel[k]['rebuild_in_ordinary_steps']:.1f}"
                                    for k in ("fresh", "reuse-ordering", "stale-pcg")) + " |")
        at128 = [r for r in lg if r["case"] == "grid 128²"]
        at64 = [r for r in lg if r["case"] == "grid 64²"]
        if at128 and at64:
            best = min(r["rebuild_in_ordinary_steps"] for r in at128)
            step64 = min(r["ordinary_step_seconds"] for r in at64)
            out += ["", f"Targets: a rebuild under 10 ordinary steps at 128² — {verdict(best < 10)} "
                    f"(best strategy {best:.1f}); a local-global step at 64² under 5 ms — "
                    f"{verdict(step64 < 0.005)} ({1e3 * step64:.1f} ms)."]

    qn = rebuild.get("quasi_newton", [])
    if qn:
        out += ["", "Quasi-Newton at its defaults: a stroke re-analyses and refactors only the "
                "scalar matrix (n×n); its cost in ordinary steps and in L-BFGS iterations:", "",
                "| case | ordinary step | iterations per step | per iteration | rebuild | "
                "rebuild in steps | rebuild in iterations |", "|---|---|---|---|---|---|---|"]
        for r in qn:
            out.append(f"| {r['case']} | {duration(r['ordinary_step_seconds'])} | "
                       f"{r['iterations_per_step']:.0f} | {duration(r['seconds_per_iteration'])} | "
                       f"{duration(r['rebuild_seconds'])} | {r['rebuild_in_ordinary_steps']:.3f} | "
                       f"{r['rebuild_in_iterations']:.1f} |")

    imp = data["implicit_step"]
    big = [r for r in imp["rows"] if r["grid"] >= 128]
    out += ["", "From `implicit_step` (linearized step by phase, AMD and METIS): a linearized step "
            f"costs {min(r['step_over_factorize'] for r in imp['rows']):.2f}–"
            f"{max(r['step_over_factorize'] for r in imp['rows']):.2f} × one factorization "
            f"(target ≤ 1.5: {verdict(max(r['step_over_factorize'] for r in imp['rows']) <= 1.5)}); "
            f"an analysis {min(r['analyze_over_factorize'] for r in imp['rows']):.2f}–"
            f"{max(r['analyze_over_factorize'] for r in imp['rows']):.2f} of one (target ≤ 1: "
            f"{verdict(max(r['analyze_over_factorize'] for r in imp['rows']) <= 1)}); at 128² and "
            f"above the factorization reaches {min(r['factorize_fraction_of_dense'] for r in big):.0%}–"
            f"{max(r['factorize_fraction_of_dense'] for r in big):.0%} of the dense multiply rate "
            f"(target ≥ 30 %: {verdict(min(r['factorize_fraction_of_dense'] for r in big) >= 0.3)})."
            if big else ""]
    for r in imp.get("iterations", []):
        if r["grid"] == 64:
            out += ["", f"One quasi-Newton iteration at 64² costs {r['quasi_over_newton']:.3f} of a "
                    f"Newton iteration ({duration(r['quasi_newton_iteration_seconds'])} against "
                    f"{duration(r['newton_iteration_seconds'])}; target ≤ 0.1: "
                    f"{verdict(r['quasi_over_newton'] <= 0.1)})."]

    # -- scaling --------------------------------------------------------------------------------
    scaling = data["scaling"]
    out += ["", "### Scaling", "", f"![scaling]({results}/scaling.png)", "",
            "Fitted slopes of step cost against vertices (log-log): "
            + ", ".join(f"{k.replace('_', ' ')} {v:.2f}" for k, v in scaling["slopes"].items())
            + "."]

    # -- Newton --------------------------------------------------------------------------------
    newton = data["newton_projection"]
    out += ["", "### Newton: Hessian projections", "",
            f"![Newton iterations]({results}/newton_projection.png)", "",
            "Iterations per step (median / mean / max), rejected factorizations per step, steps "
            "at max_newton, CPU s per simulated s; deviation from a tight run / cloth size (on "
            "the buckling scenes mostly the creases settling differently) and the step's own "
            "deviation (the largest over every 10th step, each also solved tight from the same "
            "state).", "",
            "| scene | projection | iterations | rejected/step | at max_newton | CPU s/s "
            "| deviation | one step |",
            "|---|---|---|---|---|---|---|---|"]
    for r in newton["rows"]:
        out.append(f"| {r['scene']} | {r['projection']} | {r['median_iterations']:.0f} / "
                   f"{r['mean_iterations']:.1f} / {r['max_iterations']} | "
                   f"{r['rejected_per_step']:.2f} | {r['unconverged_steps']} | "
                   f"{r['cpu_seconds_per_simulated_second']:.1f} | {r['deviation']:.1e} | "
                   + (f"{r['step_deviation']:.1e} |" if r.get("step_deviation") is not None
                      else "– |"))
    out += ["", "Target on the first scene (median <= 5, <= 0.5 rejected/step, none at max_newton, "
            "deviation <= 1e-3): " + ", ".join(
                f"{p} {'**met**' if met else '**missed**'}"
                for p, met in newton["target_met"].items()) + "."]

    # -- stability ------------------------------------------------------------------------------
    stability = data["stability_map"]
    out += ["", "### Stability", "", f"![stability map]({results}/stability_map.png)", "",
            "A sweep (`benchmarks/stability_map.toml`, run through `yore sweep`; the figure "
            "comes from its Dataset): "
            f"{stability['steps']} undamped steps per cell; cells stable / energy gain / diverged "
            "per integrator: " + "; ".join(
                f"{name} {sum(r['state'] == 'stable' for r in rows)}/"
                f"{sum(r['state'] == 'energy gain' for r in rows)}/"
                f"{sum(r['state'] == 'diverged' for r in rows)}"
                for name in dict.fromkeys(r["integrator"] for r in stability["rows"])
                for rows in [[r for r in stability["rows"] if r["integrator"] == name]]) + "."]

    # -- explicit throughput --------------------------------------------------------------------
    explicit = data["explicit_step"]
    out += ["", "### Explicit step", "", f"![explicit step]({results}/explicit_step.png)", "",
            "| grid | springs | threads | ms per step | × memory-bandwidth bound |", "|---|---|---|---|---|"]
    for r in explicit["rows"]:
        out.append(f"| {r['grid']}² | {r['springs']} | {r['threads']} | "
                   f"{1e3 * r['step_seconds_median']:.3g} | {r['over_bandwidth_bound']:.2f} |")
    largest = max(r["grid"] for r in explicit["rows"])
    best = min(r["over_bandwidth_bound"] for r in explicit["rows"] if r["grid"] == largest)
    out += ["", f"Bound: the step's least memory traffic (every array touched once) over the "
            f"STREAM-triad bandwidth measured in the same run with as many threads ("
            + ", ".join(f"{k} thread{'s' if int(k) > 1 else ''}: {v / 1e9:.1f} GB/s"
                        for k, v in explicit.get("stream_bandwidth_by_threads", {}).items())
            + "). Target: within 2× "
            f"of the bound at the largest size ({largest}²) — {verdict(best <= 2.0)} "
            f"({best:.2f}×)."
            + (" Below 1, the cloth's arrays still fit in the caches." if best < 1.0 else "")]
    # -- threads -------------------------------------------------------------------------------
    threads = data["threads"]
    out += ["", "### Threads", "", f"![threads]({results}/threads.png)", "",
            f"Default threads against one thread on {threads['machine']['cpu']} "
            f"({threads['machine']['logical_cores']} logical cores), each run a fresh process "
            "(medians; busy: a process burning the last core):", "",
            "| cell | one thread | default | default / one |", "|---|---|---|---|"]
    for cell in threads["cells"]:
        modes = {r["mode"]: r for r in threads["rows"]
                 if r["scene"] == cell["scene"] and r["load"] == cell["load"]}
        out.append(f"| {cell['scene']}, {cell['load']} | "
                   f"{duration(modes['one']['step_seconds_median'])} | "
                   f"{duration(modes['default']['step_seconds_median'])} | "
                   f"{cell['default_over_one_thread']:.2f} |")
    out += ["", f"Target: the default at most {threads['target_ratio']}× one thread in every "
            f"cell — {verdict(threads['target_met'])}."]
    # -- the crossover as a sweep ---------------------------------------------------------------
    sweep = data["crossover_sweep"]
    out += ["", "### The crossover as a sweep", "",
            f"![crossover sweep]({results}/crossover_sweep.png)", "",
            f"`benchmarks/crossover.toml` through `yore sweep` ({sweep['cells']} cells: "
            + ", ".join(f"{n} {s}" for s, n in sweep["statuses"].items())
            + "): explicit at its default step against each implicit family on a fixed ladder "
            f"of steps, error at the {sweep['horizon_seconds']:.3g} s horizon against explicit at "
            "a fine fixed step, cost in wall seconds per simulated second (two workers on two "
            "cores). Cheapest at 1 % error:", "",
            "| sheet | stiffness (N/m) | explicit (s/s) | best implicit | its cost (s/s) | implicit / explicit |",
            "|---|---|---|---|---|---|"]
    for r in sweep["summary"]:
        out.append(f"| {r['size']}² | {r['stiffness']:g} | "
                   + (f"{r['explicit_cost']:.3g}" if r["explicit_cost"] is not None else "–")
                   + f" | {r['best_implicit'] or '–'} | "
                   + (f"{r['best_implicit_cost']:.3g}" if r["best_implicit_cost"] is not None
                      else "–") + " | "
                   + (f"{r['implicit_over_explicit']:.2f}" if r["implicit_over_explicit"]
                      is not None else "–") + " |")
    winners = {r["winner"] == "explicit" for r in sweep["summary"] if r["winner"]}
    out += ["", "A coarser map than the one above: a fixed ladder, one run per cell, wall time "
            "of two workers sharing two cores, the error at the horizon only, explicit at its "
            "default step (below its limit) and a reference that is not checked for "
            "convergence." + (" Here explicit is cheaper in every cell, where speed_vs_error "
                              "(CPU time, repeats, explicit at its bisected limit, errors at "
                              "T/2 and T, a converged reference) finds implicit cheaper at 1 % "
                              "on the stiffest sheets; which of those differences decides it "
                              "is not measured yet." if winners == {True} else "")
            + " `yore sweep plot bench-results/sweeps/crossover ...` draws any recorded "
            "variable of it."]
    # -- pictures -------------------------------------------------------------------------------
    pictures = data["pictures"]
    out += ["", "### Pictures", "", f"![pictures]({results}/pictures.png)", "",
            f"{pictures['renderer']} on the CPU (Mesa llvmpipe), one picture with a colour map, "
            "colour bar and stroke (median of "
            f"{pictures['rows'][0]['repeats']}); starting polyscope in a fresh process "
            f"{pictures['start_seconds_median']:.2f} s, the viewer's pick of a pixel "
            f"{1e3 * pictures['pick_seconds_median']:.1f} ms.", "",
            "| size | vertices | " + " | ".join(
                f"×{f}" for f in sorted({r['factor'] for r in pictures['rows']})) + " |",
            "|---|---|" + "---|" * len({r["factor"] for r in pictures["rows"]})]
    for key in dict.fromkeys((r["width"], r["height"], r["vertices"]) for r in pictures["rows"]):
        cells = {r["factor"]: r for r in pictures["rows"]
                 if (r["width"], r["height"], r["vertices"]) == key}
        out.append(f"| {key[0]}×{key[1]} | {key[2]} | " + " | ".join(
            duration(cells[f]["render_seconds_median"]) if f in cells else "– (too large)"
            for f in sorted({r["factor"] for r in pictures["rows"]})) + " |")
    return "\n".join(line for line in out if line is not None)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", default="bench-results", type=Path)
    parser.add_argument("--readme", default="README.md", type=Path)
    args = parser.parse_args(argv)
    text = args.readme.read_text()
    if START not in text or END not in text:
        raise SystemExit(f"{args.readme} has no {START} … {END} block")
    before, rest = text.split(START, 1)
    after = rest.split(END, 1)[1]
    body = section(load(args.results), args.results)
    args.readme.write_text(f"{before}{START}\n{body}\n{END}{after}")
    print(f"updated the Results section of {args.readme}")


if __name__ == "__main__":
    main()
