"""Speed against error: explicit, strain-limited explicit, linearized BE, Newton BE and BDF2 on the
paper's scenes and a stiff sheet, each over a ladder of time steps.

    python -m benchmarks.speed_vs_error [--out bench-results] [--quick]

Error: RMS vertex distance to a converged reference at fixed times (0.2 s and 0.4 s), over the
cloth's bounding-box diagonal. The reference is symplectic Euler at a step 16–32× below its
stability limit; the same at half that step shows how converged it is (reported as
reference_error). On the cylinder, which gets a stroke at t = 0, the stroke region's
`yore.metrics.wrinkle_measure` (RMS normal height over the Taubin-smoothed surface, m) is
compared with the reference's (implicit Euler is known to damp wrinkles). Cost:
wall time per simulated second. Writes speed_vs_error.json and speed_vs_error.png.
"""

from __future__ import annotations

import math
import time

import numpy as np

import yore
from yore import metrics

from .common import arguments, machine_info, save

BASE = 1.0 / 30.0  # every step of the ladders is BASE / 2^k, so the sample times are whole steps

METHODS = {
    "explicit": {"integrator": "explicit"},
    "explicit + strain limit": {"integrator": "explicit", "strain_limit": 1.1},
    "BE linearized": {"integrator": "implicit", "linearized": True},
    "BE Newton": {"integrator": "implicit"},
    "BDF2": {"integrator": "bdf2"},
    "BE Newton, lagged factor": {"integrator": "implicit", "lagged_factorization": True},
    "local-global (10 it)": {"integrator": "local-global", "iterations": 10, "tolerance": 0.0,
                             "acceleration": "none"},
    "local-global (defaults)": {"integrator": "local-global"},
}


def cylinder_stroke_points(sim):
    X = sim.cloth.positions
    y = X[:, 1].min() + 0.25 * (X[:, 1].max() - X[:, 1].min())
    r = float(np.median(np.hypot(X[:, 0], X[:, 2])))
    angles = np.linspace(0.0, 2.0 * math.pi, 73)
    return np.column_stack([r * np.cos(angles), np.full_like(angles, y), r * np.sin(angles)])


def scenes(quick):
    res = 9 if quick else 13
    rings, segments = (5, 12) if quick else (9, 20)

    # The cloth starts flat between its pins (pin_spacing=1): a gathered start buckles, and
    # buckling is too sensitive to the step for a converged reference to exist.
    def hanging(**options):
        return yore.scenes.hanging_cloth(resolution=res, pin_spacing=1.0, **options), None

    def stiff(**options):
        return yore.scenes.hanging_cloth(resolution=res, pin_spacing=1.0, stretch_stiffness=2e4,
                                         bend_stiffness=2e4, **options), None

    def cylinder(**options):
        sim = yore.scenes.rotating_cylinder(rings=rings, segments=segments, **options)
        report = sim.stroke(cylinder_stroke_points(sim))  # at t = 0: same topology for all
        return sim, report

    return {"hanging cloth (soft)": hanging, "stiff sheet (100x)": stiff,
            "rotating cylinder + stroke": cylinder}


def run(make, method, dt, sample_times):
    """Positions at the sample times, wall seconds, the region's wrinkle measure; diverged →
    None."""
    sim, report = make(dt=dt, **METHODS[method])
    snapshots = []
    start = time.perf_counter()
    try:
        for t in sample_times:
            sim.advance(t - sim.time, progress=False)
            snapshots.append(sim.cloth.positions)
    except yore.SimulationDiverged:
        return None
    wall = time.perf_counter() - start
    wrinkles = None
    if report is not None:
        wrinkles = metrics.wrinkle_measure(sim.cloth.positions, sim.cloth.faces,
                                           report.region_faces)
    return {"snapshots": snapshots, "wall_seconds": wall, "wrinkle_measure": wrinkles,
            "newton_iterations": sim.stats["counters"].get("newton_iterations")}


def pareto(points):
    """Indices of the points (cost, error) no other point beats in both."""
    front = []
    for i, (cost, error) in enumerate(points):
        if not any(c <= cost and e <= error and (c, e) != (cost, error) for c, e in points):
            front.append(i)
    return front


