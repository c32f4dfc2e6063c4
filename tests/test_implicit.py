"""Implicit stepping (backward Euler, BDF2) on sparse solvers."""

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import yore
from tests.newton_systems import dense_hessian
from yore import _core

NO_GRAVITY = (0.0, 0.0, 0.0)


def oscillator(mass=0.2, stiffness=50.0, amplitude=0.1):
    V = np.array([[0.0, 0.0, 0.0], [0.0, -(1.0 + amplitude), 0.0]])
    cloth = yore.Cloth.from_springs(
        V, [[0, 1]], rest_lengths=[1.0], masses=mass, stiffness=stiffness
    )
    cloth.fix([0])
    return cloth


def displacement_and_velocity(cloth):
    return -cloth.positions[1, 1] - 1.0, -cloth.velocities[1, 1]


def test_backward_euler_amplitude_decays_by_exactly_one_over_sqrt_one_plus_omega_h_squared():
    m, k = 0.2, 50.0
    omega = math.sqrt(k / m)
    for dt in (0.01, 0.05, 0.2):
        sim = yore.Simulation(
            oscillator(m, k), integrator="implicit", dt=dt, gravity=NO_GRAVITY, newton_tol=1e-12
        )
        factor = 1.0 / math.sqrt(1.0 + (omega * dt) ** 2)
        u, v = displacement_and_velocity(sim.cloth)
        amplitude = math.hypot(omega * u, v)
        # stop while the amplitude is still far above the round-off of positions (~1e-16 m)
        for _ in range(min(20, int(math.log(1e-4) / math.log(factor)))):
            sim.step()
            u, v = displacement_and_velocity(sim.cloth)
            new_amplitude = math.hypot(omega * u, v)
            assert new_amplitude / amplitude == pytest.approx(factor, abs=1e-9)
            amplitude = new_amplitude


def global_error(integrator, per_period, periods=1):
    m, k, a = 0.2, 50.0, 0.1
    omega = math.sqrt(k / m)
    dt = 2 * math.pi / omega / per_period
    sim = yore.Simulation(
        oscillator(m, k, a), integrator=integrator, dt=dt, gravity=NO_GRAVITY, newton_tol=1e-12
    )
    error = 0.0
    for n in range(1, per_period * periods + 1):
        sim.step()
        u, _ = displacement_and_velocity(sim.cloth)
        error = max(error, abs(u - a * math.cos(omega * n * dt)))
    return error


@pytest.mark.parametrize("integrator, order", [("implicit", 1), ("bdf2", 2)])
def test_error_falls_with_the_order_of_the_method(integrator, order):
    errors = [global_error(integrator, n) for n in (200, 400, 800)]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    expected = 2.0**order
    assert np.all(np.abs(ratios - expected) < 0.15 * expected), ratios


def stiff_sheet(resolution=9):
    # 1000 × the scenes' default stiffness, no damping: a hard case for explicit stepping
    return yore.scenes.hanging_cloth(
        resolution=resolution,
        pin_spacing=1.0,
        stretch_stiffness=200e3,
        bend_stiffness=200e3,
        damping=0.0,
        drag=0.0,
        integrator="implicit",
        dt=1.0 / 30.0,
    )


@pytest.mark.slow
def test_stiff_cloth_at_a_large_step_stays_finite_and_never_gains_energy_while_explicit_diverges():
    sim = stiff_sheet()
    energies = [sim.energy()["total"]]
    for _ in range(60):
        sim.step()
        energies.append(sim.energy()["total"])
    energies = np.array(energies)
    assert np.all(np.isfinite(sim.cloth.positions))
    # undamped backward Euler dissipates: the energy never rises (beyond round-off)
    assert np.all(np.diff(energies) <= 1e-9 * np.abs(energies).max())
    assert energies[-1] < energies[0]
    explicit = yore.Simulation(stiff_sheet().cloth, integrator="explicit", dt=1.0 / 30.0)
    with pytest.raises(yore.SimulationDiverged, match="stable time step"):
        explicit.step(60)


def test_compressed_springs_factor_and_step():
    V, F = yore.grid_mesh(8, 8, width=0.4, height=0.4)
    cloth = yore.Cloth(V, F, masses=0.005, stretch_stiffness=100.0, bend_stiffness=100.0)
    cloth.springs.rest = 1.2 * cloth.springs.rest  # every spring starts compressed (paper eq. 1)
    cloth.fix([0, 7])
    for integrator in ("implicit", "bdf2"):
        sim = yore.Simulation(cloth, integrator=integrator, dt=1.0 / 60.0)
        sim.step(30)
        assert np.all(np.isfinite(sim.cloth.positions))
    # the cloth expanded towards its longer rest lengths
    ends = cloth.springs.ends
    lengths = np.linalg.norm(cloth.positions[ends[:, 0]] - cloth.positions[ends[:, 1]], axis=1)
    original = np.linalg.norm(V[ends[:, 0]] - V[ends[:, 1]], axis=1)
    assert np.mean(lengths / original) > 1.05


def small_problem(stretched=True, seed=0):
    V, F = yore.grid_mesh(4, 4, width=0.3, height=0.3)
    cloth = yore.Cloth(
        V, F, masses=0.01, stretch_stiffness=50.0, bend_stiffness=20.0, damping=0.1, drag=0.5
    )
    rng = np.random.default_rng(seed)
    scale = 1.3 if stretched else 0.8
    cloth.positions = scale * V + rng.normal(0.0, 0.002, V.shape)
    cloth.velocities = rng.normal(0.0, 0.3, V.shape)
    cloth.fix([0, 3])
    X = cloth.positions + rng.normal(0.0, 0.002, V.shape)
    return cloth, X


