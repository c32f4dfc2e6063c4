"""Pattern meshes (an equilateral lattice inside, CGAL's 2-D constrained Delaunay mesher along
the edges; or CGAL's throughout): the mesh covers exactly the pattern, is a manifold with the
right Euler characteristic, keeps its edge and angle bounds, has point-symmetric stars inside
(the lattice) or no preferred directions (Delaunay), builds cloths and scenes whose pattern
strokes work, and refuses bad outlines with one clear error."""

import numpy as np
import pytest

import yore
from yore import _core
from yore.runs import SceneError, load_scene

RECTANGLE = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]]


def edges_of(F):
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0)


def signed_areas(V, F):
    a, b, c = V[F[:, 0], :2], V[F[:, 1], :2], V[F[:, 2], :2]
    return 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )


def angles_of(V, F):
    out = []
    for k in range(3):
        p, q, r = V[F[:, k]], V[F[:, (k + 1) % 3]], V[F[:, (k + 2) % 3]]
        u, w = q - p, r - p
        cos = np.einsum("ij,ij->i", u, w) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
        out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.concatenate(out)


@pytest.mark.parametrize("interior", ["lattice", "delaunay"])
@pytest.mark.parametrize("edge_length, min_angle", [(0.1, 20.0), (0.05, 25.0), (0.03, 30.0)])
def test_a_rectangle_is_covered_exactly_within_the_bounds(edge_length, min_angle, interior):
    V, F = yore.pattern_mesh(
        RECTANGLE, edge_length=edge_length, min_angle=min_angle, interior=interior
    )
    assert V.shape[1] == 3 and np.all(V[:, 2] == 0.0)
    areas = signed_areas(V, F)
    assert np.all(areas > 0.0)  # counter-clockwise about +z
    assert areas.sum() == pytest.approx(0.5, rel=1e-12)
    edges = edges_of(F)
    lengths = np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1)
    assert lengths.max() <= edge_length * (1 + 1e-9)
    # the mesher stops at the size bound, not far below it: the mean edge is 0.6–0.8 of it
    assert 0.55 * edge_length < lengths.mean() < 0.85 * edge_length
    # the corners are 90°, so CGAL's angle bound holds everywhere (rounding aside)
    assert angles_of(V, F).min() >= min_angle - 1e-6
    _core.validate_mesh(V, F)  # a manifold: no edge with three faces, no duplicate or sliver
    # a disk: V − E + F = 1
    assert len(V) - len(edges) + len(F) == 1
    # every vertex inside the rectangle, the outline's corners among them
    assert V[:, 0].min() == 0.0 and V[:, 0].max() == 1.0 and V[:, 1].max() == 0.5
    for corner in RECTANGLE:
        assert np.any(np.all(V[:, :2] == corner, axis=1))


@pytest.mark.parametrize("interior", ["lattice", "delaunay"])
def test_holes_are_left_out_and_the_euler_characteristic_counts_them(interior):
    triangle = [[0.2, 0.1], [0.4, 0.1], [0.3, 0.35]]
    square = [[0.6, 0.1], [0.8, 0.1], [0.8, 0.3], [0.6, 0.3]][::-1]  # either orientation
    V, F = yore.pattern_mesh(
        RECTANGLE, holes=[triangle, square], edge_length=0.04, interior=interior
    )
    _core.validate_mesh(V, F)
    hole_area = 0.5 * 0.2 * 0.25 + 0.04
    assert signed_areas(V, F).sum() == pytest.approx(0.5 - hole_area, rel=1e-12)
    assert len(V) - len(edges_of(F)) + len(F) == 1 - 2
    # no face's centroid in a hole
    centroids = V[F].mean(axis=1)[:, :2]
    in_square = (
        (centroids[:, 0] > 0.6)
        & (centroids[:, 0] < 0.8)
        & (centroids[:, 1] > 0.1)
        & (centroids[:, 1] < 0.3)
    )
    assert not in_square.any()


def test_the_mesh_has_no_preferred_directions_unlike_the_grid():
    def largest_direction_share(V, F):
        edges = edges_of(F)
        d = V[edges[:, 1]] - V[edges[:, 0]]
        theta = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 180.0
        counts, _ = np.histogram(theta, bins=36, range=(0, 180))
        return counts.max() / len(edges)

    V, F = yore.pattern_mesh(RECTANGLE, edge_length=0.03, interior="delaunay")
    G, H = yore.grid_mesh(34, 17, width=1.0, height=0.5)
    # a grid's edges lie in 4 bins (rows, columns, two diagonals): the largest holds ~1/3;
    # 36 equal bins would hold 2.8 % each
    assert largest_direction_share(G, H) > 0.25
    assert largest_direction_share(V, F) < 0.08


