"""`yore demo`: the paper's first experiment three ways, at the same time and camera.

Four runs of the hanging cloth, each settled to rest before its stroke:

- yore's reproduction (the demo scene, examples/hanging.toml) into ``OUT`` — frames, pictures,
  animation and summary as any `yore run`;
- the paper's operation exactly (examples/hanging_paper.toml) into ``OUT/paper``;
- each of the two without its stroke (``--set 'strokes=[]'``) into ``OUT/no-stroke`` and
  ``OUT/paper-no-stroke``, the comparisons the measures need.

Then ``OUT/demo.png`` puts the last frames side by side (no stroke, the paper's stroke, yore's
stroke) under the demo scene's camera, and ``OUT/summary.json`` gains a ``demo`` table with
`yore.metrics.stroke_effect` of each stroke against its own no-stroke run: the stroke
region's wrinkle measure and its ratio, and the spike index of the stroke's new vertices.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

from .. import metrics
from ..camera import camera_from_settings
from ..state import load_state
from .loading import load_scene
from .record import RunRecord
from .runner import SUMMARY_NAME, STATE_NAME, write_json, run_scene

__all__ = ["run_demo", "demo_scene_text", "paper_scene_text"]

#: Sub-folders of the demo's output folder.
PAPER_DIR, PLAIN_DIR, PAPER_PLAIN_DIR = "paper", "no-stroke", "paper-no-stroke"
PICTURE_NAME = "demo.png"


def _save_picture(path, camera_settings, shown):
    """The demo's picture: one panel per (simulation, run folder, title), one camera fitted to
    all of them, coloured by wrinkle height on one shared scale, with each run's strokes."""
    from ..viz import save_panels
    from ..viz.pictures import stroke_lines
    from ..viz.render import framing_camera, picture_layout

    positions = [sim.cloth.positions for sim, _, _ in shown]
    heights = [
        1e3 * metrics.wrinkle_height(sim.cloth.positions, sim.cloth.faces) for sim, _, _ in shown
    ]
    half = max(float(max(abs(h).max() for h in heights)), 1e-9)
    full = camera_from_settings(camera_settings, positions)
    if (camera_settings or {}).get("eye") is None:
        inner_size = picture_layout(full.width, full.height, colorbar=True)
        inner = camera_from_settings(camera_settings, positions, *inner_size)
        full = framing_camera(inner, full.width, full.height)
    panels = []
    for sim, folder, title in shown:
        strokes = []
        if folder is not None and (folder / SUMMARY_NAME).is_file():
            record = json.loads((folder / SUMMARY_NAME).read_text(encoding="utf-8"))
            strokes = stroke_lines(record.get("strokes", []), sim.cloth.positions)
        panels.append((title, sim.cloth.positions, sim.cloth.faces, strokes))
    save_panels(
        path,
        panels,
        camera=full,
        values=heights,
        value_range=(-half, half),
        colormap="coolwarm",
        colorbar="wrinkles (mm)",
    )


def demo_scene_text() -> str:
    """The demo's scene file (the same text as examples/hanging.toml)."""
    return resources.files("yore").joinpath("data/hanging.toml").read_text(encoding="utf-8")


def paper_scene_text() -> str:
    """The paper's operation on the same cloth (the same text as examples/hanging_paper.toml)."""
    return resources.files("yore").joinpath("data/hanging_paper.toml").read_text(encoding="utf-8")


def _effect(stroked_dir, plain_dir):
    state_path = stroked_dir / STATE_NAME
    sim, metadata = load_state(state_path)
    record = RunRecord.from_metadata(state_path, metadata)
    plain, _ = load_state(plain_dir / STATE_NAME)
    if not record.strokes:
        return None
    stroke = record.strokes[0]
    vertices = stroke.new_vertices or stroke.line_vertices
    effect = metrics.stroke_effect(
        sim.cloth.positions,
        sim.cloth.faces,
        plain.cloth.positions,
        plain.cloth.faces,
        stroke.region_faces,
        vertices,
    )
    effect.update(
        time=sim.time,
        growth=stroke.growth,
        refine=stroke.refine,
        vertices_measured=len(vertices),
    )
    return effect, sim, plain


