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
