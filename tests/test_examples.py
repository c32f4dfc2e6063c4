"""The example scripts run (at reduced size) and write what they promise."""

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import yore

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def run(script, *args):
    result = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


@pytest.mark.slow
def test_demo_writes_frames_a_collection_and_a_picture_and_says_where(tmp_path):
    pytest.importorskip("matplotlib")
    out = run(
        "hanging_cloth.py",
        "--out",
        str(tmp_path),
        "--seconds",
        "0.2",
        "--fps",
        "20",
        "--resolution",
        "7",
    )
    pvd = tmp_path / "frames" / "hanging_cloth.pvd"
    assert str(pvd.resolve()) in out
    datasets = ET.parse(pvd).getroot().findall(".//DataSet")
    assert len(datasets) == 5  # t = 0 and four frames
    times = [float(d.get("timestep")) for d in datasets]
    assert times == sorted(times) and abs(times[-1] - 0.2) < 1e-3
    V, F = yore.load_mesh(pvd.parent / datasets[-1].get("file"))
    assert V.shape == (49, 3) and F.shape == (72, 3)
    assert V[:, 1].min() < -0.05  # it has fallen
    picture = tmp_path / "hanging_cloth.png"
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_cylinder_example_reports_the_rim_speed(tmp_path):
    pytest.importorskip("matplotlib")
    out = run("rotating_cylinder.py", "--out", str(tmp_path), "--seconds", "0.2")
    assert "ring 12:  6.283 rad/s" in out
    assert len(list((tmp_path / "cylinder").glob("*.obj"))) == 6


@pytest.mark.slow
def test_stroke_experiments_write_frames_across_the_topology_change(tmp_path):
    pytest.importorskip("matplotlib")
    out = run(
        "stroke_experiments.py",
        "--out",
        str(tmp_path),
        "--before",
        "0.2",
        "--after",
        "0.2",
        "--smooth",
        "5",
    )
    for name in ("hanging", "cylinder"):
        pvd = tmp_path / name / f"{name}.pvd"
        datasets = ET.parse(pvd).getroot().findall(".//DataSet")
        assert len(datasets) == 1 + 5 + 1 + 5  # start, before, right after the stroke, after
        first = yore.load_mesh(pvd.parent / datasets[0].get("file"))[0]
        last = yore.load_mesh(pvd.parent / datasets[-1].get("file"))[0]
        assert len(last) > len(first)  # the stroke added vertices mid-run
        assert (tmp_path / f"{name}.png").exists()
        assert f"{name} (explicit): stroke split" in out
    assert "ratio roughness" in out


@pytest.mark.slow
def test_the_gallery_script_writes_its_pictures_and_measures(tmp_path):
    run("gallery.py", "--out", str(tmp_path), "--small")
    for name in ("hanging.png", "cylinder.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import json

    data = json.loads((tmp_path / "gallery.json").read_text())
    assert data["small"] is True
    assert set(data) >= {"hanging", "hanging_paper", "cylinder", "cylinder_paper"}
    # the measures of tests/test_experiments.py, through the script; at --small's 17² (13²
    # left the 15 cm band under two edges wide before its refinement: ×1.96 once the band's
    # springs took the falloff's mean, issue 52) the wrinkle target holds (×3.1 measured); the
    # absolute spike target (0.1) is stated and tested at the demo's 21², so here yore's stroke
    # must be a small fraction of the paper's tents (0.083 against 0.35 measured)
    assert data["hanging"]["wrinkle_ratio"] >= 2.0
    assert data["hanging"]["spike_index"] <= 0.5 * data["hanging_paper"]["spike_index"]
    assert data["cylinder"]["hem_ratio"] >= 1.2 > data["cylinder_paper"]["hem_ratio"]
