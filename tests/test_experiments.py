"""The paper's two experiments, as example scenes: yore's strokes make wrinkles and a skirt where
the paper's operation makes spikes and nothing — checked at reduced size on counted quantities
(measures of the final shapes), never on timings."""

import json
from pathlib import Path

import pytest

import yore
from yore import metrics
from yore.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.slow
def test_the_demo_shows_wrinkles_where_the_paper_makes_spikes(tmp_path):
    # At the demo's own 21 × 21 vertices, where its targets are stated (~9 s): the stroke
    # region's wrinkle measure at least twice the no-stroke run's at the same time, and a
    # spike index at most 0.1 on the stroke's new vertices. Measured with the fitted bending
    # energy and the band's Simpson spring weights (issue 52): wrinkles ×4.1, spike index
    # 0.059 for yore's stroke; ×4.1 and 0.34 for the paper's. (This test ran at 13² before; there the fitted energy, softer than the
    # hinge energy for a one-vertex spike, gives 0.11.)
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "-q", "--set", "output.animation=none"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    demo = summary["demo"]
    assert demo["yore"]["wrinkle_ratio"] >= 2.0
    assert demo["yore"]["spike_index"] <= 0.1
    assert demo["yore"]["refine"] == 2 and demo["yore"]["growth"] == "along"
    # the paper's operation, measured as it is: one-face tents (a tent of a vertex lifted
    # ~0.4 edge lengths out of its ring measures ~0.4)
    assert demo["paper"]["spike_index"] > 0.2
    assert demo["paper"]["growth"] == "paper"
    # all four runs end at the same time, and the picture has three panels side by side
    assert demo["yore"]["time"] == pytest.approx(demo["paper"]["time"], abs=1e-3)
    for folder in ("paper", "no-stroke", "paper-no-stroke"):
        assert (out / folder / "state.npz").is_file()
    picture = (out / "demo.png").read_bytes()
    assert picture[:8] == b"\x89PNG\r\n\x1a\n"
    assert summary["outputs"]["demo"] == "demo.png"


def _hem_radius(run):
    sim, _ = yore.load_state(run / "state.npz")
    segments = 16
    return float(metrics.radial_distance(sim.cloth.positions[:segments]).mean())


@pytest.mark.slow
@pytest.mark.parametrize(
    "scene, low, high", [("cylinder.toml", 1.2, None), ("cylinder_paper.toml", None, 1.05)]
)
def test_the_cylinder_flares_into_a_skirt_only_with_yores_stroke(tmp_path, scene, low, high):
    # 7 rings × 16 segments instead of 13 × 32 (measured at full size: yore ×1.30, paper
    # ×0.99). The target: the hem radius at the end at least 1.2 × that of the same run
    # without strokes. The hem is the first ring (cylinder_mesh numbers rings from y = 0).
    small = [
        "--set",
        "mesh.rings=7",
        "--set",
        "mesh.segments=16",
        "--no-render",
        "-q",
        "--set",
        "output.format=none",
    ]
    assert main(["run", str(EXAMPLES / scene), "-o", str(tmp_path / "stroke"), *small]) == 0
    assert (
        main(
            [
                "run",
                str(EXAMPLES / scene),
                "-o",
                str(tmp_path / "plain"),
                *small,
                "--set",
                "strokes=[]",
            ]
        )
        == 0
    )
    ratio = _hem_radius(tmp_path / "stroke") / _hem_radius(tmp_path / "plain")
    if low is not None:
        assert ratio >= low, ratio
    if high is not None:
        assert ratio <= high, ratio
