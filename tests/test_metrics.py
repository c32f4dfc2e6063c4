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
    assert metrics.wrinkle_amplitude(wavy, F, all_faces) == pytest.approx(amplitude / np.sqrt(2),
                                                                            rel=0.05)
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
    ratios = [metrics.wrinkle_measure(ripple(V, A, 4 * edge), F) / A
              for A in (1e-4, 1e-3, 3e-3, 5e-3)]
    # a wavelength of 4 edges: the filter removes most of it; RMS of a sine is A/√2 (0.707),
    # the measure 0.442 A (boundary columns x = 0 and x = 1 carry no ripple along themselves)
    assert np.allclose(ratios, 0.442, rtol=0.01)
    # a longer wrinkle passes the low-pass filter more: a smaller share is measured
    assert metrics.wrinkle_measure(ripple(V, 1e-3, 6 * edge), F) / 1e-3 == pytest.approx(
        0.129, rel=0.02)


def test_wrinkle_measure_ignores_rigid_motions_and_measures_a_region_only():
    V, F = yore.grid_mesh(41, 41)
    W = ripple(V, 2e-3, 0.1)
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    moved = W @ R.T + np.array([0.3, -1.0, 2.0])
    assert metrics.wrinkle_measure(moved, F) == pytest.approx(metrics.wrinkle_measure(W, F),
                                                              rel=1e-9)
    # a region over the flat half of a half-rippled sheet measures (nearly) nothing
    half = V.copy()
    half[:, 2] = np.where(V[:, 0] > 0.5, W[:, 2], 0.0)
    flat_faces = np.flatnonzero(V[F][:, :, 0].max(axis=1) < 0.3)
    assert metrics.wrinkle_measure(half, F, flat_faces) < 1e-6
    assert metrics.wrinkle_measure(half, F) > 1e-4
