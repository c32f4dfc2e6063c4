"""The Cloth model: wiring (paper Fig. 1), masses, constraints and bad input."""

import numpy as np
import pytest

import yore

STRUCTURAL, BENDING = 0, 1


def pairs_of(cloth, kind):
    ends = np.sort(cloth.springs.ends[cloth.springs.kind == kind], axis=1)
    return {tuple(map(int, p)) for p in ends}


def test_spring_counts_on_2x2_and_3x3_grids_match_hand_counts():
    # 2×2 vertices: one quad, two triangles. Structural: 4 sides + 1 diagonal = 5. The diagonal
    # is the only interior edge: 1 bending spring joining the other two corners.
    cloth = yore.Cloth(*yore.grid_mesh(2, 2))
    assert len(pairs_of(cloth, STRUCTURAL)) == 5
    assert pairs_of(cloth, BENDING) == {(1, 2)}
    # 3×3 vertices: 4 quads. Structural: 6 horizontal + 6 vertical + 4 diagonals = 16. Interior
    # edges: 16 − 8 boundary = 8, each giving one bending pair; with the alternating diagonals
    # all 8 pairs are distinct and none is an edge.
    cloth = yore.Cloth(*yore.grid_mesh(3, 3))
    assert len(pairs_of(cloth, STRUCTURAL)) == 16
    assert len(pairs_of(cloth, BENDING)) == 8
    assert cloth.spring_count == 24


def test_no_duplicate_pairs_and_bending_joins_opposite_vertices():
    V, F = yore.grid_mesh(6, 5)
    cloth = yore.Cloth(V, F)
    ends = np.sort(cloth.springs.ends, axis=1)
    assert len({tuple(p) for p in ends}) == len(ends)
    # independent computation of the bending pairs from the faces
    opposite = {}
    for face in F:
        for c in range(3):
            edge = tuple(sorted((int(face[c]), int(face[(c + 1) % 3]))))
            opposite.setdefault(edge, []).append(int(face[(c + 2) % 3]))
    expected = {tuple(sorted(o)) for o in opposite.values() if len(o) == 2}
    expected -= set(opposite)  # a pair that is an edge is already a structural spring
    assert pairs_of(cloth, BENDING) == expected
    assert pairs_of(cloth, STRUCTURAL) == set(opposite)


def test_rest_lengths_come_from_the_input_geometry():
    V, F = yore.cylinder_mesh(0.3, 0.4, 4, 9)
    cloth = yore.Cloth(V, F, stretch_stiffness=10.0, bend_stiffness=5.0, damping=0.1)
    ends = cloth.springs.ends
    assert np.allclose(
        cloth.springs.rest, np.linalg.norm(V[ends[:, 0]] - V[ends[:, 1]], axis=1), rtol=1e-15
    )
    kinds = cloth.springs.kind
    assert np.all(cloth.springs.stiffness[kinds == STRUCTURAL] == 10.0)
    assert np.all(cloth.springs.stiffness[kinds == BENDING] == 5.0)
    assert np.all(cloth.springs.damping == 0.1)


def test_zero_bend_stiffness_creates_no_bending_springs():
    cloth = yore.Cloth(*yore.grid_mesh(5, 5), bend_stiffness=0.0)
    assert np.count_nonzero(cloth.springs.kind == BENDING) == 0


def test_masses_uniform_array_and_area_lumped():
    V, F = yore.grid_mesh(4, 3, width=2.0, height=1.0)
    assert np.all(yore.Cloth(V, F, masses=0.2).masses == 0.2)
    per_vertex = np.linspace(0.1, 1.0, len(V))
    assert np.array_equal(yore.Cloth(V, F, masses=per_vertex).masses, per_vertex)
    lumped = yore.Cloth(V, F, density=0.3).masses
    assert lumped.sum() == pytest.approx(0.3 * 2.0 * 1.0, rel=1e-12)
    # an interior vertex of this grid touches more area than a corner
    assert lumped.max() > lumped.min()
    with pytest.raises(ValueError, match="not both"):
        yore.Cloth(V, F, masses=0.1, density=0.3)


def test_from_springs_builds_a_chain_with_default_and_given_rest_lengths():
    V = np.array([[0.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, -3.0, 0.0]])
    edges = np.array([[0, 1], [1, 2]])
    chain = yore.Cloth.from_springs(V, edges, masses=0.5, stiffness=20.0)
    assert np.allclose(chain.springs.rest, [1.0, 2.0])
    assert chain.face_count == 0 and chain.spring_count == 2
    chain = yore.Cloth.from_springs(V, edges, rest_lengths=[0.5, 0.25])
    assert np.array_equal(chain.springs.rest, [0.5, 0.25])