def _demo_runs(out, yore_scene, paper_scene, plain):
    """The demo's four runs: (scene, folder, whether to render, label)."""
    return [
        (yore_scene, out, True, "yore's stroke"),
        (paper_scene, out / PAPER_DIR, False, "the paper's stroke"),
        (
            load_scene(Path("hanging.toml"), text=demo_scene_text(), overrides=plain),
            out / PLAIN_DIR,
            False,
            "no stroke",
        ),
        (
            load_scene(Path("hanging_paper.toml"), text=paper_scene_text(), overrides=plain),
            out / PAPER_PLAIN_DIR,
            False,
            "the paper's cloth, no stroke",
        ),
    ]


def _measured_and_shown(out):
    """The strokes' effects measured from the four runs' states, the plain run's simulation,
    and the (simulation, folder, caption) of each panel of the demo's picture."""
    yore_effect = _effect(out, out / PLAIN_DIR)
    paper_effect = _effect(out / PAPER_DIR, out / PAPER_PLAIN_DIR)
    plain_sim = None
    measured = {}
    if yore_effect is not None:
        yore, yore_sim, plain_sim = yore_effect
        measured.update(yore=yore)
    if paper_effect is not None:
        paper, paper_sim, _ = paper_effect
        measured.update(paper=paper)
    if plain_sim is None:
        plain_sim, _ = load_state(out / PLAIN_DIR / STATE_NAME)
    shown = [(plain_sim, None, "no stroke")]
    if paper_effect is not None:
        shown.append(
            (
                paper_sim,
                out / PAPER_DIR,
                f"the paper's stroke: spike index {paper.spike_index:.2f}",
            )
        )
    if yore_effect is not None:
        shown.append(
            (
                yore_sim,
                out,
                f"yore's stroke: wrinkles x{yore.wrinkle_ratio:.1f}, "
                f"spike index {yore.spike_index:.2f}",
            )
        )
    return measured, plain_sim, shown


def run_demo(out, overrides=None, quiet=False, overwrite=False, threads=None) -> dict:
    """Runs the demo into folder ``out``; returns the main run's summary with its ``demo``
    table. ``overrides``: dotted keys applied to all four runs (e.g. ``{"mesh.nx": 9}``).
    Raises what `yore.run_scene` raises."""
    out = Path(out)
    overrides = dict(overrides or {})
    plain = {
        **overrides,
        "strokes": [],
        "output.format": "none",
        "output.animation": "none",
        "output.pictures": False,
    }
    yore_scene = load_scene(Path("hanging.toml"), text=demo_scene_text(), overrides=overrides)
    paper_scene = load_scene(
        Path("hanging_paper.toml"),
        text=paper_scene_text(),
        overrides={**overrides, "output.animation": "none"},
    )
    runs = _demo_runs(out, yore_scene, paper_scene, plain)
    summary = None
    for scene, folder, render, label in runs:
        if not quiet:
            print(f"yore demo: {label} -> {folder}", flush=True)
        result = run_scene(
            scene, folder, quiet=quiet, render=render, overwrite=overwrite, threads=threads
        )
        if summary is None:
            summary = result

    measured, plain_sim, shown = _measured_and_shown(out)
    _save_picture(out / PICTURE_NAME, summary.get("camera"), shown)

    summary["demo"] = {
        "picture": PICTURE_NAME,
        "time": plain_sim.time,
        **measured,
        "runs": {"paper": PAPER_DIR, "no_stroke": PLAIN_DIR, "paper_no_stroke": PAPER_PLAIN_DIR},
    }
    summary["outputs"]["demo"] = PICTURE_NAME
    write_json(out / SUMMARY_NAME, summary)
    if not quiet:
        for name, effect in measured.items():
            print(
                f"{name:5s}: wrinkle measure {effect.wrinkle:.4f} m against "
                f"{effect.wrinkle_plain:.4f} m without the stroke "
                f"(×{effect.wrinkle_ratio:.2f}), spike index {effect.spike_index:.3f}"
            )
    return json.loads((out / SUMMARY_NAME).read_text(encoding="utf-8"))
