"""Stability map: which (stiffness, time step) pairs each integrator survives.

    python -m benchmarks.stability_map [--out bench-results] [--quick]

An undamped hanging cloth (no spring damping, no drag) is run for a fixed number of steps at
every stiffness × dt of a grid, per integrator. A run is "diverged" if it raises
SimulationDiverged, "energy gain" if its total energy ever rose by more than 5 % of the
gravitational energy it released over the run (an undamped symplectic run oscillates far less;
backward Euler and BDF2 should only lose energy), else "stable". Writes stability_map.json and a
heatmap per integrator, stability_map.png.
"""

from __future__ import annotations


import numpy as np

import yore

from .common import arguments, machine_info, save

INTEGRATORS = {
    "explicit": {"integrator": "explicit"},
    "explicit + strain limit": {"integrator": "explicit", "strain_limit": 1.1},
    "BE linearized": {"integrator": "implicit", "linearized": True},
    "BE Newton": {"integrator": "implicit"},
    "BDF2": {"integrator": "bdf2"},
}
STATES = ("stable", "energy gain", "diverged")
BASE_STIFFNESS = 200.0  # N/m, the scenes' default


def classify(resolution, multiplier, dt, options, steps):
    sim = yore.scenes.hanging_cloth(resolution=resolution, pin_spacing=1.0,
                                    stretch_stiffness=BASE_STIFFNESS * multiplier,
                                    bend_stiffness=BASE_STIFFNESS * multiplier, damping=0.0,
                                    drag=0.0, dt=dt, **options)
    start = sim.energy()
    energies = [start["total"]]
    released = 0.0
    try:
        for _ in range(10):
            sim.step(steps // 10, progress=False)
            energy = sim.energy()
            energies.append(energy["total"])
            released = max(released, start["gravity"] - energy["gravity"])
    except yore.SimulationDiverged:
        return "diverged", None
    gain = (max(energies) - energies[0]) / max(released, 1e-12)
    return ("energy gain" if gain > 0.05 else "stable"), gain


def main(argv=None):
    args = arguments(__doc__, argv)
    resolution, steps = (7, 60) if args.quick else (11, 200)
    multipliers = [1, 10, 100, 1000] if args.quick else [1, 10, 100, 1000, 10000]
    dts = ([1 / 30, 1 / 240, 1 / 1920] if args.quick
           else [1 / 30, 1 / 120, 1 / 480, 1 / 1920, 1 / 7680, 1 / 30720])
    rows = []
    for name, options in INTEGRATORS.items():
        for multiplier in multipliers:
            for dt in dts:
                state, gain = classify(resolution, multiplier, dt, options, steps)
                rows.append({"integrator": name, "stiffness": BASE_STIFFNESS * multiplier,
                             "dt": dt, "state": state, "energy_gain": gain})
        print(name, " ".join(r["state"][0] for r in rows if r["integrator"] == name))
    payload = {"benchmark": "stability_map", "machine": machine_info(), "quick": args.quick,
               "resolution": resolution, "steps": steps, "stiffness_values": [
                   BASE_STIFFNESS * m for m in multipliers], "dt_values": dts, "rows": rows}
    save(args.out, "stability_map", payload, lambda path: plot(payload, path))
    return payload


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    stiffness, dts = payload["stiffness_values"], payload["dt_values"]
    fig, axes = plt.subplots(1, len(INTEGRATORS), figsize=(3.3 * len(INTEGRATORS), 3.6),
                             sharey=True)
    cmap = ListedColormap(["#5cb85c", "#f0ad4e", "#d9534f"])
    for ax, name in zip(axes, INTEGRATORS):
        grid = np.zeros((len(stiffness), len(dts)))
        for row in payload["rows"]:
            if row["integrator"] == name:
                grid[stiffness.index(row["stiffness"]), dts.index(row["dt"])] = STATES.index(
                    row["state"])
        ax.imshow(grid, cmap=cmap, vmin=0, vmax=2, origin="lower", aspect="auto")
        ax.set_xticks(range(len(dts)), [f"1/{round(1 / dt)}" for dt in dts], rotation=45,
                      fontsize=7)
        ax.set_yticks(range(len(stiffness)), [f"{k:g}" for k in stiffness], fontsize=7)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("dt (s)")
    axes[0].set_ylabel("spring stiffness (N/m)")
    fig.suptitle("green: stable, orange: energy gain, red: diverged "
                 f"({payload['steps']} steps, undamped)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
