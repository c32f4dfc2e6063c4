"""No stroke, the paper's stroke, yore's stroke
=============================================

The paper's two experiments, each three ways side by side — no stroke, the paper's stroke and
yore's stroke — with their measures::

    python examples/gallery.py [--out docs/gallery] [--small]

Runs ``examples/hanging*.toml`` and ``examples/cylinder*.toml`` with and without their strokes
(the ``yore run`` machinery, into ``OUT/runs``), then writes ``OUT/hanging.png``,
``OUT/cylinder.png`` and ``OUT/gallery.json``: for the hanging cloth
``yore.metrics.stroke_effect`` of each stroke against its own no-stroke run (wrinkle measure and
its ratio, spike index), for the cylinder the hem radius (mean ``radial_distance`` of the first
ring) over the no-stroke run's. ``--small``: reduced sizes (a quick look; the numbers quoted in
the documentation are full size).
"""

import argparse
import json
from pathlib import Path

import numpy as np

import yore
from yore import metrics
from yore.cli import main as yore_main
from yore.camera import camera_from_settings
from yore.viz import render_image, save_png, side_by_side
from yore.viz.pictures import stroke_lines
from yore.viz.render import framing_camera, picture_layout

EXAMPLES = Path(__file__).resolve().parent


def run(scene, out, *sets):
    args = [
        "run",
        str(EXAMPLES / scene),
        "-o",
        str(out),
        "--overwrite",
        "-q",
        "--no-render",
        "--set",
        "output.format=none",
        "--set",
        "output.animation=none",
        *sets,
    ]
    if yore_main(args) != 0:
        raise SystemExit(f"yore run {scene} failed")
    return yore.load_state(out / "state.npz")


def save(path, settings, shown, width, height, wrinkles):
    """One picture of (simulation, strokes, title) panels under one camera fitted to all,
    coloured by wrinkle height on a shared scale when ``wrinkles``."""
    positions = [sim.cloth.positions for sim, _, _ in shown]
    inner = camera_from_settings(
        settings, positions, *picture_layout(width, height, colorbar=wrinkles)
    )
    camera = framing_camera(inner, width, height)
    heights = [
        1e3 * metrics.wrinkle_height(sim.cloth.positions, sim.cloth.faces) for sim, _, _ in shown
    ]
    half = max(float(np.abs(h).max()) for h in heights)
    panels = [
        render_image(
            sim.cloth.positions,
            sim.cloth.faces,
            camera,
            vertex_values=height if wrinkles else None,
            value_range=(-half, half),
            colormap="coolwarm",
            colorbar="wrinkles (mm)" if wrinkles else None,
            strokes=stroke_lines(strokes, sim.cloth.positions),
        )
        for (sim, strokes, _), height in zip(shown, heights)
    ]
    save_png(path, side_by_side(panels, [title for _, _, title in shown]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/gallery"))
    parser.add_argument("--small", action="store_true")
    args = parser.parse_args()
    runs = args.out / "runs"
    results = {}

    hanging_size = ["--set", "mesh.nx=17", "--set", "mesh.ny=17"] if args.small else []
    plain, _ = run("hanging.toml", runs / "hanging-plain", *hanging_size, "--set", "strokes=[]")
    scene = yore.load_scene(EXAMPLES / "hanging.toml")
    shown = [(plain, [], "no stroke")]
    for name, label in (
        ("hanging_paper.toml", "the paper's stroke"),
        ("hanging.toml", "yore's stroke"),
    ):
        stem = name.removesuffix(".toml")
        sim, record = run(name, runs / stem, *hanging_size)
        own, _ = run(name, runs / f"{stem}-plain", *hanging_size, "--set", "strokes=[]")
        stroke = record["strokes"][0]
        effect = metrics.stroke_effect(
            sim.cloth.positions,
            sim.cloth.faces,
            own.cloth.positions,
            own.cloth.faces,
            stroke["region_faces"],
            stroke["new_vertices"] or stroke["line_vertices"],
        )
        results[stem] = {**effect, "time": sim.time, "vertices": sim.cloth.vertex_count}
        shown.append(
            (
                sim,
                record["strokes"],
                f"{label}: wrinkles x{effect['wrinkle_ratio']:.1f}, "
                f"spike index {effect['spike_index']:.2f}",
            )
        )
    save(args.out / "hanging.png", scene.data["camera"], shown, 640, 480, wrinkles=True)

    cylinder_size = ["--set", "mesh.rings=7", "--set", "mesh.segments=16"] if args.small else []
    segments = 16 if args.small else 32
    plain, _ = run("cylinder.toml", runs / "cylinder-plain", *cylinder_size, "--set", "strokes=[]")
    scene = yore.load_scene(EXAMPLES / "cylinder.toml")
    shown = [(plain, [], "no stroke")]
    for name, label in (
        ("cylinder_paper.toml", "the paper's stroke"),
        ("cylinder.toml", "yore's stroke"),
    ):
        stem = name.removesuffix(".toml")
        sim, record = run(name, runs / stem, *cylinder_size)
        own, _ = run(name, runs / f"{stem}-plain", *cylinder_size, "--set", "strokes=[]")
        hem = float(metrics.radial_distance(sim.cloth.positions[:segments]).mean())
        hem_plain = float(metrics.radial_distance(own.cloth.positions[:segments]).mean())
        results[stem] = {
            "hem_radius": hem,
            "hem_radius_plain": hem_plain,
            "hem_ratio": hem / hem_plain,
            "time": sim.time,
        }
        shown.append((sim, record["strokes"], f"{label}: hem radius x{hem / hem_plain:.2f}"))
    save(args.out / "cylinder.png", scene.data["camera"], shown, 560, 480, wrinkles=False)
    (args.out / "gallery.json").write_text(
        json.dumps({"small": args.small, **results}, indent=1) + "\n"
    )
    for name, values in results.items():
        print(name, {k: round(v, 4) if isinstance(v, float) else v for k, v in values.items()})


if __name__ == "__main__":
    main()
