"""Strokes: location on the current surface, 1→3 subdivision, invariants, re-analysis, metrics."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import yore
from yore import metrics


def flat_cloth(n=9, **kwargs):
    V, F = yore.grid_mesh(n, n)
    cloth = yore.Cloth(
        V,
        F,
        masses=0.1 / (n * n),
        stretch_stiffness=200.0,
        bend_stiffness=200.0,
        damping=0.02,
        drag=0.3,
    )
    cloth.material_coordinates = V[:, :2]
    return cloth


def check_invariants(cloth, euler_characteristic):
    V, F = cloth.positions, cloth.faces
    yore._core.validate_mesh(V, F)  # manifold, no degenerate or duplicate face, no unused vertex
    directed = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)  # consistently oriented
    edges = np.unique(np.sort(directed, axis=1), axis=0)
    assert len(V) - len(edges) + len(F) == euler_characteristic
    assert np.all(metrics.face_areas(V, F) > 0)
    assert np.all(cloth.springs.rest > 0) and np.all(np.isfinite(cloth.springs.rest))
    assert np.all(cloth.masses > 0) and np.all(np.isfinite(cloth.masses))
    # the springs are exactly the wiring of the new mesh (paper Fig. 1), found here by hand:
    # a structural spring on every edge, a bending spring between the two vertices opposite
    # each interior edge unless they already share an edge
    structural = {tuple(e) for e in np.sort(cloth.springs.ends[cloth.springs.kind == 0], axis=1)}
    bending = {tuple(e) for e in np.sort(cloth.springs.ends[cloth.springs.kind == 1], axis=1)}
    assert structural == {tuple(e) for e in edges}
    opposite = {}
    for face in F:
        for k in range(3):
            edge = tuple(sorted((face[k], face[(k + 1) % 3])))
            opposite.setdefault(edge, []).append(face[(k + 2) % 3])
    assert bending == {
        tuple(sorted(pair))
        for pair in opposite.values()
        if len(pair) == 2 and tuple(sorted(pair)) not in structural
    }


def test_a_stroke_splits_each_crossed_face_once_with_the_counts_of_the_formula():
    cloth = flat_cloth()
    sim = yore.Simulation(cloth, gravity=(0, 0, 0))
    V0, F0 = cloth.vertex_count, cloth.face_count
    S0 = int(np.count_nonzero(cloth.springs.kind == 0))
    report = sim.stroke([[0.03, 0.52, 0.0], [0.97, 0.44, 0.0]])
    k = report.faces_split
    # a straight line across a 9×9 grid of 1/8 m cells crosses at least 8 columns of cells
    assert k >= 16 and len(report.faces_skipped) == 0 and report.missed_fraction == 0.0
    assert cloth.vertex_count == V0 + k and cloth.face_count == F0 + 2 * k
    assert np.count_nonzero(cloth.springs.kind == 0) == S0 + 3 * k
    assert report.vertices_added == k and len(report.region_faces) == 3 * k
    check_invariants(cloth, 1)
    # new springs follow eq. (1): rest = 1.1 × current length; new masses are 0.95 × the old
    new = np.isin(cloth.springs.ends, report.new_vertices).any(axis=1)
    ends = cloth.springs.ends[new]
    length = np.linalg.norm(cloth.positions[ends[:, 0]] - cloth.positions[ends[:, 1]], axis=1)
    assert np.allclose(cloth.springs.rest[new], 1.1 * length, rtol=1e-12)
    assert np.allclose(cloth.masses[report.new_vertices], 0.95 * cloth.masses[0], rtol=1e-12)
    # the new vertices lie on the old plane, on the stroke's line
    assert np.abs(cloth.positions[report.new_vertices, 2]).max() < 1e-15
    assert report.rest_area_after > report.rest_area_before


def test_a_stroke_near_a_vertex_moves_the_new_point_inward():
    cloth = flat_cloth(5)
    sim = yore.Simulation(cloth, gravity=(0, 0, 0))
    # a short stroke ending almost on vertex (0.5, 0.5)
    report = sim.stroke([[0.5 - 1e-9, 0.5 + 1e-9, 0.0]])
    assert report.faces_split == 1 and report.moved_inward == 1
    face = cloth.faces[report.region_faces]
    V = cloth.positions
    # every child keeps at least a tenth of the parent's area
    areas = metrics.face_areas(V, face)
    assert areas.min() >= 0.1 * areas.sum() * (1 - 1e-9)


def test_stroke_errors():
    cloth = flat_cloth(5)
    sim = yore.Simulation(cloth, gravity=(0, 0, 0))
    with pytest.raises(yore.StrokeMissed):
        sim.stroke([[5.0, 5.0, 5.0], [6.0, 5.0, 5.0]])
    with pytest.raises(yore.StrokeMissed):
        sim.stroke(yore.StrokePath.material([[3.0, 3.0], [4.0, 3.0]]))
    assert issubclass(yore.StrokeMissed, ValueError)
    for bad, message in [
        (np.zeros((0, 3)), "empty"),
        ([[np.nan, 0, 0]], "non-finite"),
        (np.zeros((3, 2)), r"shape \(k, 3\)"),
        ("abc", "numbers|shape"),
    ]:
        with pytest.raises(ValueError, match=message):
            sim.stroke(bad)
    for options, message in [
        ({"expansion": 0.0}, "expansion"),
        ({"expansion": -1}, "expansion"),
        ({"mass_scale": 0.0}, "mass_scale"),
        ({"mass_scale": float("nan")}, "mass_scale"),
    ]:
        with pytest.raises(ValueError, match=message):
            sim.stroke([[0.1, 0.1, 0.0], [0.9, 0.9, 0.0]], **options)
    with pytest.raises(ValueError, match="camera"):
        sim.stroke(yore.StrokePath.screen([[1.0, 2.0]], camera="front"))
    assert cloth.vertex_count == 25  # nothing was split by the failed calls
    net = yore.Cloth.from_springs([[0, 0, 0], [0, -1, 0]], [[0, 1]])
    with pytest.raises(ValueError, match="no faces"):
        yore.Simulation(net).stroke([[0, -0.5, 0]])


def test_a_partly_missing_stroke_is_reported():
    sim = yore.Simulation(flat_cloth(5), gravity=(0, 0, 0))
    report = sim.stroke([[0.2, 0.5, 0.0], [0.8, 0.5, 0.0], [3.0, 0.5, 0.0]], max_distance=0.01)
    assert report.faces_split > 0 and 0.3 < report.missed_fraction < 0.95


def test_screen_stroke_hits_the_same_faces_as_the_equivalent_3d_stroke():
    rng = np.random.default_rng(4)
    points = np.column_stack(
        [
            np.linspace(0.07, 0.93, 6) + rng.uniform(-0.01, 0.01, 6),
            0.3 + 0.4 * rng.uniform(size=6),
            np.zeros(6),
        ]
    )
    camera = yore.Camera(
        eye=(0.4, 0.6, 2.0), target=(0.5, 0.5, 0.0), fov_degrees=40, width=1200, height=900
    )
    reports = []
    for draw in ("3d", "screen"):
        sim = yore.Simulation(flat_cloth(), gravity=(0, 0, 0))
        if draw == "3d":
            reports.append(sim.stroke(points))
        else:
            reports.append(sim.stroke(yore.StrokePath.screen(camera.project(points), camera)))
    # a pinhole camera maps the 3-D segments on the flat cloth to straight pixel segments
    faces_3d = set(reports[0].region_faces[::3])  # parent index = first child
    assert faces_3d == set(reports[1].region_faces[::3])


def test_camera_projection_and_rays_agree():
    camera = yore.Camera(eye=(1.0, 2.0, 3.0), target=(0.0, 0.5, 0.0), width=640, height=480)
    points = np.array([[0.1, 0.2, 0.3], [-0.4, 0.9, 0.1], [0.0, 0.5, 0.0]])
    pixels = camera.project(points)
    assert np.allclose(pixels[2], [319.5, 239.5])  # the target is the image centre
    d0, dx, dy = camera.pixel_rays()
    for point, (px, py) in zip(points, pixels):
        direction = d0 + px * dx + py * dy
        to_point = point - np.asarray(camera.eye)
        assert np.linalg.norm(np.cross(direction, to_point)) < 1e-12 * np.linalg.norm(
            direction
        ) * np.linalg.norm(to_point)


def test_material_stroke_hits_the_faces_containing_its_points():
    sim = yore.Simulation(flat_cloth(), gravity=(0, 0, 0))
    cloth = sim.cloth
    cloth.positions = cloth.positions + np.array([0.0, 0.0, 1.0])  # current shape moved away
    report = sim.stroke(yore.StrokePath.material([[0.3, 0.3]]))
    assert report.faces_split == 1
    uv = cloth.material_coordinates[report.new_vertices[0]]
    # the new vertex sits inside the face that contained the point (moved inward at most)
    assert np.linalg.norm(uv - [0.3, 0.3]) < 0.125


def settle_after_stroke(sim, stroke_points, seconds):
    report = sim.stroke(stroke_points)
    sim.advance(seconds, progress=False)
    return report


def out_of_plane(cloth, report):
    """Mean distance of the new vertices from the plane of their face's corners, m."""
    F = cloth.faces[report.region_faces].reshape(-1, 3, 3)
    V = cloth.positions
    a, b, c, p = V[F[:, 0, 0]], V[F[:, 0, 1]], V[F[:, 1, 1]], V[F[:, 0, 2]]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return float(np.mean(np.abs(np.einsum("ij,ij->i", p - a, normal))))