def perturbed(X, free, k, h):
    Y = X.copy()
    Y[free[k // 3], k % 3] += h
    return Y


def test_assembled_gradient_and_hessian_match_finite_differences():
    cloth, X = small_problem(stretched=True)
    integrator = _core.ImplicitIntegrator()
    g, dt, h = (0.0, -9.81, 0.0), 0.01, 1e-6
    system = integrator.newton_system(cloth, g, dt, X)
    free = system["free_vertices"]
    assert len(free) == 14 and system["size"] == 42  # two fixed vertices are not unknowns

    def energy(Y):
        return integrator.newton_system(cloth, g, dt, Y)["energy"]

    def gradient(Y):
        return np.array(integrator.newton_system(cloth, g, dt, Y)["gradient"])

    numeric_gradient = np.array(
        [
            (energy(perturbed(X, free, k, h)) - energy(perturbed(X, free, k, -h))) / (2 * h)
            for k in range(system["size"])
        ]
    )
    assert (
        np.abs(numeric_gradient - system["gradient"]).max()
        < 1e-7 * np.abs(system["gradient"]).max()
    )
    numeric_hessian = np.column_stack(
        [
            (gradient(perturbed(X, free, k, h)) - gradient(perturbed(X, free, k, -h))) / (2 * h)
            for k in range(system["size"])
        ]
    )
    H = dense_hessian(system)
    # every spring is stretched here, so the PSD projection changes nothing: H is exact
    assert np.abs(numeric_hessian - H).max() < 1e-7 * np.abs(H).max()


def test_hessian_is_spd_when_springs_are_compressed():
    cloth, X = small_problem(stretched=False)
    system = _core.ImplicitIntegrator().newton_system(cloth, (0, -9.81, 0), 0.05, X)
    eigenvalues = np.linalg.eigvalsh(dense_hessian(system))
    assert eigenvalues.min() > 0


SOLVERS = [
    dict(solver="cholmod", factorization="supernodal", ordering="amd"),
    dict(solver="cholmod", factorization="simplicial", ordering="amd"),
    dict(solver="cholmod", factorization="supernodal", ordering="metis"),
    dict(solver="cholmod", factorization="supernodal", ordering="natural"),
    dict(solver="eigen-ldlt"),
    dict(solver="pcg"),
]


def test_every_backend_solves_the_newton_system_to_1e_10_and_agrees_to_1e_8():
    cloth, X = small_problem(stretched=False, seed=3)
    directions = []
    for options in SOLVERS:
        integrator = _core.ImplicitIntegrator(**options)
        system = integrator.newton_system(cloth, (0, -9.81, 0), 0.02, X)
        H, gradient, direction = dense_hessian(system), system["gradient"], system["direction"]
        assert np.linalg.norm(H @ direction + gradient) / np.linalg.norm(gradient) < 1e-10, options
        directions.append(direction)
    scale = np.abs(directions[0]).max()
    for options, direction in zip(SOLVERS[1:], directions[1:]):
        assert np.abs(direction - directions[0]).max() < 1e-8 * scale, options


def test_backends_give_the_same_steps():
    states = []
    for options in SOLVERS:
        # one projection for all (pcg cannot tell an indefinite matrix, so it takes the clamp)
        # Pins a full width apart: no gathered (buckling) start, whose mirror-image folds are
        # picked by round-off and so differ between solvers once Newton converges.
        sim = yore.scenes.hanging_cloth(
            resolution=7,
            integrator="implicit",
            dt=0.02,
            pin_spacing=1.0,
            newton_tol=1e-10,
            projection="clamp",
            **options,
        )
        sim.step(5)
        assert sim.stats["counters"]["unconverged_steps"] == 0, options
        states.append(sim.cloth.positions)
    for options, X in zip(SOLVERS[1:], states[1:]):
        assert np.abs(X - states[0]).max() < 1e-8, options


def test_symbolic_analysis_runs_once_per_topology():
    sim = yore.scenes.hanging_cloth(resolution=7, integrator="implicit")
    sim.step(100)
    counters = sim.stats["counters"]
    assert counters["analyses"] == 1
    # one factorization per Newton iteration but those solved again on the last factor (the
    # default steihaug's refused steps), plus the exact Hessians found indefinite (none here)
    assert counters["factorizations"] == (
        counters["newton_iterations"]
        - counters["factor_reuses"]
        + counters["exact_hessian_rejected"]
    )
    assert counters["exact_hessian_rejected"] == 0
    assert counters["newton_iterations"] >= 100
    version = sim.cloth.topology_version
    sim.cloth.fix([24])  # a change of the unknowns: a new topology version
    assert sim.cloth.topology_version != version
    sim.step(100)
    assert sim.stats["counters"]["analyses"] == 2
    assert sim.stats["counters"]["dofs"] == 3 * (49 - 3)


def test_statistics_report_phases_and_the_factor():
    sim = yore.scenes.hanging_cloth(resolution=7, integrator="implicit")
    sim.step(3)
    stats = sim.stats
    # phases are wall time: check their names; what ran is in the counters
    assert {"assemble_seconds", "analyze_seconds", "factorize_seconds", "solve_seconds"} <= set(
        stats["phases"]
    )
    counters = stats["counters"]
    assert counters["analyses"] == 1 and counters["factorizations"] >= 3
    assert counters["solves"] >= 3
    assert counters["ordering"] == "amd"
    dofs = counters["dofs"]
    # L holds at least the lower triangle of H (which has 6 entries per vertex block column)
    assert dofs * 2 <= counters["factor_nonzeros"] <= dofs * (dofs + 1) / 2
    assert counters["factor_flops"] > counters["factor_nonzeros"]
    assert counters["last_newton_iterations"] >= 1 and counters["last_residual"] >= 0
    # CHOLMOD's OpenMP regions ran on the calling thread, not in libgomp teams of one (a system
    # call each): this module's GOMP_parallel is the one CHOLMOD is bound to
    assert counters["openmp_regions_inlined"] >= counters["factorizations"]


def test_linearized_takes_exactly_one_newton_step_per_time_step():
    sim = yore.scenes.hanging_cloth(resolution=7, integrator="implicit", linearized=True)
    sim.step(10)
    counters = sim.stats["counters"]
    assert counters["newton_iterations"] == 10 and counters["line_search_backtracks"] == 0


def settle(integrator, dt):
    # Newton stops on its residual, so the velocity it leaves is the tolerance over h: a test
    # of rest to 1e-9 m/s asks for a tight solve.
    options = {} if integrator == "explicit" else {"newton_tol": 1e-10}
    sim = yore.scenes.hanging_cloth(
        resolution=7,
        pin_spacing=1.0,
        damping=0.5,
        drag=4.0,
        integrator=integrator,
        dt=dt,
        **options,
    )
    sim.advance(15.0, progress=False)
    return sim


def test_heavily_damped_cloth_reaches_the_same_static_shape_explicitly_and_implicitly():
    explicit = settle("explicit", None)
    implicit = settle("implicit", 1.0 / 30.0)
    for sim in (explicit, implicit):
        assert np.abs(sim.cloth.velocities).max() < 1e-9  # at rest
    # Both rest at the same minimum of spring + gravity energy, a fixed point of either step.
    # 1e-8 m on a 1 m cloth allows for the residual motion (< 1e-9 m/s) over the slowest decay
    # time (~1 s) ten times over; the cloth sags by 1 m, so a different shape could not hide.
    assert np.abs(explicit.cloth.positions - implicit.cloth.positions).max() < 1e-8


@pytest.mark.parametrize(
    "options, message",
    [
        ({"solver": "lu"}, "valid: cholmod, eigen-ldlt, pcg"),
        ({"ordering": "rcm"}, "valid: amd, metis, nesdis, auto, natural"),
        ({"factorization": "dense"}, "valid: supernodal, simplicial"),
        ({"newton_tol": -1.0}, "newton_tol"),
        ({"max_newton": 0}, "max_newton"),
        ({"solver": "eigen-ldlt", "ordering": "metis"}, "amd"),
        (
            {"linearised": True},
            "valid: adaptive_projection, divergence_energy_factor, energy_growth_tolerance, factorization",
        ),
    ],
)
def test_bad_implicit_options_are_value_errors_listing_the_valid_ones(options, message):
    cloth = yore.Cloth(*yore.grid_mesh(3, 3))
    with pytest.raises(ValueError, match=message):
        yore.Simulation(cloth, integrator="implicit", **options)


def lower_csc(H):
    n = len(H)
    indptr, indices, data = [0], [], []
    for column in range(n):
        for row in range(column, n):
            if H[row, column] != 0.0:
                indices.append(row)
                data.append(H[row, column])
        indptr.append(len(indices))
    return n, np.array(indptr), np.array(indices), np.array(data)


@pytest.mark.parametrize("integrator", ["implicit", "bdf2"])
def test_both_paper_scenes_run_implicitly_at_their_default_step(integrator):
    hanging = yore.scenes.hanging_cloth(resolution=9, integrator=integrator)
    assert hanging.dt == pytest.approx(1 / 60)
    pins = hanging.cloth.positions[hanging.scene["fixed"]].copy()
    hanging.advance(0.5, progress=False)
    assert np.array_equal(hanging.cloth.positions[hanging.scene["fixed"]], pins)
    assert hanging.cloth.positions[:, 1].mean() < -0.1
    cylinder = yore.scenes.rotating_cylinder(rings=5, segments=12, omega=3.0, integrator=integrator)
    rim = cylinder.scene["driven"]
    start = cylinder.cloth.positions[rim].copy()
    cylinder.advance(0.5, progress=False)
    angle = 3.0 * cylinder.time
    c, s = math.cos(angle), math.sin(angle)
    R = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])  # rotation by +angle about +y
    assert np.abs(cylinder.cloth.positions[rim] - start @ R.T).max() < 1e-12
    assert np.all(np.isfinite(cylinder.cloth.positions))


