"""Measurements of a cloth's surface and of a stroke's region.

Positions are n×3 arrays in metres, faces f×3 vertex indices; a "region" is a list of face
indices (a stroke report's ``region_faces``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "face_areas",
    "area",
    "rest_area",
    "area_gain",
    "wrinkle_amplitude",
    "wrinkle_measure",
    "taubin_smooth",
    "roughness",
    "rest_ratio_roughness",
    "spike_index",
    "radial_distance",
    "radius_profile",
    "stroke_effect",
]


def face_areas(V, F) -> np.ndarray:
    """Area of every face, m² (f,)."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)


def area(V, F, faces=None) -> float:
    """Current area of the given faces (all by default), m²."""
    areas = face_areas(V, F)
    return float(areas.sum() if faces is None else areas[np.asarray(faces)].sum())


def _structural_rest_lookup(cloth):
    ends = np.sort(cloth.springs.ends[cloth.springs.kind == 0], axis=1).astype(np.int64)
    keys = ends[:, 0] * (1 << 32) + ends[:, 1]
    order = np.argsort(keys)
    return keys[order], cloth.springs.rest[cloth.springs.kind == 0][order]


def rest_area(cloth, faces=None) -> float:
    """Rest area of faces (all by default), m²: Heron's formula on the rest lengths of each
    face's three structural springs (0 for a face whose rest lengths violate the triangle
    inequality)."""
    F = cloth.faces if faces is None else cloth.faces[np.asarray(faces)]
    keys, rest = _structural_rest_lookup(cloth)
    sides = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        pair = np.sort(F[:, [a, b]], axis=1).astype(np.int64)
        sides.append(rest[np.searchsorted(keys, pair[:, 0] * (1 << 32) + pair[:, 1])])
    s = 0.5 * (sides[0] + sides[1] + sides[2])
    product = s * (s - sides[0]) * (s - sides[1]) * (s - sides[2])
    return float(np.sqrt(np.clip(product, 0.0, None)).sum())


def area_gain(V, F, region_faces, area_before) -> float:
    """Current area of a stroke's region over its area before the stroke (1 = no gain)."""
    return area(V, F, region_faces) / float(area_before)


def wrinkle_amplitude(V, F, faces) -> float:
    """Out-of-plane amplitude of a region, m: RMS distance of its vertices from their
    least-squares plane. On a curved region this includes the surface's own curvature, so
    compare a region before and after, or against a flat reference."""
    V = np.asarray(V, dtype=float)
    vertices = np.unique(np.asarray(F)[np.asarray(faces)])
    points = V[vertices] - V[vertices].mean(axis=0)
    if len(points) < 4:
        return 0.0
    normal = np.linalg.svd(points, full_matrices=False)[2][-1]
    return float(np.sqrt(np.mean((points @ normal) ** 2)))


def _umbrella_neighbours(F, n):
    """Edges (e×2, each once) of faces F, the boundary flag of every vertex, and the pairs
    (vertex, neighbour) Taubin smoothing averages over: all edges at an interior vertex, only
    the boundary edges at a boundary vertex (so a boundary is smoothed along itself)."""
    all_edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    edges, uses = np.unique(all_edges, axis=0, return_counts=True)
    boundary_edges = edges[uses == 1]
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[boundary_edges.ravel()] = True
    pairs = np.concatenate([edges, edges[:, ::-1]])
    keep = ~on_boundary[pairs[:, 0]]
    boundary_pairs = np.concatenate([boundary_edges, boundary_edges[:, ::-1]])
    pairs = np.concatenate([pairs[keep], boundary_pairs])
    return pairs, on_boundary


def taubin_smooth(V, F, iterations=10, lam=0.5, mu=-0.53) -> np.ndarray:
    """Taubin λ/μ smoothing (Taubin 1995) of a triangle mesh, uniform (umbrella) weights: each
    iteration moves every vertex by λ, then by μ (< −λ), times the mean of its neighbours
    minus itself. The pair is a low-pass filter with pass-band frequency 1/λ + 1/μ (0.11 of
    the umbrella operator's range here): wrinkles a few edges long are removed, the shape
    (a plane, a cylinder's curvature) kept without Laplacian smoothing's shrinkage. Boundary
    vertices are smoothed along the boundary only (their boundary-edge neighbours), so a
    straight border stays straight and a circular one stays a circle. V n×3 (m), F f×3;
    returns n×3 (m)."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    n = len(V)
    pairs, _ = _umbrella_neighbours(F, n)
    counts = np.maximum(np.bincount(pairs[:, 0], minlength=n), 1).astype(float)
    X = V.copy()
    for _ in range(int(iterations)):
        for factor in (lam, mu):
            mean = np.zeros((n, 3))
            for c in range(3):
                mean[:, c] = np.bincount(pairs[:, 0], X[pairs[:, 1], c], n)
            X = X + factor * (mean / counts[:, None] - X)
    return X


def vertex_normals(V, F) -> np.ndarray:
    """Unit vertex normals, n×3: area-weighted means of the face normals (0 where no face)."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    face_normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    normals = np.zeros((len(V), 3))
    for c in range(3):
        np.add.at(normals, F[:, c], face_normals)
    length = np.linalg.norm(normals, axis=1)
    return normals / np.where(length > 0.0, length, 1.0)[:, None]


