"""Pictures and the viewer, on polyscope.

- `render_image` (`yore.viz.render`): one picture of a mesh from a `yore.Camera`, headless on
  EGL: smooth shading, anti-aliasing, ground shadow, colour maps with a colour bar, strokes.
- `render_run`, `render_frame` (`yore.viz.pictures`): the pictures and animation of a run
  folder or a frame file (what ``yore render`` and the end of ``yore run`` do).
- `side_by_side`, `save_png`, `save_animation` (`yore.viz.images`): composing and writing.
- `Viewer` (`yore.viz.viewer`): a live simulation in a window where strokes are drawn with the
  mouse, or headless with strokes given in pixels (``yore view``).

polyscope is imported on first use, so ``import yore`` does not need OpenGL.
"""

from __future__ import annotations

from .backend import EGL_PACKAGES, BackendUnavailable
from .images import check_ffmpeg, save_animation, save_png, side_by_side
from .render import COLORMAPS, render_image

__all__ = [
    "render_image",
    "render_run",
    "render_frame",
    "save_panels",
    "side_by_side",
    "save_png",
    "save_animation",
    "check_ffmpeg",
    "COLORMAPS",
    "BackendUnavailable",
    "EGL_PACKAGES",
    "Viewer",
]


def __getattr__(name):
    # the run pictures and the viewer load on first use
    if name in ("render_run", "render_frame", "save_panels"):
        from . import pictures

        return getattr(pictures, name)
    if name == "Viewer":
        from .viewer import Viewer

        return Viewer
    raise AttributeError(f"module 'yore.viz' has no attribute {name!r}")
