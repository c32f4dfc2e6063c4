"""Where Newton stops on the stiff sheet: iterations per step against accuracy, for the
truncation test at several fractions and for the residual test alone.

    python -m benchmarks.newton_stop [--out bench-results] [--quick]

The scene is the one the iteration goal was set on: `hanging_cloth(resolution=32,
pin_spacing=1.0, mass=0.1)`, k = 2e5 N/m, bending springs as stiff, backward Euler and BDF2 at
1/60 s for 0.25 s (15 steps), one thread. Rows: `truncation_fraction` 0 (the residual test
alone, newton_tol 1e-5: the tight run), 0.05, 0.1 (the default), 0.2, 0.3 and 0.45. Per row: mean,
median and largest Newton iterations per step, thrown-away factorizations per step, steps at
max_newton, CPU seconds (time.process_time) per simulated second; the error, the largest
vertex distance from the reference over the cloth's size at t = T/3, 2T/3 and T, and its RMS
over the vertices; and the largest distance from the tight run at the same times over the
size, and that over the tight run's own error: what stopping early adds to the
discretization's error. The reference is explicit at a quarter of `stable_dt()`'s estimate
(rounded to a step count that hits the three times), checked against explicit at half of it
(`reference_check`, the same norm). The goal (the default rows): mean and median iterations
per step at most 5, at most 0.5 thrown-away factorizations per step, no step at max_newton.
Writes newton_stop.json and newton_stop.png.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

import yore

from .common import arguments, machine_info, save

DT = 1 / 60
STIFFNESS = 2e5
FRACTIONS = (0.0, 0.05, 0.1, 0.2, 0.3, 0.45)  # 0: the residual test alone (the tight run);
# 0.2 (BE) and 0.45 (BDF2) are CVODE's stop in units of the truncation error (docs/limitations.md)
DEFAULT_FRACTION = yore._core.ImplicitIntegrator.defaults["truncation_fraction"]
INTEGRATORS = {"BE": "implicit", "BDF2": "bdf2"}
SAMPLES = 3  # error sampled at T/3, 2T/3, T
GOAL = {
    "mean_iterations": 5.0,
    "median_iterations": 5.0,
    "thrown_away_per_step": 0.5,
    "unconverged_steps": 0,
}


def make(resolution, integrator, dt, **options):
    return yore.scenes.hanging_cloth(
        resolution=resolution,
        pin_spacing=1.0,
        mass=0.1,
        stretch_stiffness=STIFFNESS,
        bend_stiffness=STIFFNESS,
        integrator=integrator,
        dt=dt,
        **options,
    )


def run(resolution, integrator, steps, duration, **options):
    """(simulation, positions at the SAMPLES times, Newton iterations of each step, CPU s)."""
    sim = make(resolution, integrator, duration / steps, **options)
    samples, per_step = [], []
    every = steps // SAMPLES
    start = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # capped steps are counted
        if integrator == "explicit":  # no iterations to count, and many steps
            for _ in range(SAMPLES):
                sim.step(every, progress=False)
                samples.append(np.array(sim.cloth.positions))
            return sim, samples, per_step, time.process_time() - start
        for k in range(1, steps + 1):
            before = sim.stats["counters"]["newton_iterations"]
            sim.step(1, progress=False)
            per_step.append(sim.stats["counters"]["newton_iterations"] - before)
            if k % every == 0:
                samples.append(np.array(sim.cloth.positions))
    return sim, samples, per_step, time.process_time() - start


def largest(a, b):
    return max(float(np.linalg.norm(x - y, axis=1).max()) for x, y in zip(a, b))


def rms(a, b):
    return max(float(np.sqrt((np.linalg.norm(x - y, axis=1) ** 2).mean())) for x, y in zip(a, b))


def main(argv=None):
    args = arguments(__doc__, argv)
    resolution, steps = (10, 6) if args.quick else (32, 15)
    duration = steps * DT
    probe = make(resolution, "explicit", 1e-4)
    size = float(np.linalg.norm(np.ptp(probe.cloth.positions, axis=0)))
    # the reference: explicit at a quarter of the estimate, a step count divisible by SAMPLES
    fine = SAMPLES * math.ceil(duration / (0.25 * probe.stable_dt()) / SAMPLES)
    fine += fine % (2 * SAMPLES)  # so that half of it still hits the sample times
    _, reference, _, _ = run(resolution, "explicit", fine, duration)
    _, coarse, _, _ = run(resolution, "explicit", fine // 2, duration)
    reference_check = largest(reference, coarse) / size
    print(
        f"{resolution}² sheet, reference: explicit dt {duration / fine:.3g} s, "
        f"{reference_check:.2e} of the size from the run at twice that step",
        flush=True,
    )
    rows = []
    for name, integrator in INTEGRATORS.items():
        tight = None
        for fraction in FRACTIONS:
            sim, samples, per_step, cpu = run(
                resolution, integrator, steps, duration, truncation_fraction=fraction
            )
            counters = sim.stats["counters"]
            if fraction == 0.0:
                tight = samples
            error = largest(samples, reference) / size
            from_tight = largest(samples, tight) / size
            row = {
                "integrator": name,
                "truncation_fraction": fraction,
                "default": fraction == DEFAULT_FRACTION,
                "steps": steps,
                "iterations": per_step,
                "mean_iterations": float(np.mean(per_step)),
                "median_iterations": float(np.median(per_step)),
                "max_iterations": int(max(per_step)),
                "thrown_away_per_step": counters["factorizations_thrown_away"] / steps,
                "unconverged_steps": int(counters["unconverged_steps"]),
                "cpu_seconds_per_simulated_second": cpu / duration,
                "error": error,
                "rms_error": rms(samples, reference) / size,
                "from_tight": from_tight,
            }
            rows.append(row)
            print(
                f"{name:4s} truncation_fraction {fraction:<4g} {row['mean_iterations']:5.2f} "
                f"it/step (median {row['median_iterations']:g}, max "
                f"{row['max_iterations']}), thrown {row['thrown_away_per_step']:.2f}, capped "
                f"{row['unconverged_steps']}, {row['cpu_seconds_per_simulated_second']:.2f} "
                f"CPU s/s, error {error:.2e} (RMS {row['rms_error']:.2e}), from tight "
                f"{from_tight:.2e}",
                flush=True,
            )
        tight_error = next(
            r["error"] for r in rows if r["integrator"] == name and r["truncation_fraction"] == 0.0
        )
        for r in rows:
            if r["integrator"] == name:
                r["from_tight_over_tight_error"] = r["from_tight"] / tight_error
    goal_met = {}
    for r in rows:
        if r["default"]:
            goal_met[r["integrator"]] = (
                r["mean_iterations"] <= GOAL["mean_iterations"]
                and r["median_iterations"] <= GOAL["median_iterations"]
                and r["thrown_away_per_step"] <= GOAL["thrown_away_per_step"]
                and r["unconverged_steps"] <= GOAL["unconverged_steps"]
            )
    payload = {
        "benchmark": "newton_stop",
        "machine": machine_info(),
        "quick": args.quick,
        "rows": rows,
        "dt": DT,
        "stretch_stiffness": STIFFNESS,
        "resolution": resolution,
        "duration": duration,
        "size": size,
        "reference_dt": duration / fine,
        "reference_check": reference_check,
        "default_fraction": DEFAULT_FRACTION,
        "goal": GOAL,
        "goal_met": goal_met,
    }
    save(args.out, "newton_stop", payload, lambda path: plot(payload, path))
    return payload


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for name in INTEGRATORS:
        for ax, key in zip(axes, ("error", "from_tight")):
            # the tight run is 0 from itself: no point on the log axis
            mine = [
                r
                for r in payload["rows"]
                if r["integrator"] == name and (key == "error" or r["truncation_fraction"] > 0)
            ]
            ax.plot([r["mean_iterations"] for r in mine], [r[key] for r in mine], "o-", label=name)
            for r in mine:
                ax.annotate(
                    f"{r['truncation_fraction']:g}",
                    (r["mean_iterations"], r[key]),
                    fontsize=7,
                    textcoords="offset points",
                    xytext=(3, 3),
                )
    axes[0].set_ylabel("error against explicit / size")
    axes[1].set_ylabel("distance from the tight run / size")
    for ax in axes:
        ax.set_xlabel("Newton iterations per step (mean)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ticks = [
            t
            for t in (2, 3, 5, 10, 20, 50, 100)
            if t <= max(r["mean_iterations"] for r in payload["rows"]) * 1.5
        ]
        ax.set_xticks(ticks, [str(t) for t in ticks])
        ax.axvline(GOAL["mean_iterations"], color="grey", lw=0.8, ls="--")
        ax.legend(fontsize=8)
    fig.suptitle(
        f"{payload['resolution']}² stiff sheet (k = {STIFFNESS:g} N/m, bending equal), "
        "dt = 1/60 s; labels: truncation_fraction (0: residual test alone)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
