"""Per-spring kernels against finite differences and invariants."""

import numpy as np
import pytest

import yore

RNG = np.random.default_rng(7)


def random_springs(count, compressed=False):
    xi = RNG.normal(size=(count, 3))
    xj = RNG.normal(size=(count, 3))
    length = np.linalg.norm(xi - xj, axis=1)
    # rest lengths from 0.5× (stretched springs) to 1.5× (compressed) the current length
    factor = RNG.uniform(1.05, 1.5, count) if compressed else RNG.uniform(0.5, 0.95, count)
    rest = factor * length
    stiffness = RNG.uniform(1.0, 100.0, count)
    return xi, xj, rest, stiffness


@pytest.mark.parametrize("compressed", [False, True])
def test_gradient_matches_central_differences_of_energy(compressed):
    xi, xj, rest, k = random_springs(20, compressed)
    analytic = yore.springs.gradient(xi, xj, rest, k)
    h = 1e-6
    numeric = np.empty_like(analytic)
    for c in range(3):
        step = np.zeros(3)
        step[c] = h
        numeric[:, c] = (
            yore.springs.energy(xi + step, xj, rest, k)
            - yore.springs.energy(xi - step, xj, rest, k)
        ) / (2 * h)
    # Central differences: truncation O(h²·E''') plus round-off O(eps·E/h) ≈ 1e-9 relative here.
    scale = np.abs(analytic).max()
    assert np.abs(numeric - analytic).max() < 1e-7 * scale


@pytest.mark.parametrize("compressed", [False, True])
def test_hessian_matches_central_differences_of_gradient(compressed):
    xi, xj, rest, k = random_springs(20, compressed)
    analytic = yore.springs.hessian(xi, xj, rest, k, project_psd=False)
    h = 1e-6
    numeric = np.empty_like(analytic)
    for c in range(3):
        step = np.zeros(3)
        step[c] = h
        numeric[:, :, c] = (
            yore.springs.gradient(xi + step, xj, rest, k)
            - yore.springs.gradient(xi - step, xj, rest, k)
        ) / (2 * h)
    scale = np.abs(analytic).max()
    assert np.abs(numeric - analytic).max() < 1e-7 * scale


def test_gradient_with_respect_to_second_end_is_the_negative():
    xi, xj, rest, k = random_springs(5)
    h = 1e-6
    for c in range(3):
        step = np.zeros(3)
        step[c] = h
        d_second = (
            yore.springs.energy(xi, xj + step, rest, k)
            - yore.springs.energy(xi, xj - step, rest, k)
        ) / (2 * h)
        assert np.allclose(
            d_second, -yore.springs.gradient(xi, xj, rest, k)[:, c], rtol=1e-6, atol=1e-9
        )


def test_projected_hessian_is_symmetric_psd_and_exact_when_stretched():
    for compressed in (False, True):
        xi, xj, rest, k = random_springs(50, compressed)
        projected = yore.springs.hessian(xi, xj, rest, k, project_psd=True)
        exact = yore.springs.hessian(xi, xj, rest, k, project_psd=False)
        assert np.allclose(projected, np.transpose(projected, (0, 2, 1)), atol=0)
        eigenvalues = np.linalg.eigvalsh(projected)
        assert eigenvalues.min() >= -1e-12 * k.max()
        if compressed:
            # The exact Hessian of a compressed spring is indefinite: projection is needed.
            assert np.linalg.eigvalsh(exact).min() < 0
        else:
            assert np.allclose(projected, exact, rtol=0, atol=1e-12 * k.max())


def test_zero_force_at_rest_and_translation_invariance():
    xi, xj, _, k = random_springs(10)
    rest = np.linalg.norm(xi - xj, axis=1)
    assert np.abs(yore.springs.gradient(xi, xj, rest, k)).max() < 1e-12 * k.max()
    assert np.abs(yore.springs.energy(xi, xj, rest, k)).max() < 1e-20 * k.max()
    _, _, rest2, _ = random_springs(10)
    shift = np.array([3.0, -2.0, 0.5])
    assert np.allclose(
        yore.springs.energy(xi + shift, xj + shift, rest2, k),
        yore.springs.energy(xi, xj, rest2, k),
        rtol=1e-12,
    )


def test_energy_and_gradient_match_the_formula_for_one_spring():
    xi, xj = np.array([1.0, 2.0, 2.0]), np.zeros(3)  # length 3
    assert yore.springs.energy(xi, xj, 2.0, 10.0) == pytest.approx(0.5 * 10.0 * 1.0**2)
    assert np.allclose(yore.springs.gradient(xi, xj, 2.0, 10.0), 10.0 * 1.0 * xi / 3.0)


def test_damping_force_acts_along_the_spring_on_relative_velocity_only():
    xi, xj = np.array([0.0, 0.0, 2.0]), np.zeros(3)
    c = 0.5
    # closing speed along the spring: force opposes it with magnitude c·speed
    f = yore.springs.damping_force(
        xi, xj, np.array([0.3, -0.2, 1.5]), np.array([0.3, -0.2, 0.5]), c
    )
    assert np.allclose(f, [0.0, 0.0, -c * 1.0])
    # motion perpendicular to the spring, or common to both ends, is not damped
    assert np.allclose(
        yore.springs.damping_force(xi, xj, np.array([1.0, 2.0, 0.0]), np.zeros(3), c), 0
    )
    assert np.allclose(yore.springs.damping_force(xi, xj, np.ones(3), np.ones(3), c), 0)


def test_kernels_reject_mismatched_shapes():
    with pytest.raises(ValueError, match="shape"):
        yore.springs.energy(np.zeros((3, 3)), np.zeros((2, 3)), 1.0, 1.0)
    with pytest.raises(ValueError, match="rest_length"):
        yore.springs.energy(np.zeros((3, 3)), np.ones((3, 3)), np.ones(2), 1.0)
