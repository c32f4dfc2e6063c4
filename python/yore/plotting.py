"""Quick PNG pictures of cloth states with matplotlib (needs the `plot` extra: matplotlib)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["save_side_by_side"]


def save_side_by_side(path, panels, elevation=20.0, azimuth=-60.0, size_inches=(5.0, 5.0)):
    """Writes a PNG with one shaded 3-D view per panel.

    panels : list of (title, V, F) with V n×3 positions (m, y up) and F f×3 faces.
    All panels share one bounding box, so shapes compare at the same scale.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LightSource

    lows = np.min([np.min(V, axis=0) for _, V, _ in panels], axis=0)
    highs = np.max([np.max(V, axis=0) for _, V, _ in panels], axis=0)
    center, half = (lows + highs) / 2, np.max(highs - lows) / 2 or 1.0
    fig = plt.figure(figsize=(size_inches[0] * len(panels), size_inches[1]))
    light = LightSource(azdeg=315, altdeg=45)
    for k, (title, V, F) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), k + 1, projection="3d")
        # matplotlib's 3-D axes have z up; the simulation has y up.
        ax.plot_trisurf(V[:, 0], V[:, 2], V[:, 1], triangles=F, color="#6fa8dc",
                        edgecolor="#3d6f99", linewidth=0.1, lightsource=light, shade=True)
        ax.set_xlim(center[0] - half, center[0] + half)
        ax.set_ylim(center[2] - half, center[2] + half)
        ax.set_zlim(center[1] - half, center[1] + half)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elevation, azim=azimuth)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("z (m)")
        ax.set_zlabel("y (m)")
        ax.set_title(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
