"""Stable explicit time step: the estimates against the largest stable dt found by trying.

    python -m benchmarks.stable_dt [--out bench-results] [--quick]

Per scene (the paper's hanging cloth and rotating cylinder, and a grid hung by its top edge) and
stiffness (structural = bending), damped (the scenes' damping and drag) and undamped: the
Gershgorin estimate (Cloth.gershgorin_time_step), the state-independent Laplacian bound
(Cloth.stable_time_step_bound), the tight current-state estimate (Cloth.stable_time_step), the
largest stable dt found by bisection (a dt is unstable if a run of a fixed number of steps from
the scene's start raises SimulationDiverged: its energy grew past yore's bound; deterministic,
no wall time), and the default dt (yore.simulation
.default_explicit_dt) with its ratio to the found limit. Writes stable_dt.json and stable_dt.png.
"""

from __future__ import annotations

import numpy as np

import yore
from yore.simulation import EXPLICIT_DT_SAFETY

from .common import arguments, machine_info, save

BASE_STIFFNESS = 200.0  # N/m, the scenes' default


def hung_grid(resolution=15, dt=None, **material):
    """A vertical grid (x–y plane) held along its top edge, under gravity."""
    V, F = yore.grid_mesh(resolution, resolution, width=1.0, height=1.0)
    mass = 0.1 / len(V)
    cloth = yore.Cloth(
        V,
        F,
        masses=mass,
        stretch_stiffness=material["stretch_stiffness"],
        bend_stiffness=material["bend_stiffness"],
        damping=material.get("damping", yore.scenes.DAMPING),
        drag=material.get("drag", yore.scenes.DRAG),
    )
    top = np.flatnonzero(V[:, 1] >= V[:, 1].max() - 1e-12).astype(np.int32)
    cloth.fix(top)
    return yore.Simulation(cloth, dt=dt)


def scenes(quick):
    if quick:
        return {
            "hanging_cloth": lambda **kw: yore.scenes.hanging_cloth(resolution=9, **kw),
            "rotating_cylinder": lambda **kw: yore.scenes.rotating_cylinder(
                rings=5, segments=12, **kw
            ),
        }
    return {
        "hanging_cloth": yore.scenes.hanging_cloth,
        "rotating_cylinder": yore.scenes.rotating_cylinder,
        "hung_grid": hung_grid,
    }


def is_stable(make, dt, steps):
    """Whether `steps` steps at `dt` from make(dt)'s start stay bounded (counted, not timed):
    yore's divergence monitor raises once the energy grows past 10× its bound, which an
    unstable mode reaches within a few hundred steps of exponential growth."""
    sim = make(dt)
    try:
        sim.step(steps, progress=False)
    except yore.SimulationDiverged:
        return False
    return bool(np.isfinite(sim.cloth.positions).all())


def largest_stable_dt(make, low, high, steps, iterations):
    """Bisection on dt between a stable `low` and an unstable `high` (both checked)."""
    if not is_stable(make, low, steps):
        raise RuntimeError(f"the lower end {low} s is not stable")
    while is_stable(make, high, steps):
        low, high = high, 2.0 * high
    for _ in range(iterations):
        middle = 0.5 * (low + high)
        if is_stable(make, middle, steps):
            low = middle
        else:
            high = middle
    return low


def main(argv=None):
    args = arguments(__doc__, argv)
    multipliers = [1, 100] if args.quick else [1, 10, 100]
    steps, iterations = (300, 8) if args.quick else (4000, 16)
    rows = []
    for name, scene in scenes(args.quick).items():
        for multiplier in multipliers:
            for damped in (True, False):
                material = {
                    "stretch_stiffness": BASE_STIFFNESS * multiplier,
                    "bend_stiffness": BASE_STIFFNESS * multiplier,
                }
                if not damped:
                    material.update(damping=0.0, drag=0.0)

                def make(dt, scene=scene, material=material):
                    return scene(dt=dt, **material)

                probe = make(None)
                cloth = probe.cloth
                gershgorin = cloth.gershgorin_time_step()
                bound = cloth.stable_time_step_bound()
                tight = cloth.stable_time_step()
                found = largest_stable_dt(make, gershgorin, 1.5 * tight, steps, iterations)
                default = probe.dt
                row = {
                    "scene": name,
                    "stiffness": BASE_STIFFNESS * multiplier,
                    "damped": damped,
                    "vertices": cloth.vertex_count,
                    "gershgorin_dt": gershgorin,
                    "bound_dt": bound,
                    "estimate_dt": tight,
                    "found_dt": found,
                    "default_dt": default,
                    "gershgorin_ratio": gershgorin / found,
                    "bound_ratio": bound / found,
                    "estimate_ratio": tight / found,
                    "default_ratio": default / found,
                }
                rows.append(row)
                print(
                    f"{name:18s} k={row['stiffness']:8g} damped={damped!s:5s} "
                    f"gersh {gershgorin:.4g} bound {bound:.4g} est {tight:.4g} "
                    f"found {found:.4g} default {default:.4g} "
                    f"default/found {row['default_ratio']:.3f}"
                )
    payload = {
        "benchmark": "stable_dt",
        "machine": machine_info(),
        "quick": args.quick,
        "steps": steps,
        "bisection_iterations": iterations,
        "safety": EXPLICIT_DT_SAFETY,
        "rows": rows,
    }
    save(args.out, "stable_dt", payload, lambda path: plot(payload, path))
    return payload


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = payload["rows"]
    labels = [
        f"{r['scene'].replace('_', ' ')}\nk={r['stiffness']:g}{'' if r['damped'] else ', undamped'}"
        for r in rows
    ]
    x = np.arange(len(rows))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.55 * len(rows) + 2), 4.2))
    for offset, key, label in (
        (-0.3, "gershgorin_ratio", "Gershgorin"),
        (-0.1, "bound_ratio", "Laplacian bound"),
        (0.1, "estimate_ratio", "Lanczos estimate"),
        (0.3, "default_ratio", f"default dt ({payload['safety']} ×)"),
    ):
        ax.bar(x + offset, [r[key] for r in rows], width=0.2, label=label)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axhline(0.8, color="k", lw=0.8, ls="--")
    ax.set_xticks(x, labels, rotation=60, ha="right", fontsize=6)
    ax.set_ylabel("dt / largest stable dt found")
    ax.set_title(f"stable explicit dt ({payload['steps']} steps per trial)", fontsize=9)
    ax.legend(fontsize=7, ncol=4, loc="lower center")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
