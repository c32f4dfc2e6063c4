"""Bending that is the same on any mesh (issue 52): each bending energy's cylinder test on every
mesh kind and size, and what the fitted energy's wider matrix costs an implicit step.

    python -m benchmarks.bending_consistency [--out bench-results] [--quick]

One thread. A 1 m × 0.5 m sheet on five mesh kinds — `grid_mesh` with the rulings along its
lines (0°), at 30° and at 45° to them, a CGAL `pattern_mesh` (isotropic triangles) and an
equilateral mesh — at longest edges 0.08 to 0.005 m, rolled isometrically onto a cylinder of
radius 0.5 m (axis along the length): the energy of `bending="quadratic"` (½ B ∫ |∇∇x|², each
vertex's Hessian fitted over its 1-ring) and of `bending="hinge"` (Bergou et al. 2006) over the
continuum's ½ B A / R² (issue 52's target: within 2 % on every mesh kind and size). Per mesh
also Q's entries per row and its build time (CPU, median of three). The cost: the implicit
integrator (TR-BDF2, 1/64 s) on `hanging_cloth` at 33² and 65² vertices with B = 1e-4 N·m,
CPU per step and per Newton iteration (median of three runs of 16 steps) and CHOLMOD's factor
non-zeros and flops, for both energies in one run. Writes bending_consistency.json and .png.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

import yore

from . import common

RADIUS = 0.5
MODULUS = 1e-4  # N·m
KINDS = ["grid 0°", "grid 30°", "grid 45°", "pattern", "equilateral"]
EDGES = [0.08, 0.04, 0.02, 0.01, 0.005]
QUICK_EDGES = [0.08, 0.04]
MODELS = ["quadratic", "hinge"]
COST_RESOLUTIONS = [33, 65]
QUICK_COST_RESOLUTIONS = [9]
COST_STEPS = 16
TARGET = 0.02


def equilateral_mesh(edge, length=1.0, width=0.5):
    """Rows of equilateral triangles of side `edge` covering about length × width (the odd rows
    stick out half an edge), alternate rows offset by half an edge."""
    columns = int(math.ceil(length / edge)) + 1
    height = edge * math.sqrt(3) / 2
    rows = int(math.ceil(width / height)) + 1
    V = np.array(
        [
            [i * edge + (0.5 * edge if j % 2 else 0.0), j * height, 0.0]
            for j in range(rows)
            for i in range(columns)
        ]
    )
    F = []
    for j in range(rows - 1):
        for i in range(columns - 1):
            a, b = j * columns + i, j * columns + i + 1
            c, d = (j + 1) * columns + i, (j + 1) * columns + i + 1
            F += [[a, b, c], [b, d, c]] if j % 2 == 0 else [[a, b, d], [a, d, c]]
    return V, np.array(F, dtype=np.int32)


def mesh(kind, edge):
    """(V, F) of a 1 m × 0.5 m sheet of `kind` whose longest edge is about `edge`."""
    if kind == "pattern":  # CGAL's irregular triangles throughout (the lattice is "equilateral")
        return yore.pattern_mesh(
            [[0, 0], [1, 0], [1, 0.5], [0, 0.5]], edge_length=edge, interior="delaunay"
        )
    if kind == "equilateral":
        return equilateral_mesh(edge)
    degrees = float(kind.split()[1].rstrip("°"))
    # a grid turned by `degrees`, cut to cover the sheet: the turned grid's square covers the
    # 1 m × 0.5 m sheet, whose rulings then cross its lines at that angle
    spacing = edge / math.sqrt(2)
    side = 1.2 if degrees == 0 else 1.6
    n = int(math.ceil(side / spacing)) + 1
    V, F = yore.grid_mesh(
        n,
        n if degrees else int(math.ceil(0.5 / spacing)) + 1,
        width=side if degrees else 1.0,
        height=side if degrees else 0.5,
    )
    if degrees:
        turn = math.radians(degrees)
        centre = V.mean(axis=0)
        rotation = np.array(
            [[math.cos(turn), -math.sin(turn), 0], [math.sin(turn), math.cos(turn), 0], [0, 0, 1]]
        )
        V = (V - centre) @ rotation.T + [0.5, 0.25, 0.0]
        V, F = _keep_inside(V, F)
    return V, F


def _keep_inside(V, F):
    """The faces wholly inside the 1 m × 0.5 m sheet (with a round-off margin), reindexed."""
    inside = (
        (V[:, 0] >= -1e-9) & (V[:, 0] <= 1 + 1e-9) & (V[:, 1] >= -1e-9) & (V[:, 1] <= 0.5 + 1e-9)
    )
    F = F[inside[F].all(axis=1)]
    used = np.unique(F)
    index = -np.ones(len(V), dtype=np.int64)
    index[used] = np.arange(len(used))
    return V[used], index[F].astype(np.int32)


def rolled(V):
    """The flat sheet V rolled isometrically onto the cylinder (axis along u)."""
    angle = V[:, 1] / RADIUS
    return np.column_stack([V[:, 0], RADIUS * np.sin(angle), RADIUS * (1 - np.cos(angle))])


def cylinder_row(kind, edge):
    V, F = mesh(kind, edge)
    continuum = 0.5 * MODULUS * yore.metrics.area(V, F) / RADIUS**2
    row = {"kind": kind, "edge_length": edge, "vertices": int(len(V)), "faces": int(len(F))}
    for model in MODELS:
        seconds = []
        for _ in range(3):
            start = time.process_time()
            cloth = yore.Cloth(V, F, bending=model, bending_modulus=MODULUS)
            seconds.append(time.process_time() - start)
        cloth.positions = rolled(V)
        q = cloth.quadratic_bending
        row[model] = {
            "ratio": cloth.energy((0.0, 0.0, 0.0))["bending"] / continuum,
            "entries_per_row": len(q["data"]) / len(V),
            "cloth_build_seconds": statistics.median(seconds),
        }
    return row


def cost_row(resolution, model):
    runs = []
    for _ in range(3):
        sim = yore.scenes.hanging_cloth(
            resolution=resolution,
            bending=model,
            bending_modulus=MODULUS,
            integrator="tr-bdf2",
            dt=1.0 / 64,
        )
        start = time.process_time()
        sim.step(COST_STEPS, progress=False)
        seconds = time.process_time() - start
        counters = sim.stats["counters"]
        runs.append((seconds, counters))
    seconds = statistics.median(r[0] for r in runs)
    counters = runs[0][1]
    return {
        "resolution": resolution,
        "model": model,
        "steps": COST_STEPS,
        "cpu_per_step": seconds / COST_STEPS,
        "newton_iterations_per_step": counters["newton_iterations"] / COST_STEPS,
        "cpu_per_iteration": seconds / counters["newton_iterations"],
        "factor_nonzeros": counters["factor_nonzeros"],
        "factor_flops": counters["factor_flops"],
    }


def summarize(rows, costs):
    out = {}
    for model in MODELS:
        errors = [abs(r[model]["ratio"] - 1) for r in rows]
        worst = max(rows, key=lambda r: abs(r[model]["ratio"] - 1))
        out[model] = {
            "largest_error": max(errors),
            "worst": {
                "kind": worst["kind"],
                "edge_length": worst["edge_length"],
                "ratio": worst[model]["ratio"],
            },
            "within_target": all(e <= TARGET for e in errors),
        }
    out["cost"] = []
    for resolution in sorted({c["resolution"] for c in costs}):
        pair = {c["model"]: c for c in costs if c["resolution"] == resolution}
        if set(pair) == set(MODELS):
            out["cost"].append(
                {
                    "resolution": resolution,
                    "step_quadratic_over_hinge": (
                        pair["quadratic"]["cpu_per_step"] / pair["hinge"]["cpu_per_step"]
                    ),
                    "iteration_quadratic_over_hinge": (
                        pair["quadratic"]["cpu_per_iteration"] / pair["hinge"]["cpu_per_iteration"]
                    ),
                    "factor_nonzeros_quadratic_over_hinge": (
                        pair["quadratic"]["factor_nonzeros"] / pair["hinge"]["factor_nonzeros"]
                    ),
                }
            )
    out["target"] = TARGET
    return out


def draw(rows, costs, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for ax, model in zip(axes[:2], MODELS):
        for kind in KINDS:
            mine = sorted((r for r in rows if r["kind"] == kind), key=lambda r: r["edge_length"])
            ax.semilogx(
                [r["edge_length"] for r in mine],
                [r[model]["ratio"] for r in mine],
                "o-",
                label=kind,
            )
        ax.axhspan(1 - TARGET, 1 + TARGET, color="0.9", label="±2 % (target)")
        ax.set_xlabel("longest edge (m)")
        ax.set_ylabel("energy / ½ B A / R²")
        ax.set_title(f'bending="{model}": a rolled cylinder')
        ax.legend(fontsize=7)
    ax = axes[2]
    resolutions = sorted({c["resolution"] for c in costs})
    for k, model in enumerate(MODELS):
        values = [
            next(c["cpu_per_step"] for c in costs if c["resolution"] == r and c["model"] == model)
            for r in resolutions
        ]
        ax.bar(np.arange(len(resolutions)) + 0.38 * k, [1e3 * v for v in values], 0.38, label=model)
    ax.set_xticks(np.arange(len(resolutions)) + 0.19)
    ax.set_xticklabels([f"{r}²" for r in resolutions])
    ax.set_ylabel("CPU ms per TR-BDF2 step (1/64 s)")
    ax.set_title("hanging cloth, B = 1e-4 N·m")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    args = common.arguments(__doc__, argv)
    yore.set_num_threads(1)
    rows = []
    for kind in KINDS:
        for edge in QUICK_EDGES if args.quick else EDGES:
            rows.append(cylinder_row(kind, edge))
            r = rows[-1]
            print(
                f"  {kind:11s} h={edge:<6g} {r['vertices']:6d} vertices: quadratic "
                f"{r['quadratic']['ratio']:.4f}, hinge {r['hinge']['ratio']:.4f}",
                flush=True,
            )
    costs = []
    for resolution in QUICK_COST_RESOLUTIONS if args.quick else COST_RESOLUTIONS:
        for model in MODELS:
            costs.append(cost_row(resolution, model))
            c = costs[-1]
            print(
                f"  cost {resolution}² {model}: {1e3 * c['cpu_per_step']:.1f} ms a step, "
                f"{c['newton_iterations_per_step']:.2f} iterations, factor "
                f"{c['factor_nonzeros']:.3g} non-zeros",
                flush=True,
            )
    payload = {
        "benchmark": "bending_consistency",
        "machine": common.machine_info(),
        "quick": args.quick,
        "radius": RADIUS,
        "bending_modulus": MODULUS,
        "rows": rows,
        "cost": costs,
        "summary": summarize(rows, costs),
    }
    common.save(args.out, "bending_consistency", payload, lambda path: draw(rows, costs, path))


if __name__ == "__main__":
    main()
