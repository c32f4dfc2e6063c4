"""Newton with the Hessian always projected to PSD against the adaptive projection (exact
Hessian where it is positive definite), on the paper's scenes and after strokes.

    python -m benchmarks.newton_projection [--out bench-results] [--quick]

Backward Euler at 1/60 s, newton_tol = 1e-5: Newton iterations per step, rejected exact
factorizations, steps that hit max_newton, wall time per simulated second. Writes
newton_projection.json and newton_projection.png.
"""

from __future__ import annotations

import time

import yore

from .common import arguments, machine_info, save


def scenes(quick):
    res = 9 if quick else 21
    rings, segments = (7, 16) if quick else (13, 32)

    def hanging_flat(**options):
        return yore.scenes.hanging_cloth(resolution=res, pin_spacing=1.0, **options), None

    def hanging_gathered(**options):
        return yore.scenes.hanging_cloth(resolution=res, **options), None

    def cylinder(**options):
        return yore.scenes.rotating_cylinder(rings=rings, segments=segments, **options), None

    def strokes(**options):
        sim = yore.scenes.hanging_cloth(resolution=res, **options)
        return sim, lambda k: sim.stroke_material([[0.2, 0.32 + 0.01 * k], [0.8, 0.36 + 0.01 * k]])

    return {"rotating cylinder": cylinder, "hanging cloth, pin_spacing=1": hanging_flat,
            "hanging cloth, gathered": hanging_gathered, "hanging cloth, 5 strokes": strokes}


def main(argv=None):
    args = arguments(__doc__, argv)
    seconds = 0.25 if args.quick else 1.0
    rows = []
    for scene, make in scenes(args.quick).items():
        for adaptive in (False, True):
            sim, stroke = make(integrator="implicit", adaptive_projection=adaptive,
                               max_newton=200)
            start = time.perf_counter()
            if stroke is None:
                sim.advance(seconds, progress=False)
            else:
                for k in range(5):
                    stroke(k)
                    sim.advance(seconds / 5, progress=False)
            wall = time.perf_counter() - start
            stats = sim.stats
            counters = stats["counters"]
            rows.append({"scene": scene, "adaptive_projection": adaptive,
                         "steps": stats["steps"],
                         "newton_iterations_per_step": counters["newton_iterations"] / stats["steps"],
                         "rejected_per_step": counters["exact_hessian_rejected"] / stats["steps"],
                         "unconverged_steps": counters["unconverged_steps"],
                         "wall_seconds_per_simulated_second": wall / sim.time})
            r = rows[-1]
            print(f"{scene:30s} adaptive={adaptive!s:5s} {r['newton_iterations_per_step']:6.1f} "
                  f"it/step, {r['rejected_per_step']:4.1f} rejected, {r['unconverged_steps']} "
                  f"unconverged, {r['wall_seconds_per_simulated_second']:.2f} s/s")
    payload = {"benchmark": "newton_projection", "machine": machine_info(), "quick": args.quick,
               "rows": rows, "max_newton": 200, "newton_tol": 1e-5, "dt": 1 / 60}
    save(args.out, "newton_projection", payload, lambda path: plot(rows, path))
    return payload


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    x = np.arange(len(scenes))
    fig, ax = plt.subplots(figsize=(7, 3.8))
    for offset, adaptive, label in ((-0.2, False, "always projected"),
                                    (0.2, True, "adaptive (default)")):
        values = [next(r["newton_iterations_per_step"] for r in rows
                       if r["scene"] == s and r["adaptive_projection"] == adaptive) for s in scenes]
        ax.bar(x + offset, values, width=0.4, label=label)
    ax.set_xticks(x, scenes, rotation=12, fontsize=8)
    ax.set_ylabel("Newton iterations per step")
    ax.set_title("backward Euler, dt = 1/60 s, newton_tol = 1e-5")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
