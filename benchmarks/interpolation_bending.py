"""What the mesh adds to a wrinkle's membrane energy (issue 52), per mesh kind, membrane strain
and direction, from the library's own energy.

    python -m benchmarks.interpolation_bending [--out bench-results] [--quick]

A 0.6 m square sheet on three mesh kinds at one longest edge (12.5 mm; quick 40 mm): the
default `pattern_mesh` (an equilateral lattice inside, CGAL along the edges), the same pattern
meshed by CGAL throughout (`interior="delaunay"`) and `grid_mesh` (right triangles, alternating
diagonals), each turned by 0°–90° under a fixed load, with the membrane's constant-strain
faces (the default) and its smoothed strain (`membrane_strain="smoothed"`). A wrinkle
z = a sin(k y + φ) along x, of 10 mean edges (four phases, a = 1e-6 m):

- **Tension leak**: the sheet stretched 10 % along x (ν = 0: no stress across). The continuum
  charges nothing (the wrinkle has no slope along x); the discrete energy is the
  interpolation's spurious slope under the tension, ε² of the wrinkle's slope squared, an
  artificial bending modulus B_art = S_xx ε² / k² = c_leak h² S_xx with c_leak = ε² / (k h)².
- **Compression deficit**: the sheet shortened 1 % along y (no stress along x). The continuum
  charges ½ S_yy ∫ z_y² (negative); the discrete energy falls short of it by a fraction
  d = c_comp (k h)², the smoothing of the wrinkle's slope: a buckled sheet whose compression is
  relieved to the critical 2 B k² (Cerda & Mahadevan) sees B grow by ~2 c_comp (k h)² B.

The whole sheet counts, its edges included. h is the mesh's mean edge. One thread, no timing.
Writes interpolation_bending.json and .png.
"""

from __future__ import annotations

import math

import numpy as np

import yore

from . import common

SIDE = 0.6  # m
EDGE = 0.0125  # m, the longest edge
QUICK_EDGE = 0.04
ANGLES = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
QUICK_ANGLES = [0.0, 30.0]
KINDS = ["lattice", "delaunay", "grid"]
STRAINS = {
    "faces": dict(bending="quadratic", bending_modulus=0.0, membrane_strain="faces"),
    "smoothed": dict(bending="quadratic", bending_modulus=0.0, membrane_strain="smoothed"),
}
YOUNG = 1e4  # N/m
AMPLITUDE = 1e-6  # m
POINTS_PER_WAVELENGTH = 10


def sheet(kind, edge, degrees):
    """(V, F) of the square on `kind` turned by `degrees` about its centre (rest = flat)."""
    square = [[0.0, 0.0], [SIDE, 0.0], [SIDE, SIDE], [0.0, SIDE]]
    if kind == "grid":
        n = int(math.ceil(SIDE / (edge / math.sqrt(2.0)))) + 1
        V, F = yore.grid_mesh(n, n, width=SIDE, height=SIDE)
    else:
        V, F = yore.pattern_mesh(square, edge_length=edge, interior=kind)
    turn = math.radians(degrees)
    rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    return np.column_stack([(V[:, :2] - 0.5 * SIDE) @ rotation.T, np.zeros(len(V))]), F


def mean_edge(V, F):
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0
    )
    return float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())


def wrinkle_energy(cloth, V, scale, k):
    """Σ over four phases of the membrane energy the wrinkle adds to the sheet at V scaled by
    `scale` (per axis)."""
    flat = V * np.asarray(scale)
    cloth.positions = flat
    before = cloth.energy((0.0, 0.0, 0.0))["membrane"]
    total = 0.0
    for phase in np.arange(4) * math.pi / 4:
        wrinkled = flat.copy()
        wrinkled[:, 2] = AMPLITUDE * np.sin(k * V[:, 1] + phase)
        cloth.positions = wrinkled
        total += cloth.energy((0.0, 0.0, 0.0))["membrane"] - before
    return total


