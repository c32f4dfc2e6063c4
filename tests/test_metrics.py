"""yore.metrics against analytic values."""

import numpy as np
import pytest

import yore
from yore import metrics


def test_areas_of_a_grid_and_of_a_tilted_copy():
    V, F = yore.grid_mesh(5, 4, width=2.0, height=1.5)
    assert metrics.area(V, F) == pytest.approx(3.0, rel=1e-12)
    assert np.allclose(metrics.face_areas(V, F), 3.0 / len(F))
    c, s = np.cos(0.3), np.sin(0.3)
    R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    assert metrics.area(V @ R.T, F) == pytest.approx(3.0, rel=1e-12)


def test_rest_area_equals_area_for_an_unstretched_cloth_and_scales_with_rest_lengths():
    V, F = yore.grid_mesh(6, 6)
    cloth = yore.Cloth(V, F)
    assert metrics.rest_area(cloth) == pytest.approx(1.0, rel=1e-12)
    cloth.springs.rest = 1.1 * cloth.springs.rest
    assert metrics.rest_area(cloth) == pytest.approx(1.21, rel=1e-12)  # lengths ×1.1 → area ×1.21


def test_area_gain_of_a_stretched_region():
    V, F = yore.grid_mesh(4, 4)
    region = [0, 1, 2]
    before = metrics.area(V, F, region)
    assert metrics.area_gain(2.0 * V, F, region, before) == pytest.approx(4.0)


def test_wrinkle_amplitude_and_roughness_are_zero_on_a_plane_and_grow_with_a_wave():
    V, F = yore.grid_mesh(21, 21)
    all_faces = np.arange(len(F))
    assert metrics.wrinkle_amplitude(V, F, all_faces) < 1e-15
    assert metrics.roughness(V, F) < 1e-15
    amplitude = 0.01
    wavy = V.copy()
    wavy[:, 2] = amplitude * np.sin(2 * np.pi * 4 * V[:, 0])
    # RMS of a sine over whole periods is amplitude / √2
    assert metrics.wrinkle_amplitude(wavy, F, all_faces) == pytest.approx(
        amplitude / np.sqrt(2), rel=0.05
    )
    assert metrics.roughness(wavy, F) > 0.01
    wavier = V.copy()
    wavier[:, 2] = 2 * amplitude * np.sin(2 * np.pi * 4 * V[:, 0])
    assert metrics.roughness(wavier, F) == pytest.approx(2 * metrics.roughness(wavy, F), rel=0.05)


def ripple(V, amplitude, wavelength):
    W = V.copy()
    W[:, 2] = amplitude * np.sin(2 * np.pi * V[:, 0] / wavelength)
    return W


def test_wrinkle_measure_is_zero_on_a_plane_and_small_on_a_cylinder():
    V, F = yore.grid_mesh(41, 41)
    assert metrics.wrinkle_measure(V, F) < 1e-15
    # a cylinder is smooth, but the λ/μ filter's pass band is not exactly flat: a discretisation
    # error ~ (2π/segments)² × radius, 0.0088 R at 24 segments, 0.0025 R at 48
    coarse = metrics.wrinkle_measure(*yore.cylinder_mesh(0.3, 0.6, 12, 24)) / 0.3
    fine = metrics.wrinkle_measure(*yore.cylinder_mesh(0.3, 0.6, 12, 48)) / 0.3
    assert coarse < 0.01 and fine < 0.003
    assert fine < coarse / 3  # it falls with refinement, as a discretisation error does


def test_wrinkle_measure_is_proportional_to_a_ripple_amplitude():
    V, F = yore.grid_mesh(41, 41)
    edge = 1.0 / 40
    ratios = [
        metrics.wrinkle_measure(ripple(V, A, 4 * edge), F) / A for A in (1e-4, 1e-3, 3e-3, 5e-3)
    ]
    # a wavelength of 4 edges: the filter removes most of it; RMS of a sine is A/√2 (0.707),
    # the measure 0.442 A (boundary columns x = 0 and x = 1 carry no ripple along themselves)
    assert np.allclose(ratios, 0.442, rtol=0.01)
    # a longer wrinkle passes the low-pass filter more: a smaller share is measured
    assert metrics.wrinkle_measure(ripple(V, 1e-3, 6 * edge), F) / 1e-3 == pytest.approx(
        0.129, rel=0.02
    )


def test_wrinkle_measure_ignores_rigid_motions_and_measures_a_region_only():
    V, F = yore.grid_mesh(41, 41)
    W = ripple(V, 2e-3, 0.1)
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    moved = W @ R.T + np.array([0.3, -1.0, 2.0])
    assert metrics.wrinkle_measure(moved, F) == pytest.approx(
        metrics.wrinkle_measure(W, F), rel=1e-9
    )
    # a region over the flat half of a half-rippled sheet measures (nearly) nothing
    half = V.copy()
    half[:, 2] = np.where(V[:, 0] > 0.5, W[:, 2], 0.0)
    flat_faces = np.flatnonzero(V[F][:, :, 0].max(axis=1) < 0.3)
    assert metrics.wrinkle_measure(half, F, flat_faces) < 1e-6
    assert metrics.wrinkle_measure(half, F) > 1e-4


def _ring_neighbours(F, v):
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return np.unique(np.concatenate([edges[edges[:, 0] == v, 1], edges[edges[:, 1] == v, 0]]))


