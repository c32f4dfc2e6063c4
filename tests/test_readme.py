"""What the README shows a newcomer works as shown: its first scene file loads and its first
Python script runs and prints what the README says it prints."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

import yore

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks(language):
    return re.findall(rf"^```{language}\n(.*?)^```", README.read_text(encoding="utf-8"),
                      re.M | re.S)


def test_the_readme_stays_short_and_links_pages_that_exist():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    links = re.findall(r"\]\((docs/[^)#]+)", text)
    assert links, "the README links into the documentation"
    for link in links:
        assert (README.parent / link).exists(), link


def test_the_first_scene_file_loads_and_has_its_stroke(tmp_path):
    (scene_text,) = _blocks("toml")
    path = tmp_path / "first.toml"
    path.write_text(scene_text, encoding="utf-8")
    scene = yore.load_scene(path)
    sim, _ = scene.build()
    assert sim.cloth.vertex_count == 21 * 21
    assert len(scene.data["strokes"]) == 1 and scene.data["simulation"]["duration"] == 2.0


@pytest.mark.slow
def test_the_first_python_script_runs_and_splits_faces(tmp_path):
    (script,) = _blocks("python")
    completed = subprocess.run([sys.executable, "-c", script], cwd=tmp_path,
                               capture_output=True, text=True, timeout=600)
    assert completed.returncode == 0, completed.stderr
    first, iterations = completed.stdout.strip().splitlines()
    split = int(first.split()[0])
    assert split > 0 and "faces split" in first
    before, after = (float(x) for x in re.findall(r"(\d+\.\d+)", first))
    assert after > before  # the stroke grew the rest area
    assert int(iterations) > 0
    assert (tmp_path / "cloth.obj").is_file()
