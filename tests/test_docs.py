"""The README and the documentation tell the truth: the README's first scene file loads and its
first Python script runs as shown, its links exist, and the option tables of the integrators'
page list the registry's options with its defaults."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

import yore

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks(language):
    return re.findall(
        rf"^```{language}\n(.*?)^```", README.read_text(encoding="utf-8"), re.M | re.S
    )


def test_the_readme_stays_short_and_links_pages_that_exist():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 200
    links = re.findall(r"\]\((docs/[^)#]+)", text)
    assert links, "the README links into the documentation"
    for link in links:
        assert (README.parent / link).exists(), link


def test_the_readmes_limitations_are_a_short_table_with_a_link_per_row():
    """At most 25 lines (issue 54): one row per limitation, its number, and a link to the
    section of docs/limitations.md that holds the measurements."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Limitations") :]
    section = section[: section.index("\n## ", 1)] if "\n## " in section[1:] else section
    lines = section.strip().splitlines()
    assert len(lines) <= 25
    rows = [line for line in lines if line.startswith("| ") and not line.startswith("| What")]
    assert len(rows) >= 10
    headings = {
        _slug(line[3:])
        for line in (README.parent / "docs" / "limitations.md").read_text("utf-8").splitlines()
        if line.startswith("## ")
    }
    for row in rows:
        anchors = re.findall(r"\(docs/limitations\.md#([a-z0-9-]+)\)", row)
        assert len(anchors) == 1, row
        assert anchors[0] in headings, row


def _slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    kept = re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", ""))
    return kept.replace(" ", "-")


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
    completed = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert completed.returncode == 0, completed.stderr
    first, iterations, kinetic, settled = completed.stdout.strip().splitlines()
    split = int(first.split()[0])
    assert split > 0 and "faces split" in first
    before, after = (float(x) for x in re.findall(r"(\d+\.\d+)", first))
    assert after > before  # the stroke grew the rest area
    assert int(iterations) > 0
    assert 0.0 < float(kinetic) < 10.0  # the TR-BDF2 sheet still swings, and did not blow up
    assert settled == "True True"  # the stretched membrane settled, on a stable state
    assert (tmp_path / "cloth.obj").is_file()


def _option_tables(text):
    """{integrator heading: {option: default text}} from docs/integrators.md's Options tables:
    rows of `` `name` (default) `` cells, one or several names per row."""
    tables, current = {}, None
    for line in text.splitlines():
        heading = re.fullmatch(r"\*\*([a-z0-9 ,-]+)\*\*", line.strip())
        if heading:
            current = tables.setdefault(heading.group(1), {})
        elif current is not None and line.startswith("| `"):
            cell = line.split("|")[1]
            for name, default in re.findall(r"`([a-z_]+)` \(([^)]*)\)", cell):
                current[name] = default
    return tables


def _matches(text, value):
    """Whether a documented default (its first word) is the value."""
    word = text.replace("`", "").split(" ")[0]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return word == (f'"{value}"' if isinstance(value, str) else str(value))
    return float(word) == value


def test_the_documented_integrator_options_and_defaults_are_the_registrys():
    from yore.options import INTEGRATOR_OPTIONS

    tables = _option_tables((README.parent / "docs" / "integrators.md").read_text("utf-8"))
    newton = tables["implicit, bdf2 and tr-bdf2"]
    auto = tables["bdf2 and tr-bdf2"]
    documented = {
        "explicit": tables["explicit"],
        "implicit": newton,
        "bdf2": {**newton, **auto},
        "tr-bdf2": {**newton, **auto, **tables["tr-bdf2"]},
        "generalized-alpha": {**newton, **tables["generalized-alpha"]},
        "implicit-midpoint": {**newton, **tables["implicit-midpoint"]},
        "local-global": tables["local-global"],
        "quasi-newton": tables["quasi-newton"],
        "cvode": {
            name: value for name, value in tables["cvode and arkode"].items() if name != "order"
        },
        "arkode": {
            name: value for name, value in tables["cvode and arkode"].items() if name != "max_order"
        },
    }
    for integrator, options in INTEGRATOR_OPTIONS.items():
        assert set(documented[integrator]) == set(options), integrator
        for name, value in options.items():
            # "0 = off" style notes follow the value
            assert _matches(documented[integrator][name], value), (integrator, name, value)


def test_the_docs_integrator_lists_are_the_registrys():
    """python.md and scene-files.md list the integrators, and integrators.md tabulates them,
    between markers that tools/docs_lists.py fills from yore.options.INTEGRATOR_SPECS: every
    registered name, none by hand (issue 54)."""
    sys.path.insert(0, str(README.parent / "tools"))
    try:
        import docs_lists
    finally:
        sys.path.pop(0)
    pages = {path.name for path in docs_lists.pages_with_lists()}
    assert {"python.md", "scene-files.md", "integrators.md"} <= pages
    for name in pages:
        text = (README.parent / "docs" / name).read_text("utf-8")
        assert docs_lists.refreshed(text) == text, f"{name} is stale: run tools/docs_lists.py"
        marked = re.findall(r"<!-- integrators -->(.*?)<!-- /integrators -->", text)
        marked += re.findall(
            r"<!-- integrator-table -->(.*?)<!-- /integrator-table -->", text, re.S
        )
        assert marked, name
        for listed in marked:
            assert re.findall(r'`"([a-z0-9-]+)"`', listed) == list(yore.INTEGRATORS)
    # the integrators page's table is the generated one, no hand-written copy beside it
    page = (README.parent / "docs" / "integrators.md").read_text("utf-8")
    assert page.count("| integrator | method | per step |") == 1