def hanging_stroke_points(sim, n):
    X = sim.cloth.positions
    return 0.5 * (X[n + 2 : n + n - 2] + X[2 * n + 2 : 2 * n + n - 2])  # between rows 1 and 2


def cylinder_stroke_points(height_fraction=0.25, radius=0.25, height=0.5):
    angles = np.linspace(0.0, 2 * math.pi, 73)
    y = height_fraction * height
    return np.column_stack(
        [radius * np.cos(angles), np.full_like(angles, y), radius * np.sin(angles)]
    )


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_hanging_cloth_stroke_grows_the_region_and_lifts_it_out_of_plane(integrator):
    n = 11
    sim = yore.scenes.hanging_cloth(resolution=n, integrator=integrator)
    sim.advance(1.0, progress=False)
    report = settle_after_stroke(sim, hanging_stroke_points(sim, n), 1.5)
    gain = metrics.area_gain(
        sim.cloth.positions, sim.cloth.faces, report.region_faces, report.area_before
    )
    # The new spokes rest 10 % longer than they were drawn, so at rest the region would grow by
    # well over 10 % (the rest area grows by about 40 %); the surrounding cloth holds part of it
    # back. A 5 % gain is half the length increase: clearly more than numerical drift.
    assert gain > 1.05, gain
    assert report.rest_area_after > 1.2 * report.rest_area_before
    # the new vertices leave their faces' planes (1 % of a 0.1 m cell at least)
    assert out_of_plane(sim.cloth, report) > 1e-3
    assert np.all(np.isfinite(sim.cloth.positions))


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["explicit", "implicit"])
def test_rotating_cylinder_stroke_grows_the_lower_band(integrator):
    sim = yore.scenes.rotating_cylinder(rings=9, segments=24, integrator=integrator)
    sim.advance(0.5, progress=False)
    report = settle_after_stroke(sim, cylinder_stroke_points(), 1.0)
    assert report.faces_split >= 24  # the whole ring of faces around the tube
    gain = metrics.area_gain(
        sim.cloth.positions, sim.cloth.faces, report.region_faces, report.area_before
    )
    assert gain > 1.05, gain  # same margin and reason as the hanging cloth
    assert out_of_plane(sim.cloth, report) > 1e-3