def row(kind, strain, edge, degrees):
    V, F = sheet(kind, edge, degrees)
    cloth = yore.Cloth(
        V,
        F,
        masses=1e-3,
        stretch="membrane",
        young_modulus=YOUNG,
        poisson_ratio=0.0,
        **STRAINS[strain],
    )
    h = mean_edge(V, F)
    k = 2 * math.pi / (POINTS_PER_WAVELENGTH * h)
    area = yore.metrics.area(V, F)
    # Σ_φ ½ S ∫ (k a cos)² = S a² k² A over the four phases; ν = 0: S = Y E
    tension = YOUNG * 0.5 * (1.1**2 - 1)
    leak = wrinkle_energy(cloth, V, (1.1, 1.0, 1.0), k) / (tension * AMPLITUDE**2 * k**2 * area)
    compression = YOUNG * 0.5 * (0.99**2 - 1)
    charged = wrinkle_energy(cloth, V, (1.0, 0.99, 1.0), k) / (
        compression * AMPLITUDE**2 * k**2 * area
    )
    kh = k * h
    return {
        "kind": kind,
        "strain": strain,
        "degrees": degrees,
        "vertices": int(len(V)),
        "mean_edge": h,
        "kh": kh,
        "spurious_slope_squared": leak,
        "c_leak": leak / kh**2,
        "compression_deficit": 1.0 - charged,
        "c_compression": (1.0 - charged) / kh**2,
        "membrane_strain": cloth.membrane_strain,
    }


def summarize(rows):
    out = {}
    for kind in KINDS:
        for strain in STRAINS:
            mine = [r for r in rows if r["kind"] == kind and r["strain"] == strain]
            out[f"{kind}, {strain}"] = {
                "c_leak_largest": max(r["c_leak"] for r in mine),
                "c_leak_smallest": min(r["c_leak"] for r in mine),
                "c_compression_mean": float(np.mean([r["c_compression"] for r in mine])),
            }
    return out


def draw(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    for kind, colour in zip(KINDS, ("tab:blue", "tab:orange", "tab:green")):
        for strain, style in (("faces", "s--"), ("smoothed", "o-")):
            mine = sorted(
                (r for r in rows if r["kind"] == kind and r["strain"] == strain),
                key=lambda r: r["degrees"],
            )
            x = [r["degrees"] for r in mine]
            axes[0].semilogy(
                x,
                [max(r["c_leak"], 1e-7) for r in mine],
                style,
                color=colour,
                label=f"{kind}, {strain}",
            )
            axes[1].plot(
                x,
                [r["c_compression"] for r in mine],
                style,
                color=colour,
                label=f"{kind}, {strain}",
            )
    axes[0].set_title("tension leak: B_art = c h² S (a wrinkle along the tension)")
    axes[0].set_ylabel("c_leak (floored at 1e-7)")
    axes[1].set_title("compression deficit: d = c (k h)²")
    axes[1].set_ylabel("c_compression")
    for ax in axes:
        ax.set_xlabel("mesh turned against the load (°)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    args = common.arguments(__doc__, argv)
    yore.set_num_threads(1)
    edge = QUICK_EDGE if args.quick else EDGE
    rows = []
    for kind in KINDS:
        for strain in STRAINS:
            for degrees in QUICK_ANGLES if args.quick else ANGLES:
                rows.append(row(kind, strain, edge, degrees))
                r = rows[-1]
                print(
                    f"  {kind:8s} {strain:8s} {degrees:4.0f}°: c_leak {r['c_leak']:.2e}, "
                    f"c_compression {r['c_compression']:.3f}",
                    flush=True,
                )
    payload = {
        "benchmark": "interpolation_bending",
        "machine": common.machine_info(),
        "quick": args.quick,
        "settings": {
            "side": SIDE,
            "edge_length": edge,
            "young": YOUNG,
            "amplitude": AMPLITUDE,
            "points_per_wavelength": POINTS_PER_WAVELENGTH,
        },
        "rows": rows,
        "summary": summarize(rows),
    }
    common.save(args.out, "interpolation_bending", payload, lambda path: draw(rows, path))
    return payload


if __name__ == "__main__":
    main()
