"""A scene file, then a stroke by hand
====================================

Scripting yore from Python: run a scene file, then go on from its saved state by hand::

    python examples/scripted_scene.py [--out yore-out/scripted] [--resolution 21] [--seconds 2]

1. Loads ``examples/hanging.toml`` with a few keys overridden (as ``yore run --set`` does) and
   runs it with ``yore.run_scene``: frames, ParaView collection, ``summary.json``,
   ``state.npz``, pictures.
2. Loads the saved state (``yore.load_state``), draws a second stroke the way the paper's user
   does — a 2-D line over a rendered view (``sim.stroke_screen`` through a ``yore.Camera``) —
   smooths the rest lengths around it, runs one more second, and renders a picture.
3. Prints what the strokes did: faces split, rest-area growth and the region's area gain.
"""

import argparse
from pathlib import Path

import numpy as np

import yore
from yore import metrics
from yore.camera import fit_camera
from yore.viz import render_image, save_png

HERE = Path(__file__).resolve().parent


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("yore-out/scripted"))
    parser.add_argument("--resolution", type=int, default=21, help="vertices per cloth edge")
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated time of part 1")
    args = parser.parse_args(argv)

    # 1. the scene file, with overrides, run to its end
    scene = yore.load_scene(
        HERE / "hanging.toml",
        overrides={
            "mesh.nx": args.resolution,
            "mesh.ny": args.resolution,
            "simulation.duration": args.seconds,
            "strokes.0.time": 0.5 * args.seconds,
            # a stroke a fifth of the way down, so it crosses faces at any resolution
            "strokes.0.material": [[0.15, 0.2], [0.85, 0.2]],
            "output.animation": "none",
        },
    )
    summary = yore.run_scene(scene, args.out)
    first = summary["strokes"][0]
    print(
        f"part 1: {summary['steps']} steps to t = {summary['time']:.2f} s; stroke split "
        f"{first['faces_split']} faces, rest area of the region "
        f"{first['rest_area_before']:.4f} -> {first['rest_area_after']:.4f} m²"
    )

    # 2. continue by hand from the saved state
    sim, _ = yore.load_state(args.out / "state.npz")
    camera = fit_camera(sim.cloth.positions, width=640, height=480)
    # a horizontal line across the middle of the view, in pixels
    middle = camera.project(sim.cloth.positions.mean(axis=0))[0]
    line = np.array([[middle[0] - 120, middle[1]], [middle[0] + 120, middle[1]]])
    report = sim.stroke(yore.StrokePath.screen(line, camera), expansion=1.1)
    smoothing = sim.smooth_rest_lengths(iterations=10, strength=0.5)
    area_before = metrics.area(sim.cloth.positions, sim.cloth.faces, report.region_faces)
    sim.advance(1.0, progress=False)
    gain = metrics.area(sim.cloth.positions, sim.cloth.faces, report.region_faces) / area_before
    picture = save_png(
        args.out / "scripted.png",
        render_image(
            sim.cloth.positions,
            sim.cloth.faces,
            camera,
            strokes=[sim.cloth.positions[report.line_vertices]],
            title=f"t = {sim.time:.2f} s",
        ),
    )
    print(
        f"part 2: screen stroke split {report.faces_split} faces; smoothing roughness "
        f"{smoothing['roughness_before']:.4f} -> {smoothing['roughness_after']:.4f}; "
        f"region area x{gain:.3f} after 1 s"
    )
    print(f"picture: {picture.resolve()}")


if __name__ == "__main__":
    main()