def test_implicit_analyses_equal_strokes_plus_one_and_reanalysis_is_reported():
    sim = yore.scenes.hanging_cloth(resolution=9, integrator="implicit")
    sim.step(5)
    reports = []
    for k in range(3):
        reports.append(sim.stroke(hanging_stroke_points(sim, 9)))
        sim.step(5)
    assert sim.stats["counters"]["analyses"] == 3 + 1
    assert all(isinstance(r.reanalyze_seconds, float) for r in reports)
    explicit = yore.scenes.hanging_cloth(resolution=9)
    report = explicit.stroke(hanging_stroke_points(explicit, 9))
    explicit.step(1)
    assert report.reanalyze_seconds == 0.0  # explicit stepping rebuilds nothing


def min_angle_degrees(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]

    def angle(apex, p, q):
        u, v = p - apex, q - apex
        return np.degrees(
            np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("ij,ij->i", u, v))
        )

    return float(np.min([angle(a, b, c), angle(b, c, a), angle(c, a, b)]))


@pytest.mark.slow
@pytest.mark.parametrize("adaptive", [None, False])
def test_five_strokes_over_one_region_keep_angles_and_the_implicit_solver_healthy(adaptive):
    # Newton to its residual test alone, so the last residual says how close it got
    sim = yore.scenes.hanging_cloth(
        resolution=9,
        integrator="implicit",
        max_newton=400,
        adaptive_projection=adaptive,
        truncation_fraction=0.0,
    )
    sim.step(1)
    euler = 1
    for k in range(5):
        before = min_angle_degrees(sim.cloth.positions, sim.cloth.faces)
        report = sim.stroke(
            yore.StrokePath.material([[0.2, 0.32 + 0.01 * k], [0.8, 0.36 + 0.01 * k]])
        )
        assert report.faces_split > 0
        check_invariants(sim.cloth, euler)
        # The split rule never creates an angle below 5° (a face whose children would have one
        # is left whole): the new faces respect it, so a stroke never makes the mesh worse than
        # 5° or than it already was. (Later motion deforms triangles; that is not subdivision.)
        V, F = sim.cloth.positions, sim.cloth.faces
        assert min_angle_degrees(V, F[report.region_faces]) >= 5.0 - 1e-9
        assert min_angle_degrees(V, F) >= min(5.0, before) - 1e-9
        sim.step(10)
        assert np.all(np.isfinite(sim.cloth.positions))
    counters = sim.stats["counters"]
    # The last residual is a small fraction of the weight of one vertex (1.2e-2 N).
    assert counters["last_residual"] < 1e-3
    if adaptive is None:
        # The default (the clamp with the mixed matrices) converges every step to its
        # residual test. adaptive_projection=False maps to the same clamp; it is not asserted
        # there, as before the clamp was the default (linear convergence once many springs
        # are compressed may use up max_newton on a step).
        assert counters["unconverged_steps"] == 0
    assert counters["analyses"] == 6


