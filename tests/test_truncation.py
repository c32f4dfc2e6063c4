"""Newton's truncation test (`truncation_fraction`): a step's Newton iterations stop once their
estimated distance to the solution is a fraction of the step's estimated local truncation
error, as stiff integrators stop theirs."""

import numpy as np
import pytest

import yore

TIGHT = {"truncation_fraction": 0.0, "newton_tol": 1e-9}


def stiff_sheet(integrator, resolution=12, **options):
    """The stiff sheet of docs/limitations.md: k = 2e5 N/m, bending springs as stiff, pinned
    1 m apart, 1/60 s; each step takes Newton 16–150 iterations to its residual test."""
    return yore.scenes.hanging_cloth(
        resolution=resolution,
        pin_spacing=1.0,
        mass=0.1,
        stretch_stiffness=2e5,
        bend_stiffness=2e5,
        dt=1 / 60,
        integrator=integrator,
        **options,
    )


def tight_copy(sim):
    """The same simulation, its next step to be solved to the residual test alone, tight."""
    state = sim.state()
    return yore.Simulation.from_state(dict(state, options=dict(state["options"], **TIGHT)))


@pytest.mark.parametrize("integrator", ["implicit", "bdf2"])
def test_the_truncation_error_is_the_methods_local_error_formula(integrator):
    # An independent computation from the states before and after each step: backward Euler's
    # ½ h² a = ½ |x⁺ − xₙ − h vₙ|, BDF2's (2/9) h³ x''' ≈ (2/9) h |v⁺ − 2vₙ + vₙ₋₁| (its first
    # step is backward Euler's), largest over the vertices (fixed ones do not move).
    sim = yore.scenes.hanging_cloth(resolution=8, integrator=integrator, dt=1 / 60)
    h = sim.dt
    x, v = [sim.cloth.positions], [sim.cloth.velocities]
    for n in range(4):
        sim.step(1, progress=False)
        x.append(sim.cloth.positions)
        v.append(sim.cloth.velocities)
        if integrator == "bdf2" and n > 0:
            local = 2 / 9 * h * np.linalg.norm(v[-1] - 2 * v[-2] + v[-3], axis=1)
        else:
            local = 0.5 * np.linalg.norm(x[-1] - x[-2] - h * v[-2], axis=1)
        estimate = sim.stats["counters"]["last_truncation_error"]
        assert estimate == pytest.approx(local.max(), rel=1e-9)
        assert estimate > 1e-4  # the cloth falls: not a vacuous 0 == 0


@pytest.mark.parametrize("integrator", ["implicit", "bdf2"])
def test_the_truncation_test_stops_newton_within_the_steps_own_error(integrator):
    # From the same state each step is solved twice: with the default test and tight. The
    # stopped iterate is within the step's own estimated truncation error of the tight one
    # (measured: 0.05–0.66 of it; the estimate of Newton's remaining error, its last move times
    # min(1, contraction rate), is optimistic when the rate nears 1), in a fraction of the
    # iterations.
    sim = stiff_sheet(integrator)
    iterations = tight_iterations = 0
    for _ in range(12):
        tight = tight_copy(sim)
        before = sim.stats["counters"]["newton_iterations"]
        sim.step(1, progress=False)
        tight.step(1, progress=False)
        counters = sim.stats["counters"]
        iterations += counters["newton_iterations"] - before
        tight_iterations += tight.stats["counters"]["newton_iterations"]
        assert tight.stats["counters"]["unconverged_steps"] == 0
        distance = np.linalg.norm(sim.cloth.positions - tight.cloth.positions, axis=1).max()
        assert distance <= counters["last_truncation_error"]
    assert counters["truncation_stops"] == 12 and counters["unconverged_steps"] == 0
    assert counters["factorizations_thrown_away"] == 0
    assert iterations <= 0.15 * tight_iterations


def chain_positions(steps, seconds=0.5, **options):
    # a damped chain swinging down from horizontal: its springs turn within every step
    V = np.array([[0.2 * i, 0.0, 0.0] for i in range(6)])
    cloth = yore.Cloth.from_springs(
        V, [[i, i + 1] for i in range(5)], masses=0.05, stiffness=200.0, damping=0.5
    )
    cloth.fix([0])
    sim = yore.Simulation(cloth, integrator="bdf2", dt=seconds / steps, **options)
    sim.step(steps)
    return sim


def test_bdf2_stays_second_order_with_the_truncation_test():
    # The truncation test stops Newton at a tenth of the local error (O(h³) for BDF2), so the
    # global error keeps its O(h²): the stopped runs converge at the tight runs' order.
    reference = chain_positions(
        6400, newton_tol=1e-12, max_newton=200, truncation_fraction=0.0
    ).cloth.positions
    steps = np.array([100, 200, 400])
    runs = [chain_positions(n, newton_tol=1e-12, max_newton=200) for n in steps]
    assert all(run.stats["counters"]["truncation_stops"] > 0 for run in runs)
    errors = [np.abs(run.cloth.positions - reference).max() for run in runs]
    order = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert order >= 1.9, (order, errors)


def test_truncation_fraction_is_checked_and_zero_turns_the_test_off():
    cloth = stiff_sheet("implicit", resolution=4).cloth
    for bad in (-0.1, 1.5, float("nan"), float("inf"), "0.1", True):
        with pytest.raises(ValueError, match="truncation_fraction"):
            yore.Simulation(cloth, integrator="implicit", truncation_fraction=bad)
    with pytest.raises(ValueError, match="truncation_fraction"):  # Newton's, not L-BFGS's
        yore.Simulation(cloth, integrator="quasi-newton", truncation_fraction=0.1)
    off = stiff_sheet("implicit", truncation_fraction=0.0)
    off.step(2, progress=False)
    assert off.stats["counters"]["truncation_stops"] == 0
    assert off.stats["counters"]["last_scaled_residual"] <= 1e-5  # the residual test ended it


def test_a_state_saved_before_the_truncation_test_continues_as_it_ran():
    # Such a state has no truncation_fraction, projection None (then: steihaug) and mixed
    # False; it continues with those, not with today's defaults. States saved now record the
    # resolved options.
    sim = stiff_sheet("bdf2", resolution=6)
    sim.step(2, progress=False)
    state = sim.state()
    assert state["options"]["projection"] == "clamp" and state["options"]["mixed"] is True
    old = dict(state["options"], projection=None, mixed=False)
    del old["truncation_fraction"]
    resumed = yore.Simulation.from_state(dict(state, options=old))
    options = resumed.resolved_options
    assert options["projection"] == "steihaug" and options["truncation_fraction"] == 0.0
    assert options["mixed"] is False
    linearized = yore.Simulation.from_state(dict(state, options=dict(old, linearized=True)))
    assert linearized.resolved_options["projection"] == "clamp"
