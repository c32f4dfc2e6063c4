"""The stroke pipeline in one call of the core (stroke_pipeline.hpp ↔ _core.apply_stroke), as
Python sees it: the report, refusals that leave the cloth as it was, and its errors. (That one
call equals the step-by-step primitives, to the bit, is tests/cpp/stroke/test_stroke_pipeline.cpp's.)"""

import numpy as np
import pytest

import yore
from yore import _core
from yore.stroke import RefinementTooLarge, StrokeMissed, predicted_refined_vertices

STROKE = np.array([[0.08, 0.3, 0.0], [0.5, 0.62, 0.0], [0.93, 0.41, 0.0]])


def flat_cloth(n=9):
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


def snapshot(cloth):
    springs = cloth.springs
    return {
        "positions": cloth.positions,
        "velocities": cloth.velocities,
        "masses": cloth.masses,
        "faces": cloth.faces,
        "ends": springs.ends,
        "rest": springs.rest,
        "reference": springs.reference,
        "kind": springs.kind,
        "uv": cloth.material_coordinates,
        "topology_version": cloth.topology_version,
    }


def assert_same(a, b):
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key, strict=True)


def test_a_simulation_stroke_is_one_core_call_with_the_python_report():
    sim = yore.Simulation(flat_cloth(), gravity=(0, 0, 0))
    report = sim.stroke(STROKE, growth="isotropic", width=0.2, refine=1)
    assert isinstance(report, yore.StrokeReport)
    assert report.faces_refined > 0 and report.springs_grown > 0
    assert {"spring_weights", "vertex_weights"} <= set(report.extra)
    assert report.topology_version == sim.cloth.topology_version
    assert report.locate_seconds > 0 and report.subdivide_seconds > 0
    assert report.line_vertices.dtype == np.int32 and len(report.line_vertices) > 0


@pytest.mark.parametrize("trace", ["closest", "material", "rays"])
def test_a_refused_refinement_leaves_the_cloth_unchanged(trace):
    cloth = flat_cloth()
    before = snapshot(cloth)
    camera = yore.Camera(eye=(0.5, 0.5, 2.0), target=(0.5, 0.5, 0.0))
    d0, dx, dy = camera.pixel_rays()
    inputs = {
        "closest": (STROKE, {"max_distance": 0.05}),
        "material": (STROKE, {"max_distance": 1e-9}),
        "rays": (
            np.column_stack([camera.project(STROKE), np.zeros(3)]),
            {
                "eye": camera.eye,
                "base_direction": d0,
                "direction_per_pixel_x": dx,
                "direction_per_pixel_y": dy,
            },
        ),
    }
    points, options = inputs[trace]
    with pytest.raises(RefinementTooLarge, match="more than the limit of 100 .*unchanged"):
        _core.apply_stroke(cloth, trace, points, refine=2, width=0.2, max_vertices=100, **options)
    assert_same(before, snapshot(cloth))
    # the same stroke under the limit refines
    report = _core.apply_stroke(cloth, trace, points, refine=2, width=0.2, **options)
    assert report.faces_refined > 0 and cloth.vertex_count > 81


def test_the_size_check_is_the_documented_estimate():
    assert predicted_refined_vertices(100, 10, 0) == 100
    assert predicted_refined_vertices(100, 10, 3) == 100 + 2.0 * 10 * (1 + 5 + 25)
    sim = yore.Simulation(flat_cloth(), gravity=(0, 0, 0))
    before = snapshot(sim.cloth)
    with pytest.raises(
        RefinementTooLarge,
        match=r"4 passes over a band of \d+ faces could make "
        r"the mesh [\d.e+]+ vertices, more than the limit of 1000",
    ):
        # a band of b faces predicts 81 + 2 b (1 + 5 + 25 + 125) > 1000 vertices
        _core.apply_stroke(
            sim.cloth, "closest", STROKE, max_distance=0.05, refine=4, width=1.0, max_vertices=1000
        )
    assert_same(before, snapshot(sim.cloth))


def test_a_missed_stroke_raises_stroke_missed_and_changes_nothing():
    cloth = flat_cloth()
    before = snapshot(cloth)
    far = STROKE + np.array([0.0, 0.0, 5.0])
    with pytest.raises(StrokeMissed, match="touches the cloth nowhere"):
        _core.apply_stroke(cloth, "closest", far, max_distance=0.05, refine=1)
    with pytest.raises(yore.StrokeMissed):
        yore.Simulation(cloth).stroke(far, max_distance=0.05)
    assert_same(before, snapshot(cloth))


@pytest.mark.parametrize(
    "arguments, match",
    [
        ({"trace": "nearest"}, "trace: got 'nearest'"),
        ({"refine": 5}, r"refine: got 5; expected an integer in \[0, 4\]"),
        ({"width": -1.0}, "width must be finite and >= 0"),
        ({"growth": "sideways"}, "sideways"),
        ({"trace": "rays"}, "eye"),
        (
            {"expansion": 0.0, "refine": 1, "growth": "isotropic"},
            "expansion must be finite and > 0",
        ),
        ({"mass_scale": float("nan"), "refine": 1}, "mass_scale must be finite and > 0"),
    ],
)
def test_bad_arguments_are_value_errors_before_anything_changes(arguments, match):
    cloth = flat_cloth()
    before = snapshot(cloth)
    call = {"trace": "closest", "max_distance": 0.05, **arguments}
    trace = call.pop("trace")
    with pytest.raises(ValueError, match=match):
        _core.apply_stroke(cloth, trace, STROKE, **call)
    assert_same(before, snapshot(cloth))


def test_a_material_stroke_needs_material_coordinates():
    V, F = yore.grid_mesh(5, 5)
    cloth = yore.Cloth(V, F, masses=0.01, stretch_stiffness=100.0)
    with pytest.raises(ValueError, match="no material coordinates"):
        _core.apply_stroke(cloth, "material", STROKE, max_distance=1e-9)