def test_adaptive_projection_reaches_the_same_steps_in_fewer_iterations():
    results = []
    for adaptive in (False, True):  # always projected (clamp), then exact
        sim = yore.scenes.hanging_cloth(
            resolution=9,
            integrator="implicit",
            newton_tol=1e-10,
            max_newton=1000,
            adaptive_projection=adaptive,
            truncation_fraction=0.0,
        )
        sim.step(5)
        # a stroke's springs start compressed (rest = 1.1 × length): the projection matters
        sim.stroke(yore.StrokePath.material([[0.2, 0.35], [0.8, 0.4]]))
        sim.step(5)
        results.append((sim.cloth.positions, sim.stats["counters"]))
    (projected, p_counters), (adaptive, a_counters) = results
    assert p_counters["unconverged_steps"] == 0 and a_counters["unconverged_steps"] == 0
    # the same minimiser of the same energy each step (to the Newton tolerance, 1e-10 × 0.17 m)
    assert np.abs(projected - adaptive).max() < 1e-8
    # the exact Hessian is tried again only after a back-off once it was found indefinite, so
    # few factorizations are thrown away
    assert a_counters["newton_iterations"] < 0.8 * p_counters["newton_iterations"]
    assert a_counters["exact_hessian_rejected"] <= 10  # at most about one per step here
    assert p_counters["exact_hessian_rejected"] == 0


