"""The paper's two experiments with a stroke
==========================================

The paper's two experiments with a stroke (§3.1 Fig. 3 and §3.2 Fig. 4)::

    python examples/stroke_experiments.py [--scene hanging|cylinder|both] [--integrator explicit]
                                          [--out yore-out] [--before 1.5] [--after 2.0]

hanging: the cloth hung from two points settles, then a stroke along the fold just below its
top edge splits the faces it crosses; the region grows and wrinkles. cylinder: the tube held at
its rotating top rim spins up, then a stroke around its lower part makes that band larger, and
the spin spreads it into a skirt. Each writes a ParaView collection of frames (the topology
changes mid-run), a before/after picture, and prints the stroke report and the region's area
gain and wrinkle amplitude.
"""

import argparse
import math
from pathlib import Path

import numpy as np

import yore
from yore import metrics
from yore.io import FrameSeries
from yore.viz import save_panels


def hanging(integrator):
    n = 21
    sim = yore.scenes.hanging_cloth(resolution=n, integrator=integrator)

    def stroke_points():
        # along the fold just below the top edge: midway between the first two rows inside
        X = sim.cloth.positions
        return 0.5 * (X[n + 3 : 2 * n - 3] + X[2 * n + 3 : 3 * n - 3])

    return sim, stroke_points


def cylinder(integrator):
    radius, height = 0.25, 0.5
    sim = yore.scenes.rotating_cylinder(radius=radius, height=height, integrator=integrator)

    def stroke_points():
        # a ring around the lower part, at a quarter of the height, on the current surface
        angles = np.linspace(0.0, 2.0 * math.pi, 97)
        X = sim.cloth.positions
        y = X[:, 1].min() + 0.25 * (X[:, 1].max() - X[:, 1].min())
        r = np.median(np.hypot(X[:, 0], X[:, 2]))
        return np.column_stack([r * np.cos(angles), np.full_like(angles, y), r * np.sin(angles)])

    return sim, stroke_points


def run(name, make, integrator, out, before_seconds, after_seconds, smooth=0, fps=25.0):
    sim, stroke_points = make(integrator)
    cloth = sim.cloth
    with FrameSeries(out / name, stem=name, fmt="vtu") as frames:

        def write():
            frames.write(
                sim.time, cloth.positions, cloth.faces, point_data={"velocity": cloth.velocities}
            )

        write()
        for _ in range(round(before_seconds * fps)):
            sim.advance(1.0 / fps)
            write()
        before = cloth.positions, cloth.faces
        report = sim.stroke(stroke_points())
        if smooth:
            smoothing = sim.smooth_rest_lengths(iterations=smooth, strength=0.5)
            print(
                f"  rest-length smoothing ({smooth} iterations): ratio roughness "
                f"{smoothing['roughness_before']:.4f} -> {smoothing['roughness_after']:.4f}"
            )
        write()
        for _ in range(round(after_seconds * fps)):
            sim.advance(1.0 / fps)
            write()
    region = report.region_faces
    gain = metrics.area_gain(cloth.positions, cloth.faces, region, report.area_before)
    picture = save_panels(
        out / f"{name}.png",
        [
            (f"before the stroke (t = {before_seconds:.1f} s)", *before),
            (f"{after_seconds:.1f} s after it", cloth.positions, cloth.faces),
        ],
    )
    print(
        f"{name} ({integrator}): stroke split {report.faces_split} faces "
        f"({len(report.faces_skipped)} skipped, {report.missed_fraction:.0%} of samples missed), "
        f"+{report.vertices_added} vertices, +{report.springs_added}/-{report.springs_removed} "
        f"springs; located in {1e3 * report.locate_seconds:.1f} ms, subdivided in "
        f"{1e3 * report.subdivide_seconds:.1f} ms, re-analysis "
        f"{1e3 * (report.reanalyze_seconds or 0.0):.1f} ms"
    )
    print(
        f"  region rest area {report.rest_area_before:.4f} -> {report.rest_area_after:.4f} m², "
        f"current area gain x{gain:.3f}, wrinkle amplitude "
        f"{1e3 * metrics.wrinkle_amplitude(cloth.positions, cloth.faces, region):.1f} mm"
    )
    print(f"  frames: {frames.pvd_path.resolve()}  picture: {picture.resolve()}")
    return sim, report


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", choices=("hanging", "cylinder", "both"), default="both")
    parser.add_argument(
        "--integrator", default="explicit", choices=("explicit", "implicit", "bdf2")
    )
    parser.add_argument("--out", type=Path, default=Path("yore-out"))
    parser.add_argument("--before", type=float, default=1.5, help="seconds before the stroke")
    parser.add_argument("--after", type=float, default=2.0, help="seconds after the stroke")
    parser.add_argument(
        "--smooth",
        type=int,
        default=0,
        help="iterations of rest-length smoothing after the stroke (paper §2.3)",
    )
    args = parser.parse_args(argv)
    scenes = {"hanging": hanging, "cylinder": cylinder}
    for name in ("hanging", "cylinder") if args.scene == "both" else (args.scene,):
        run(name, scenes[name], args.integrator, args.out, args.before, args.after, args.smooth)


if __name__ == "__main__":
    main()