CIRCLE = [[0.3 * np.cos(t), 0.3 * np.sin(t)] for t in np.linspace(0, 2 * np.pi, 60, endpoint=False)]
STAR = [
    [r * np.cos(t), r * np.sin(t)]
    for r, t in zip([0.5, 0.22] * 7, np.linspace(0, 2 * np.pi, 14, endpoint=False))
]


def test_the_lattice_interior_has_point_symmetric_stars():
    # What the default interior is for (issue 52): a vertex whose star is point-symmetric has
    # no first-order error in its faces' mean slope, in any direction. Away from the CGAL strip
    # (over two edge lengths from the outline) every vertex has six neighbours at ±a along
    # three directions 60° apart, a = 0.7 edge_length, the rows along u.
    edge_length = 0.03
    V, F = yore.pattern_mesh(RECTANGLE, edge_length=edge_length)
    edges = edges_of(F)
    inner = np.flatnonzero(
        (V[:, 0] > 2 * edge_length)
        & (V[:, 0] < 1 - 2 * edge_length)
        & (V[:, 1] > 2 * edge_length)
        & (V[:, 1] < 0.5 - 2 * edge_length)
    )
    assert len(inner) > 0.6 * len(V)
    side = 0.7 * edge_length
    for p in inner:
        ring = np.concatenate([edges[edges[:, 0] == p, 1], edges[edges[:, 1] == p, 0]])
        offsets = V[ring, :2] - V[p, :2]
        assert len(ring) == 6
        assert np.allclose(np.linalg.norm(offsets, axis=1), side, rtol=1e-9)
        angles = np.sort(np.degrees(np.arctan2(offsets[:, 1], offsets[:, 0])) % 360.0)
        assert np.allclose(angles, np.arange(0.0, 360.0, 60.0), atol=1e-6)


@pytest.mark.parametrize(
    "outline, holes, edge_length",
    [
        (
            CIRCLE,
            [
                [
                    [0.1 * np.cos(t), 0.1 * np.sin(t)]
                    for t in np.linspace(0, 2 * np.pi, 30, endpoint=False)
                ]
            ],
            0.1,
        ),  # CGAL splits lattice edges here: the lattice gives those triangles up
        (CIRCLE, [], 0.02),
        (STAR, [], 0.013),
        ([[0.0, 0.0], [1.0, 0.0], [1.0, 0.03], [0.0, 0.03]], [], 0.02),  # no lattice fits: CGAL
    ],
)
def test_lattice_and_strip_meet_edge_to_edge_on_any_outline(outline, holes, edge_length):
    # a manifold with the outline's Euler characteristic and exactly its area, within the
    # bounds: the strip's points on the lattice's boundary are the lattice's own
    V, F = yore.pattern_mesh(outline, holes=holes, edge_length=edge_length)
    _core.validate_mesh(V, F)
    edges = edges_of(F)
    assert len(V) - len(edges) + len(F) == 1 - len(holes)

    def area(polygon):
        x, y = np.asarray(polygon).T
        return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

    expected = area(outline) - sum(area(h) for h in holes)
    assert signed_areas(V, F).min() > 0
    assert signed_areas(V, F).sum() == pytest.approx(expected, rel=1e-12)
    lengths = np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1)
    assert lengths.max() <= edge_length * (1 + 1e-9)
    assert angles_of(V, F).min() >= yore.meshes.PATTERN_MIN_ANGLE - 1e-6


def test_a_pattern_cloth_takes_material_strokes_and_a_membrane():
    outline = [[0.0, 0.0], [0.6, 0.0], [0.6, 0.6], [0.3, 0.8], [0.0, 0.6]]  # a house shape
    V, F = yore.pattern_mesh(outline, edge_length=0.06)
    cloth = yore.Cloth(
        V, F, masses=1e-3, stretch="membrane", young_modulus=500.0, bend_stiffness=0.0
    )
    cloth.material_coordinates = V[:, :2]
    top = int(np.argmax(V[:, 1]))
    cloth.fix([top])
    sim = yore.Simulation(cloth, integrator="implicit", dt=0.01)
    sim.step(3)
    report = sim.stroke(yore.StrokePath.material([[0.1, 0.3], [0.5, 0.3]]))
    assert len(report.new_vertices) > 0
    # new vertices got the pattern point they were added at: inside the outline, on the line
    uv = sim.cloth.material_coordinates[report.new_vertices]
    assert np.all((uv[:, 0] > 0.0) & (uv[:, 0] < 0.6))
    sim.step(3)
    assert np.isfinite(sim.energy()["total"])


