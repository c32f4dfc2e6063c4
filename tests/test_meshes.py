"""Invariants of the procedural meshes in yore.meshes (grid_mesh, cylinder_mesh, cylinder_ring)."""

import math
from collections import Counter

import numpy as np
import pytest

import yore
from yore.meshes import cylinder_ring


def face_cross(V, F):
    """Unnormalised face normals: (b - a) × (c - a), whose length is twice the area."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.cross(b - a, c - a)


def face_areas(V, F):
    return 0.5 * np.linalg.norm(face_cross(V, F), axis=1)


def directed_edges(F):
    return [(int(F[k, e]), int(F[k, (e + 1) % 3])) for k in range(len(F)) for e in range(3)]


def undirected_edge_counts(F):
    return Counter(tuple(sorted(edge)) for edge in directed_edges(F))


def check_common_invariants(V, F):
    """dtype/layout contract, manifold edges and consistent orientation."""
    assert V.dtype == np.float64 and V.flags.c_contiguous and V.shape[1] == 3
    assert F.dtype == np.int32 and F.flags.c_contiguous and F.shape[1] == 3
    assert F.min() >= 0 and F.max() < len(V)
    # Each face has three distinct corners.
    assert (F[:, 0] != F[:, 1]).all() and (F[:, 1] != F[:, 2]).all() and (F[:, 0] != F[:, 2]).all()
    # Every vertex is used by some face.
    assert set(np.unique(F).tolist()) == set(range(len(V)))
    counts = undirected_edge_counts(F)
    assert max(counts.values()) <= 2
    # Consistent winding: an interior edge is traversed once in each direction.
    directed = Counter(directed_edges(F))
    assert max(directed.values()) == 1
    return counts


GRID_CASES = [(2, 2, 1.0, 1.0), (3, 5, 1.0, 1.0), (7, 4, 2.5, 0.7), (6, 6, 0.1, 3.0)]
CYLINDER_CASES = [(0.5, 2.0, 2, 3), (1.3, 0.4, 5, 8), (0.2, 1.0, 4, 7), (2.0, 3.0, 3, 32)]


@pytest.mark.parametrize("nx, ny, width, height", GRID_CASES)
def test_grid_counts_and_positions(nx, ny, width, height):
    V, F = yore.grid_mesh(nx, ny, width=width, height=height)
    assert V.shape == (nx * ny, 3)
    assert F.shape == (2 * (nx - 1) * (ny - 1), 3)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    expected = np.stack(
        [i.ravel() * width / (nx - 1), j.ravel() * height / (ny - 1), 0 * i.ravel()], axis=1
    )
    np.testing.assert_allclose(V, expected, rtol=1e-14, atol=0)
    assert V[:, 0].min() == 0.0 and V[:, 0].max() == width
    assert V[:, 1].min() == 0.0 and V[:, 1].max() == height
    assert (V[:, 2] == 0.0).all()


@pytest.mark.parametrize("nx, ny, width, height", GRID_CASES)
def test_grid_area_and_orientation(nx, ny, width, height):
    V, F = yore.grid_mesh(nx, ny, width, height)
    areas = face_areas(V, F)
    assert (areas > 0).all()
    assert math.isclose(areas.sum(), width * height, rel_tol=1e-12)
    normals = face_cross(V, F)
    # Counter-clockwise seen from +z: normals point straight up.
    assert (normals[:, 2] > 0).all()
    assert (normals[:, :2] == 0).all()


@pytest.mark.parametrize("nx, ny, width, height", GRID_CASES)
def test_grid_topology(nx, ny, width, height):
    V, F = yore.grid_mesh(nx, ny, width, height)
    counts = check_common_invariants(V, F)
    boundary = [edge for edge, count in counts.items() if count == 1]
    assert len(boundary) == 2 * (nx - 1) + 2 * (ny - 1)
    # Boundary edges lie on the rectangle's border.
    for a, b in boundary:
        on_x = V[a, 0] == V[b, 0] and V[a, 0] in (0.0, width)
        on_y = V[a, 1] == V[b, 1] and V[a, 1] in (0.0, height)
        assert on_x or on_y
    assert len(V) - len(counts) + len(F) == 1  # Euler characteristic of a disk


def test_grid_diagonals_alternate():
    nx, ny = 5, 4
    V, F = yore.grid_mesh(nx, ny)
    edges = set(undirected_edge_counts(F))
    for j in range(ny - 1):
        for i in range(nx - 1):
            a, b = j * nx + i, j * nx + i + 1
            d, c = a + nx, b + nx
            rising, falling = (a, c), (b, d)
            if (i + j) % 2 == 0:
                assert rising in edges and falling not in edges
            else:
                assert falling in edges and rising not in edges
            # The quad's two triangles are rows 2q and 2q+1.
            q = j * (nx - 1) + i
            assert set(F[2 * q].tolist()) | set(F[2 * q + 1].tolist()) == {a, b, c, d}


@pytest.mark.parametrize("radius, height, rings, segments", CYLINDER_CASES)
def test_cylinder_counts_and_positions(radius, height, rings, segments):
    V, F = yore.cylinder_mesh(radius, height, rings, segments)
    assert V.shape == (rings * segments, 3)
    assert F.shape == (2 * segments * (rings - 1), 3)
    np.testing.assert_allclose(np.hypot(V[:, 0], V[:, 2]), radius, rtol=1e-12)
    r, s = np.divmod(np.arange(rings * segments), segments)
    np.testing.assert_allclose(V[:, 1], r * height / (rings - 1), rtol=1e-14, atol=0)
    theta = 2 * np.pi * s / segments
    np.testing.assert_allclose(V[:, 0], radius * np.cos(theta), rtol=0, atol=1e-14 * radius)
    np.testing.assert_allclose(V[:, 2], radius * np.sin(theta), rtol=0, atol=1e-14 * radius)


@pytest.mark.parametrize("radius, height, rings, segments", CYLINDER_CASES)
def test_cylinder_area_and_outward_normals(radius, height, rings, segments):
    V, F = yore.cylinder_mesh(radius, height, rings, segments)
    areas = face_areas(V, F)
    assert (areas > 0).all()
    # Each quad is a flat rectangle: chord 2 r sin(pi/segments) by the ring spacing.
    lateral = segments * 2 * radius * math.sin(math.pi / segments) * height
    assert math.isclose(areas.sum(), lateral, rel_tol=1e-12)
    centroids = V[F].mean(axis=1)
    radial = centroids * np.array([1.0, 0.0, 1.0])
    normals = face_cross(V, F)
    assert (np.einsum("ij,ij->i", normals, radial) > 0).all()
    # The tube's faces are parallel to its axis.
    np.testing.assert_allclose(normals[:, 1], 0, atol=1e-12 * radius * height)


@pytest.mark.parametrize("radius, height, rings, segments", CYLINDER_CASES)
def test_cylinder_topology(radius, height, rings, segments):
    V, F = yore.cylinder_mesh(radius, height, rings, segments)
    counts = check_common_invariants(V, F)
    boundary = [edge for edge, count in counts.items() if count == 1]
    assert len(boundary) == 2 * segments
    rims = {int(v) for which in (0, -1) for v in cylinder_ring(rings, segments, which)}
    assert all(a in rims and b in rims for a, b in boundary)
    assert len(V) - len(counts) + len(F) == 0  # Euler characteristic of an annulus


def test_cylinder_diagonals_alternate_across_seam():
    rings, segments = 3, 6
    V, F = yore.cylinder_mesh(1.0, 1.0, rings, segments)
    edges = set(undirected_edge_counts(F))
    for r in range(rings - 1):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            d, c = a + segments, b + segments
            rising, falling = tuple(sorted((a, c))), tuple(sorted((b, d)))
            if (r + s) % 2 == 0:
                assert rising in edges and falling not in edges
            else:
                assert falling in edges and rising not in edges


def test_cylinder_ring():
    radius, height, rings, segments = 0.7, 1.5, 4, 9
    V, _ = yore.cylinder_mesh(radius, height, rings, segments)
    top = cylinder_ring(rings, segments, -1)
    assert top.dtype == np.int32 and top.shape == (segments,)
    assert (V[top, 1] == height).all()
    np.testing.assert_array_equal(top, cylinder_ring(rings, segments, rings - 1))
    bottom = cylinder_ring(rings, segments, 0)
    assert (V[bottom, 1] == 0.0).all()
    np.testing.assert_array_equal(bottom, np.arange(segments))
    middle = cylinder_ring(rings, segments, -3)
    np.testing.assert_allclose(V[middle, 1], height / (rings - 1))
    # Increasing angle around the ring.
    angles = np.arctan2(V[middle, 2], V[middle, 0]) % (2 * np.pi)
    assert (np.diff(angles) > 0).all()
    for which in (rings, -rings - 1, 1.0, "top"):
        with pytest.raises(ValueError, match="which"):
            cylinder_ring(rings, segments, which)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(nx=1, ny=3), "nx"),
        (dict(nx=3, ny=0), "ny"),
        (dict(nx=3.0, ny=3), "nx"),
        (dict(nx=3, ny="4"), "ny"),
        (dict(nx=True, ny=3), "nx"),
        (dict(nx=3, ny=3, width=0.0), "width"),
        (dict(nx=3, ny=3, width=-1.0), "width"),
        (dict(nx=3, ny=3, height=float("nan")), "height"),
        (dict(nx=3, ny=3, height=float("inf")), "height"),
    ],
)
def test_grid_rejects_bad_arguments(kwargs, name):
    with pytest.raises(ValueError, match=name):
        yore.grid_mesh(**kwargs)


@pytest.mark.parametrize(
    "args, name",
    [
        ((1.0, 1.0, 3, 2), "segments"),
        ((1.0, 1.0, 1, 8), "rings"),
        ((1.0, 1.0, 2.5, 8), "rings"),
        ((1.0, 1.0, 3.0, 8), "rings"),
        ((0.0, 1.0, 3, 8), "radius"),
        ((-0.5, 1.0, 3, 8), "radius"),
        ((1.0, 0.0, 3, 8), "height"),
        ((1.0, float("nan"), 3, 8), "height"),
    ],
)
def test_cylinder_rejects_bad_arguments(args, name):
    with pytest.raises(ValueError, match=name):
        yore.cylinder_mesh(*args)


def test_numpy_integers_are_accepted():
    V, F = yore.grid_mesh(np.int64(3), np.int32(4), np.float32(2.0), 1)
    assert V.shape == (12, 3) and V[:, 0].max() == 2.0
    V, F = yore.cylinder_mesh(1, 2, np.int64(3), np.int16(5))
    assert V.shape == (15, 3)


@pytest.mark.parametrize(
    "make",
    [
        lambda: yore.grid_mesh(2**63 - 1, 2),
        lambda: yore.grid_mesh(100000, 21),
        lambda: yore.cylinder_mesh(1.0, 1.0, 2000, 2000),
    ],
)
def test_a_mesh_beyond_the_vertex_limit_is_refused_before_allocating(make):
    with pytest.raises(ValueError, match=f"more than the limit of {yore.meshes.MAX_MESH_VERTICES}"):
        make()