def test_adaptive_projection_needs_a_cholesky_backend():
    cloth = yore.Cloth(*yore.grid_mesh(3, 3))
    with pytest.raises(ValueError, match="pcg"):
        yore.Simulation(cloth, integrator="implicit", solver="pcg", adaptive_projection=True)


def test_lagged_factorization_reaches_the_same_steps_with_fewer_factorizations():
    results = []
    for lagged in (False, True):
        sim = yore.scenes.hanging_cloth(
            resolution=9,
            pin_spacing=1.0,
            integrator="implicit",
            adaptive_projection=False,
            newton_tol=1e-10,
            max_newton=500,
            truncation_fraction=0.0,
            lagged_factorization=lagged,
        )
        sim.step(20)
        results.append((sim.cloth.positions, sim.stats["counters"]))
    (plain, plain_counters), (lagged, lagged_counters) = results
    assert plain_counters["unconverged_steps"] == 0 == lagged_counters["unconverged_steps"]
    # both solve each step's objective to newton_tol (1e-10 of a 0.125 m spring)
    assert np.abs(plain - lagged).max() < 1e-8
    assert lagged_counters["lagged_solves"] > 0
    assert lagged_counters["factorizations"] < 0.5 * plain_counters["factorizations"]
    # each Newton system is solved once: by CG on the kept factor (a reuse) or, when that CG
    # fails or there is no factor yet, by a fresh factorization (none thrown away: the clamp)
    assert lagged_counters["newton_iterations"] == (
        lagged_counters["factorizations"] + lagged_counters["factor_reuses"]
    )


def test_a_kept_factor_that_never_serves_is_tried_on_a_doubling_schedule_and_changes_nothing():
    # One CG iteration cannot reach a 1e-14 relative residual on the stiff sheet, so every try
    # on the kept factor fails and is refactored: the directions, and so the steps, are the
    # unlagged run's to the bit, and after the k-th failure the next min(2^(k-1), 32)
    # iterations refactor without trying.
    def run(**options):
        sim = yore.scenes.hanging_cloth(
            resolution=10,
            pin_spacing=1.0,
            mass=0.1,
            stretch_stiffness=2e5,
            bend_stiffness=2e5,
            integrator="bdf2",
            dt=1 / 60,
            **options,
        )
        sim.step(12)
        return sim.cloth.positions, sim.stats["counters"]

    plain, plain_counters = run()
    lagged, counters = run(lagged_factorization=True, lag_max_cg_iterations=1, lag_cg_tol=1e-14)
    assert np.array_equal(plain, lagged)
    assert counters["factor_reuses"] == 0
    assert counters["factorizations"] == plain_counters["factorizations"]
    failures, iterations = counters["lagged_failures"], counters["newton_iterations"]
    assert failures >= 3
    skips = [min(2**k, 32) for k in range(failures)]
    # the first iteration has no factor; each failure is followed by its skips (the last one's
    # perhaps cut short by the end of the run)
    assert 1 + failures + sum(skips[:-1]) <= iterations <= 1 + failures + sum(skips)


def test_lagged_factorization_needs_the_projected_hessian_and_a_cholesky_backend():
    cloth = yore.Cloth(*yore.grid_mesh(3, 3))
    with pytest.raises(ValueError, match="lagged"):
        yore.Simulation(
            cloth, integrator="implicit", lagged_factorization=True, adaptive_projection=True
        )
    with pytest.raises(ValueError, match="lagged"):
        yore.Simulation(cloth, integrator="implicit", lagged_factorization=True, solver="pcg")


def test_iteration_counts_beyond_32_bits_are_value_errors_naming_the_option():
    V, F = yore.grid_mesh(3, 3)
    cloth = yore.Cloth(V, F)
    for option in ("max_newton", "pcg_max_iterations", "lag_max_cg_iterations"):
        with pytest.raises(ValueError, match=option):
            yore.Simulation(cloth, integrator="implicit", **{option: 2**31})
    with pytest.raises(ValueError, match="strain_limit_passes"):
        yore.Simulation(cloth, integrator="explicit", strain_limit=1.1, strain_limit_passes=2**32)


def test_a_step_cut_short_is_not_converged_and_max_newton_is_warned_about():
    # one Newton iteration from the inertial prediction cannot meet a 1e-10 residual
    sim = yore.scenes.hanging_cloth(
        resolution=7, integrator="implicit", newton_tol=1e-10, max_newton=1
    )
    with pytest.warns(
        RuntimeWarning, match=r"implicit: 3 of 3 steps reached the iteration cap \(max_newton = 1\)"
    ):
        sim.step(3)
    counters = sim.stats["counters"]
    assert counters["unconverged_steps"] == 3
    assert counters["last_scaled_residual"] > 1e-10


def test_newton_stops_on_its_residual_scaled_to_a_displacement():
    for dt in (1 / 240, 1 / 60, 1 / 15):
        sim = yore.scenes.hanging_cloth(
            resolution=7,
            integrator="implicit",
            dt=dt,
            newton_tol=1e-6,
            max_newton=1000,
            truncation_fraction=0.0,
        )
        sim.step(5)
        counters = sim.stats["counters"]
        assert counters["unconverged_steps"] == 0
        assert 0.0 <= counters["last_scaled_residual"] <= 1e-6


