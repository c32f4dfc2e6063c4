"""Procedural triangle meshes used by the scenes and the tests.

Every function returns ``(V, F)``: ``V`` is an n×3 C-contiguous float64 array of vertex
positions in metres and ``F`` an f×3 C-contiguous int32 array of vertex indices, one row per
triangle. Quads are split into two triangles with alternating (checkerboard) diagonals so the
triangulation has no preferred shear direction, which would otherwise show up as anisotropic
stiffness in a mass-spring cloth.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .limits import LIMITS
from . import _core
from .checks import check_factor, check_integer
from .pattern_lattice import lattice_pattern_mesh

__all__ = [
    "grid_mesh",
    "cylinder_mesh",
    "cylinder_ring",
    "pattern_mesh",
    "MAX_MESH_VERTICES",
    "PATTERN_MIN_ANGLE",
]

#: The smallest angle pattern_mesh asks for unless told, degrees: well inside what CGAL's
#: mesher reaches (it proves termination to 20.7° and in practice goes to 30°, the ceiling here).
PATTERN_MIN_ANGLE = 25.0

#: Most vertices a generated mesh may have (e.g. 1000×1000), checked before anything is
#: allocated: a cloth of a million vertices already needs some GB for its springs and factor.
MAX_MESH_VERTICES = LIMITS.max_mesh_vertices
#: Largest |u| or |v| of a pattern point, m (the core's kPatternMaxCoordinate).
MAX_PATTERN_COORDINATE = LIMITS.max_pattern_coordinate


def _check_vertex_count(count: int, what: str, argument=None) -> None:
    """ValueError past MAX_MESH_VERTICES (an `yore.ArgumentError` naming ``argument`` if
    given)."""
    if count > MAX_MESH_VERTICES:
        message = f"{what} gives {count} vertices, more than the limit of {MAX_MESH_VERTICES}"
        raise ValueError(message) if argument is None else _invalid(message, argument)


def _size(value, name):
    """A mesh's width or height, m: finite, > 0 and at most `MAX_PATTERN_COORDINATE` (a 1e150 m
    grid was refused only later, as "degenerate", naming no key); an ArgumentError naming it."""
    try:
        size = check_factor(value, name, "m")
    except ValueError as error:
        raise _invalid(str(error), name) from None
    if size > MAX_PATTERN_COORDINATE:
        raise _invalid(f"{name} must be at most {MAX_PATTERN_COORDINATE:g} m, got {size:g}", name)
    return size


def _invalid(message, argument):
    """A `yore.ArgumentError` (a ValueError) naming ``argument``."""
    error = _core.ArgumentError(message)
    error.argument = argument
    return error


def _split_quads(a, b, c, d, even) -> np.ndarray:
    """Triangulate quads (a, b, c, d), given counter-clockwise, into an f×3 int32 array.

    Quad k becomes triangles 2k and 2k+1. Where ``even`` holds the diagonal is a–c, otherwise
    b–d; both triangles keep the quad's winding.
    """
    first = np.where(even[:, None], np.stack([a, b, c], axis=1), np.stack([a, b, d], axis=1))
    second = np.where(even[:, None], np.stack([a, c, d], axis=1), np.stack([b, c, d], axis=1))
    faces = np.stack([first, second], axis=1).reshape(-1, 3)
    return np.ascontiguousarray(faces, dtype=np.int32)


def grid_mesh(nx, ny, width=1.0, height=1.0):
    """Flat triangulated rectangle in the z = 0 plane.

    Parameters
    ----------
    nx, ny : int
        Number of vertices along x and along y, each >= 2.
    width, height : float
        Size of the rectangle along x and y in metres, finite and > 0. The rectangle covers
        x in [0, width], y in [0, height].

    Returns
    -------
    V : (nx*ny, 3) float64 array, metres
        Vertex (i, j) has index ``j*nx + i`` and position
        ``(i*width/(nx-1), j*height/(ny-1), 0)``.
    F : (2*(nx-1)*(ny-1), 3) int32 array
        Triangles, counter-clockwise seen from +z (normals point to +z). Quad (i, j) is split
        along the diagonal (i, j)–(i+1, j+1) when i+j is even and along (i+1, j)–(i, j+1)
        otherwise; its two triangles are rows ``2*q`` and ``2*q+1`` with ``q = j*(nx-1) + i``.

    Raises
    ------
    ValueError
        If nx or ny is not an integer >= 2, nx·ny is more than `MAX_MESH_VERTICES`, or width
        or height is not finite and > 0.
    """
    nx = check_integer(nx, "nx", 2)
    ny = check_integer(ny, "ny", 2)
    width = _size(width, "width")
    height = _size(height, "height")
    _check_vertex_count(nx * ny, f"nx × ny = {nx} × {ny}")

    # linspace pins the last coordinate to exactly width/height.
    x, y = np.meshgrid(np.linspace(0.0, width, nx), np.linspace(0.0, height, ny), indexing="xy")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(nx * ny)], axis=1)

    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="xy")
    i, j = i.ravel(), j.ravel()
    a = j * nx + i
    b = a + 1
    c = a + nx + 1
    d = a + nx
    F = _split_quads(a, b, c, d, (i + j) % 2 == 0)
    return np.ascontiguousarray(V, dtype=np.float64), F


def cylinder_mesh(radius, height, rings, segments):
    """Open triangulated tube (no caps) whose axis is the y axis.

    Parameters
    ----------
    radius : float
        Distance of every vertex from the y axis in metres, finite and > 0.
    height : float
        Length of the tube along y in metres, finite and > 0; it spans y in [0, height].
    rings : int
        Number of vertex rings, >= 2. Ring r lies at ``y = r*height/(rings-1)``: ring 0 is the
        bottom rim, ring ``rings-1`` the top rim.
    segments : int
        Number of vertices per ring, >= 3. Vertex s of a ring is at angle
        ``theta = 2*pi*s/segments`` with ``x = radius*cos(theta)``, ``z = radius*sin(theta)``.

    Returns
    -------
    V : (rings*segments, 3) float64 array, metres
        Vertex s of ring r has index ``r*segments + s``.
    F : (2*segments*(rings-1), 3) int32 array
        Triangles with outward normals (pointing away from the axis). The quad between
        segments s, s+1 (wrapping around the seam) and rings r, r+1 is split with the same
        checkerboard of diagonals as :func:`grid_mesh`, using parity of s+r; with an odd
        number of segments two neighbouring quads at the seam share a diagonal direction.

    Raises
    ------
    ValueError
        If radius or height is not finite and > 0, rings is not an integer >= 2, segments
        is not an integer >= 3, or rings·segments is more than `MAX_MESH_VERTICES`.
    """
    radius = _size(radius, "radius")
    height = _size(height, "height")
    rings = check_integer(rings, "rings", 2)
    segments = check_integer(segments, "segments", 3)
    _check_vertex_count(rings * segments, f"rings × segments = {rings} × {segments}")

    theta = 2.0 * np.pi * np.arange(segments) / segments
    y = np.linspace(0.0, height, rings)
    V = np.empty((rings, segments, 3), dtype=np.float64)
    V[:, :, 0] = radius * np.cos(theta)[None, :]
    V[:, :, 1] = y[:, None]
    V[:, :, 2] = radius * np.sin(theta)[None, :]
    V = V.reshape(-1, 3)

    s, r = np.meshgrid(np.arange(segments), np.arange(rings - 1), indexing="xy")
    s, r = s.ravel(), r.ravel()
    s_next = (s + 1) % segments
    a = r * segments + s
    b = r * segments + s_next
    c = (r + 1) * segments + s_next
    d = (r + 1) * segments + s
    # (a, b, c, d) is counter-clockwise in the (theta, y) parameter plane, which on the tube
    # faces the axis; reversing the winding makes the normals point outward.
    F = _split_quads(a, b, c, d, (s + r) % 2 == 0)[:, [0, 2, 1]]
    return np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int32)


def cylinder_ring(rings, segments, which):
    """Vertex indices of one ring of a :func:`cylinder_mesh` with the same rings and segments.

    Parameters
    ----------
    rings, segments : int
        As given to :func:`cylinder_mesh` (rings >= 2, segments >= 3).
    which : int
        Ring number, counted from the bottom (0) like a Python index: negative values count
        from the top, so -1 is the top rim at y = height.

    Returns
    -------
    (segments,) int32 array
        Indices ``which*segments + s`` for s = 0 .. segments-1, in order of increasing angle.

    Raises
    ------
    ValueError
        If rings or segments is invalid, or which is not an integer in [-rings, rings).
    """
    rings = check_integer(rings, "rings", 2)
    segments = check_integer(segments, "segments", 3)
    if not isinstance(which, numbers.Integral) or isinstance(which, bool):
        raise ValueError(f"which must be an integer ring number, got {which!r}")
    if not -rings <= which < rings:
        raise ValueError(f"which must be in [-{rings}, {rings}) for {rings} rings, got {which!r}")
    ring = int(which) % rings
    return np.arange(ring * segments, (ring + 1) * segments, dtype=np.int32)


def _polygon(points, name):
    argument = "holes" if name.startswith("hole") else "outline"
    try:
        array = np.array(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise _invalid(
            f"{name} must be a list of [u, v] points (m), got {type(points).__name__}", argument
        ) from None
    if array.ndim != 2 or array.shape[1] != 2:
        raise _invalid(
            f"{name} must have shape (m, 2): [u, v] points (m), got shape {array.shape}", argument
        )
    return np.ascontiguousarray(array)


def _check_pattern_size(outline, edge_length):
    """Refuses an edge_length that needs more than MAX_MESH_VERTICES vertices on `outline`."""
    # The core refuses non-finite points and points past its coordinate bound; the estimate
    # below runs only on points it would accept, and in ratios that cannot overflow.
    # No triangle with edges at most edge_length is larger than the equilateral one, and a
    # mesh has about two faces per vertex: fewer vertices than this cannot cover the outline.
    if np.isfinite(outline).all() and np.abs(outline).max() <= MAX_PATTERN_COORDINATE:
        u, v = outline[:, 0], outline[:, 1]
        area = 0.5 * abs(float(np.dot(u, np.roll(v, -1)) - np.dot(v, np.roll(u, -1))))
        ratio = math.sqrt(area) / edge_length  # inf (no exception) for a subnormal edge_length
        if ratio > math.sqrt(MAX_MESH_VERTICES):
            raise _invalid(
                f"edge_length {edge_length:g} m on an outline of {area:g} m² gives "
                f"more than the limit of {MAX_MESH_VERTICES} vertices; use a larger "
                "edge_length",
                "edge_length",
            )
        least = ratio * ratio / (math.sqrt(3.0) / 4.0) / 2.0
        _check_vertex_count(
            int(least), f"edge_length {edge_length:g} m on an outline of {area:g} m²", "edge_length"
        )


# over 60 lines: a docstring for the pattern mesher and its 5 parameters (the code is 31 lines)
def pattern_mesh(
    outline, holes=(), edge_length=0.05, min_angle=PATTERN_MIN_ANGLE, interior="lattice"
):
    """Triangle mesh of a flat pattern: the region inside ``outline`` and outside every hole,
    every edge at most ``edge_length`` long and every angle at least ``min_angle`` degrees.

    By default (``interior="lattice"``) the inside is an equilateral lattice of side
    0.7 × ``edge_length`` with rows along u (the grain), and a strip along the pattern's edges
    (0.75–1.6 sides wide) is meshed by CGAL's 2-D constrained Delaunay mesher. A membrane's
    faces read a wrinkle along the rows exactly, and every lattice vertex's star is
    point-symmetric, so its smoothed strain has no interpolation bending there in any direction
    (issue 52; docs/limitations.md). ``interior="delaunay"``
    meshes the whole pattern with CGAL: isotropic triangles with no preferred directions, whose
    interpolation adds a bending modulus of ~0.0007 h² × the tension to the smoothed membrane
    (~0.018 h² to constant-strain faces). A pattern too small for one lattice triangle away
    from its edges is meshed by CGAL alone.

    Parameters
    ----------
    outline : (m, 2) array-like
        The pattern's boundary, [u, v] points in metres, a simple polygon of at least 3 points
        (either orientation; a last point equal to the first is dropped).
    holes : sequence of (k, 2) array-likes
        Holes, each a simple polygon strictly inside the outline and apart from the others.
    edge_length : float
        Longest edge, m (the mean edge comes out at about 0.6–0.7 of it).
    min_angle : float
        Smallest angle, degrees, in (0, 30].
    interior : {"lattice", "delaunay"}
        The inside's triangles: an equilateral lattice, or CGAL's.

    Returns
    -------
    V : (n, 3) float64
        Vertices in the z = 0 plane: (u, v, 0); ``V[:, :2]`` are the material coordinates.
    F : (f, 3) int32
        Faces, counter-clockwise about +z.

    Raises
    ------
    ValueError
        On a polygon with too few points, a non-finite point, zero area or a self-intersection;
        a hole that leaves the outline or overlaps another; a bad edge_length or min_angle; or
        a mesh of more than `MAX_MESH_VERTICES` vertices; an unknown interior.
    """
    if interior not in ("lattice", "delaunay"):
        raise _invalid(f'interior must be "lattice" or "delaunay", got {interior!r}', "interior")
    outline = _polygon(outline, "outline")
    if isinstance(holes, np.ndarray) and holes.ndim == 2:
        raise _invalid(
            "holes must be a list of polygons, got one (k, 2) array: wrap it in a list", "holes"
        )
    holes = [_polygon(hole, f"hole {k}") for k, hole in enumerate(holes)]
    try:
        edge_length = check_factor(edge_length, "edge_length", "m")
    except ValueError as error:
        raise _invalid(str(error), "edge_length") from None
    if isinstance(min_angle, (bool, np.bool_)) or not isinstance(min_angle, numbers.Real):
        raise _invalid(f"min_angle must be a number of degrees, got {min_angle!r}", "min_angle")
    _check_pattern_size(outline, edge_length)
    lattice = None
    if interior == "lattice":
        # the core checks the polygons and the angle (and names them): here on the outline
        # alone, with no size bound
        _core.pattern_mesh(outline, holes, 1e308, float(min_angle), MAX_MESH_VERTICES)
        lattice = lattice_pattern_mesh(
            outline, holes, edge_length, float(min_angle), MAX_MESH_VERTICES
        )
    if lattice is None:
        points, faces, _ = _core.pattern_mesh(
            outline, holes, edge_length, float(min_angle), MAX_MESH_VERTICES
        )
    else:
        points, faces = lattice
    V = np.column_stack([points, np.zeros(len(points))])
    return np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int32)
