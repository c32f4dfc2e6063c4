"""sphinx-gallery hooks for yore's examples: run each script small, show the PNGs it wrote.

The scripts in ``examples/`` take argparse options whose defaults are the paper's sizes; the
gallery runs them with the options below instead (sphinx-gallery's ``reset_argv``), each into
its own folder under ``docs/_build/gallery-runs/``. yore draws its pictures with polyscope, not
matplotlib, so ``png_scraper`` collects the PNG files a script wrote into that folder.
"""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst

DOCS = Path(__file__).resolve().parents[1]
RUNS = DOCS / "_build" / "gallery-runs"

#: Command-line options of each example in the gallery: a few seconds each.
SMALL_OPTIONS = {
    "hanging_cloth.py": ["--seconds", "1", "--resolution", "13"],
    "rotating_cylinder.py": ["--seconds", "0.5"],
    "scripted_scene.py": ["--resolution", "11", "--seconds", "1"],
    "stroke_experiments.py": ["--before", "0.3", "--after", "0.5"],
    "gallery.py": ["--small"],
}

_shown: dict[str, set] = {}


def output_folder(src_file) -> Path:
    """Where the gallery's run of an example writes (``--out``)."""
    return RUNS / Path(src_file).stem


def small_argv(gallery_conf, script_vars) -> list:
    """``sys.argv[1:]`` for one example: its small options and an ``--out`` of its own.

    sphinx-gallery runs a script without ``__file__`` and with an empty ``__doc__``; the
    examples use both (``Path(__file__)`` to find the scene files beside them, the docstring's
    first line as their ``--help`` description), so both are set as a plain ``python
    examples/X.py`` would set them.
    """
    src_file = Path(script_vars["src_file"])
    example_globals = script_vars.get("example_globals")
    if example_globals is not None:
        example_globals["__file__"] = str(src_file)
        example_globals["__doc__"] = ast.get_docstring(ast.parse(src_file.read_text()), clean=False)
    out = output_folder(src_file)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    _shown[str(src_file)] = set()
    return [*SMALL_OPTIONS.get(src_file.name, []), "--out", str(out)]


def png_scraper(block, block_vars, gallery_conf) -> str:
    """The PNG files the example wrote into its output folder since the last code block,
    oldest first, copied to the gallery's image paths."""
    src_file = str(block_vars["src_file"])
    out = output_folder(src_file)
    if not out.is_dir():
        return ""
    shown = _shown.setdefault(src_file, set())
    new = sorted(
        (p for p in out.rglob("*.png") if p not in shown),
        key=lambda p: (p.stat().st_mtime_ns, str(p)),
    )
    images = []
    for png, target in zip(new, block_vars["image_path_iterator"]):
        shutil.copyfile(png, target)
        shown.add(png)
        images.append(target)
    return figure_rst(images, gallery_conf["src_dir"]) if images else ""