def smoothing_iterations(V, F, length) -> int:
    """Taubin iterations whose filter reaches about `length` (m) on the mesh (V, F): 10 reach
    about 6 mean edges h (a ripple of 8 edges is kept at 0.96, one of 4 removed to 0.56) and the
    reach grows as h √iterations, so 10 (length / 6h)², at least 1. With it a wrinkle measure
    sees the same wrinkles, those shorter than about `length`, on coarse and fine meshes."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    length = float(length)
    if not (math.isfinite(length) and length > 0.0):
        raise ValueError(f"length must be finite and > 0 (m), got {length}")
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    h = float(np.linalg.norm(V[edges[:, 1]] - V[edges[:, 0]], axis=1).mean())
    return max(1, int(round(10.0 * (length / (6.0 * h)) ** 2)))


def wrinkle_measure(V, F, region=None, iterations=10, lam=0.5, mu=-0.53) -> float:
    """Wrinkle size, m: RMS over the region's vertices of the normal component of (vertex −
    Taubin-smoothed surface). The smoothed surface (`taubin_smooth` of the whole mesh, with
    ``iterations``, ``lam``, ``mu``) keeps the cloth's large-scale shape and drops its
    wrinkles; the normal is the smoothed surface's vertex normal. Zero on a plane; on a
    cylinder ≈ 9e-3 × its radius at 24 segments, 2.5e-3 at 48 (discretisation: the
    filter's pass band is not flat, the error falls ~1/segments²); linear in the amplitude of
    a ripple z = A sin(2πx/λ) on a flat grid: 0.442 A at λ = 4 edges, 0.129 A at 6, 0.037 A at
    8 (iterations = 10; more iterations reach longer wrinkles, 50 give 0.69, 0.43, 0.15 A, at
    the cost of a 4× larger cylinder value). Invariant to rigid motions.

    V n×3 (m), F f×3 vertex indices; region: face indices (a stroke report's
    ``region_faces``; their vertices are measured) or None for every vertex."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    vertices = np.unique(F) if region is None else np.unique(F[np.asarray(region, dtype=np.int64)])
    if vertices.size == 0:
        return 0.0
    height = wrinkle_height(V, F, iterations, lam, mu)[vertices]
    return float(np.sqrt(np.mean(height**2)))


def wrinkle_height(V, F, iterations=10, lam=0.5, mu=-0.53) -> np.ndarray:
    """Per-vertex signed wrinkle height, m: the normal component of (vertex − Taubin-smoothed
    surface), what `wrinkle_measure` takes the RMS of (and what pictures colour by with
    ``color_by="wrinkles"``). Vertices on no face get 0."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    smooth = taubin_smooth(V, F, iterations, lam, mu)
    normals = vertex_normals(smooth, F)
    return np.einsum("ij,ij->i", V - smooth, normals)


def spike_index(V, F, vertices=None) -> float:
    """How spiky a set of vertices is, dimensionless: RMS over ``vertices`` of each one's
    distance from the least-squares plane of its one-ring (its edge neighbours, itself left
    out), over the mean length of the edges at those vertices. A plane gives 0; a smooth
    surface of curvature radius R about h/(2R) at edge length h (a vertex sits h²/(2R) off
    its ring's plane); a tent — a vertex lifted out of its ring by t times its edge length —
    gives ≈ t. The paper's 1→3 split with expansion 1.1 on a flat face makes a tent of height
    √(1.1² − 1) ≈ 0.46 of the distance to the corners: 0.42 for that vertex.

    V n×3 (m), F f×3 vertex indices, vertices: indices (a stroke report's new vertices) or
    None for all. Vertices with fewer than three neighbours (no plane) are left out; a
    ValueError if none is left."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    n = len(V)
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0
    )
    pairs = np.concatenate([edges, edges[:, ::-1]])
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
    starts = np.searchsorted(pairs[:, 0], np.arange(n + 1))
    chosen = np.arange(n) if vertices is None else np.unique(np.asarray(vertices, dtype=np.int64))
    if chosen.size and (chosen.min() < 0 or chosen.max() >= n):
        raise ValueError(f"vertices must be in [0, {n}), got {chosen.min()}..{chosen.max()}")
    distances, lengths = [], []
    for v in chosen:
        ring = pairs[starts[v] : starts[v + 1], 1]
        if len(ring) < 3:
            continue
        points = V[ring]
        centre = points.mean(axis=0)
        normal = np.linalg.svd(points - centre, full_matrices=False)[2][-1]
        distances.append(abs(float((V[v] - centre) @ normal)))
        lengths.extend(np.linalg.norm(points - V[v], axis=1))
    if not distances:
        raise ValueError("spike_index needs at least one vertex with three or more neighbours")
    mean_length = float(np.mean(lengths))
    if mean_length == 0.0:
        return 0.0
    return float(np.sqrt(np.mean(np.square(distances)))) / mean_length


def radial_distance(V, center=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0)) -> np.ndarray:
    """(n,) distance of every vertex from the line through ``center`` along ``axis``, m (a
    tube's local radius; the rotating cylinder's axis is y through the origin)."""
    V = np.asarray(V, dtype=float)
    axis = np.asarray(axis, dtype=float)
    length = np.linalg.norm(axis)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V must have shape (n, 3), got {V.shape}")
    if axis.shape != (3,) or not np.isfinite(length) or length == 0.0:
        raise ValueError(f"axis must be a non-zero 3-vector, got {axis!r}")
    axis = axis / length
    offset = V - np.asarray(center, dtype=float)
    return np.linalg.norm(offset - np.outer(offset @ axis, axis), axis=1)


def radius_profile(V, center=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0), bins=16, vertices=None):
    """A tube's radius along its axis: (heights (bins,), radii (bins,)), the mean
    `radial_distance` of the vertices in each of ``bins`` equal slices of their extent along
    the axis (heights: the slice's vertices' mean position along the axis from ``center``,
    m; NaN for an empty slice). vertices: indices or None for all. A cylinder of radius r gives r in
    every slice; a skirt flaring at its hem, a larger radius in the lowest slices."""
    V = np.asarray(V, dtype=float)
    radius = radial_distance(V, center, axis)
    chosen = np.arange(len(V)) if vertices is None else np.asarray(vertices, dtype=np.int64)
    bins = int(bins)
    if bins < 1:
        raise ValueError(f"bins must be >= 1, got {bins}")
    if chosen.size == 0:
        raise ValueError("radius_profile needs at least one vertex")
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    height = (V[chosen] - np.asarray(center, dtype=float)) @ axis
    low, high = float(height.min()), float(height.max())
    edges = np.linspace(low, high, bins + 1) if high > low else np.array([low - 0.5, low + 0.5])
    if high <= low:
        bins = 1
    which = np.clip(np.searchsorted(edges, height, side="right") - 1, 0, bins - 1)
    counts = np.bincount(which, minlength=bins)
    sums = np.bincount(which, radius[chosen], minlength=bins)
    levels = np.bincount(which, height, minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        radii = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
        heights = np.where(counts > 0, levels / np.maximum(counts, 1), np.nan)
    return heights, radii


def roughness(V, F, vertices=None) -> float:
    """Surface roughness: RMS over vertices of the normal part of the umbrella Laplacian
    (mean of neighbours minus the vertex), divided by the mean edge length. 0 for a plane;
    a smooth curved surface gives a small value that falls with refinement; wrinkles and spikes
    give large ones. Boundary vertices are left out."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    n = len(V)
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0
    )
    sums = np.zeros((n, 3))
    counts = np.zeros(n)
    for a, b in ((0, 1), (1, 0)):
        np.add.at(sums, edges[:, a], V[edges[:, b]])
        np.add.at(counts, edges[:, a], 1)
    laplacian = sums / np.maximum(counts, 1)[:, None] - V
    face_normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    normals = np.zeros((n, 3))
    for c in range(3):
        np.add.at(normals, F[:, c], face_normals)
    normals /= np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]
    # boundary vertices: on an edge used by one face only
    all_edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    unique, uses = np.unique(all_edges, axis=0, return_counts=True)
    interior = np.ones(n, dtype=bool)
    interior[unique[uses == 1].ravel()] = False
    selected = (
        interior
        if vertices is None
        else np.intersect1d(np.flatnonzero(interior), np.asarray(vertices))
    )
    mean_edge = np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean()
    normal_part = np.einsum("ij,ij->i", laplacian[selected], normals[selected])
    return float(np.sqrt(np.mean(normal_part**2)) / mean_edge) if normal_part.size else 0.0


def rest_ratio_roughness(cloth, springs=None) -> float:
    """Roughness of the rest-length ratio field (rest / reference length) over the spring
    graph: RMS difference between each spring's ratio and the mean ratio around its two ends.
    Rest-length smoothing lowers it."""
    ratio = cloth.springs.rest / cloth.springs.reference
    neighbour = spring_mean_around_ends(cloth, ratio)
    difference = ratio - neighbour
    if springs is not None:
        difference = difference[np.asarray(springs)]
    return float(np.sqrt(np.mean(difference**2))) if difference.size else 0.0


def vertex_mean_of_springs(cloth, values) -> np.ndarray:
    """(n,) mean of per-spring ``values`` (s,) over the springs at each vertex (0 where none)."""
    ends = cloth.springs.ends
    n = cloth.vertex_count
    sums = np.bincount(ends[:, 0], values, n) + np.bincount(ends[:, 1], values, n)
    counts = np.bincount(ends[:, 0], None, n) + np.bincount(ends[:, 1], None, n)
    return sums / np.maximum(counts, 1)


def vertex_expansion(cloth) -> np.ndarray:
    """(n,) mean rest / reference length ratio of each vertex's springs: 1 where untouched,
    about the stroke's expansion around a stroke (what frames store and pictures colour)."""
    return vertex_mean_of_springs(cloth, cloth.springs.rest / cloth.springs.reference)


def spring_mean_around_ends(cloth, values):
    """For each spring, the mean of `values` over the springs at its two ends."""
    at_vertex = vertex_mean_of_springs(cloth, values)
    ends = cloth.springs.ends
    return 0.5 * (at_vertex[ends[:, 0]] + at_vertex[ends[:, 1]])


def stroke_effect(V, F, V_plain, F_plain, region_faces, vertices) -> dict:
    """What a stroke did, against the same run without it at the same time.

    V, F: the stroked cloth (its first ``len(V_plain)`` vertices are the original ones: strokes
    append); V_plain, F_plain: the run without the stroke; region_faces: the stroke's region in
    the stroked mesh (a report's ``region_faces``); vertices: where spikes would be (a report's
    ``new_vertices``, or its ``line_vertices`` when it added none).

    Returns {"wrinkle": the region's `wrinkle_measure` (m), "wrinkle_plain": the same in the
    plain run, "wrinkle_ratio", "spike_index": `spike_index` of ``vertices``,
    "spike_index_plain": of the region's original vertices in the plain run}. Both wrinkle
    values are taken on the original vertices with the plain mesh's faces, so one filter at one
    resolution measures both (refined or split faces would change what Taubin smoothing keeps,
    and new vertices are the spike index's business)."""
    V, F = np.asarray(V, dtype=float), np.asarray(F)
    V_plain, F_plain = np.asarray(V_plain, dtype=float), np.asarray(F_plain)
    n = len(V_plain)
    if len(V) < n or V.ndim != 2 or V_plain.ndim != 2:
        raise ValueError(f"the stroked cloth has {len(V)} vertices, fewer than the plain run's {n}")
    region = np.asarray(region_faces, dtype=np.int64)
    if region.size == 0:
        raise ValueError("stroke_effect needs the stroke's region faces, got none")
    original = np.unique(F[region])
    original = original[original < n]
    faces = np.flatnonzero(np.all(np.isin(F_plain, original), axis=1))
    if faces.size == 0:
        raise ValueError("the stroke's region holds no whole face of the plain mesh")
    wrinkle = wrinkle_measure(V[:n], F_plain, faces)
    plain = wrinkle_measure(V_plain, F_plain, faces)
    from .results import StrokeEffect

    return StrokeEffect(
        wrinkle=wrinkle,
        wrinkle_plain=plain,
        wrinkle_ratio=wrinkle / plain if plain > 0 else float("inf"),
        spike_index=spike_index(V, F, vertices),
        spike_index_plain=spike_index(V_plain, F_plain, original),
    )