@pytest.mark.parametrize("integrator", ["implicit", "bdf2", "quasi-newton"])
def test_a_small_step_still_applies_the_forces(integrator):
    # At h = 1/3840 s the start's scaled residual h̃²|a| is below newton_tol × the mean rest
    # length (1e-5 × 0.125 m): the length test alone accepted the start with no iteration and
    # the cloth hung still in mid-air. The start must also balance every vertex's forces.
    dt, steps = 1 / 3840, 96

    def run(**options):
        sim = yore.scenes.hanging_cloth(
            resolution=9, pin_spacing=1.0, integrator=integrator, dt=dt, **options
        )
        start = np.array(sim.cloth.positions)
        sim.step(steps, progress=False)
        return start, np.array(sim.cloth.positions), sim.stats["counters"]

    start, default, counters = run()
    _, tight, _ = run(
        newton_tol=1e-12,
        max_newton=1000,
        **({} if integrator == "quasi-newton" else {"truncation_fraction": 0.0}),
    )
    fall = 0.5 * 9.81 * (steps * dt) ** 2  # 3.1 mm: the free vertices' drop so far, nearly
    assert counters["newton_iterations"] >= steps
    assert np.abs(start - tight).max() > 0.5 * fall
    # Newton's own error, far below the motion (it was all of it); quasi-Newton, converging
    # linearly, stops just inside the residual test every step, and 96 such steps add up to
    # ~1.5 % of the motion
    bound = 0.05 if integrator == "quasi-newton" else 1e-3
    assert np.abs(default - tight).max() < bound * fall


def test_a_truncated_line_search_step_does_not_count_as_converged():
    # A step so large that the first iterations backtrack: the old move-based rule called the
    # halved steps converged; the residual rule iterates on to the tolerance.
    sim = yore.scenes.hanging_cloth(
        resolution=7,
        integrator="implicit",
        dt=0.5,
        projection="clamp",
        newton_tol=1e-8,
        max_newton=500,
        truncation_fraction=0.0,
    )
    sim.step(2)
    counters = sim.stats["counters"]
    assert counters["line_search_backtracks"] > 0
    assert counters["unconverged_steps"] == 0 and counters["last_scaled_residual"] <= 1e-8


@pytest.mark.slow
def test_gathered_cloth_takes_few_newton_iterations_and_rejects_few_exact_hessians():
    # counts are deterministic: the iteration target of the default Newton as a count
    # (the first step, from the flat gathered start, needs ~100 iterations: max_newton 500)
    sim = yore.scenes.hanging_cloth(
        resolution=12, integrator="implicit", newton_tol=1e-3, max_newton=500
    )
    per_step = []
    for _ in range(60):
        before = sim.stats["counters"]["newton_iterations"]
        sim.step()
        per_step.append(sim.stats["counters"]["newton_iterations"] - before)
    counters = sim.stats["counters"]
    assert np.median(per_step) <= 5, per_step
    assert counters["exact_hessian_rejected"] <= 0.5 * 60
    assert counters["unconverged_steps"] == 0


def damped_chain(damping):
    # horizontal at the start: it swings down, so the spring directions turn during a step
    V = np.array([[0.2 * i, 0.0, 0.0] for i in range(6)])
    cloth = yore.Cloth.from_springs(
        V, [[i, i + 1] for i in range(5)], masses=0.05, stiffness=200.0, damping=damping
    )
    cloth.fix([0])
    return cloth


def chain_positions(integrator, steps, damping, seconds=0.5):
    sim = yore.Simulation(
        damped_chain(damping),
        integrator=integrator,
        dt=seconds / steps,
        newton_tol=1e-12,
        max_newton=200,
    )
    sim.step(steps)
    return sim.cloth.positions


def test_bdf2_is_second_order_with_spring_damping():
    # damping along the predicted directions (an O(h²) extrapolation of the end-of-step ones)
    reference = chain_positions("bdf2", 6400, 0.5)
    steps = np.array([100, 200, 400])
    errors = [np.abs(chain_positions("bdf2", n, 0.5) - reference).max() for n in steps]
    order = -np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert order >= 1.9, (order, errors)


def spinning_cloth_angular_momentum(integrator, damping):
    V, F = yore.grid_mesh(9, 9, width=1.0, height=1.0)
    cloth = yore.Cloth(
        V - V.mean(axis=0),
        F,
        masses=1 / 81,
        stretch_stiffness=200.0,
        bend_stiffness=20.0,
        damping=damping,
    )
    omega = np.array([0.0, 0.0, 2 * math.pi])  # one turn a second about the normal, all free
    cloth.velocities = np.cross(omega, cloth.positions)

    def angular_momentum():
        x, v, m = cloth.positions, cloth.velocities, cloth.masses[:, None]
        centre = (m * x).sum(axis=0) / m.sum()
        return (m * np.cross(x - centre, v)).sum(axis=0)[2]

    before = angular_momentum()
    sim = yore.Simulation(
        cloth, integrator=integrator, dt=1 / 60, gravity=NO_GRAVITY, newton_tol=1e-10
    )
    sim.advance(1.0, progress=False)
    return angular_momentum() / before


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["implicit", "bdf2"])
def test_spring_damping_leaves_a_rigid_spin_alone(integrator):
    undamped = spinning_cloth_angular_momentum(integrator, 0.0)
    damped = spinning_cloth_angular_momentum(integrator, 2.0)
    assert damped >= 0.99 * undamped, (damped, undamped)