SCENE = """
[mesh]
generator = "pattern"
{mesh}
[simulation]
duration = 0.02
dt = 0.01
"""


def test_scene_files_mesh_patterns_and_name_bad_keys():
    sim, sets = load_scene(
        text=SCENE.format(
            mesh="outline = [[0, 0], [1, 0], [1, 0.5], [0, 0.5]]\nedge_length = 0.1\n"
            'holes = [[[0.4, 0.2], [0.6, 0.2], [0.5, 0.3]]]\nplane = "xz"'
        )
    ).build()
    cloth = sim.cloth
    assert np.all(cloth.positions[:, 1] == 0.0)  # the xz plane
    assert np.array_equal(cloth.material_coordinates, cloth.positions[:, [0, 2]])
    # interior = "delaunay": CGAL's triangles throughout, a different mesh of the same pattern
    other, _ = load_scene(
        text=SCENE.format(
            mesh="outline = [[0, 0], [1, 0], [1, 0.5], [0, 0.5]]\nedge_length = 0.1\n"
            'holes = [[[0.4, 0.2], [0.6, 0.2], [0.5, 0.3]]]\ninterior = "delaunay"'
        )
    ).build()
    V, F = yore.pattern_mesh(
        RECTANGLE,
        holes=[[[0.4, 0.2], [0.6, 0.2], [0.5, 0.3]]],
        edge_length=0.1,
        interior="delaunay",
    )
    assert np.array_equal(other.cloth.positions, V)
    assert other.cloth.vertex_count != cloth.vertex_count
    for mesh, key in [
        ("outline = [[0, 0], [1, 0]]", "mesh.outline"),
        ("outline = [[0, 0], [1, 1], [1, 0], [0, 1]]", "mesh.outline"),  # a bow tie
        ("outline = [[0, 0], [1, 0], [1, 1]]\nholes = [[[2, 2], [3, 2], [3, 3]]]", "mesh.holes"),
        ("outline = [[0, 0], [1, 0], [1, 1]]\nedge_length = 0", "mesh.edge_length"),
        ("outline = [[0, 0], [1, 0], [1, 1]]\nmin_angle = 40", "mesh.min_angle"),
        ("edge_length = 0.1", "mesh.outline"),
        ("outline = [[0, 0], [1, 0], [1, 1e-9]]\nedge_length = 0.5", "mesh.outline"),  # R01
        ("outline = [[0, 0], [1, 0], [1, 1]]\nedge_length = 1e-300", "mesh.edge_length"),
        ('outline = [[0, 0], [1, 0], [1, 1]]\ninterior = "grid"', "mesh.interior"),
    ]:
        with pytest.raises(SceneError) as caught:
            load_scene(text=SCENE.format(mesh=mesh)).build()
        assert caught.value.key == key, mesh


@pytest.mark.parametrize(
    "outline, holes, kwargs, message",
    [
        ([[0, 0], [1, 0]], [], {}, "at least 3"),
        ([[0, 0], [1, 0], [0, 0]], [], {}, "at least 3"),  # closed by repetition: 2 distinct
        ([[0, 0], [1, 1], [1, 0], [0, 1]], [], {}, "intersects itself"),
        ([[0, 0], [1, 0], [2, 0]], [], {}, "zero area|intersects itself"),
        ([[0, 0], [1, 0], [float("nan"), 1]], [], {}, "not finite"),
        ([[0, 0], [1, 0], [1, 1]], [], {"edge_length": 0.0}, "edge_length"),
        ([[0, 0], [1, 0], [1, 1]], [], {"edge_length": float("nan")}, "edge_length"),
        ([[0, 0], [1, 0], [1, 1]], [], {"min_angle": 0.0}, "min_angle"),
        ([[0, 0], [1, 0], [1, 1]], [], {"min_angle": 31.0}, "min_angle"),
        ([[0, 0], [1, 0], [1, 1]], [], {"min_angle": True}, "min_angle"),
        ([[0, 0], [1, 0], [1, 1]], [], {"edge_length": 1e-5}, "more than the limit"),
        ([[0, 0], [1, 0], [1, 1], [0, 1]], [[[2, 2], [3, 2], [3, 3]]], {}, "not inside"),
        (
            [[0, 0], [1, 0], [1, 1], [0, 1]],
            [[[0.5, 0.5], [1.5, 0.5], [0.5, 0.7]]],
            {},
            "not inside|crosses",
        ),
        (
            [[0, 0], [1, 0], [1, 1], [0, 1]],
            [[[0.2, 0.2], [0.6, 0.2], [0.4, 0.6]], [[0.3, 0.25], [0.5, 0.25], [0.4, 0.4]]],
            {},
            "overlaps",
        ),
        ([[0, 0], [1, 0], [1, 1]], [[[0.5, 0.1], [0.9, 0.1], [0.5, 0.8]]], {}, "not inside"),
        ("square", [], {}, "list of \\[u, v\\] points"),
        ([[0, 0, 0], [1, 0, 0], [1, 1, 0]], [], {}, "shape"),
    ],
)
def test_bad_patterns_are_value_errors(outline, holes, kwargs, message):
    with pytest.raises(ValueError, match=message):
        yore.pattern_mesh(outline, holes=holes, **kwargs)


