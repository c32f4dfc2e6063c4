"""One stroke object: `yore.StrokeOptions` (the C++ tables' defaults) and one
`Simulation.stroke(path, options)` for a 3-D, screen or pattern path; smoothing its optional
last stage; the old `stroke_screen`/`stroke_material` as deprecated wrappers giving the same
cloth bit for bit; the viewer's picking on the core's rays."""

import numpy as np
import pytest

import yore
from yore import _core
from yore.camera import fit_camera
from yore.stroke import StrokeOptions, StrokePath

LINE_UV = [[0.2, 0.62], [0.8, 0.58]]


def _sim():
    sim = yore.scenes.hanging_cloth(resolution=9)
    sim.advance(0.05)
    return sim


def _same_cloth(a, b):
    assert a.cloth.vertex_count == b.cloth.vertex_count
    assert np.array_equal(a.cloth.positions, b.cloth.positions)
    assert np.array_equal(a.cloth.masses, b.cloth.masses)
    assert np.array_equal(a.cloth.springs.rest, b.cloth.springs.rest)
    assert np.array_equal(a.cloth.faces, b.cloth.faces)


def test_options_take_a_dict_or_changes_and_check_every_field():
    options = StrokeOptions.of({"expansion": 1.2}, growth="isotropic", width=0.2, refine=1)
    assert (options.expansion, options.growth, options.width, options.refine) == (
        1.2,
        "isotropic",
        0.2,
        1,
    )
    assert StrokeOptions.of() == StrokeOptions().checked()
    assert StrokeOptions.of(mass_scale="conserve").mass_scale == "conserve"
    assert StrokeOptions.of(smooth=4).smooth["iterations"] == 4
    for changes, message in (
        ({"expansion": 20.0}, "expansion must be in"),
        ({"growth": "sideways"}, "growth: got 'sideways'"),
        ({"refine": 1.5}, r"refine: got 1\.5"),
        ({"width": -1.0}, "width must be finite and > 0"),
        ({"max_distance": 0.0}, "max_distance must be finite and > 0"),
        (
            {"smooth": {"strength": 2.0}},
            r"smooth strength: got float "
            r"2\.0; expected a number in "
            r"\(0, 1\]",
        ),
        ({"smooth": {"passes": 2}}, "smooth: unknown key 'passes'"),
        ({"smooth": {"region": "near"}}, "smooth region: got 'near'"),
        ({"colour": 1}, "unknown stroke option 'colour'"),
    ):
        with pytest.raises(ValueError, match=message):
            StrokeOptions.of(**changes)
    with pytest.raises(ValueError, match="options must be a yore.StrokeOptions"):
        StrokeOptions.of(1.1)


def test_paths_check_their_points_and_their_space():
    assert StrokePath.world([[0, 0, 0]]).points.shape == (1, 3)
    uv = StrokePath.material([[0.1, 0.2], [0.3, 0.4]])
    assert uv.space == "material" and np.array_equal(uv.points[:, 2], [0.0, 0.0])
    with pytest.raises(ValueError, match=r"points_uv must have shape \(k, 2\)"):
        StrokePath.material([[0.1, 0.2, 0.0]])
    with pytest.raises(ValueError, match="camera must be a yore.Camera"):
        StrokePath.screen([[1.0, 2.0]], camera="front")
    with pytest.raises(ValueError, match="stroke path space"):
        StrokePath("sky", [[0, 0, 0]])
    assert StrokePath.of(uv) is uv and StrokePath.of([[0, 0, 0]]).space == "world"