def test_spike_index_is_zero_on_a_plane_and_measures_a_lifted_vertex():
    V, F = yore.grid_mesh(9, 9, width=1.0, height=1.0)
    interior = [i for i in range(len(V)) if 0 < V[i, 0] < 1 and 0 < V[i, 1] < 1]
    assert yore.metrics.spike_index(V, F, interior) < 1e-12
    assert yore.metrics.spike_index(V, F) < 1e-12  # boundary vertices too (collinear rings)
    # A tent: one vertex lifted by t·h out of its flat ring; independently, its distance from
    # the ring's plane is t·h and its edges have length √(dᵢ² + (t h)²).
    v = 40  # the centre
    h = 1.0 / 8
    for t in (0.1, 0.46):
        lifted = V.copy()
        lifted[v, 2] += t * h
        ring = _ring_neighbours(F, v)
        lengths = np.linalg.norm(lifted[ring] - lifted[v], axis=1)
        expected = t * h / lengths.mean()
        assert yore.metrics.spike_index(lifted, F, [v]) == pytest.approx(expected, rel=1e-12)
    # rigid motions and uniform scaling leave it unchanged
    R = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))[0]
    moved = 2.5 * lifted @ R.T + np.array([0.3, -1.0, 2.0])
    assert yore.metrics.spike_index(moved, F, [v]) == pytest.approx(
        yore.metrics.spike_index(lifted, F, [v]), rel=1e-9
    )


def test_spike_index_of_a_smooth_tube_is_small_and_falls_with_refinement():
    # A cylinder of radius R at edge length h: a vertex sits ~h²/(2R) off its ring's plane, so
    # the index is ~h/(2R) — below 0.05 at 48 segments and halving when the segments double.
    values = []
    for segments in (48, 96):
        V, F = yore.cylinder_mesh(0.25, 0.25, segments // 4 + 1, segments)
        rings = V[:, 1]
        inner = np.flatnonzero((rings > rings.min() + 1e-9) & (rings < rings.max() - 1e-9))
        values.append(yore.metrics.spike_index(V, F, inner))
    assert values[0] < 0.05
    assert values[1] == pytest.approx(values[0] / 2, rel=0.15)


def test_spike_index_rejects_vertices_it_cannot_measure():
    V, F = yore.grid_mesh(3, 3)
    with pytest.raises(ValueError, match="vertices must be in"):
        yore.metrics.spike_index(V, F, [99])
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match="three or more neighbours"):
        yore.metrics.spike_index(V, np.array([[0, 1, 2]]))


def test_radius_profile_of_a_cylinder_and_of_a_cone():
    V, F = yore.cylinder_mesh(0.3, 0.5, 11, 64)
    heights, radii = yore.metrics.radius_profile(V, bins=5)
    assert np.allclose(radii, 0.3, rtol=1e-12)
    assert heights[0] < heights[-1] and heights[0] > 0.0 and heights[-1] < 0.5
    # A cone r(y) = 0.1 + 0.4 y: each slice's mean radius is r at the mean height of its
    # vertices (linear), and the hem slice is the widest.
    cone = V.copy()
    scale = (0.1 + 0.4 * V[:, 1]) / 0.3
    cone[:, 0] *= scale
    cone[:, 2] *= scale
    heights, radii = yore.metrics.radius_profile(cone, bins=7)
    assert np.allclose(radii, 0.1 + 0.4 * heights, atol=1e-12)
    # an axis elsewhere, and rigid motion with it
    shifted = V + np.array([1.0, 0.0, -2.0])
    assert np.allclose(yore.metrics.radial_distance(shifted, center=(1.0, 5.0, -2.0)), 0.3)
    with pytest.raises(ValueError, match="axis must be"):
        yore.metrics.radial_distance(V, axis=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="bins"):
        yore.metrics.radius_profile(V, bins=0)


def test_a_wrinkle_measure_in_metres_sees_the_same_ripple_on_coarse_and_fine_meshes():
    # A 0.1 m ripple on grids of 12.5 and 6.25 mm: with the smoothing set by a length in metres
    # (smoothing_iterations) the measure is the same fraction of the amplitude on both
    # (measured 0.118 and 0.113 of A/√2); with a fixed 10 iterations it falls 3× with the
    # edge (0.043, 0.013), since the filter's reach is counted in edges.
    physical, fixed = [], []
    for n in (81, 161):
        V, F = yore.grid_mesh(n, n)
        X = V.copy()
        X[:, 2] = 1e-3 * np.sin(2 * np.pi * V[:, 0] / 0.1)
        inner = np.flatnonzero(
            ((V[:, 0] > 0.2) & (V[:, 0] < 0.8) & (V[:, 1] > 0.2) & (V[:, 1] < 0.8))[F].all(axis=1)
        )
        iterations = metrics.smoothing_iterations(V, F, 0.15)
        physical.append(metrics.wrinkle_measure(X, F, inner, iterations=iterations))
        fixed.append(metrics.wrinkle_measure(X, F, inner))
    assert abs(physical[1] / physical[0] - 1) < 0.1, physical
    assert fixed[0] / fixed[1] > 2.5, fixed
    with pytest.raises(ValueError, match="length"):
        metrics.smoothing_iterations(V, F, -1.0)
