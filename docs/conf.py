"""Sphinx configuration of yore's documentation.

Build it from the repository root (``make docs`` does)::

    .venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html

Prose pages are Markdown (MyST), the API reference comes from the docstrings of the installed
package (autodoc + napoleon), and the gallery runs the scripts in ``examples/`` at a small size
(sphinx-gallery; the hooks that make them small and collect their pictures are in
``_ext/yore_gallery.py``).
"""

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

# The examples show tqdm progress bars on a terminal; the gallery captures only their stdout.
os.environ.setdefault("TQDM_DISABLE", "1")

import yore  # noqa: E402  (the installed package, which autodoc documents)

project = "yore"
author = "the yore developers"
copyright = "the yore developers"
release = version = yore.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "gallery/runs"]

# -- MyST ------------------------------------------------------------------------------------
# "#heading" links between pages, written as a code host writes them
myst_heading_anchors = 3

# -- autodoc and napoleon --------------------------------------------------------------------
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
napoleon_google_docstring = True
napoleon_numpy_docstring = True

# -- the gallery -----------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": str(DOCS.parent / "examples"),
    "gallery_dirs": "auto_examples",
    # every script of examples/ runs, each at a small size (yore_gallery.small_argv)
    "filename_pattern": r".*\.py$",
    "reset_argv": "yore_gallery.small_argv",
    "image_scrapers": ("yore_gallery.png_scraper",),
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "min_reported_time": 0,
    "capture_repr": (),
}

# -- HTML ------------------------------------------------------------------------------------
html_theme = "furo"
html_title = f"yore {release}"
html_static_path = []


# -- docstrings of the compiled module -------------------------------------------------------
def _signature_as_literal(app, what, name, obj, options, lines):
    """The class docstring of ``yore.Cloth`` (written in C++, ``cpp/bindings``) shows its call
    as ``Cloth(vertices, ...)`` over several lines; reST would read those lines as a
    definition, so they are shown as a literal block."""
    if what != "class" or getattr(obj, "__module__", None) != "yore._native":
        return
    call = f"{obj.__name__}("
    starts = [i for i, line in enumerate(lines) if line.startswith(call)]
    if not starts:
        return
    start = end = starts[0]
    while (
        end < len(lines) and lines[end].strip() and (end == start or lines[end].startswith("    "))
    ):
        end += 1
    lines[start:end] = ["::", "", *(f"    {line}" for line in lines[start:end]), ""]


def _attribute_docstring_is_prose(app, what, name, obj, options, lines):
    """yore documents attributes and properties in prose ("The bending model: "springs" or
    "quadratic"."), not in napoleon's ``type: description`` form, where the words before the
    first colon would become the type. An empty reST comment first gives napoleon a line
    without a colon; it renders as nothing."""
    if what in ("attribute", "property", "data") and lines and ":" in lines[0]:
        lines[0:0] = ["..", ""]


def setup(app):
    app.connect("autodoc-process-docstring", _signature_as_literal)
    # before napoleon's own handler (priority 500)
    app.connect("autodoc-process-docstring", _attribute_docstring_is_prose, priority=400)
