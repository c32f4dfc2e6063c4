"""Newton's matrices on the mixed formulation (`mixed`): the springs' transverse stiffness from
the forces the step's linearization predicts. The solution must not change; on stiff sheets the
iterations must fall."""

import warnings

import numpy as np
import pytest

import yore


def stiff_sheet(resolution=12, **options):
    """The stiff sheet of docs/integrators.md: k = 2e5 N/m, bending springs as stiff, pinned
    1 m apart (no slack), 1/60 s."""
    return yore.scenes.hanging_cloth(
        resolution=resolution,
        pin_spacing=1.0,
        mass=0.1,
        stretch_stiffness=2e5,
        bend_stiffness=2e5,
        dt=1 / 60,
        **options,
    )


def test_mixed_is_on_with_the_clamp_by_default_and_a_newton_option():
    # None decides: on with the clamp (the default projection), off with the others
    for integrator in ("implicit", "bdf2"):
        assert yore.options.defaults(integrator)["projection"] == "clamp"
        assert yore.options.defaults(integrator)["mixed"] is True
    cloth = stiff_sheet(4).cloth
    for projection in ("steihaug", "shifted", "exact", "abs"):
        sim = yore.Simulation(cloth, integrator="implicit", projection=projection)
        assert sim.resolved_options["mixed"] is False
    assert (
        yore.Simulation(cloth, integrator="implicit", mixed=False).resolved_options["mixed"]
        is False
    )
    sim = yore.Simulation(cloth, integrator="bdf2", projection="clamp", step_tol=3e-3, mixed=True)
    assert sim.resolved_options["mixed"] is True
    with pytest.raises(ValueError, match="mixed"):
        yore.Simulation(cloth, integrator="quasi-newton", mixed=True)
    with pytest.raises(ValueError, match="option mixed"):
        yore.Simulation(cloth, integrator="implicit", mixed="yes")


@pytest.mark.parametrize("integrator", ["implicit", "bdf2"])
def test_the_linearized_step_from_the_start_is_the_same_with_either_matrix(integrator):
    # λ starts each step at the springs' forces at xₙ, where the one linearized step builds its
    # matrix: the two matrices are equal up to the rounding of k(ℓ − L)/ℓ against k(1 − L/ℓ)
    # (~1e-16 relative), so the runs agree to round-off (positions ~1 m: 1e-12 m is ~1e4 ulps)
    runs = []
    for mixed in (False, True):
        sim = stiff_sheet(10, integrator=integrator, linearized=True, mixed=mixed)
        sim.step(6, progress=False)
        runs.append(sim.cloth.positions)
    np.testing.assert_allclose(runs[1], runs[0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("integrator", ["implicit", "bdf2"])
def test_each_step_converges_to_the_same_solution_with_either_matrix(integrator):
    # a soft sheet (k = 2e3 N/m) whose steps have one minimum: from the same states, every
    # step solved tight with the mixed matrices lands where the actual forces' matrices land
    sim = yore.scenes.hanging_cloth(
        resolution=10,
        pin_spacing=1.0,
        integrator=integrator,
        dt=1 / 60,
        newton_tol=1e-10,
        truncation_fraction=0.0,
    )
    for _ in range(8):
        ends = []
        for mixed in (False, True):
            state = sim.state()
            state["options"] = dict(state["options"], mixed=mixed)
            trial = yore.Simulation.from_state(state)
            trial.step(1, progress=False)
            ends.append(trial.cloth.positions)
        # newton_tol 1e-10 of the rest length (0.11 m), as a displacement through the inertia:
        # both are within ~1e-11 m of the step's solution
        np.testing.assert_allclose(ends[1], ends[0], rtol=0, atol=1e-9)
        sim.step(1, progress=False)


def test_on_a_stiff_sheet_the_mixed_matrices_take_fewer_newton_iterations():
    # measured (docs/integrators.md): on the 12² stiff sheet, 10 BDF2 steps, the clamp with the
    # step test took 30 iterations against 46, steihaug 94 against 113
    counts = {}
    for mixed in (False, True):
        for name, options in (
            ("steihaug", {"projection": "steihaug", "truncation_fraction": 0}),
            ("clamp", {"projection": "clamp", "step_tol": 3e-3, "truncation_fraction": 0}),
        ):
            sim = stiff_sheet(12, integrator="bdf2", mixed=mixed, **options)
            with warnings.catch_warnings():
                warnings.simplefilter("error")  # no step may reach max_newton
                sim.step(10, progress=False)
            counts[name, mixed] = sim.stats["counters"]["newton_iterations"]
    assert counts["clamp", True] <= 0.8 * counts["clamp", False]
    assert counts["steihaug", True] <= 0.95 * counts["steihaug", False]


def test_springs_of_zero_stiffness_add_no_transverse_term():
    # bending springs of stiffness 0: their force and f/ℓ are 0, not 0/0; solved tight, the
    # mixed and the actual-force matrices reach the same steps (pinned without slack: no
    # buckling, one minimum per step)
    ends = []
    for mixed in (False, True):
        sim = yore.scenes.hanging_cloth(
            resolution=8,
            pin_spacing=1.0,
            bend_stiffness=0.0,
            integrator="bdf2",
            dt=1 / 60,
            newton_tol=1e-10,
            mixed=mixed,
            truncation_fraction=0.0,
        )
        sim.step(5, progress=False)
        assert np.isfinite(sim.cloth.positions).all()
        ends.append(sim.cloth.positions)
    np.testing.assert_allclose(ends[1], ends[0], rtol=0, atol=1e-8)
