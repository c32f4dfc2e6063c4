"""Mesh surgery as pure functions (no springs, no masses), the shape of libigl's
``false_barycentric_subdivision``: vertices, faces and the requested splits in; vertices, faces
and the parent of every child face out. The input vertices keep their indices and come first;
an untouched face keeps its row; a subdivided face's first child takes its row and the others
are appended. Every child keeps its parent's orientation.

`split_faces_1to3` is the paper's split (the one `yore.Simulation.stroke` does in paper mode);
`refine_faces_1to4` the midpoint refinement of ``refine=``. Its conforming closure: a face left
with two or three split edges is refined 1→4 too, until every other face has at most one split
edge, which is bisected 1→2 from the midpoint to the opposite corner (no hanging vertices).
Limitation: repeated passes bisect bisected faces again (no green-face undo), so angles in the
closure ring shrink by up to half per pass.
"""

from __future__ import annotations

import numpy as np

from . import _core
from .results import FaceRefinement, FaceSplit
from .stroke import MIN_ANGLE_DEGREES, MIN_BARYCENTRIC

__all__ = ["split_faces_1to3", "refine_faces_1to4"]


def split_faces_1to3(
    V,
    F,
    faces,
    barycentric=None,
    min_barycentric=MIN_BARYCENTRIC,
    min_angle_degrees=MIN_ANGLE_DEGREES,
) -> FaceSplit:
    """The paper's 1→3 split of ``faces`` of the mesh (V n×3 m, F f×3) at barycentric points
    (k×3, default the centroids), with its degenerate-case rules (`yore.stroke`).

    Returns a `yore.results.FaceSplit` (a dict whose fields are also attributes):
    ``vertices`` (n+k')×3, ``faces``, ``parents`` (per output face, its input
    face), ``new_vertex_corners`` / ``new_vertex_weights`` (k'×3: each new vertex as weights of
    input vertices), ``split_faces``, ``faces_skipped`` and ``moved_inward``. Raises ValueError
    on a bad mesh, faces out of range or repeated, or bad weights.
    """
    faces = np.asarray(faces, dtype=np.int64).reshape(-1)
    if barycentric is None:
        barycentric = np.full((len(faces), 3), 1.0 / 3.0)
    return _core.split_faces_1to3(
        V,
        F,
        faces,
        barycentric,
        min_barycentric=min_barycentric,
        min_angle_degrees=min_angle_degrees,
    )


def refine_faces_1to4(V, F, faces) -> FaceRefinement:
    """1→4 midpoint refinement of ``faces`` of the mesh (V n×3 m, F f×3) with the conforming
    closure described in the module docstring.

    Returns a `yore.results.FaceRefinement` (a dict whose fields are also attributes):
    ``vertices``, ``faces``, ``parents``, ``new_vertex_corners`` /
    ``new_vertex_weights`` (as for `split_faces_1to3`), ``refined_faces`` (requested plus
    closure), ``bisected_faces`` and ``split_edges`` (k×2; new vertex n + i is the midpoint of
    split_edges[i]). Raises ValueError on a bad mesh or faces out of range.
    """
    return _core.refine_faces_1to4(V, F, np.asarray(faces, dtype=np.int64).reshape(-1))
