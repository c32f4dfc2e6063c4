"""A tube turned by its top rim
=============================

Scripting example: the paper's second scene (§3.2), an open cylinder whose top rim rotates::

    python examples/rotating_cylinder.py [--out yore-out] [--seconds 2] [--fps 25]

Writes OBJ frames (for Blender) and a before/after picture, and prints how the tube follows the
rim: the mean angular speed of each ring about the axis.
"""

import argparse
from pathlib import Path

import numpy as np

import yore
from yore.io import FrameSeries
from yore.meshes import cylinder_ring
from yore.viz import save_panels


def ring_angular_speed(cloth, ring):
    """Mean angular speed (rad/s) of a ring's vertices about the y axis."""
    X, V = cloth.positions[ring], cloth.velocities[ring]
    radius_squared = X[:, 0] ** 2 + X[:, 2] ** 2
    # ω_y = (z·vx − x·vz) / r² for rotation about +y
    return float(np.mean((X[:, 2] * V[:, 0] - X[:, 0] * V[:, 2]) / radius_squared))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("yore-out"))
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--fps", type=float, default=25.0)
    args = parser.parse_args(argv)

    rings, segments = 13, 32
    sim = yore.scenes.rotating_cylinder(rings=rings, segments=segments, omega=2 * np.pi)
    cloth = sim.cloth
    before = cloth.positions
    with FrameSeries(args.out / "cylinder", stem="cylinder", fmt="obj") as frames:
        frames.write(sim.time, cloth.positions, cloth.faces)
        for _ in range(round(args.seconds * args.fps)):
            sim.advance(1.0 / args.fps)
            frames.write(sim.time, cloth.positions, cloth.faces)
    picture = save_panels(
        args.out / "rotating_cylinder.png",
        [("t = 0 s", before, cloth.faces), (f"t = {sim.time:.2f} s", cloth.positions, cloth.faces)],
    )
    print(f"t = {sim.time:.2f} s, rim turns at {sim.scene['omega']:.3f} rad/s")
    for ring in (rings - 1, rings // 2, 0):
        speed = ring_angular_speed(cloth, cylinder_ring(rings, segments, ring))
        print(f"  ring {ring:2d}: {speed:6.3f} rad/s")
    print(f"frames in {(args.out / 'cylinder').resolve()}, picture {picture.resolve()}")


if __name__ == "__main__":
    main()