def test_state_arrays_are_read_only_copies_and_assignment_is_checked():
    cloth = yore.Cloth(*yore.grid_mesh(3, 3))
    with pytest.raises(ValueError):
        cloth.positions[0, 0] = 1.0  # read-only: assign a whole array instead
    X = cloth.positions + 1.0
    cloth.positions = X
    assert np.array_equal(cloth.positions, X)
    with pytest.raises(ValueError, match=r"shape \(9, 3\)"):
        cloth.positions = np.zeros((8, 3))
    bad = X.copy()
    bad[4, 1] = np.nan
    with pytest.raises(ValueError, match="vertex 4"):
        cloth.positions = bad
    with pytest.raises(ValueError, match="rest length of spring 0"):
        cloth.springs.rest = np.r_[-1.0, cloth.springs.rest[1:]]


def test_fix_and_drive_change_the_topology_version_and_check_indices():
    cloth = yore.Cloth(*yore.grid_mesh(4, 4))
    version = cloth.topology_version
    cloth.fix([0, 3])
    assert cloth.topology_version > version
    # versions are unique across cloths: a cache keyed by one never confuses two cloths
    assert yore.Cloth(*yore.grid_mesh(4, 4)).topology_version > cloth.topology_version
    assert list(cloth.fixed_vertices) == [0, 3]
    with pytest.raises(ValueError, match="out of range"):
        cloth.fix([16])
    with pytest.raises(ValueError, match="fixed"):
        cloth.drive_rotation([3], center=(0, 0, 0), axis=(0, 1, 0), omega=1.0)
    with pytest.raises(ValueError, match="axis"):
        cloth.drive_rotation([5], center=(0, 0, 0), axis=(0, 0, 0), omega=1.0)
    cloth.drive_rotation([12, 13], center=(0, 0, 0), axis=(0, 1, 0), omega=1.0)
    assert list(cloth.driven_vertices) == [12, 13]
    with pytest.raises(ValueError, match="driven"):
        cloth.fix([12])


GOOD_V, GOOD_F = yore.grid_mesh(3, 3)


@pytest.mark.parametrize(
    "vertices, faces, kwargs, message",
    [
        (np.where(np.arange(27).reshape(9, 3) == 4, np.nan, GOOD_V), GOOD_F, {}, "non-finite"),
        (GOOD_V, np.vstack([GOOD_F, [[0, 1, 9]]]), {}, "out of range"),
        (GOOD_V, np.vstack([GOOD_F, [[0, -1, 2]]]), {}, "out of range"),
        (np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32), {}, "no vertices"),
        (GOOD_V, np.zeros((0, 3), dtype=np.int32), {}, "no faces"),
        (
            np.vstack([GOOD_V, [[2.0, 0.0, 0.0]]]),
            np.vstack([GOOD_F, [[0, 1, 9]]]),
            {},
            "degenerate",
        ),
        (GOOD_V, np.vstack([GOOD_F, [[0, 0, 1]]]), {}, "repeats a vertex"),
        (GOOD_V, np.vstack([GOOD_F, GOOD_F[:1]]), {}, "shared by 3 faces|same triangle"),
        (np.vstack([GOOD_V, [[5.0, 5.0, 5.0]]]), GOOD_F, {}, "belongs to no face"),
        (GOOD_V[:, :2], GOOD_F, {}, r"shape \(n, 3\)"),
        (GOOD_V, GOOD_F[:, :2], {}, r"shape \(n, 3\)"),
        (GOOD_V, GOOD_F.astype(float), {}, "integer"),
        (GOOD_V, GOOD_F, {"masses": -1.0}, "mass of vertex 0"),
        (GOOD_V, GOOD_F, {"masses": np.ones(4)}, r"masses must have shape \(9,\)"),
        (GOOD_V, GOOD_F, {"stretch_stiffness": -5.0}, "stretch_stiffness"),
        (GOOD_V, GOOD_F, {"stretch_stiffness": 0.0}, "stretch_stiffness"),
        (GOOD_V, GOOD_F, {"bend_stiffness": np.nan}, "bend_stiffness"),
        (GOOD_V, GOOD_F, {"damping": -0.1}, "damping"),
        (GOOD_V, GOOD_F, {"drag": -1.0}, "drag"),
        (GOOD_V, GOOD_F, {"density": 0.0}, "density"),
    ],
)
def test_bad_cloth_input_raises_value_error_naming_the_problem(vertices, faces, kwargs, message):
    with pytest.raises(ValueError, match=message):
        yore.Cloth(vertices, faces, **kwargs)


def test_non_manifold_edge_is_rejected():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], dtype=float)
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    with pytest.raises(ValueError, match=r"edge \(0, 1\) is shared by 3 faces"):
        yore.Cloth(V, F)


@pytest.mark.parametrize(
    "edges, kwargs, message",
    [
        ([[0, 1], [1, 5]], {}, "out of range"),
        ([[0, 1], [1, 1]], {}, "itself"),
        ([[0, 1], [1, 0]], {}, "more than one spring"),
        ([[0, 1]], {"rest_lengths": [0.0]}, "rest length"),
        ([[0, 1]], {"stiffness": -1.0}, "stiffness"),
        (np.zeros((0, 2), dtype=int), {}, "at least one spring"),
    ],
)
def test_bad_spring_network_input(edges, kwargs, message):
    V = np.array([[0.0, 0, 0], [0, -1, 0], [0, -2, 0]])
    with pytest.raises(ValueError, match=message):
        yore.Cloth.from_springs(V, np.asarray(edges), **kwargs)