@pytest.mark.parametrize("projection", ["clamp", "abs", "exact", "trust-region", "shifted"])
def test_every_projection_converges_and_exact_reaches_the_clamps_step(projection):
    def run(projection):
        sim = yore.scenes.hanging_cloth(
            resolution=7,
            integrator="implicit",
            newton_tol=1e-10,
            max_newton=1000,
            projection=projection,
            truncation_fraction=0.0,
            mixed=False,
        )
        sim.step(5)
        assert sim.stats["counters"]["unconverged_steps"] == 0
        return sim.cloth.positions

    positions = run(projection)
    if projection == "exact":  # abs and trust-region may settle the buckled start elsewhere
        assert np.abs(positions - run("clamp")).max() < 1e-8


def gathered_iterations(projection, resolution=12, steps=30):
    # the projections compared under the residual test alone, with the springs' actual forces
    sim = yore.scenes.hanging_cloth(
        resolution=resolution,
        integrator="implicit",
        dt=1 / 60,
        projection=projection,
        truncation_fraction=0.0,
        mixed=False,
    )
    sim.step(steps)
    return sim


@pytest.mark.slow
def test_shifted_projection_keeps_the_exact_curvature_and_beats_the_clamp():
    # Counts are deterministic. Levenberg–Marquardt on the exact Hessian: the gathered cloth's
    # compressed springs make it indefinite (rejected, then shifted factorizations), and
    # keeping their curvature takes far fewer iterations than clamping it away.
    shifted = gathered_iterations("shifted").stats["counters"]
    clamp = gathered_iterations("clamp").stats["counters"]
    assert shifted["exact_hessian_rejected"] > 0 and shifted["shifted_factorizations"] > 0
    assert shifted["exact_hessian_accepted"] > 0  # μ returns to 0 near a minimum
    assert shifted["newton_iterations"] < 0.5 * clamp["newton_iterations"]
    assert clamp["exact_hessian_rejected"] == clamp["shifted_factorizations"] == 0


def test_shifted_projection_on_a_convex_step_is_plain_newton():
    # a cloth stretched by gravity from its rest shape: the exact Hessian is SPD, μ stays 0
    cloth = yore.Cloth(
        *yore.grid_mesh(6, 6), masses=0.01, stretch_stiffness=200.0, bend_stiffness=0.0
    )
    cloth.fix([30, 35])
    sim = yore.Simulation(cloth, integrator="implicit", dt=1 / 60, projection="shifted")
    sim.step(1)
    counters = sim.stats["counters"]
    assert counters["exact_hessian_rejected"] == counters["shifted_factorizations"] == 0
    assert counters["exact_hessian_accepted"] == counters["newton_iterations"] > 0
    assert sim.state()["projection_memory"]["shift"] == 0.0


def test_shifted_projection_resumes_with_its_shift():
    def gathered():
        # every spring 20 % compressed: the steps end with the shift still up (μ ≈ 3–14)
        V, F = yore.grid_mesh(8, 8, width=0.4, height=0.4)
        cloth = yore.Cloth(V, F, masses=0.005, stretch_stiffness=100.0, bend_stiffness=100.0)
        cloth.springs.rest = 1.2 * cloth.springs.rest
        cloth.fix([0, 7])
        return yore.Simulation(cloth, integrator="implicit", dt=1 / 60, projection="shifted")

    straight = gathered()
    straight.step(6)
    sim = gathered()
    sim.step(1)
    state = sim.state()
    assert state["projection_memory"]["shift"] > 0.0  # the compressed start ends shifted
    resumed = yore.Simulation.from_state(state)
    resumed.step(5)
    assert np.array_equal(resumed.cloth.positions, straight.cloth.positions)
    unshifted = {**state["projection_memory"], "shift": 0.0}
    forgetful = yore.Simulation.from_state({**state, "projection_memory": unshifted})
    forgetful.step(5)
    assert not np.array_equal(forgetful.cloth.positions, straight.cloth.positions)
    bad = {**state, "projection_memory": {**state["projection_memory"], "shift": -1.0}}
    with pytest.raises(ValueError, match="shift"):
        yore.Simulation.from_state(bad)


@pytest.mark.slow
def test_steihaug_throws_no_factorization_away_on_a_buckling_cloth():
    # Counts are deterministic. The gathered cloth's compressed springs make the exact Hessian
    # indefinite: the shifted projection throws factorizations away, trust-region Newton–CG
    # factors only the clamped Hessian (SPD) and solves a refused step again on that factor.
    steihaug = gathered_iterations("steihaug").stats["counters"]
    shifted = gathered_iterations("shifted").stats["counters"]
    assert shifted["factorizations_thrown_away"] > 0
    assert steihaug["factorizations_thrown_away"] == steihaug["exact_hessian_rejected"] == 0
    assert steihaug["unconverged_steps"] == 0
    # it met negative curvature and refused steps, each solved again on the kept factor
    assert steihaug["negative_curvature_steps"] > 0 and steihaug["trust_region_rejections"] > 0
    assert steihaug["factor_reuses"] == steihaug["trust_region_rejections"]
    assert steihaug["newton_iterations"] == (steihaug["factorizations"] + steihaug["factor_reuses"])
    assert steihaug["trust_region_cg_iterations"] > 0
    assert steihaug["factorizations"] < shifted["factorizations"]


