"""Stability map: which (stiffness, time step) pairs each integrator survives — a sweep.

    python -m benchmarks.stability_map [--out bench-results] [--quick] [--workers N]

The grid is the sweep file benchmarks/stability_map.toml (--quick: stability_map_quick.toml)
over the scene benchmarks/stability_scene.toml: an undamped hanging cloth (no spring damping,
no drag) run for a fixed number of steps at every stiffness × dt, per integrator (a zip of
variants). It runs through `yore.sweep` (Dask, one task per cell; the sweep's folder is
OUT/sweeps/stability_map, its Dataset results.nc), and the figure and JSON come from the
Dataset. A cell is "diverged" if its run diverged, "energy gain" if its total energy ever rose
(at the 10 recorded frames) by more than 5 % of the gravitational energy it released (an undamped
symplectic run oscillates far less; backward Euler and BDF2 should only lose energy), else
"stable". Writes stability_map.json and a heat map per integrator, stability_map.png.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .common import arguments, machine_info, save

HERE = Path(__file__).resolve().parent
STATES = ("stable", "energy gain", "diverged")
ENERGY_GAIN_LIMIT = 0.05


def classify(status, gain, released):
    if status == "diverged":
        return "diverged", None
    if status != "done":
        return "failed", None
    ratio = gain / max(released, 1e-12)
    return ("energy gain" if ratio > ENERGY_GAIN_LIMIT else "stable"), float(ratio)


def main(argv=None):
    from yore.sweep import load_sweep, run

    args = arguments(
        __doc__,
        argv,
        extra=lambda p: p.add_argument(
            "--workers", type=int, default=None, help="Dask workers (default: the cores)"
        ),
    )
    sweep = load_sweep(HERE / ("stability_map_quick.toml" if args.quick else "stability_map.toml"))
    results = run(
        sweep,
        Path(args.out) / "sweeps" / "stability_map",
        workers=args.workers,
        overwrite=True,
        quiet=True,
    )
    dataset = results.dataset()
    methods = [str(m) for m in dataset["method"].values]
    stiffness = [float(k) for k in dataset["material.stretch_stiffness"].values]
    dts = [float(d) for d in dataset["simulation.dt"].values]
    steps = int(round(float(dataset["simulation.duration"].values[0]) / dts[0]))
    rows = []
    for i, name in enumerate(methods):
        for j, k in enumerate(stiffness):
            for m, dt in enumerate(dts):
                cell = dataset.isel(method=i, stiffness=j, step=m)
                state, gain = classify(
                    str(cell["status"].values),
                    float(cell["max_energy_gain"].values),
                    float(cell["gravity_released"].values),
                )
                rows.append(
                    {
                        "integrator": name,
                        "stiffness": k,
                        "dt": dt,
                        "state": state,
                        "energy_gain": gain,
                    }
                )
        print(name, " ".join(r["state"][0] for r in rows if r["integrator"] == name))
    payload = {
        "benchmark": "stability_map",
        "machine": machine_info(),
        "quick": args.quick,
        "resolution": int(sweep.sets["mesh.nx"]),
        "steps": steps,
        "stiffness_values": stiffness,
        "dt_values": dts,
        "integrators": methods,
        "sweep": str((Path(args.out) / "sweeps" / "stability_map").as_posix()),
        "rows": rows,
    }
    save(args.out, "stability_map", payload, lambda path: plot(payload, path))
    return payload


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    stiffness, dts = payload["stiffness_values"], payload["dt_values"]
    integrators = payload["integrators"]
    fig, axes = plt.subplots(
        1, len(integrators), figsize=(3.3 * len(integrators), 3.6), sharey=True
    )
    cmap = ListedColormap(["#5cb85c", "#f0ad4e", "#d9534f"])
    for ax, name in zip(axes, integrators):
        grid = np.zeros((len(stiffness), len(dts)))
        for row in payload["rows"]:
            if row["integrator"] == name:
                grid[stiffness.index(row["stiffness"]), dts.index(row["dt"])] = (
                    STATES.index(row["state"]) if row["state"] in STATES else np.nan
                )
        ax.imshow(grid, cmap=cmap, vmin=0, vmax=2, origin="lower", aspect="auto")
        ax.set_xticks(
            range(len(dts)), [f"1/{round(1 / dt)}" for dt in dts], rotation=45, fontsize=7
        )
        ax.set_yticks(range(len(stiffness)), [f"{k:g}" for k in stiffness], fontsize=7)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("dt (s)")
    axes[0].set_ylabel("spring stiffness (N/m)")
    fig.suptitle(
        f"green: stable, orange: energy gain, red: diverged ({payload['steps']} steps, undamped)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