def _grid_cloth(**kwargs):
    V, F = yore.grid_mesh(3, 3)
    return yore.Cloth(V, F, **kwargs)


def test_subnormal_zero_and_nan_masses_are_value_errors_and_the_stable_dt_is_never_nan():
    for mass in (5e-324, 1e-310, 0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="mass of vertex 0"):
            _grid_cloth(masses=mass)
    cloth = _grid_cloth(masses=1e-300, stretch_stiffness=1e12)  # k/m overflows
    assert cloth.stable_time_step() == 0.0
    with pytest.raises(ValueError, match=r"stretch_stiffness must be a normal number in .*1e"):
        _grid_cloth(masses=1e-3, stretch_stiffness=1e300)  # past the material limit
    # issue 41, class 16: a subnormal stiffness was accepted, then "diverged at step 0"
    for name in ("stretch_stiffness", "bend_stiffness", "damping"):
        with pytest.raises(ValueError, match=f"{name} must be .*normal number"):
            _grid_cloth(masses=1e-3, **{name: 5e-324})
    _grid_cloth(masses=1e-3, stretch_stiffness=1e-300, bend_stiffness=0.0)  # tiny but normal
    state = _grid_cloth(masses=1e-3).state()
    state["masses"] = np.full(len(state["masses"]), 1e-310)
    with pytest.raises(ValueError, match="mass of vertex 0"):
        yore.Cloth.from_state(state)


def test_indices_beyond_32_bits_are_value_errors_naming_the_argument():
    V, F = yore.grid_mesh(3, 3)
    for big in (np.array([[0, 1, 2**31]]), np.array([[0, 1, 2**64 - 1]], dtype=np.uint64)):
        with pytest.raises(ValueError, match="faces holds the index"):
            yore.Cloth(V, big)
    cloth = yore.Cloth(V, F)
    for index in (2**31, 2**40, np.uint64(2**64 - 1)):
        with pytest.raises(ValueError, match="indices holds the index"):
            cloth.fix([index])
    with pytest.raises(ValueError, match="edges holds the index"):
        yore.Cloth.from_springs(V, np.array([[0, 2**33]]))


def test_tampered_states_are_value_errors_naming_the_field():
    good = _grid_cloth(masses=1e-3).state()
    n, s = len(good["masses"]), len(good["spring_rest"])
    cases = [
        ("positions", np.zeros((n + 1, 3)), "velocities"),
        ("masses", -np.ones(n), "mass of vertex"),
        ("masses", np.full(n, np.nan), "mass of vertex"),
        ("masses", np.ones(n + 1), "masses"),
        ("spring_ends", np.full((s, 2), n + 5, dtype=np.int32), "spring 0 has ends"),
        ("spring_ends", np.full((s, 2), 2**40), "spring_ends holds the index"),
        ("spring_kind", np.full(s, np.nan), "spring_kind"),
        ("spring_kind", np.full(s, 1e300), "spring_kind"),
        ("spring_rest", np.ones(s + 1), "spring_rest"),
        ("faces", np.array([[0, 1, n + 3]], dtype=np.int32), "face|vert|index"),
        ("vertex_states", np.full(n, 7, dtype=np.uint8), "vertex_states"),
        ("clock_dt", float("nan"), "clock"),
    ]
    for key, value, message in cases:
        state = dict(good)
        state[key] = value
        with pytest.raises(ValueError, match=message):
            yore.Cloth.from_state(state)


def test_the_former_mass_keyword_still_works_for_one_version_with_a_deprecation_warning():
    V, F = yore.grid_mesh(3, 3)
    masses = np.linspace(1e-3, 2e-3, 9)
    with pytest.warns(DeprecationWarning, match="masses="):
        old = yore.Cloth(V, F, mass=masses)
    assert np.array_equal(old.masses, yore.Cloth(V, F, masses=masses).masses)
    with pytest.warns(DeprecationWarning):
        chain = yore.Cloth.from_springs(V[:2], [[0, 1]], mass=1e-3)
    assert np.array_equal(chain.masses, [1e-3, 1e-3])
    with pytest.raises(ValueError, match="not also its former name"):
        yore.Cloth(V, F, masses=masses, mass=masses)


@pytest.mark.parametrize(
    "keyword, value, message",
    [
        # issue 53: these were pybind11's TypeError ("incompatible constructor arguments")
        ("stretch", None, 'stretch must be "springs" or "membrane", got None'),
        ("bending", 3, 'bending must be "springs", "quadratic" or "hinge", got 3'),
        ("damping", None, "damping: got None; expected a number"),
        ("drag", "still", "drag: got 'still'; expected a number"),
    ],
)
def test_a_wrongly_typed_keyword_is_a_value_error_naming_it(keyword, value, message):
    V, F = yore.grid_mesh(3, 3)
    with pytest.raises(ValueError, match=message) as caught:
        yore.Cloth(V, F, **{keyword: value})
    assert caught.value.argument == keyword