def test_rest_length_smoothing_lowers_the_ratio_roughness_in_the_region_only():
    sim = yore.Simulation(flat_cloth(), gravity=(0, 0, 0), integrator="implicit")
    sim.step(1)
    report = sim.stroke([[0.05, 0.5, 0.0], [0.95, 0.45, 0.0]])
    sim.step(1)
    rest_before = sim.cloth.springs.rest.copy()
    result = sim.smooth_rest_lengths(iterations=20, strength=0.5)
    assert result["roughness_after"] < 0.5 * result["roughness_before"]
    changed = sim.cloth.springs.rest != rest_before
    near = np.isin(sim.cloth.springs.ends, np.unique(sim.cloth.faces[report.region_faces]))
    assert changed.any() and not np.any(
        changed
        & ~np.isin(sim.cloth.springs.ends, np.unique(sim.cloth.springs.ends[near.any(axis=1)])).any(
            axis=1
        )
    )
    sim.step(1)
    assert sim.stats["counters"]["analyses"] == 2  # smoothing needs no re-analysis
    with pytest.raises(ValueError, match="strength"):
        sim.smooth_rest_lengths(strength=0.0)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    strokes=st.lists(
        st.lists(st.tuples(st.floats(-0.1, 1.1), st.floats(-0.1, 1.1)), min_size=1, max_size=5),
        min_size=1,
        max_size=3,
    )
)
def test_random_strokes_never_break_the_mesh(strokes):
    sim = yore.Simulation(flat_cloth(6), gravity=(0, 0, 0))
    cloth = sim.cloth
    for stroke in strokes:
        V0, F0 = cloth.vertex_count, cloth.face_count
        S0 = int(np.count_nonzero(cloth.springs.kind == 0))
        points = np.column_stack([np.asarray(stroke), np.zeros(len(stroke))])
        try:
            report = sim.stroke(points, max_distance=0.05)
        except yore.StrokeMissed:
            continue
        k = report.faces_split
        assert cloth.vertex_count == V0 + k and cloth.face_count == F0 + 2 * k
        assert np.count_nonzero(cloth.springs.kind == 0) == S0 + 3 * k
        check_invariants(cloth, 1)