def test_one_stroke_call_for_every_path_and_the_old_ones_give_the_same_cloth():
    camera = yore.Camera(eye=(0.5, -0.3, 2.5), target=(0.5, -0.4, 0.0), width=320, height=240)
    for space in ("material", "screen"):
        new, old = _sim(), _sim()
        if space == "material":
            report = new.stroke(StrokePath.material(LINE_UV), expansion=1.15)
            with pytest.warns(DeprecationWarning, match="stroke_material is deprecated"):
                before = old.stroke_material(LINE_UV, expansion=1.15)
        else:
            pixels = camera.project(new.cloth.positions[[9 * 4 + 1, 9 * 5 + 7]])
            report = new.stroke(StrokePath.screen(pixels, camera), StrokeOptions(refine=1))
            with pytest.warns(DeprecationWarning, match="stroke_screen is deprecated"):
                before = old.stroke_screen(pixels, camera, refine=1)
        assert report.faces_split == before.faces_split > 0
        _same_cloth(new, old)
        new.advance(0.02)
        old.advance(0.02)
        _same_cloth(new, old)


def test_max_distance_is_refused_for_paths_it_does_not_apply_to():
    sim = _sim()
    with pytest.raises(ValueError, match="max_distance is for 3-D"):
        sim.stroke(StrokePath.material(LINE_UV), max_distance=0.1)
    assert sim.cloth.vertex_count == 81  # nothing changed


def test_a_bare_array_is_a_world_path():
    a, b = _sim(), _sim()
    X = a.cloth.positions
    points = 0.5 * (X[9 + 2 : 18 - 2] + X[18 + 2 : 27 - 2])
    first = a.stroke(points, max_distance=0.05)
    second = b.stroke(StrokePath.world(points), {"max_distance": 0.05})
    assert first.faces_split == second.faces_split > 0
    _same_cloth(a, b)


def test_smoothing_is_the_last_stage_and_equals_smoothing_after_the_stroke():
    staged, by_hand = _sim(), _sim()
    report = staged.stroke(StrokePath.material(LINE_UV), smooth={"iterations": 6, "strength": 0.4})
    by_hand.stroke(StrokePath.material(LINE_UV))
    expected = by_hand.smooth_rest_lengths(iterations=6, strength=0.4)
    _same_cloth(staged, by_hand)
    assert report.extra["smoothing"] == expected
    assert expected["roughness_after"] < expected["roughness_before"]  # it did smooth
    plain = _sim()
    assert "smoothing" not in plain.stroke(StrokePath.material(LINE_UV)).extra


def _ray_triangle(origin, direction, a, b, c):
    """Möller–Trumbore for one triangle: (t, barycentric) or None; independent of the core."""
    e1, e2 = b - a, c - a
    p = np.cross(direction, e2)
    det = e1 @ p
    if abs(det) < 1e-15:
        return None
    s = origin - a
    u = (s @ p) / det
    q = np.cross(s, e1)
    v = (direction @ q) / det
    t = (e2 @ q) / det
    if u < -1e-12 or v < -1e-12 or u + v > 1 + 1e-12 or t <= 0:
        return None
    return t, np.array([1 - u - v, u, v])


def test_picking_rays_find_the_nearest_face_a_brute_force_search_finds():
    sim = yore.scenes.rotating_cylinder(rings=5, segments=12)  # rays cross the tube twice
    camera = fit_camera(sim.cloth.positions, 64, 48)
    rng = np.random.default_rng(3)
    pixels = np.column_stack([rng.uniform(0, 63, 40), rng.uniform(0, 47, 40)])
    picked = _core.pick_rays(
        sim.cloth,
        np.column_stack([pixels, np.zeros(40)]),
        np.asarray(camera.eye, float),
        *camera.pixel_rays(),
    )
    V, F = sim.cloth.positions, sim.cloth.faces
    d0, dx, dy = camera.pixel_rays()
    hits = 0
    for k, (px, py) in enumerate(pixels):
        direction = d0 + px * dx + py * dy
        found = [
            (hit[0], f, hit[1])
            for f, face in enumerate(F)
            if (hit := _ray_triangle(np.asarray(camera.eye, float), direction, *V[face]))
            is not None
        ]
        if not found:
            assert picked["faces"][k] == -1
            continue
        hits += 1
        t, face, bary = min(found, key=lambda item: item[0])
        assert picked["faces"][k] == face
        assert np.allclose(picked["barycentric"][k], bary, atol=1e-9)
    assert 5 < hits < 40  # some rays hit, some miss