def test_steihaug_on_a_convex_step_is_plain_newton():
    # A chain pulled taut by gravity from its rest shape: no spring compressed, so the clamped
    # Hessian is the exact one, each subproblem is one solve (no CG iteration) and the iterates
    # are Newton's, as the clamp projection's full steps.
    def chain(projection):
        n = 8
        V = np.column_stack([np.linspace(0.0, 0.7, n), np.zeros(n), np.zeros(n)])
        edges = np.column_stack([np.arange(n - 1), np.arange(1, n)]).astype(np.int32)
        cloth = yore.Cloth.from_springs(V, edges, masses=1e-3, stiffness=1e3, damping=0.0)
        cloth.fix([0])
        sim = yore.Simulation(
            cloth, integrator="implicit", dt=1 / 60, projection=projection, mixed=False
        )
        sim.step(3)
        return sim

    steihaug, clamp = chain("steihaug"), chain("clamp")
    counters = steihaug.stats["counters"]
    assert counters["trust_region_cg_iterations"] == 0
    assert counters["trust_region_rejections"] == counters["negative_curvature_steps"] == 0
    assert clamp.stats["counters"]["line_search_backtracks"] == 0
    assert counters["newton_iterations"] == clamp.stats["counters"]["newton_iterations"]
    assert np.abs(steihaug.cloth.positions - clamp.cloth.positions).max() < 1e-12


def test_steihaug_and_shifted_agree_when_solved_tight():
    # Two minimisers of the same potential: where the step's minimum is unique (no gathered
    # start) they reach it to solver round-off; CG's inexact solves only change the path.
    X = {}
    for projection in ("steihaug", "shifted"):
        sim = yore.scenes.hanging_cloth(
            resolution=9,
            integrator="implicit",
            dt=0.02,
            pin_spacing=1.0,
            newton_tol=1e-10,
            projection=projection,
            truncation_fraction=0.0,
        )
        sim.step(10)
        assert sim.stats["counters"]["unconverged_steps"] == 0
        X[projection] = sim.cloth.positions
    assert np.abs(X["steihaug"] - X["shifted"]).max() < 1e-9


def test_steihaug_resumes_with_its_trust_radius():
    def gathered():
        return yore.scenes.hanging_cloth(
            resolution=8, integrator="bdf2", dt=1 / 60, projection="steihaug"
        )

    straight = gathered()
    straight.step(6)
    sim = gathered()
    sim.step(2)
    state = sim.state()
    assert state["projection_memory"]["radius"] > 0.0
    resumed = yore.Simulation.from_state(state)
    resumed.step(4)
    assert np.array_equal(resumed.cloth.positions, straight.cloth.positions)
    forgetful = yore.Simulation.from_state(
        {**state, "projection_memory": {**state["projection_memory"], "radius": 0.0}}
    )
    forgetful.step(4)
    assert not np.array_equal(forgetful.cloth.positions, straight.cloth.positions)
    bad = {**state, "projection_memory": {**state["projection_memory"], "radius": -1.0}}
    with pytest.raises(ValueError, match="radius"):
        yore.Simulation.from_state(bad)


def test_projection_options_are_checked():
    cloth = yore.Cloth(*yore.grid_mesh(3, 3))
    with pytest.raises(
        ValueError, match="valid: clamp, abs, exact, trust-region, shifted, steihaug"
    ):
        yore.Simulation(cloth, integrator="implicit", projection="none")
    with pytest.raises(ValueError, match="contradicts"):
        yore.Simulation(cloth, integrator="implicit", projection="clamp", adaptive_projection=True)
    with pytest.raises(ValueError, match="Cholesky"):
        yore.Simulation(cloth, integrator="implicit", solver="pcg", projection="exact")
    with pytest.raises(ValueError, match="Cholesky"):
        yore.Simulation(cloth, integrator="implicit", solver="pcg", projection="shifted")
    with pytest.raises(ValueError, match="Cholesky"):
        yore.Simulation(cloth, integrator="implicit", solver="pcg", projection="steihaug")
    with pytest.raises(ValueError, match="is not linearized"):
        yore.Simulation(cloth, integrator="implicit", linearized=True, projection="steihaug")


def _stiff_chain(**options):
    """A horizontal chain of 10 stiff springs (1e5 N/m, 1 g per vertex, 0.1 m each) fixed at
    one end, about to swing down: every spring stretches, so the clamp is the exact Hessian
    and Newton converges quadratically near the step's solution. The truncation test is off
    unless given (the step and residual tests are the subject)."""
    options.setdefault("truncation_fraction", 0.0)
    n = 11
    V = np.column_stack([np.linspace(0.0, 1.0, n), np.zeros(n), np.zeros(n)])
    edges = np.column_stack([np.arange(n - 1), np.arange(1, n)]).astype(np.int32)
    chain = yore.Cloth.from_springs(V, edges, masses=1e-3, stiffness=1e5, damping=0.0)
    chain.fix([0])
    return yore.Simulation(chain, integrator="implicit", dt=1 / 60, projection="clamp", **options)


def test_the_step_test_stops_within_its_distance_of_the_solution():
    # Reference: the same step solved to a residual 1e5 times tighter than the default.
    tight = _stiff_chain(newton_tol=1e-10, max_newton=200)
    tight.step()
    residual_only = _stiff_chain()
    residual_only.step()
    stepped = _stiff_chain(step_tol=1e-3)
    stepped.step()
    counters = stepped.stats["counters"]
    assert counters["step_test_stops"] == 1 and counters["unconverged_steps"] == 0
    # the residual test (inertia-scaled) asks for more than the step test on stiff springs
    assert counters["newton_iterations"] < residual_only.stats["counters"]["newton_iterations"]
    # Near the solution Newton converges quadratically: after a full step of at most
    # step_tol × L (L = 0.1 m) the iterate is much closer than that to the solution.
    distance = np.abs(stepped.cloth.positions - tight.cloth.positions).max()
    assert distance <= 1e-3 * 0.1
    # and it did move: the chain fell (the check is not vacuous)
    assert tight.cloth.positions[:, 1].min() < -1e-3