def test_far_stroke_points_are_clipped_to_the_cloths_reach_before_sampling():
    # one point 1e6 m (or 1e9 m) away used to cost 17.6 M samples, 18 s and 2 GB (or MemoryError)
    for far in (1e6, 1e9):
        sim = yore.Simulation(flat_cloth(5), gravity=(0, 0, 0))
        near = sim.stroke([[0.2, 0.5, 0.0], [0.8, 0.5, 0.0]], max_distance=0.01)
        sim = yore.Simulation(flat_cloth(5), gravity=(0, 0, 0))
        report = sim.stroke([[0.2, 0.5, 0.0], [0.8, 0.5, 0.0], [far, 0.5, 0.0]], max_distance=0.01)
        # the part near the cloth is sampled as before; the clipped-away part counts as missed
        assert report.faces_split == near.faces_split
        evaluated = report.samples - (report.missed_samples - near.missed_samples)
        assert evaluated < 10 * near.samples
        assert report.missed_fraction > 0.99
        with pytest.raises(yore.StrokeMissed):
            sim.stroke([[far, 0.5, 0.0], [far, -far, 0.0]])
    for uv in ([[0.2, 0.5], [0.8, 0.5], [1e9, 0.5]], [[-1e9, 0.5], [1e9, 0.5]]):
        sim = yore.Simulation(flat_cloth(5), gravity=(0, 0, 0))
        assert sim.stroke(yore.StrokePath.material(uv)).faces_split > 0
    with pytest.raises(yore.StrokeMissed):
        sim.stroke(yore.StrokePath.material([[1e9, 0.5], [1e9, 1e9]]))


def test_far_screen_strokes_are_clipped_to_the_projected_cloth():
    sim = yore.Simulation(flat_cloth(5), gravity=(0, 0, 0))
    camera = yore.Camera(eye=(0.5, 0.5, 2.0), target=(0.5, 0.5, 0.0), width=200, height=200)
    a, b = camera.project([[0.2, 0.5, 0.0], [0.8, 0.5, 0.0]])
    report = sim.stroke(yore.StrokePath.screen([a, b, [1e9, b[1]]], camera))
    assert report.faces_split > 0 and report.missed_fraction > 0.99
    assert report.samples - report.missed_samples < 10_000


def test_a_stroke_needing_too_many_samples_is_refused_naming_the_limit():
    sim = yore.Simulation(flat_cloth(5), gravity=(0, 0, 0))
    # a huge max_distance keeps the whole polyline within reach: the cap applies
    with pytest.raises(ValueError, match="1000000"):
        sim.stroke([[0.2, 0.5, 0.0], [1e6, 0.5, 0.0]], max_distance=1e7)
    assert sim.cloth.vertex_count == 25
    for bad in ([[1e13, 0.0, 0.0]], [[0.0, -1e300, 0.0]]):
        with pytest.raises(ValueError, match="beyond"):
            sim.stroke(bad)


def test_clip_keeps_strokes_inside_unchanged_and_splits_at_exits():
    sim = yore.Simulation(flat_cloth(5), gravity=(0, 0, 0))
    # in and out and in again: both passes over the cloth are found, in order
    report = sim.stroke(
        [[0.1, 0.3, 0.0], [5.0, 0.3, 0.0], [5.0, 0.7, 0.0], [0.1, 0.7, 0.0]], max_distance=0.01
    )
    centres = sim.cloth.positions[report.new_vertices]
    assert np.any(centres[:, 1] < 0.4) and np.any(centres[:, 1] > 0.6)
