"""Factor reuse in Newton on stiff sheets: fresh, reused and thrown-away factorizations per step,
what reuse saves in CPU time, and what it costs in accuracy, at 64² and 128².

    python -m benchmarks.factor_reuse [--out bench-results] [--quick] [--sizes 64 128]

The sheet is the crossover's stiffest measured kind: `hanging_cloth(resolution=N,
pin_spacing=1.0, mass=0.1)`, k = 2e5 N/m, bending springs as stiff, BDF2 at 1/60 s, one
thread, for 0.25 s (64²) and 0.125 s (128²). Variants: the default Newton (the clamp with the
mixed matrices, stopped by the truncation test) and the same with `lagged_factorization`;
steihaug (CG on the exact Hessian preconditioned by the clamped Hessian's factor, in a trust
region; a refused step is solved again on the same factor, a reuse; residual test; the former
default) and the same with `lagged_factorization` (the factor kept across iterations and steps,
refactored when CG on it needs more than 20 iterations); the shifted projection
(Levenberg–Marquardt: each indefinite matrix is a thrown-away factorization); the clamp with the
step test
(`projection="clamp", step_tol=3e-3, mixed=True`, the setting docs/integrators.md recommends for
stiff sheets); that with `lagged_factorization` (CG on the clamped Hessian, 20 iterations at
most, before a refactorization); and, for what the mixed matrices change in the same run,
steihaug with `mixed=True` and the clamp with the step test without (`newton_over_actual_forces`
and `cpu_over_actual_forces` on the rows with them). Per row: Newton iterations, fresh factorizations, factor reuses (CG solves
on a kept factor), failed CG runs on a kept factor (after the k-th failure in a row the next
min(2^(k-1), 32) iterations refactor without trying) and thrown-away factorizations per step,
CPU seconds (time.process_time) per simulated second, the largest vertex distance from the
default run's end state over the cloth's size, and the CPU time of one factorization and of one
solve with a factor, the price a reuse has to beat. Writes factor_reuse.json and
factor_reuse.png.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

import yore

from .common import arguments, grouped_bars, machine_info, save

DT = 1 / 60
STIFFNESS = 2e5
RESIDUAL = {"truncation_fraction": 0.0}  # Newton stopped by its residual test alone
VARIANTS = {
    "default (clamp, mixed, truncation test)": {},
    "default, lagged factor": {"lagged_factorization": True},
    "steihaug, residual test": {"projection": "steihaug", **RESIDUAL},
    "steihaug, lagged factor": {"projection": "steihaug", "lagged_factorization": True, **RESIDUAL},
    "shifted, residual test": {"projection": "shifted", **RESIDUAL},
    "clamp, step test": {"projection": "clamp", "step_tol": 3e-3, "mixed": True, **RESIDUAL},
    "clamp, step test, lagged factor": {
        "projection": "clamp",
        "step_tol": 3e-3,
        "mixed": True,
        "lagged_factorization": True,
        **RESIDUAL,
    },
    # what the mixed matrices change, in the same run: steihaug with them, the clamp without
    "steihaug, mixed": {"projection": "steihaug", "mixed": True, **RESIDUAL},
    "clamp, step test, actual forces": {
        "projection": "clamp",
        "step_tol": 3e-3,
        "mixed": False,
        **RESIDUAL,
    },
}


def sizes(quick, only=None):
    """resolution → simulated seconds (``only``: those resolutions of the full set)."""
    chosen = {12: 2 * DT, 16: 2 * DT} if quick else {64: 0.25, 128: 0.125}
    if only:
        unknown = sorted(set(only) - set(chosen))
        if unknown:
            raise SystemExit(f"--sizes: {unknown} not among {sorted(chosen)}")
        chosen = {n: t for n, t in chosen.items() if n in only}
    return chosen


def run(resolution, duration, options, max_seconds):
    sim = yore.scenes.hanging_cloth(
        resolution=resolution,
        pin_spacing=1.0,
        mass=0.1,
        stretch_stiffness=STIFFNESS,
        bend_stiffness=STIFFNESS,
        integrator="bdf2",
        dt=DT,
        **options,
    )
    planned = max(1, round(duration / DT))
    start = time.process_time()
    steps = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # capped steps are counted below
        while steps < planned and time.process_time() - start < max_seconds:
            sim.step(1, progress=False)
            steps += 1
    cpu = time.process_time() - start
    c = sim.stats["counters"]
    phases = sim.stats["phases"]
    fresh = c["factorizations"] - c["factorizations_thrown_away"]
    return sim, {
        "resolution": resolution,
        "steps": steps,
        "planned_steps": planned,
        "stopped_by_cpu_cap": steps < planned,
        "simulated_seconds": steps * DT,
        "newton_per_step": c["newton_iterations"] / steps,
        "fresh_factorizations_per_step": fresh / steps,
        "factor_reuses_per_step": c["factor_reuses"] / steps,
        "thrown_away_per_step": c["factorizations_thrown_away"] / steps,
        "lagged_cg_iterations_per_reuse": (
            c["lagged_cg_iterations"] / c["factor_reuses"] if c["factor_reuses"] else 0.0
        ),
        # CG runs on a kept factor that missed their bound (each followed by a factorization)
        "lagged_failures_per_step": c["lagged_failures"] / steps,
        "lagged_cg_iterations_per_step": c["lagged_cg_iterations"] / steps,
        # what a reuse has to beat: one factorization's CPU time in solves with a factor (a CG
        # iteration on a kept factor is one solve and one product with the matrix)
        "factorization_ms": 1e3 * phases["factorize_seconds"] / max(1, c["factorizations"]),
        "solve_ms": 1e3 * phases["solve_seconds"] / max(1, c["solves"]),
        "unconverged_steps": c["unconverged_steps"],
        "cpu_seconds_per_simulated_second": cpu / (steps * DT),
    }


def options(parser):
    parser.add_argument(
        "--sizes",
        type=int,
        nargs="+",
        metavar="N",
        help="run only these resolutions (of 64 128; --quick: 12 16)",
    )
    parser.add_argument(
        "--max-run-seconds",
        type=float,
        default=900.0,
        help="CPU seconds after which a run stops at the end of its step "
        "(default 900); its figures are then per step done",
    )


def main(argv=None):
    args = arguments(__doc__, argv, options)
    rows = []
    for resolution, duration in sizes(args.quick, args.sizes).items():
        reference = None
        for name, variant_options in VARIANTS.items():
            sim, row = run(resolution, duration, variant_options, args.max_run_seconds)
            positions = np.asarray(sim.cloth.positions)
            if reference is None:
                reference = (positions, row["steps"])
            size = float(np.ptp(positions, axis=0).max())
            # (None when the two runs did not reach the same time)
            deviation = (
                float(np.linalg.norm(positions - reference[0], axis=1).max() / size)
                if row["steps"] == reference[1]
                else None
            )
            row.update(variant=name, options=variant_options, deviation_from_default=deviation)
            rows.append(row)
            print(
                f"{resolution:4d}² {name:34s} {row['newton_per_step']:6.1f} it/step, fresh "
                f"{row['fresh_factorizations_per_step']:5.1f}, reused "
                f"{row['factor_reuses_per_step']:5.1f}, thrown "
                f"{row['thrown_away_per_step']:4.1f}, capped {row['unconverged_steps']}, "
                f"{row['cpu_seconds_per_simulated_second']:8.2f} CPU s/s, deviation "
                f"{row['deviation_from_default']}"
                + (
                    f" (stopped by the CPU cap after {row['steps']} of {row['planned_steps']} "
                    "steps)"
                    if row["stopped_by_cpu_cap"]
                    else ""
                ),
                flush=True,
            )
    pairs = (
        ("default, lagged factor", "default (clamp, mixed, truncation test)"),
        ("steihaug, lagged factor", "steihaug, residual test"),
        ("clamp, step test, lagged factor", "clamp, step test"),
    )
    mixed_pairs = (
        ("steihaug, mixed", "steihaug, residual test"),
        ("clamp, step test", "clamp, step test, actual forces"),
    )
    for resolution in sizes(args.quick, args.sizes):
        chosen = {r["variant"]: r for r in rows if r["resolution"] == resolution}
        for lagged_name, plain_name in pairs:
            lagged, plain = chosen[lagged_name], chosen[plain_name]
            lagged["cpu_over_unlagged"] = (
                lagged["cpu_seconds_per_simulated_second"]
                / plain["cpu_seconds_per_simulated_second"]
            )
        for mixed_name, actual_name in mixed_pairs:
            mixed, actual = chosen[mixed_name], chosen[actual_name]
            mixed["newton_over_actual_forces"] = (
                mixed["newton_per_step"] / actual["newton_per_step"]
            )
            mixed["cpu_over_actual_forces"] = (
                mixed["cpu_seconds_per_simulated_second"]
                / actual["cpu_seconds_per_simulated_second"]
            )
    payload = {
        "benchmark": "factor_reuse",
        "machine": machine_info(),
        "quick": args.quick,
        "rows": rows,
        "dt": DT,
        "stretch_stiffness": STIFFNESS,
        "variants": list(VARIANTS),
    }
    save(args.out, "factor_reuse", payload, lambda path: plot(rows, path))
    return payload


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    x, resolutions = grouped_bars(
        axes,
        rows,
        "resolution",
        "variant",
        ("fresh_factorizations_per_step", "cpu_seconds_per_simulated_second"),
    )
    axes[0].set_ylabel("fresh factorizations per step")
    axes[1].set_ylabel("CPU s per simulated s")
    axes[1].set_yscale("log")
    for ax in axes:
        ax.set_xticks(x, [f"{n}²" for n in resolutions])
    axes[0].legend(fontsize=7)
    fig.suptitle(
        f"stiff sheet (k = {STIFFNESS:g} N/m, bending equal), BDF2, dt = 1/60 s, one thread",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
