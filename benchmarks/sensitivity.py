"""How much a crossover cell's answer depends on where it starts: the floor under every error the
crossover judges.

    python -m benchmarks.sensitivity [--out bench-results] [--quick]
        [--crossover bench-results/crossover.json] [--max-run-seconds 200]
        [--cell SIZE:K:BENDING ...] [--merge EARLIER.json [--verdicts-only]]

A crossover cell judges a run by its distance from an explicit reference, halving the
reference's step until two references agree to a tenth of the threshold. On some buckling
sheets the references stop agreeing better than 1e-4–9e-4 of the size however small the step
(`reference_converged` false). This benchmark asks whether the sheet itself is that sensitive:
for each cell of the crossover's JSON whose reference chain's first run cost at most
--max-run-seconds CPU s, it runs explicit at that run's step (the reference's coarsest) from the
cell's start, once more from the same start (it must repeat exactly), and from starts whose
free vertices moved by EPSILONS (1e-14 m, about a hundred round-off units of a 1 m coordinate,
and 1e-10 m) in fixed random directions. The distance is the crossover's: RMS vertex distance
over the bounding-box diagonal at the start, at T/2 and at T, the larger of the two.

Per cell it records the distances at each ε, their growth over ε (linear response: ten
thousand times from 1e-14 to 1e-10; about once when it saturates, that is when a start moved
by round-off already changes how the sheet buckles), the floor (the distance at the smaller ε:
one sample of how far round-off alone moves the answer, so good to a factor of about two) and
whether a threshold is judgeable at all: the floor at most a tenth of it, the crossover's rule
for its references.

Floor-aware verdicts (`floor_aware`): where the crossover's rule leaves a threshold out (the
reference too coarse) or judges it on a floor above a tenth of it, the verdict the crossover
would give if every run's error were charged the reference's own uncertainty, u = max(its
last difference, the floor): a run meets t when error + u ≤ t. Labelled as such, beside the
crossover's verdicts, not in them.

--cell runs only the cells named (e.g. "128:2e7:real cloth", whatever their cost); --merge
keeps an earlier file's rows of the cells not run now; --verdicts-only runs nothing and only
recomputes the floor-aware verdicts (after cells were added to the crossover). --quick runs two
small cells (a 12² sheet, a smooth one and a stiff one) from scratch, without the crossover.
Writes sensitivity.json and sensitivity.png.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from . import crossover as cx
from .common import arguments, machine_info, save

EPSILONS = (1e-14, 1e-10)  # m: how far each free vertex's start moves
SEED = 20261203
QUICK_CELLS = (
    {"size": 12, "stretch_stiffness": 2e3, "bending": "soft"},
    {"size": 12, "stretch_stiffness": 2e6, "bending": "equal"},
)


def run(make, dt_steps, duration, epsilon):
    """Explicit from the start (free vertices moved by epsilon): positions at T/2 and T, CPU s."""
    sim = make(dt=duration / dt_steps, integrator="explicit")
    if epsilon:
        positions = np.array(sim.cloth.positions)
        free = np.ones(len(positions), bool)
        free[np.asarray(sim.cloth.fixed_vertices, int)] = False
        directions = np.random.default_rng(SEED).standard_normal(positions.shape)
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        positions[free] += epsilon * directions[free]
        sim.cloth.positions = positions
    start = time.thread_time()
    sim.step(dt_steps // 2, progress=False)
    half = np.array(sim.cloth.positions)
    sim.step(dt_steps - dt_steps // 2, progress=False)
    return [half, np.array(sim.cloth.positions)], time.thread_time() - start


def cells_from(crossover_json, max_run_seconds):
    """(cell, steps of the reference's coarsest run, the reference's facts) of every measured
    crossover cell whose coarsest reference run cost at most max_run_seconds, and the cells
    left out with the reason."""
    summary = json.loads(Path(crossover_json).read_text())["summary"]["cells"]
    chosen, left_out = [], []
    for c in summary:
        chain = c.get("reference_chain")
        where = {k: c[k] for k in ("size", "stretch_stiffness", "bending")}
        if not chain:
            left_out.append(dict(where, reason="not run"))
            continue
        if chain[0]["cpu_seconds"] > max_run_seconds:
            left_out.append(
                dict(
                    where,
                    reason=f"its reference's first run cost "
                    f"{chain[0]['cpu_seconds']:.0f} CPU s > --max-run-seconds",
                )
            )
            continue
        chosen.append(
            (
                dict(where, horizon=c["horizon"]),
                chain[0]["steps"],
                {
                    "reference_converged": c["reference_converged"],
                    "reference_error": c["reference_error"],
                    "reference_steps": [link["steps"] for link in chain],
                    "reference_differences": [link["difference_to_previous"] for link in chain[1:]],
                },
            )
        )
    return chosen, left_out


def measure(cell, steps, facts):
    make = cx.sheet(cell["size"], cell["stretch_stiffness"], cell["bending"])
    duration = cell["horizon"]
    probe = make()
    scale = float(np.linalg.norm(np.ptp(probe.cloth.positions, axis=0)))
    base, cpu = run(make, steps, duration, 0.0)
    again, _ = run(make, steps, duration, 0.0)
    row = dict(
        cell,
        **facts,
        steps=steps,
        dt=duration / steps,
        scale=scale,
        cpu_seconds_per_run=cpu,
        repeat_distance=max(cx.relative_errors(again, base, scale)),
    )
    for epsilon in EPSILONS:
        moved, _ = run(make, steps, duration, epsilon)
        half, end = cx.relative_errors(moved, base, scale)
        row[f"distance_{epsilon:g}"] = max(half, end)
        row[f"distance_half_{epsilon:g}"] = half
        row[f"distance_end_{epsilon:g}"] = end
    small, large = (row[f"distance_{e:g}"] for e in EPSILONS)
    row["growth"] = large / small if small > 0 else float("inf")
    row["floor"] = small
    row["judgeable"] = {f"{t:g}": small <= cx.REFERENCE_FRACTION * t for t in cx.THRESHOLDS}
    return row


def floor_aware(crossover, rows):
    """The verdicts the crossover's rule leaves out, or gives on a floor above a tenth of the
    threshold, with every error charged the reference's own uncertainty: there a run meets t
    when its error plus the allowance u = max(the reference's last difference, the cell's
    floor) is at most t (the triangle inequality, u standing for the reference's distance from
    the sheet's motion, which round-off defines no better than the floor). The crossover's own
    selection (`summarize_cell`: usable runs, the cell's families, the cheapest by median CPU)
    does the rest."""
    floors = {key(r): r["floor"] for r in rows}
    out = []
    for cell in crossover["summary"]["cells"]:
        k = key(cell)
        if k not in floors or cell.get("reference_error") is None:
            continue
        families = [f for f in crossover["families"] if f not in cell.get("families_dropped", {})]
        for threshold in cx.THRESHOLDS:
            if (
                cx.reference_serves(cell, threshold)
                and floors[k] <= cx.REFERENCE_FRACTION * threshold
            ):
                continue  # the crossover's verdict stands as it is
            allowance = max(cell["reference_error"], floors[k])
            found = dict(
                size=k[0],
                stretch_stiffness=k[1],
                bending=k[2],
                threshold=threshold,
                allowance=allowance,
                reference_error=cell["reference_error"],
                floor=floors[k],
                ratio=None,
                implicit=None,
                explicit=None,
            )
            errors = [
                r["error"]
                for r in crossover["rows"]
                if key(r) == k
                and cx.usable(r)
                and r["method"] in families
                and r["method"] != "explicit"
            ]
            found["least_implicit_error"] = min(errors, default=None)
            if allowance < threshold:
                shifted = [
                    dict(r, error=r["error"] + allowance)
                    for r in crossover["rows"]
                    if key(r) == k and "error" in r
                ]
                verdict = cx.summarize_cell(dict(cell, reference_error=0.0), shifted, families)[
                    f"at_{threshold:g}"
                ]
                for side in ("implicit", "explicit"):
                    best = verdict[f"best_{side}"]
                    if best:
                        found[side] = {
                            n: best.get(n)
                            for n in (
                                "method",
                                "dt",
                                "repeats",
                                "cost_seconds_per_simulated_second",
                            )
                        }
                        found[side]["error"] = best["error"] - allowance
                found["ratio"] = verdict.get("implicit_over_explicit_cost")
            out.append(found)
    return out


def describe(row):
    return f"{row['size']}² k={row['stretch_stiffness']:g} {row['bending']}"


def key(cell):
    return (int(cell["size"]), float(cell["stretch_stiffness"]), cell["bending"])


def merged(earlier, rows, left_out):
    """This run's rows and left-out cells joined with an earlier payload's: a cell run now
    replaces its earlier row, and a cell is left out only if no row measures it."""
    now = {key(r) for r in rows}
    rows = [r for r in earlier["rows"] if key(r) not in now] + rows
    done = {key(r) for r in rows}
    left = {key(c): c for c in earlier["left_out"] + left_out if key(c) not in done}
    return rows, list(left.values())


def parse_cell(text):
    """ "SIZE:K:BENDING" -> the cell's key; ValueError naming the problem."""
    parts = text.split(":")
    if len(parts) != 3 or parts[2] not in cx.BENDING_ROWS:
        raise ValueError(
            f"--cell wants SIZE:K:BENDING with BENDING one of "
            f"{', '.join(cx.BENDING_ROWS)}, got {text!r}"
        )
    return int(parts[0]), float(parts[1]), parts[2]


def main(argv=None):
    args = arguments(
        __doc__,
        argv,
        extra=lambda parser: (
            parser.add_argument(
                "--crossover", type=Path, default=Path("bench-results") / "crossover.json"
            ),
            parser.add_argument("--max-run-seconds", type=float, default=200.0),
            parser.add_argument("--cell", action="append", default=[], type=parse_cell),
            parser.add_argument("--merge", type=Path, default=None),
            parser.add_argument("--verdicts-only", action="store_true"),
        ),
    )
    if args.verdicts_only and (args.merge is None or args.cell or args.quick):
        raise SystemExit("--verdicts-only takes --merge EARLIER.json and no --cell or --quick")
    if args.verdicts_only:
        jobs, left_out = [], []
    elif args.quick:
        jobs, left_out = [], []
        for cell in QUICK_CELLS:
            cell = dict(cell, horizon=0.125)
            make = cx.sheet(cell["size"], cell["stretch_stiffness"], cell["bending"])
            steps = cx.even_steps(cell["horizon"], 0.5 * make().stable_dt())
            jobs.append(
                (
                    cell,
                    steps,
                    {
                        "reference_converged": None,
                        "reference_error": None,
                        "reference_steps": [],
                        "reference_differences": [],
                    },
                )
            )
    else:
        named = set(args.cell)
        jobs, left_out = cells_from(args.crossover, math.inf if named else args.max_run_seconds)
        if named:
            jobs = [job for job in jobs if key(job[0]) in named]
            left_out = [c for c in left_out if key(c) in named]
        jobs.sort(key=lambda job: job[0]["size"] ** 3 * job[1])  # the cheapest first
    rows = []
    for cell, steps, facts in jobs:
        row = measure(cell, steps, facts)
        rows.append(row)
        reference = row["reference_error"]
        print(
            f"{describe(row)}: {steps} steps, floor {row['floor']:.2e}, at 1e-10 m "
            f"{row['distance_1e-10']:.2e} (growth {row['growth']:.3g}), reference "
            f"{'—' if reference is None else format(reference, '.2e')}, "
            f"repeat {row['repeat_distance']:.1e}",
            flush=True,
        )
    if args.merge is not None:
        rows, left_out = merged(json.loads(args.merge.read_text()), rows, left_out)
    crossover = None if args.quick else json.loads(args.crossover.read_text())
    verdicts = floor_aware(crossover, rows) if crossover else []
    payload = {
        "benchmark": "sensitivity",
        "machine": machine_info(),
        "quick": args.quick,
        "rows": rows,
        "left_out": left_out,
        "epsilons": list(EPSILONS),
        "seed": SEED,
        "thresholds": list(cx.THRESHOLDS),
        "reference_fraction": cx.REFERENCE_FRACTION,
        "floor_aware": verdicts,
    }
    save(args.out, "sensitivity", payload, lambda path: plot(payload, path))
    return payload


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    markers = {"equal": "o", "soft": "s", "real cloth": "^"}
    colors = {32: "tab:blue", 64: "tab:orange", 128: "tab:green", 12: "tab:grey"}
    small, large = (f"distance_{e:g}" for e in payload["epsilons"])
    for r in payload["rows"]:
        for key, filled in ((small, True), (large, False)):
            ax.plot(
                r["stretch_stiffness"],
                max(r[key], 1e-16),
                markers[r["bending"]],
                color=colors.get(r["size"], "k"),
                mfc=colors.get(r["size"], "k") if filled else "none",
            )
        if r["reference_error"]:
            ax.plot(
                r["stretch_stiffness"],
                r["reference_error"],
                "_",
                ms=14,
                color=colors.get(r["size"], "k"),
            )
    for t in payload["thresholds"]:
        ax.axhline(payload["reference_fraction"] * t, color="grey", lw=0.8, ls="--")
        ax.annotate(
            f"a tenth of {t:g}",
            (ax.get_xlim()[0], payload["reference_fraction"] * t),
            fontsize=7,
            va="bottom",
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("stretch stiffness k, N/m")
    ax.set_ylabel("distance at max(T/2, T) / size")
    handles = [plt.Line2D([], [], ls="", marker=m, color="k", label=b) for b, m in markers.items()]
    handles += [
        plt.Line2D([], [], ls="", marker="o", color=c, label=f"{s}²")
        for s, c in colors.items()
        if any(r["size"] == s for r in payload["rows"])
    ]
    handles += [
        plt.Line2D(
            [], [], ls="", marker="o", color="k", label=f"start moved {payload['epsilons'][0]:g} m"
        ),
        plt.Line2D(
            [],
            [],
            ls="",
            marker="o",
            mfc="none",
            color="k",
            label=f"start moved {payload['epsilons'][1]:g} m",
        ),
        plt.Line2D(
            [], [], ls="", marker="_", ms=14, color="k", label="reference's last difference"
        ),
    ]
    ax.legend(handles=handles, fontsize=7, ncol=2)
    ax.set_title(
        "How far a start moved by ε ends up (explicit at the reference's step)", fontsize=9
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
