"""The lattice interior of `pattern_mesh` (issue 52).

A wrinkle's piecewise-linear interpolant on a triangle that is not aligned with it has a spurious
slope across the wrinkle; a membrane under tension charges that slope like bending, and on
CGAL's isotropic meshes that artificial modulus (∝ h² × the tension) set the wavelength. Around a
vertex whose star is point-symmetric the slopes' first-order errors cancel exactly, so the
membrane's smoothed strain (the area-weighted mean of a vertex's face gradients) has no such
term in any direction. An equilateral lattice has such stars everywhere; this module lays one
over the pattern, keeps its triangles that lie at least `margin` inside the pattern, and leaves
the strip between them and the pattern's edges to CGAL's constrained Delaunay mesher (which
may not split an edge of the lattice: where it does, the lattice gives up the triangle and the
strip is meshed again)."""

from __future__ import annotations

import math

import numpy as np

from . import _core

#: The lattice's side over the mesh's longest edge: its vertex density is then that of CGAL's
#: meshes at the same bound (measured: ~2.5 vertices per edge_length², the lattice 2.36).
LATTICE_SIDE = 0.7
#: A kept lattice vertex is at least this many sides from the pattern's edges: the strip CGAL
#: meshes is then 0.75–1.6 sides wide, room for triangles of its angle bound.
LATTICE_MARGIN = 0.75
#: Rounds of giving up triangles whose edges CGAL split before the lattice is abandoned.
LATTICE_ROUNDS = 8


def _rows(outline, side):
    """The lattice rows over the outline's bounding box: per row its v and first u."""
    lo, hi = outline.min(axis=0), outline.max(axis=0)
    pitch = side * math.sqrt(3.0) / 2.0
    count_v = int(math.floor((hi[1] - lo[1]) / pitch)) + 1
    count_u = int(math.floor((hi[0] - lo[0]) / side)) + 2
    v = lo[1] + pitch * np.arange(count_v)
    u0 = lo[0] + 0.5 * side * (np.arange(count_v) % 2)
    return v, u0, count_u


def _segments(polygons):
    return np.concatenate([np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in polygons])


def _usable(segments, v, u0, count_u, side, margin):
    """Which lattice points lie inside the pattern (outline minus holes: crossing parity over
    every polygon's edges) and at least `margin` from every edge."""
    u = u0[:, None] + side * np.arange(count_u)[None, :]
    a, b = segments[:, 0], segments[:, 1]
    inside = np.zeros(u.shape, dtype=bool)
    for row, height in enumerate(v):
        crosses = (a[:, 1] <= height) != (b[:, 1] <= height)
        t = (height - a[crosses, 1]) / (b[crosses, 1] - a[crosses, 1])
        at = np.sort(a[crosses, 0] + t * (b[crosses, 0] - a[crosses, 0]))
        inside[row] = np.searchsorted(at, u[row], side="right") % 2 == 1
    pitch = side * math.sqrt(3.0) / 2.0
    for p, q in zip(a, b):
        rows = np.arange(
            max(0, int(math.floor((min(p[1], q[1]) - margin - v[0]) / pitch))),
            min(len(v), int(math.ceil((max(p[1], q[1]) + margin - v[0]) / pitch)) + 1),
        )
        if len(rows) == 0:
            continue
        cu = u[rows]
        point = np.stack([cu, np.broadcast_to(v[rows, None], cu.shape)], axis=-1)
        d = q - p
        t = np.clip(((point - p) @ d) / max(float(d @ d), 1e-300), 0.0, 1.0)
        near = np.linalg.norm(point - (p + t[..., None] * d), axis=-1) < margin
        inside[rows] &= ~near
    return inside, u


def _triangles(inside, u0, side):
    """The lattice triangles with three usable corners, counter-clockwise, as (row, column)
    flat indices into the (rows × columns) point array."""
    rows, cols = inside.shape
    index = np.arange(rows * cols).reshape(rows, cols)
    out = []
    for r in range(rows - 1):
        lower, upper = index[r], index[r + 1]
        if u0[r + 1] > u0[r]:  # the upper row sits half a side to the right
            up = np.stack([lower[:-1], lower[1:], upper[:-1]], axis=1)
            down = np.stack([upper[:-1], lower[1:], upper[1:]], axis=1)
        else:
            up = np.stack([lower[:-1], lower[1:], upper[1:]], axis=1)
            down = np.stack([lower[:-1], upper[1:], upper[:-1]], axis=1)
        out += [up, down]
    if not out:
        return np.zeros((0, 3), dtype=np.int64)
    tri = np.concatenate(out)
    flat = inside.ravel()
    return tri[flat[tri].all(axis=1)]


def _boundary(tri):
    """Directed boundary edges (an edge whose reverse no kept triangle has) of the kept set,
    (m, 2)."""
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    scale = int(tri.max()) + 1 if len(tri) else 1
    keys = np.sort(directed[:, 0] * scale + directed[:, 1])
    reverse = directed[:, 1] * scale + directed[:, 0]
    at = np.minimum(np.searchsorted(keys, reverse), len(keys) - 1)
    return directed[keys[at] != reverse]