def main(argv=None):
    args = arguments(__doc__, argv)
    duration = 0.2 if args.quick else 0.4
    sample_times = [duration / 2, duration]
    implicit_levels = range(0, 4 if args.quick else 6)  # BASE ... BASE/32
    results = []
    for scene, make in scenes(args.quick).items():
        probe, _ = make()
        stable = probe.stable_dt()
        size = float(np.linalg.norm(np.ptp(probe.cloth.positions, axis=0)))
        # reference: symplectic Euler 16–32× below its stability estimate, and at half that step
        level_ref = math.ceil(math.log2(BASE / (stable / 16)))
        reference = run(make, "explicit", BASE / 2**level_ref, sample_times)
        finer = run(make, "explicit", BASE / 2 ** (level_ref + 1), sample_times)

        def error(result):
            return float(np.sqrt(np.mean([np.mean(np.sum((a - b) ** 2, axis=1))
                                          for a, b in zip(result["snapshots"],
                                                          reference["snapshots"])])) / size)

        reference_error = error(finer)
        for method in METHODS:
            explicit = METHODS[method]["integrator"] == "explicit"
            levels = range(0, level_ref - 2) if explicit else implicit_levels
            for level in levels:
                dt = BASE / 2**level
                result = run(make, method, dt, sample_times)
                row = {"scene": scene, "method": method, "dt": dt, "diverged": result is None,
                       "stable_dt_estimate": stable}
                if result is not None:
                    row.update(error=error(result),
                               cost_seconds_per_simulated_second=result["wall_seconds"] / duration,
                               newton_iterations=result["newton_iterations"])
                    if result["wrinkle_measure"] is not None:
                        row["wrinkle_measure"] = result["wrinkle_measure"]
                        row["wrinkle_measure_over_reference"] = (
                            result["wrinkle_measure"] / reference["wrinkle_measure"])
                results.append(row)
                print(f"{scene:28s} {method:24s} dt={dt:.2e} "
                      + ("diverged" if result is None else
                         f"error={row['error']:.2e} cost={row['cost_seconds_per_simulated_second']:.3g} s/s"))
        results.append({"scene": scene, "method": "reference", "dt": BASE / 2**level_ref,
                        "reference_error": reference_error, "size": size,
                        "reference_wrinkle_measure": reference["wrinkle_measure"],
                        "cost_seconds_per_simulated_second": reference["wall_seconds"] / duration})
    summary = summarize(results)
    payload = {"benchmark": "speed_vs_error", "machine": machine_info(), "quick": args.quick,
               "duration_seconds": duration, "sample_times": sample_times, "rows": results,
               "summary": summary}
    save(args.out, "speed_vs_error", payload, lambda path: plot(results, path))
    for line in summary["lines"]:
        print(line)
    return payload


def cheapest_at(results, scene, methods, tolerance):
    rows = [r for r in results if r["scene"] == scene and r["method"] in methods
            and not r["diverged"] and r["error"] <= tolerance]
    return min(rows, key=lambda r: r["cost_seconds_per_simulated_second"]) if rows else None


def summarize(results):
    lines, targets = [], {}
    explicit_methods = ("explicit", "explicit + strain limit")
    implicit_methods = tuple(m for m in METHODS if m not in explicit_methods)
    for scene in dict.fromkeys(r["scene"] for r in results):
        for tolerance in (0.01, 0.001):
            best_explicit = cheapest_at(results, scene, explicit_methods, tolerance)
            best_implicit = cheapest_at(results, scene, implicit_methods, tolerance)
            key = f"{scene} @ {tolerance:g}"
            entry = {"explicit": best_explicit and {k: best_explicit[k] for k in
                                                    ("method", "dt", "error",
                                                     "cost_seconds_per_simulated_second")},
                     "implicit": best_implicit and {k: best_implicit[k] for k in
                                                    ("method", "dt", "error",
                                                     "cost_seconds_per_simulated_second")}}
            if best_explicit and best_implicit:
                entry["explicit_over_implicit_cost"] = (
                    best_explicit["cost_seconds_per_simulated_second"]
                    / best_implicit["cost_seconds_per_simulated_second"])
            targets[key] = entry
            lines.append(f"{key}: cheapest explicit "
                         + (f"{best_explicit['method']} dt={best_explicit['dt']:.2e} "
                            f"{best_explicit['cost_seconds_per_simulated_second']:.3g} s/s"
                            if best_explicit else "none")
                         + "; cheapest implicit "
                         + (f"{best_implicit['method']} dt={best_implicit['dt']:.2e} "
                            f"{best_implicit['cost_seconds_per_simulated_second']:.3g} s/s"
                            if best_implicit else "none")
                         + (f"; explicit/implicit cost {entry['explicit_over_implicit_cost']:.2f}"
                            if "explicit_over_implicit_cost" in entry else ""))
    return {"cheapest_at_tolerance": targets, "lines": lines}


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene_names = list(dict.fromkeys(r["scene"] for r in results))
    fig, axes = plt.subplots(1, len(scene_names), figsize=(5.2 * len(scene_names), 4.4))
    markers = dict(zip(METHODS, "os^Dv<>P"))
    for ax, scene in zip(np.atleast_1d(axes), scene_names):
        rows = [r for r in results if r["scene"] == scene and r["method"] in METHODS]
        finite = [r for r in rows if not r["diverged"]]
        top = max([r["error"] for r in finite] + [1e-3]) * 3
        for method in METHODS:
            sel = [r for r in finite if r["method"] == method]
            ax.loglog([r["cost_seconds_per_simulated_second"] for r in sel],
                      [r["error"] for r in sel], marker=markers[method], linestyle="-",
                      label=method)
            bad = [r for r in rows if r["method"] == method and r["diverged"]]
            if bad:
                ax.scatter([1e-3] * len(bad), [top] * len(bad), marker="x", color="red")
        front = [finite[i] for i in pareto([(r["cost_seconds_per_simulated_second"], r["error"])
                                            for r in finite])]
        front.sort(key=lambda r: r["cost_seconds_per_simulated_second"])
        ax.plot([r["cost_seconds_per_simulated_second"] for r in front],
                [r["error"] for r in front], color="k", linewidth=2.5, alpha=0.25,
                label="Pareto front")
        ax.axhline(0.01, color="gray", linestyle=":", linewidth=1)
        ax.set_title(f"{scene}\n(red x at the top: diverged runs)", fontsize=9)
        ax.set_xlabel("wall seconds per simulated second")
        ax.set_ylabel("RMS error / cloth size")
        ax.grid(True, which="both", alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