def test_step_tol_off_by_default_and_checked():
    sim = _stiff_chain()
    sim.step()
    assert sim.stats["counters"]["step_test_stops"] == 0
    with pytest.raises(ValueError, match="step_tol"):
        _stiff_chain(step_tol=-1e-3)
    with pytest.raises(ValueError, match="step_tol"):
        _stiff_chain(step_tol=float("nan"))


def test_supernode_sizes_of_a_factor_that_is_one_dense_block():
    # Two free vertices joined to each other and to a fixed one: all 6 unknowns couple, so the
    # supernodal factor is a single 6-column supernode with no rows below it; the simplicial
    # factor has none.
    positions = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]])
    for factorization, expected in (("supernodal", (6.0, 0.0)), ("simplicial", (0.0, 0.0))):
        cloth = yore.Cloth(positions, np.array([[0, 1, 2]]), masses=0.01)
        cloth.fix([0])
        sim = yore.Simulation(cloth, integrator="implicit", factorization=factorization)
        sim.step(1)
        counters = sim.stats["counters"]
        assert (
            counters["supernode_median_columns"],
            counters["supernode_median_rows"],
        ) == expected, factorization


EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))


@pytest.mark.slow
@pytest.mark.parametrize("method", ["implicit", "bdf2"])
@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_the_default_newton_converges_on_every_example_scene_through_its_strokes(
    path, method, tmp_path
):
    # Each example as its scene file has it (mesh, material, pins, strokes) but stepped by the
    # default Newton of `method` at 1/60 s with no [integrator] options, until 0.5 s after its
    # last stroke: every step converges at newton_tol or stops on the truncation test (a step
    # at max_newton would count in unconverged_steps and warn, and a warning is an error here).
    scene = yore.runs.load_scene(path)
    last = max((s["time"] for s in scene.data.get("strokes", [])), default=0.0)
    assert last > 0.0, "every example has a stroke: the test covers a topology change"
    overrides = {
        "simulation.integrator": method,
        "integrator": {},
        "simulation.dt": 1 / 60,
        "simulation.duration": last + 0.5,
        "output.format": "none",
        "output.pictures": False,
        "output.animation": "none",
    }
    scene = yore.runs.load_scene(path, overrides=overrides)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yore.runs.run_scene(scene, tmp_path / "run", render=False, quiet=True)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text(encoding="utf-8"))
    counters = summary["counters"]
    assert summary["finished"] and summary["steps"] == round((last + 0.5) * 60)
    assert summary["strokes"] and all(
        s["faces_split"] + s["springs_grown"] > 0 for s in summary["strokes"]
    )
    assert counters["unconverged_steps"] == 0
    assert counters["factorizations_thrown_away"] == 0
    # converged, and in few iterations: the default's mean on these scenes is 2–6 per step
    assert counters["newton_iterations"] <= 8 * summary["steps"]


@pytest.mark.parametrize("method", ["implicit", "bdf2"])
@pytest.mark.parametrize("scene", ["hanging_cloth", "rotating_cylinder"])
def test_the_default_newton_converges_on_the_scenes_soft_and_stiff(scene, method):
    for stiffness in (200.0, 2e4):
        sim = getattr(yore.scenes, scene)(
            integrator=method, dt=1 / 60, stretch_stiffness=stiffness, bend_stiffness=stiffness
        )
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            sim.advance(1.0)
        counters = sim.stats["counters"]
        assert counters["unconverged_steps"] == 0, stiffness
        assert counters["factorizations_thrown_away"] == 0, stiffness
        assert counters["newton_iterations"] <= 8 * 60, stiffness


def test_a_step_that_gains_energy_is_redone_to_the_residual_test():
    # With damping and drag nothing feeds a cloth energy; a step whose energy rises past the
    # growth check's allowance was stopped short of its solution by Newton's early stops, and
    # is redone once with them off before the call fails. A damped stiff 24² sheet at 1/32 s
    # with the loosest truncation test gains at its 22nd step (measured).
    def make(**options):
        return yore.scenes.hanging_cloth(
            resolution=24,
            pin_spacing=1.0,
            mass=0.1,
            stretch_stiffness=2e5,
            bend_stiffness=2e5,
            damping=1.0,
            integrator="bdf2",
            dt=1 / 32,
            **options,
        )

    loose = make(truncation_fraction=1.0, energy_growth_tolerance=1e-3)
    for _ in range(64):
        before = loose.state()
        loose.step(1, progress=False)
        if loose.stats["counters"]["energy_retries"]:
            break
    assert loose.stats["counters"]["energy_retries"] == 1

    def one_step_from(state, **changes):
        state = {**state, "options": {**state["options"], **changes}}
        sim = yore.Simulation.from_state(state)
        sim.step(1, progress=False)
        return sim

    # the redone step is the step with the early stops off, bit for bit, from the same start
    tight = one_step_from(before, truncation_fraction=0.0)
    assert np.array_equal(loose.cloth.positions, tight.cloth.positions)
    assert np.array_equal(loose.cloth.velocities, tight.cloth.velocities)
    assert tight.stats["counters"]["energy_retries"] == 0
    # and it mattered: the step as first taken (the check off, so no redo) ends with more energy
    first = one_step_from(before, energy_growth_tolerance=0.0)
    assert first.stats["counters"]["energy_retries"] == 0
    assert first.energy()["total"] > loose.energy()["total"]
    assert not np.array_equal(first.cloth.positions, loose.cloth.positions)