@pytest.mark.parametrize(
    "outline, kwargs, message, argument",
    [
        # R01: needles 1e-9 … 1e-15 of their length high crashed CGAL's mesher (SIGSEGV) or made it
        # spin; a huge outline ended in SIGFPE
        ([[0, 0], [1, 0], [1, 1e-9]], {"edge_length": 0.5}, "thinner than", "outline"),
        ([[0, 0], [1, 0], [1, 1e-15]], {"edge_length": 0.5}, "thinner than", "outline"),
        ([[0, 0], [1, 0], [0.5, 1e-9], [0, 1]], {"edge_length": 0.5}, "thinner than", "outline"),
        ([[0, 0], [1e200, 0], [0, 1e200]], {}, "beyond", "outline"),
        ([[0, 0], [1e300, 0], [1e300, 1e300]], {"edge_length": 1e300}, "beyond", "outline"),
        # R02: arithmetic before the checks (ZeroDivisionError, OverflowError)
        ([[0, 0], [1, 0], [1, 1]], {"edge_length": 5e-324}, "more than the limit", "edge_length"),
        ([[0, 0], [1, 0], [1, 1]], {"edge_length": 1e-300}, "more than the limit", "edge_length"),
        ([[0, 0], [1, 0], [1, 1]], {"edge_length": 1e-160}, "more than the limit", "edge_length"),
        ([[0, 0], [1e-300, 0], [0, 1e-300]], {}, "zero area|thinner than", "outline"),
    ],
)
def test_degenerate_and_extreme_patterns_are_refused_not_crashes(
    outline, kwargs, message, argument
):
    with pytest.raises(yore.ArgumentError, match=message) as caught:
        yore.pattern_mesh(outline, **kwargs)
    assert caught.value.argument == argument


def test_a_hole_too_near_the_outline_is_refused():
    with pytest.raises(yore.ArgumentError, match="thinner than") as caught:
        yore.pattern_mesh(RECTANGLE, holes=[[[0.2, 1e-8], [0.4, 1e-8], [0.3, 0.2]]])
    assert caught.value.argument == "holes"


def test_a_huge_edge_length_meshes_the_outline_alone():
    # 1e308 m: no refinement by size; its square overflows, which the estimate must not do
    V, F = yore.pattern_mesh(RECTANGLE, edge_length=1e308)
    assert len(V) >= 4 and np.all(signed_areas(V, F) > 0)
    assert np.isclose(signed_areas(V, F).sum(), 0.5)


def test_a_refinement_past_the_vertex_limit_stops_with_an_error():
    # the core counts the vertices as it refines: a limit far below the mesh's size stops it
    with pytest.raises(ValueError, match="more than 100 vertices"):
        _core.pattern_mesh(np.array(RECTANGLE), [], 0.01, 25.0, 100)


@pytest.mark.parametrize(
    "outline, holes, kwargs, argument",
    [
        ([[0, 0], [1, 0]], [], {}, "outline"),  # Python's check: too few points in C++
        ([[0, 0], [1, 1], [1, 0], [0, 1]], [], {}, "outline"),  # C++: self-intersecting
        ([[0, 0], [1, 0], [1, 1]], [], {"edge_length": 0.0}, "edge_length"),
        ([[0, 0], [1, 0], [1, 1]], [], {"edge_length": 1e-5}, "edge_length"),
        ([[0, 0], [1, 0], [1, 1]], [], {"min_angle": 31.0}, "min_angle"),
        ([[0, 0], [1, 0], [1, 1], [0, 1]], [[[2, 2], [3, 2], [3, 3]]], {}, "holes"),
        ("square", [], {}, "outline"),
        ([[0, 0], [1, 0], [1, 1]], [], {"interior": "grid"}, "interior"),
    ],
)
def test_a_bad_pattern_names_its_argument(outline, holes, kwargs, argument):
    # the scene-file key at fault comes from the error's argument, not from its text
    with pytest.raises(yore.ArgumentError) as caught:
        yore.pattern_mesh(outline, holes=holes, **kwargs)
    assert caught.value.argument == argument