def _drop_pinches(tri):
    """Drops the triangles at vertices where the kept region touches itself at a point (two
    boundary edges leave the vertex), until none is left: the region's boundary is then simple
    loops."""
    while len(tri):
        starts = _boundary(tri)[:, 0]
        if len(starts) == 0:
            return tri
        counts = np.bincount(starts)
        pinched = np.flatnonzero(counts > 1)
        if len(pinched) == 0:
            return tri
        tri = tri[~np.isin(tri, pinched).any(axis=1)]
    return tri


def _loops(tri):
    """The kept region's boundary as closed loops of point indices."""
    following = dict(_boundary(tri).tolist())
    loops, seen = [], set()
    for start in following:
        if start in seen:
            continue
        loop, p = [], start
        while p not in seen:
            seen.add(p)
            loop.append(p)
            p = following[p]
        loops.append(loop)
    return loops


def _signed_area(polygon):
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _contains(polygon, point):
    a, b = polygon, np.roll(polygon, -1, axis=0)
    crosses = (a[:, 1] <= point[1]) != (b[:, 1] <= point[1])
    t = (point[1] - a[crosses, 1]) / (b[crosses, 1] - a[crosses, 1])
    return (
        int(np.count_nonzero(a[crosses, 0] + t * (b[crosses, 0] - a[crosses, 0]) > point[0])) % 2
        == 1
    )


def _strips(outline, holes, tri, points):
    """The regions between the kept lattice and the pattern's edges, each an (outline, holes)
    for CGAL: the pattern's outline around the kept region's outer loops (and the holes the
    lattice does not surround), and each inner loop of the kept region around the holes in it."""
    outer, inner = [], []
    for loop in _loops(tri):
        polygon = points[loop]
        (outer if _signed_area(polygon) > 0 else inner).append(polygon)
    regions = [(outline, [])] + [(polygon, []) for polygon in inner]
    for hole in outer + list(holes):
        # the innermost region around it: the inner loops lie inside the outline
        home = 0
        for k in range(1, len(regions)):
            if _contains(regions[k][0], hole[0]):
                home = k
        regions[home][1].append(hole)
    return regions


def lattice_pattern_mesh(outline, holes, edge_length, min_angle, max_vertices):
    """(points (n, 2), faces (f, 3)) of the pattern with a lattice interior, or None when no
    lattice triangle fits (the caller meshes it with CGAL alone)."""
    side = LATTICE_SIDE * edge_length
    extent = outline.max(axis=0) - outline.min(axis=0)
    if not side < 0.5 * extent.min():
        return None  # no lattice triangle fits 0.75 sides inside the outline
    area = abs(_signed_area(outline))
    if area / (side * side * math.sqrt(3.0) / 2.0) > max_vertices:
        return None  # more lattice points than the limit: CGAL's count check names it
    v, u0, count_u = _rows(outline, side)
    inside, u = _usable(
        _segments([outline] + list(holes)), v, u0, count_u, side, LATTICE_MARGIN * side
    )
    lattice = np.stack([u, np.broadcast_to(v[:, None], u.shape)], axis=-1).reshape(-1, 2)
    tri = _drop_pinches(_triangles(inside, u0, side))
    for _ in range(LATTICE_ROUNDS):
        if len(tri) == 0:
            return None
        pieces = []
        try:
            for region, inner in _strips(outline, holes, tri, lattice):
                points, faces, _ = _core.pattern_mesh(
                    region, inner, edge_length, min_angle, max_vertices
                )
                pieces.append((points, faces))
        except _core.ArgumentError:
            return None  # a strip CGAL refuses (the pattern itself passed): CGAL throughout
        boundary = _boundary(tri)
        split = _split_edges(boundary, lattice, pieces)
        if not split:
            return _merge(lattice, tri, pieces, max_vertices)
        tri = _drop_pinches(tri[~np.isin(tri, list(split)).any(axis=1)])
    return None


def _split_edges(boundary, lattice, pieces):
    """The lattice points at the ends of boundary edges on which CGAL put a point of its own."""
    points = np.concatenate([p for p, _ in pieces])
    split = set()
    for p, q in boundary.tolist():
        a, b = lattice[p], lattice[q]
        d = b - a
        t = (points - a) @ d / float(d @ d)
        off = np.abs((points[:, 0] - a[0]) * d[1] - (points[:, 1] - a[1]) * d[0])
        on = (t > 1e-9) & (t < 1 - 1e-9) & (off < 1e-9 * float(d @ d))
        if on.any():
            split.update((p, q))
    return split


def _merge(lattice, tri, pieces, max_vertices):
    """One mesh of the kept lattice and the strips, their shared points merged: the strips meet
    the lattice at its boundary points, whose coordinates CGAL keeps exactly."""
    used = np.unique(tri)
    coordinates = [lattice[used]]
    faces = [np.searchsorted(used, tri)]
    rim = np.unique(_boundary(tri))
    index = {
        tuple(point): int(k) for point, k in zip(lattice[rim].tolist(), np.searchsorted(used, rim))
    }
    count = len(used)
    for points, piece in pieces:
        remap = np.empty(len(points), dtype=np.int64)
        fresh = []
        for k, point in enumerate(points.tolist()):
            key = tuple(point)
            if key not in index:
                index[key] = count
                count += 1
                fresh.append(point)
            remap[k] = index[key]
        if fresh:
            coordinates.append(np.asarray(fresh, dtype=np.float64))
        faces.append(remap[piece])
    if count > max_vertices:
        return None
    return np.concatenate(coordinates), np.concatenate(faces).astype(np.int32)
