"""Pictures on polyscope, headless (EGL, Mesa llvmpipe on the CPU): what a picture costs by
image size, supersampling factor and mesh size, and what starting polyscope costs.

    python -m benchmarks.pictures [--out bench-results] [--quick]

Each cell renders `yore.viz.render_image` of a hanging cloth (run 0.3 s) with a colour map, a
colour bar and a stroke, median of repeated renders after a warm-up, in this one process
(polyscope's start is timed in a fresh process, median of a few). Rows: image size, factor,
vertices, seconds per picture; plus the viewer's pick of one pixel.
"""

from __future__ import annotations

import statistics
import subprocess
import sys

import numpy as np

import yore
from yore.camera import fit_camera
from yore.viz import backend
from yore.viz.render import render_image

from .common import arguments, machine_info, median_seconds, save

START = (
    "import time; t = time.perf_counter(); from yore.viz import backend; "
    "backend.ensure(); print(time.perf_counter() - t)"
)


def start_seconds(repeats):
    samples = []
    for _ in range(repeats):
        out = subprocess.run(
            [sys.executable, "-c", START], capture_output=True, text=True, check=True, timeout=300
        ).stdout.split()
        samples.append(float(out[-1]))
    return statistics.median(samples)


def cloth(n):
    sim = yore.scenes.hanging_cloth(resolution=n)
    sim.advance(0.3, progress=False)
    return sim


def main(argv=None):
    args = arguments(__doc__, argv)
    sizes = (
        [(320, 240), (640, 480)]
        if args.quick
        else [(320, 240), (640, 480), (1280, 720), (1920, 1080)]
    )
    factors = [1, 3] if args.quick else [1, 2, 3]
    meshes = [21] if args.quick else [21, 64]
    repeats = 2 if args.quick else 7
    rows = []
    backend.ensure()
    for n in meshes:
        sim = cloth(n)
        V, F = sim.cloth.positions, sim.cloth.faces
        values = yore.metrics.vertex_expansion(sim.cloth) + 0.01 * V[:, 1]
        stroke = V[np.argsort(np.abs(V[:, 1] - V[:, 1].max() * 0.5))[:8]]
        for width, height in sizes:
            camera = fit_camera(V, width, height)
            for factor in factors:
                if backend.supersampling(width, height, factor) != factor:
                    continue  # too large for this factor: render_image lowers it
                timing = median_seconds(
                    lambda: render_image(
                        V,
                        F,
                        camera,
                        vertex_values=values,
                        colorbar="expansion",
                        strokes=[stroke],
                        antialias=factor if factor > 1 else False,
                    ),
                    repeats=repeats,
                )
                row = {
                    "width": width,
                    "height": height,
                    "pixels": width * height,
                    "factor": factor,
                    "vertices": sim.cloth.vertex_count,
                    "render_seconds_median": timing["median"],
                    "render_seconds_min": timing["min"],
                    "repeats": repeats,
                }
                rows.append(row)
                print(
                    f"{n:3d}² {width:4d}×{height:<4d} ×{factor}: {1e3 * timing['median']:7.1f} ms"
                )
    # the viewer's pick of one pixel (polyscope's pick buffer, then the ray test)
    from yore.viz.viewer import Viewer

    sim = cloth(21)
    viewer = Viewer(sim, fit_camera(sim.cloth.positions, 640, 480), headless=True)
    pixels = np.array([[320.0, 240.0]])
    pick = median_seconds(lambda: viewer.pick_surface(pixels), repeats=repeats * 5)
    start = start_seconds(2 if args.quick else 5)
    payload = {
        "benchmark": "pictures",
        "machine": machine_info(),
        "quick": args.quick,
        "renderer": "polyscope " + _polyscope_version() + ", EGL",
        "start_seconds_median": start,
        "pick_seconds_median": pick["median"],
        "rows": rows,
    }
    print(f"polyscope start {start:.2f} s, one pick {1e3 * pick['median']:.2f} ms")
    save(args.out, "pictures", payload, lambda path: plot(payload, path))
    return payload


def _polyscope_version():
    from importlib.metadata import version

    return version("polyscope")


def plot(payload, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    rows = payload["rows"]
    for vertices in sorted({r["vertices"] for r in rows}):
        for factor in sorted({r["factor"] for r in rows}):
            cells = [r for r in rows if r["vertices"] == vertices and r["factor"] == factor]
            ax.plot(
                [r["pixels"] / 1e6 for r in cells],
                [r["render_seconds_median"] for r in cells],
                "o-",
                label=f"{vertices} vertices, supersampling ×{factor}",
            )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("picture size (megapixels)")
    ax.set_ylabel("seconds per picture (median)")
    ax.set_title(
        f"{payload['renderer']} (llvmpipe); start {payload['start_seconds_median']:.2f} s",
        fontsize=9,
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
