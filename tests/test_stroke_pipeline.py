"""The stroke pipeline in one call of the core (stroke_pipeline.hpp ↔ _core.apply_stroke):
the same cloth and report as the step-by-step primitives, refusals that leave the cloth as it
was, and its errors."""

import numpy as np
import pytest

import yore
from yore import _core, metrics
from yore.stroke import (MIN_ANGLE_DEGREES, MIN_BARYCENTRIC, RefinementTooLarge, StrokeMissed,
                         mean_edge_length, predicted_refined_vertices)

STROKE = np.array([[0.08, 0.3, 0.0], [0.5, 0.62, 0.0], [0.93, 0.41, 0.0]])


def flat_cloth(n=9):
    V, F = yore.grid_mesh(n, n)
    cloth = yore.Cloth(V, F, masses=0.1 / (n * n), stretch_stiffness=200.0, bend_stiffness=200.0,
                       damping=0.02, drag=0.3)
    cloth.material_coordinates = V[:, :2]
    return cloth


def snapshot(cloth):
    springs = cloth.springs
    return {"positions": cloth.positions, "velocities": cloth.velocities,
            "masses": cloth.masses, "faces": cloth.faces, "ends": springs.ends,
            "rest": springs.rest, "reference": springs.reference, "kind": springs.kind,
            "uv": cloth.material_coordinates, "topology_version": cloth.topology_version}


def assert_same(a, b):
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key, strict=True)


def step_by_step(cloth, growth, refine, width, max_distance):
    """The stroke from the core's primitives, one at a time (the Python pipeline it replaced)."""
    def trace():
        spacing = 0.25 * mean_edge_length(cloth.positions, cloth.faces)
        return _core.trace_closest(cloth, STROKE, max_distance, spacing)

    def path(found):
        corners = cloth.positions[cloth.faces[found["path_faces"]]]
        return np.einsum("mc,mcd->md", found["path_barycentric"], corners), found["path_part"]

    found = trace()
    area_before = float(metrics.face_areas(cloth.positions, cloth.faces)[found["faces"]].sum())
    mass_before = float(cloth.masses.sum())
    counts = {"faces_refined": 0, "springs_added": 0, "springs_removed": 0}
    for _ in range(refine):
        band = _core.stroke_band(cloth, *path(found), found["faces"], width)
        refined = _core.refine_faces(cloth, band["faces"])
        counts["faces_refined"] += len(refined["refined_faces"])
        counts["springs_added"] += refined["springs_added"]
        counts["springs_removed"] += refined["springs_removed"]
        found = trace()
    if growth == "paper":
        split = _core.split_faces(cloth, found["faces"], found["barycentric"], expansion=1.1,
                                  mass_scale=0.95, min_barycentric=MIN_BARYCENTRIC,
                                  min_angle_degrees=MIN_ANGLE_DEGREES)
        counts["springs_added"] += split["springs_added"]
        counts["springs_removed"] += split["springs_removed"]
        report = {"faces_split": len(split["split_faces"]),
                  "rest_area_before": split["rest_area_before"],
                  "rest_area_after": split["rest_area_after"]}
    else:
        grown = _core.grown_rest_lengths(cloth, *path(found), found["faces"], width, growth, 1.1)
        report = {"faces_split": 0, "springs_grown": grown["springs_grown"],
                  "rest_length_added": grown["rest_added"],
                  "rest_area_before": metrics.rest_area(cloth, grown["faces"])}
        cloth.springs.rest = grown["rest_lengths"]
        report["rest_area_after"] = metrics.rest_area(cloth, grown["faces"])
    report.update(counts, area_before=area_before, samples=found["samples"],
                  missed_samples=found["missed_samples"],
                  mass_added=float(cloth.masses.sum()) - mass_before)
    return report


@pytest.mark.parametrize("growth, refine, width",
                         [("paper", 0, 0.0), ("paper", 1, 0.0), ("paper", 2, 0.2),
                          ("isotropic", 0, 0.2), ("along", 1, 0.15), ("across", 2, 0.1)])
def test_one_call_gives_the_cloth_and_report_of_the_step_by_step_pipeline(growth, refine, width):
    max_distance = 0.05
    by_hand, in_core = flat_cloth(), flat_cloth()
    expected = step_by_step(by_hand, growth, refine, width, max_distance)
    report = _core.apply_stroke(in_core, "closest", STROKE, max_distance=max_distance,
                                growth=growth, width=width, refine=refine)
    for key, value in expected.items():
        assert report[key] == value, key  # to the bit: same numbers, same order of sums
    expected_state, state = snapshot(by_hand), snapshot(in_core)
    expected_state.pop("topology_version")
    state.pop("topology_version")
    assert_same(expected_state, state)
    assert report["vertices_added"] == len(report["new_vertices"])
    assert report["vertices_added"] == in_core.vertex_count - 81


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
    inputs = {"closest": (STROKE, {"max_distance": 0.05}),
              "material": (STROKE, {"max_distance": 1e-9}),
              "rays": (np.column_stack([camera.project(STROKE), np.zeros(3)]),
                       {"eye": camera.eye, "base_direction": d0, "direction_per_pixel_x": dx,
                        "direction_per_pixel_y": dy})}
    points, options = inputs[trace]
    with pytest.raises(RefinementTooLarge, match="more than the limit of 100 .*unchanged"):
        _core.apply_stroke(cloth, trace, points, refine=2, width=0.2, max_vertices=100,
                           **options)
    assert_same(before, snapshot(cloth))
    # the same stroke under the limit refines
    report = _core.apply_stroke(cloth, trace, points, refine=2, width=0.2, **options)
    assert report["faces_refined"] > 0 and cloth.vertex_count > 81


def test_the_size_check_is_the_documented_estimate():
    assert predicted_refined_vertices(100, 10, 0) == 100
    assert predicted_refined_vertices(100, 10, 3) == 100 + 2.0 * 10 * (1 + 5 + 25)
    sim = yore.Simulation(flat_cloth(), gravity=(0, 0, 0))
    before = snapshot(sim.cloth)
    with pytest.raises(RefinementTooLarge, match=r"4 passes over a band of \d+ faces could make "
                       r"the mesh [\d.e+]+ vertices, more than the limit of 1000"):
        # a band of b faces predicts 81 + 2 b (1 + 5 + 25 + 125) > 1000 vertices
        _core.apply_stroke(sim.cloth, "closest", STROKE, max_distance=0.05, refine=4,
                           width=1.0, max_vertices=1000)
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


@pytest.mark.parametrize("arguments, match", [
    ({"trace": "nearest"}, "trace: got 'nearest'"),
    ({"refine": 5}, r"refine: got 5; expected an integer in \[0, 4\]"),
    ({"width": -1.0}, "width must be finite and >= 0"),
    ({"growth": "sideways"}, "sideways"),
    ({"trace": "rays"}, "eye"),
    ({"expansion": 0.0, "refine": 1, "growth": "isotropic"}, "expansion must be finite and > 0"),
    ({"mass_scale": float("nan"), "refine": 1}, "mass_scale must be finite and > 0"),
])
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
