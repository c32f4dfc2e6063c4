"""Mesh surgery as pure functions (yore.subdivision ↔ subdivision.hpp), tested without springs,
and the Cloth rewiring that uses them (refine_faces, the mass-conserving split)."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import yore
from yore import metrics
from yore.subdivision import refine_faces_1to4, split_faces_1to3

# Areas and positions are sums of a few products of O(1) numbers: round-off is ~1e-16 relative;
# 1e-12 leaves room for the sums over a whole mesh.
TOLERANCE = 1e-12


def edges_of(F):
    directed = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return directed, np.unique(np.sort(directed, axis=1), axis=0)


def boundary_edge_count(F):
    directed, _ = edges_of(F)
    _, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    return int(np.sum(counts == 1))


def signed_normals(V, F):
    return np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])


def check_surgery(V, F, out):
    """The invariants of every subdivision: a valid manifold mesh, consistently oriented, the
    same Euler characteristic, children of one parent tiling it (area, orientation, corners)."""
    V2, F2, parents = out["vertices"], out["faces"], out["parents"]
    yore._core.validate_mesh(V2, F2)  # manifold, no degenerate, duplicate or unused element
    directed, edges = edges_of(F2)
    assert len(np.unique(directed, axis=0)) == len(directed)  # consistently oriented
    _, edges0 = edges_of(F)
    assert len(V2) - len(edges) + len(F2) == len(V) - len(edges0) + len(F)
    np.testing.assert_array_equal(V2[: len(V)], V)  # old vertices keep their indices
    assert len(parents) == len(F2) and parents.min() >= 0 and parents.max() < len(F)
    child_area = metrics.face_areas(V2, F2)
    parent_area = metrics.face_areas(V, F)
    np.testing.assert_allclose(
        np.bincount(parents, child_area, minlength=len(F)), parent_area, rtol=TOLERANCE, atol=0
    )
    # Orientation kept: each child's normal points the way its parent's does.
    n_child, n_parent = signed_normals(V2, F2), signed_normals(V, F)[parents]
    assert np.all(np.einsum("ij,ij->i", n_child, n_parent) > 0)
    # Each child lies in its parent: its corners are old corners of the parent or new vertices
    # interpolated from the parent's corners only.
    corners = out["new_vertex_corners"]
    for g, p in enumerate(parents):
        allowed = set(F[p])
        for v in F2[g]:
            if v < len(V):
                assert v in allowed
            else:
                k = v - len(V)
                used = corners[k][out["new_vertex_weights"][k] > 0]
                assert set(used) <= allowed
    # New vertices are where their stencil says.
    weights = out["new_vertex_weights"]
    np.testing.assert_allclose(
        V2[len(V) :], np.einsum("kc,kcd->kd", weights, V[corners]), rtol=0, atol=TOLERANCE
    )
    # Untouched faces keep their rows.
    touched = np.unique(parents[len(F) :])
    untouched = np.setdiff1d(np.arange(len(F)), touched)
    np.testing.assert_array_equal(F2[untouched], F[untouched])


def test_split_1to3_of_some_faces():
    V, F = yore.grid_mesh(6, 5)
    faces = [0, 7, 8, 19]
    bary = [[0.2, 0.3, 0.5], [1 / 3, 1 / 3, 1 / 3], [0.6, 0.2, 0.2], [0.1, 0.1, 0.8]]
    out = split_faces_1to3(V, F, faces, bary)
    check_surgery(V, F, out)
    assert len(out["faces"]) == len(F) + 2 * len(faces)
    assert len(out["vertices"]) == len(V) + len(faces)
    np.testing.assert_array_equal(out["split_faces"], faces)
    # The paper's rows: (a, b, p) in the parent's row, (b, c, p), (c, a, p) appended in order.
    a, b, c = F[7]
    p = len(V) + 1
    np.testing.assert_array_equal(out["faces"][7], [a, b, p])
    np.testing.assert_array_equal(out["faces"][len(F) + 2], [b, c, p])
    np.testing.assert_array_equal(out["faces"][len(F) + 3], [c, a, p])
    np.testing.assert_array_equal(out["parents"][len(F) :], np.repeat(faces, 2))


def test_split_1to3_skips_slivers_and_refuses_bad_requests():
    V, F = yore.grid_mesh(4, 4)
    # No child of a right triangle split anywhere has all angles above 59°: every face skipped.
    out = split_faces_1to3(V, F, [0, 1], min_angle_degrees=59.0)
    assert list(out["faces_skipped"]) == [0, 1] and len(out["split_faces"]) == 0
    np.testing.assert_array_equal(out["faces"], F)
    with pytest.raises(ValueError, match="out of range"):
        split_faces_1to3(V, F, [len(F)])
    with pytest.raises(ValueError, match="split twice"):
        split_faces_1to3(V, F, [1, 1])
    with pytest.raises(ValueError, match="sum to 1"):
        split_faces_1to3(V, F, [1], [[0.5, 0.5, 0.5]])


def split_edge_count(F, face, split_edges):
    keys = {tuple(e) for e in split_edges}
    return sum(tuple(sorted((F[face, i], F[face, (i + 1) % 3]))) in keys for i in range(3))


def check_refinement(V, F, requested, out):
    check_surgery(V, F, out)
    refined, bisected = set(out["refined_faces"]), set(out["bisected_faces"])
    assert set(requested) <= refined and not refined & bisected
    children = np.bincount(out["parents"], minlength=len(F))
    assert all(children[f] == 4 for f in refined) and all(children[f] == 2 for f in bisected)
    assert np.all(children[np.setdiff1d(np.arange(len(F)), list(refined | bisected))] == 1)
    # The closure: a face that is not refined has at most one split edge, and it is bisected
    # exactly when it has one.
    for f in range(len(F)):
        if f not in refined:
            count = split_edge_count(F, f, out["split_edges"])
            assert count <= 1 and (count == 1) == (f in bisected)
    # No hanging vertex: only split boundary edges add boundary edges (a T-junction would add
    # three, its long edge and two halves, all with one face).
    split_boundary = sum(1 for e in out["split_edges"] if _is_boundary(F, e))
    assert boundary_edge_count(out["faces"]) == boundary_edge_count(F) + split_boundary
    # Refined children: 4 similar triangles of a quarter of the area; bisected: two halves.
    areas = metrics.face_areas(out["vertices"], out["faces"])
    parent_area = metrics.face_areas(V, F)[out["parents"]]
    quarter = np.isin(out["parents"], list(refined))
    half = np.isin(out["parents"], list(bisected))
    # (midpoints are exact halves; cross products of O(1) numbers: ~1e-15 measured)
    np.testing.assert_allclose(areas[quarter], parent_area[quarter] / 4, rtol=TOLERANCE)
    np.testing.assert_allclose(areas[half], parent_area[half] / 2, rtol=TOLERANCE)


def _is_boundary(F, edge):
    return np.sum(np.isin(F, edge).sum(axis=1) == 2) == 1  # one face holds both ends


def test_refine_1to4_of_one_face_bisects_its_three_neighbours():
    V, F = yore.grid_mesh(5, 5)
    face = 10  # an interior face: three neighbours, one across each edge
    out = refine_faces_1to4(V, F, [face])
    check_refinement(V, F, [face], out)
    assert list(out["refined_faces"]) == [face] and len(out["bisected_faces"]) == 3
    assert len(out["vertices"]) == len(V) + 3 and len(out["faces"]) == len(F) + 3 + 3


def test_refine_closure_refines_a_face_with_two_split_edges():
    V, F = yore.grid_mesh(5, 5)
    # Two neighbours of one face: it is left with two split edges, so it is refined too.
    neighbours = {
        f: [g for g in range(len(F)) if g != f and len(set(F[f]) & set(F[g])) == 2]
        for f in range(len(F))
    }
    face = 10
    a, b = neighbours[face][:2]
    out = refine_faces_1to4(V, F, [a, b])
    check_refinement(V, F, [a, b], out)
    assert face in out["refined_faces"]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_refinements_keep_the_mesh_manifold_and_the_area(data):
    kind = data.draw(st.sampled_from(["grid", "cylinder"]))
    V, F = yore.grid_mesh(6, 5) if kind == "grid" else yore.cylinder_mesh(0.3, 0.5, 4, 8)
    requested = data.draw(st.lists(st.integers(0, len(F) - 1), max_size=10, unique=True))
    out = refine_faces_1to4(V, F, requested)
    check_refinement(V, F, requested, out)
    # and once more on the result (a second pass)
    again = data.draw(st.lists(st.integers(0, len(out["faces"]) - 1), max_size=6, unique=True))
    check_refinement(
        out["vertices"],
        out["faces"],
        again,
        refine_faces_1to4(out["vertices"], out["faces"], again),
    )


def test_refine_refuses_faces_out_of_range():
    V, F = yore.grid_mesh(3, 3)
    with pytest.raises(ValueError, match="out of range"):
        refine_faces_1to4(V, F, [-1])
