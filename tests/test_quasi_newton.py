"""Quasi-Newton (L-BFGS on the prefactored local-global matrix) against Newton and
local-global on the same incremental potential."""

import warnings

import numpy as np
import pytest

import yore

NO_GRAVITY = (0.0, 0.0, 0.0)


def flat_cloth(integrator, resolution=12, **options):
    # hanging flat between its pins: a convex-enough step, so both minimisers find the same
    # minimum (a gathered cloth buckles, and different minimisers may settle in different folds)
    return yore.scenes.hanging_cloth(
        resolution=resolution, pin_spacing=1.0, integrator=integrator, **options
    )


@pytest.mark.parametrize("method, newton", [("backward-euler", "implicit"), ("bdf2", "bdf2")])
def test_quasi_newton_converges_to_newtons_step(method, newton):
    reference = flat_cloth(newton, newton_tol=1e-11, max_newton=200, truncation_fraction=0.0)
    reference.step(5)
    sim = flat_cloth("quasi-newton", method=method, newton_tol=1e-9, max_newton=5000)
    sim.step(5)
    assert sim.stats["counters"]["unconverged_steps"] == 0
    # a residual of 1e-9 mean rest lengths as a displacement: the steps agree far below 1e-6 m
    assert np.abs(sim.cloth.positions - reference.cloth.positions).max() <= 1e-6


def test_quasi_newton_needs_fewer_iterations_than_local_global_for_the_same_residual():
    sim = flat_cloth("quasi-newton", newton_tol=1e-6)
    sim.step(1)
    counters = sim.stats["counters"]
    iterations = counters["newton_iterations"]
    assert counters["unconverged_steps"] == 0 and counters["last_scaled_residual"] <= 1e-6
    # local-global at its defaults (Chebyshev), given as many global solves, no early stop
    lg = flat_cloth("local-global", iterations=iterations, tolerance=0.0)
    lg.step(1)
    assert lg.stats["counters"]["last_residual"] > 3 * counters["last_scaled_residual"], (
        lg.stats["counters"]["last_residual"],
        counters["last_scaled_residual"],
    )


def test_the_scalar_matrix_is_analysed_per_topology_and_factored_per_step_size():
    sim = flat_cloth("quasi-newton", resolution=9)
    sim.step(5)
    counters = sim.stats["counters"]
    assert (counters["analyses"], counters["factorizations"]) == (1, 1)
    sim._dt = 1 / 120  # a new step size: refactor, no new analysis
    sim.step(3)
    counters = sim.stats["counters"]
    assert (counters["analyses"], counters["factorizations"]) == (1, 2)
    sim.stroke(yore.StrokePath.material([[0.2, 0.5], [0.8, 0.5]]))
    sim.step(2)
    counters = sim.stats["counters"]
    assert (counters["analyses"], counters["factorizations"]) == (2, 3)
    assert counters["unconverged_steps"] == 0


def test_bdf2_refactors_once_for_its_backward_euler_start():
    sim = flat_cloth("quasi-newton", resolution=9, method="bdf2")
    sim.step(6)
    # step 1 is backward Euler (h̃ = h), the rest BDF2 (h̃ = 2h/3): two factors, one analysis
    assert (sim.stats["counters"]["analyses"], sim.stats["counters"]["factorizations"]) == (1, 2)


def test_the_scalar_factor_is_about_a_ninth_of_the_newton_factor():
    quasi = flat_cloth("quasi-newton", resolution=16)
    newton = flat_cloth("implicit", resolution=16)
    quasi.step(1)
    newton.step(1)
    ratio = quasi.stats["counters"]["factor_nonzeros"] / newton.stats["counters"]["factor_nonzeros"]
    # a scalar unknown per vertex instead of a 3×3 block: ≈ 1/9 (orderings differ a little)
    assert 0.08 <= ratio <= 0.16, ratio


def test_a_step_at_the_iteration_cap_is_counted_and_warned_about():
    sim = flat_cloth("quasi-newton", resolution=9, newton_tol=1e-9, max_newton=3)
    with pytest.warns(RuntimeWarning, match="max_newton = 3"):
        sim.step(2)
    assert sim.stats["counters"]["unconverged_steps"] == 2
    assert sim.stats["counters"]["newton_iterations"] == 6


