"""A cloth hung from two corners
==============================

The paper's first scene (§3.1): a square cloth hung from two points, run with the explicit
integrator. The script writes ParaView frames and a picture of the cloth at the start and at the
end::

    python examples/hanging_cloth.py [--out yore-out] [--seconds 3] [--fps 30] [--resolution 21]
"""

import argparse
import time
from pathlib import Path

import yore
from yore.io import FrameSeries
from yore.viz import save_panels


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("yore-out"))
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated time, s")
    parser.add_argument("--fps", type=float, default=30.0, help="frames per simulated second")
    parser.add_argument("--resolution", type=int, default=21, help="vertices per cloth edge")
    args = parser.parse_args(argv)

    sim = yore.scenes.hanging_cloth(resolution=args.resolution)
    cloth = sim.cloth
    before = cloth.positions
    frames = FrameSeries(args.out / "frames", stem="hanging_cloth", fmt="vtu")
    frames.write(sim.time, before, cloth.faces, point_data={"velocity": cloth.velocities})
    frame_count = max(1, round(args.seconds * args.fps))
    started = time.perf_counter()
    from tqdm.auto import tqdm

    for _ in tqdm(range(frame_count), desc="hanging cloth", unit="frame"):
        sim.advance(1.0 / args.fps, progress=False)
        frames.write(
            sim.time, cloth.positions, cloth.faces, point_data={"velocity": cloth.velocities}
        )
    wall = time.perf_counter() - started
    frames.close()
    picture = save_panels(
        args.out / "hanging_cloth.png",
        [("t = 0 s", before, cloth.faces), (f"t = {sim.time:.2f} s", cloth.positions, cloth.faces)],
    )

    stats = sim.stats
    print(
        f"simulated {sim.time:.2f} s in {stats['steps']} explicit steps of {sim.dt:.3g} s "
        f"({wall:.2f} s wall, {stats['steps_per_second']:.0f} steps/s)"
    )
    print(f"frames:  {len(frames)} VTU files in {frames.pvd_path.parent.resolve()}")
    print(f"ParaView collection: {frames.pvd_path.resolve()}")
    print(f"picture: {picture.resolve()}")


if __name__ == "__main__":
    main()
