"""The paper's two scenes: constraints hold exactly and the default settings run stably."""

import math

import numpy as np
import pytest

import yore


def test_hanging_cloth_pins_never_move_and_the_cloth_sags_below_them():
    sim = yore.scenes.hanging_cloth(resolution=13, drag=3.0)  # more drag: settles sooner
    pins = sim.scene["fixed"]
    assert sorted(pins) == sorted(sim.cloth.fixed_vertices)
    start = sim.cloth.positions[pins].copy()
    sim.advance(3.0)  # default dt: must not diverge
    X = sim.cloth.positions
    assert np.array_equal(X[pins], start)
    # it has swung down from the horizontal start and hangs below the pins (1 m cloth)
    assert X[:, 1].mean() < -0.4
    assert X[:, 1].min() < -0.8
    assert np.all(np.isfinite(X))
    # the pins are the corners of one edge, pin_spacing × width apart
    assert np.linalg.norm(start[0] - start[1]) == 0.8
    # the slack between the pins sags: the top edge hangs below the pins between them
    top = np.arange(13)
    assert X[top[1:-1], 1].max() < 0.0


def test_hanging_cloth_dissipates_towards_rest():
    sim = yore.scenes.hanging_cloth(resolution=9, drag=2.0)
    sim.advance(1.0)
    early = sim.energy()["kinetic"]
    sim.advance(4.0)
    assert sim.energy()["kinetic"] < 0.1 * early


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def test_rotating_cylinder_rim_follows_the_prescribed_rotation_exactly():
    sim = yore.scenes.rotating_cylinder(rings=7, segments=16, omega=3.0)
    rim = sim.scene["driven"]
    center = sim.scene["axis_center"]
    start = sim.cloth.positions[rim].copy()
    assert np.allclose(start[:, 1], 0.5)  # the top rim
    sim.advance(1.5)  # default dt: must not diverge
    R = rotation((0, 1, 0), 3.0 * sim.time)
    expected = (start - center) @ R.T + center
    assert np.abs(sim.cloth.positions[rim] - expected).max() < 1e-12
    # prescribed velocity ω × r
    arm = expected - center
    assert np.abs(sim.cloth.velocities[rim] - np.cross([0, 3.0, 0], arm)).max() < 1e-12
    # the rest of the tube is dragged round the same way (counter-clockwise seen from above:
    # positive angular momentum about +y)
    X, V, m = sim.cloth.positions, sim.cloth.velocities, sim.cloth.masses
    bottom = yore.meshes.cylinder_ring(7, 16, 0)
    L = (m[bottom, None] * np.cross(X[bottom], V[bottom]))[:, 1].sum()
    assert L > 0
    assert np.all(np.isfinite(X))


def test_scenes_accept_material_and_integrator_options():
    sim = yore.scenes.hanging_cloth(
        resolution=5, stretch_stiffness=50.0, bend_stiffness=0.0, dt=1e-4, strain_limit=1.1
    )
    assert sim.dt == 1e-4
    assert sim.options["strain_limit"] == 1.1
    assert sim.stats["active_terms"]["bending_springs"] == 0
    assert np.all(sim.cloth.springs.stiffness == 50.0)
    sim.step(50)
    assert sim.stats["active_terms"]["strain_limiting"] and sim.stats["steps"] == 50


@pytest.mark.parametrize(
    "keyword, value", [("width", -0.5), ("length", 0.0), ("width", float("nan")), ("length", None)]
)
def test_a_stretched_sheet_of_no_size_is_refused_naming_the_size(keyword, value):
    # issue 53: a negative width meshed the mirror-image rectangle without a word
    with pytest.raises(ValueError, match=f"{keyword} must be"):
        yore.scenes.stretched_sheet(**{keyword: value}, edge_length=0.1)


def test_hanging_cloth_on_a_pattern_mesh_hangs_from_the_same_two_corners():
    # mesh="pattern" (issue 52's stroke experiment on CGAL meshes): the pins are the pattern's
    # corners (0, 0) and (1, 0), 0.8 m apart, about resolution² vertices; the grid stays the
    # default, with its pins at vertices 0 and resolution − 1 as before.
    grid = yore.scenes.hanging_cloth(resolution=13)
    assert list(grid.scene["fixed"]) == [0, 12]
    sim = yore.scenes.hanging_cloth(
        resolution=13,
        mesh="pattern",
        bending="quadratic",
        bending_modulus=1e-4,
        stretch="membrane",
        young_modulus=400.0,
        poisson_ratio=0.3,
    )
    uv = sim.scene["uv"]
    pins = sim.scene["fixed"]
    assert np.allclose(uv[pins], [[0.0, 0.0], [1.0, 0.0]])
    assert 0.5 * 13**2 < sim.cloth.vertex_count < 2.0 * 13**2
    start = sim.cloth.positions[pins].copy()
    assert np.linalg.norm(start[0] - start[1]) == pytest.approx(0.8)
    sim.advance(0.5)
    X = sim.cloth.positions
    assert np.array_equal(X[pins], start) and X[:, 1].mean() < -0.1
    with pytest.raises(ValueError, match="mesh"):
        yore.scenes.hanging_cloth(mesh="hexagons")