def test_spring_damping_leaves_a_rigid_spin_alone():
    def angular_momentum_kept(damping):
        V, F = yore.grid_mesh(9, 9, width=1.0, height=1.0)
        cloth = yore.Cloth(
            V - V.mean(axis=0),
            F,
            masses=1 / 81,
            stretch_stiffness=200.0,
            bend_stiffness=20.0,
            damping=damping,
        )
        cloth.velocities = np.cross([0.0, 0.0, 2 * np.pi], cloth.positions)

        def angular_momentum():
            x, v, m = cloth.positions, cloth.velocities, cloth.masses[:, None]
            centre = (m * x).sum(axis=0) / m.sum()
            return (m * np.cross(x - centre, v)).sum(axis=0)[2]

        before = angular_momentum()
        sim = yore.Simulation(
            cloth,
            integrator="quasi-newton",
            dt=1 / 60,
            gravity=NO_GRAVITY,
            newton_tol=1e-9,
            max_newton=5000,
        )
        sim.advance(1.0, progress=False)
        return angular_momentum() / before

    undamped, damped = angular_momentum_kept(0.0), angular_momentum_kept(2.0)
    assert damped >= 0.99 * undamped, (damped, undamped)


def test_a_saved_bdf2_state_continues_bit_for_bit(tmp_path):
    sim = flat_cloth("quasi-newton", resolution=9, method="bdf2")
    sim.step(3)
    path = tmp_path / "qn.npz"
    yore.save_state(path, sim)
    sim.step(3)
    resumed, _ = yore.load_state(path)
    assert resumed.options["method"] == "bdf2"
    resumed.step(3)
    np.testing.assert_array_equal(resumed.cloth.positions, sim.cloth.positions)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"lbfgs_history": 0}, "lbfgs_history"),
        ({"method": "rk4"}, "method"),
        ({"linearized": True}, r"unknown option\(s\) 'linearized'"),
        ({"max_newton": 2.5}, "max_newton"),
    ],
)
def test_bad_quasi_newton_options_are_value_errors(options, message):
    V, F = yore.grid_mesh(4, 4)
    with pytest.raises(ValueError, match=message):
        yore.Simulation(yore.Cloth(V, F), integrator="quasi-newton", **options)


def test_the_gathered_cloth_stays_finite_and_loses_energy_without_a_newton_hessian():
    # compressed springs make the step's potential nonconvex: L-BFGS's line search still
    # descends, so the run neither diverges nor gains energy
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sim = yore.scenes.hanging_cloth(
            resolution=9, integrator="quasi-newton", gravity=NO_GRAVITY, newton_tol=1e-7
        )
        before = sim.energy()["total"]
        sim.step(30)
    assert np.all(np.isfinite(sim.cloth.positions))
    assert sim.energy()["total"] <= before + 1e-12


def test_a_predictor_of_none_is_decided_not_passed_to_the_core():
    # None means "decide" for every integrator that takes a predictor: quasi-Newton's is the
    # inertial guess (a None reaching the core was pybind11's "Unable to cast" RuntimeError)
    sim = yore.scenes.hanging_cloth(resolution=5, integrator="quasi-newton", predictor=None)
    assert sim.resolved_options["predictor"] == "inertial"
    sim.step(1)
    reference = yore.scenes.hanging_cloth(
        resolution=5, integrator="quasi-newton", predictor="inertial"
    )
    reference.step(1)
    assert np.array_equal(sim.cloth.positions, reference.cloth.positions)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # steps at the cap are not the subject
@pytest.mark.parametrize("integrator", ["quasi-newton", "implicit"])
def test_a_resume_after_a_growing_stroke_is_exact(integrator):
    # Issue 53, R05: a growth stroke changes rest lengths without changing the topology; the
    # stopping tests' length scale (the mean rest length) was taken at the last topology
    # change, so the straight run stopped on the old scale and a resumed one on the new: 7e-6 m
    # apart. It is now the rest lengths' of every step.
    path = yore.StrokePath.material([[0.2, 0.3], [0.8, 0.45]])
    growth = {"growth": "isotropic", "width": 0.5, "expansion": 10}
    straight = yore.scenes.hanging_cloth(resolution=9, integrator=integrator)
    straight.step(5)
    before = yore.Simulation.from_state(straight.state())
    straight.stroke(path, **growth)
    before.stroke(path, **growth)
    straight.step(2)
    before.step(2)
    after = yore.Simulation.from_state(straight.state())
    for sim in (straight, before, after):
        sim.step(3)
    assert np.array_equal(straight.cloth.positions, before.cloth.positions)
    assert np.array_equal(straight.cloth.positions, after.cloth.positions)
    assert np.array_equal(straight.cloth.velocities, after.cloth.velocities)
