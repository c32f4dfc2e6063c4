"""Symplectic Euler against analytic solutions and conservation laws."""

import math
from pathlib import Path

import numpy as np
import pytest

import yore

NO_GRAVITY = (0.0, 0.0, 0.0)


def oscillator(mass=0.2, stiffness=50.0, rest=1.0, amplitude=0.1, damping=0.0):
    """One mass on a spring whose other end is fixed; returns the cloth (mass is vertex 1)."""
    V = np.array([[0.0, 0.0, 0.0], [0.0, -(rest + amplitude), 0.0]])
    cloth = yore.Cloth.from_springs(
        V, [[0, 1]], rest_lengths=[rest], masses=mass, stiffness=stiffness, damping=damping
    )
    cloth.fix([0])
    return cloth


def trajectory(sim, steps):
    """Displacement of vertex 1 from the rest length after each of `steps` steps."""
    out = np.empty(steps + 1)
    out[0] = -sim.cloth.positions[1, 1] - 1.0
    for n in range(steps):
        sim.step()
        out[n + 1] = -sim.cloth.positions[1, 1] - 1.0
    return out


def test_oscillator_period_matches_analytic_within_one_percent():
    m, k = 0.2, 50.0
    period = 2 * math.pi * math.sqrt(m / k)
    dt = period / 400
    sim = yore.Simulation(oscillator(m, k), dt=dt, gravity=NO_GRAVITY)
    u = trajectory(sim, 400 * 10)
    # downward zero crossings, linearly interpolated
    idx = np.nonzero((u[:-1] > 0) & (u[1:] <= 0))[0]
    crossings = (idx + u[idx] / (u[idx] - u[idx + 1])) * dt
    measured = np.mean(np.diff(crossings))
    assert len(crossings) >= 9
    assert abs(measured - period) / period < 0.01


def test_oscillator_error_is_first_order_in_dt():
    m, k, a = 0.2, 50.0, 0.1
    omega = math.sqrt(k / m)
    period = 2 * math.pi / omega
    errors = []
    for per_period in (100, 200, 400):
        dt = period / per_period
        sim = yore.Simulation(oscillator(m, k, amplitude=a), dt=dt, gravity=NO_GRAVITY)
        u = trajectory(sim, per_period)
        t = dt * np.arange(per_period + 1)
        errors.append(np.abs(u - a * np.cos(omega * t)).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    # symplectic Euler: global error ≈ a·ω·dt/2, so halving dt halves it
    assert np.all((ratios > 1.8) & (ratios < 2.2)), ratios
    assert errors[0] == pytest.approx(a * omega * (period / 100) / 2, rel=0.15)


def test_stable_dt_estimate_is_exact_for_one_spring_and_marks_the_stability_edge():
    m, k, c = 0.2, 50.0, 0.3
    cloth = oscillator(m, k)
    assert cloth.stable_time_step() == pytest.approx(2 * math.sqrt(m / k), rel=1e-14)
    # with damping the edge of symplectic Euler is h²ω² + 2hγ = 4, γ = c/m
    damped = oscillator(m, k, damping=c)
    gamma, w2 = c / m, k / m
    edge = (math.sqrt(gamma**2 + 4 * w2) - gamma) / w2
    assert damped.stable_time_step() == pytest.approx(edge, rel=1e-14)
    for make in (lambda: oscillator(m, k), lambda: oscillator(m, k, damping=c)):
        below = yore.Simulation(make(), dt=0.95 * make().stable_time_step(), gravity=NO_GRAVITY)
        u = np.abs(trajectory(below, 4000))
        # no growth (1e-3: the sampled peak of a closed orbit varies slightly between windows)
        assert u[-1000:].max() <= u[:1000].max() * (1 + 1e-3)
        above = yore.Simulation(make(), dt=1.05 * make().stable_time_step(), gravity=NO_GRAVITY)
        with pytest.raises(yore.SimulationDiverged):
            above.step(2000)


def test_all_three_stable_dt_estimates_are_exact_for_one_spring():
    m, k, c = 0.2, 50.0, 0.3
    for cloth in (oscillator(m, k), oscillator(m, k, damping=c)):
        exact = cloth.stable_time_step()
        assert cloth.stable_time_step_bound() == pytest.approx(exact, rel=1e-12)
        assert cloth.gershgorin_time_step() == pytest.approx(exact, rel=1e-12)


def _survives(make, dt, steps):
    """Counted, not timed: `steps` steps at `dt` without the divergence monitor firing."""
    try:
        make(dt).step(steps, progress=False)
    except yore.SimulationDiverged:
        return False
    return True


def _largest_stable_dt(make, low, high, steps=300, iterations=12):
    """Bisection between a stable `low` and an unstable `high` (both checked)."""
    assert _survives(make, low, steps) and not _survives(make, high, steps)
    for _ in range(iterations):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if _survives(make, middle, steps) else (low, middle)
    return low


SMALL_SCENES = {
    "hanging": lambda dt, **kw: yore.scenes.hanging_cloth(resolution=9, dt=dt, **kw),
    "hanging stiff": lambda dt, **kw: yore.scenes.hanging_cloth(
        resolution=9, stretch_stiffness=2e4, bend_stiffness=2e4, dt=dt, **kw
    ),
    "hanging undamped": lambda dt, **kw: yore.scenes.hanging_cloth(
        resolution=9, damping=0.0, drag=0.0, dt=dt, **kw
    ),
    "cylinder": lambda dt, **kw: yore.scenes.rotating_cylinder(rings=5, segments=12, dt=dt, **kw),
    "cylinder stiff undamped": lambda dt, **kw: yore.scenes.rotating_cylinder(
        rings=5,
        segments=12,
        stretch_stiffness=2e3,
        bend_stiffness=2e3,
        damping=0.0,
        drag=0.0,
        dt=dt,
        **kw,
    ),
}


@pytest.mark.parametrize("name", sorted(SMALL_SCENES))
def test_stable_dt_estimates_against_the_limit_found_by_bisection(name):
    make = SMALL_SCENES[name]
    probe = make(None)
    cloth = probe.cloth
    gershgorin = cloth.gershgorin_time_step()
    bound = cloth.stable_time_step_bound()
    estimate = cloth.stable_time_step()
    found = _largest_stable_dt(make, gershgorin, 1.5 * estimate)
    # Gershgorin <= the state-independent Laplacian bound <= the limit <= ...
    assert gershgorin <= bound * (1 + 1e-12)
    assert bound <= found
    # ... and the current-state Lanczos estimate is tight
    assert 0.95 * found <= estimate <= 1.05 * found, (estimate, found)
    # the default explicit dt (0.98 × the bound) is below the limit and within 30 % of it
    assert 0.7 * found <= probe.dt < found, (probe.dt, found)
    assert probe.dt == yore.simulation.default_explicit_dt(cloth)


@pytest.mark.slow
def test_the_demo_scene_runs_its_whole_duration_at_the_default_dt(tmp_path):
    from yore.runs import run_scene

    scene = yore.load_scene(Path(__file__).resolve().parents[1] / "examples" / "hanging_paper.toml")
    sim, _ = scene.build()
    assert sim.integrator == "explicit"
    assert sim.dt == yore.simulation.default_explicit_dt(sim.cloth)
    # through its stroke at 1.5 s (lighter vertices, compressed springs) to its end at 3 s
    run_scene(scene, tmp_path / "out", quiet=True, render=False)
    assert (tmp_path / "out").exists()


def small_cloth(damping=0.0, seed=1):
    V, F = yore.grid_mesh(8, 8, width=0.5, height=0.5)
    cloth = yore.Cloth(
        V, F, masses=0.01, stretch_stiffness=50.0, bend_stiffness=50.0, damping=damping
    )
    rng = np.random.default_rng(seed)
    # a smooth out-of-plane bump plus small in-plane noise: all modes excited, no rigid motion
    bump = 0.05 * np.sin(np.pi * V[:, 0] / 0.5) * np.sin(np.pi * V[:, 1] / 0.5)
    cloth.positions = V + np.column_stack([rng.normal(0, 2e-3, (len(V), 2)), bump])
    cloth.fix([0, 7, 56, 63])
    return cloth


def energy_history(sim, steps, every=1):
    out = []
    for _ in range(steps // every):
        sim.step(every)
        out.append(sim.energy()["total"])
    return np.array(out)


def test_undamped_energy_stays_bounded_without_drift():
    cloth = small_cloth()
    dt = 0.1 * cloth.stable_time_step()
    sim = yore.Simulation(cloth, dt=dt)
    e0 = sim.energy()["total"]
    scale = sim.energy()["spring"]  # the energy that sloshes between kinetic and elastic
    history = energy_history(sim, 2000)
    # Symplectic Euler conserves a shadow energy within O(ω h) of the true one: for a mode of
    # frequency ω the energy oscillates by at most ≈ ω h / 2 of its own energy, and ω h ≤ 0.2 at
    # dt = 0.1 × stable (the estimate is 2 / ω_max bound). The error oscillates, it does not drift.
    omega_h = 2.0 * dt / cloth.stable_time_step()
    assert np.abs(history - e0).max() < 0.5 * omega_h * scale
    drift = history[-500:].mean() - history[:500].mean()
    assert abs(drift) < 0.1 * np.abs(history - e0).max()


def test_energy_error_halves_with_dt():
    deviations = []
    for fraction in (0.2, 0.1):
        cloth = small_cloth()
        sim = yore.Simulation(cloth, dt=fraction * cloth.stable_time_step())
        e0 = sim.energy()["total"]
        history = energy_history(sim, int(400 / fraction))
        deviations.append(np.abs(history - e0).max())
    assert 1.6 < deviations[0] / deviations[1] < 2.5


def test_damping_dissipates_energy():
    cloth = small_cloth(damping=0.05)
    sim = yore.Simulation(cloth, dt=0.1 * cloth.stable_time_step())
    e0 = sim.energy()["total"]
    history = energy_history(sim, 4000, every=10)
    undamped_swing = 0.02 * small_cloth().energy((0, -9.81, 0))["spring"]
    assert history.max() < e0 + undamped_swing
    # energy above the static minimum is dissipated
    assert history[-1] < e0 - 0.5 * (e0 - history.min())
    assert np.all(np.diff(history[::40]) < 0)


def test_free_cloth_conserves_linear_momentum_to_round_off():
    V, F = yore.cylinder_mesh(0.2, 0.3, 5, 12)
    rng = np.random.default_rng(3)
    masses = rng.uniform(0.005, 0.02, len(V))
    cloth = yore.Cloth(
        V, F, masses=masses, stretch_stiffness=80.0, bend_stiffness=20.0, damping=0.02
    )
    cloth.velocities = rng.normal(0.0, 0.5, (len(V), 3))
    p0 = masses @ cloth.velocities
    scale = masses @ np.linalg.norm(cloth.velocities, axis=1)
    sim = yore.Simulation(cloth, dt=0.3 * cloth.stable_time_step(), gravity=NO_GRAVITY)
    sim.step(1000)
    p1 = masses @ sim.cloth.velocities
    # pairwise equal and opposite spring forces: only summation round-off remains
    assert np.abs(p1 - p0).max() < 1e-12 * scale
    assert not np.allclose(sim.cloth.velocities, 0)


def test_strain_limiting_conserves_momentum_and_caps_stretch():
    V, F = yore.grid_mesh(6, 6, width=0.5, height=0.5)
    cloth = yore.Cloth(V, F, masses=0.01, stretch_stiffness=5.0, bend_stiffness=0.0)
    rng = np.random.default_rng(5)
    cloth.velocities = rng.normal(0.0, 2.0, (len(V), 3))
    p0 = cloth.masses @ cloth.velocities
    sim = yore.Simulation(
        cloth,
        dt=0.2 * cloth.stable_time_step(),
        gravity=NO_GRAVITY,
        strain_limit=1.1,
        strain_limit_passes=50,
    )
    sim.step(200)
    X, ends, rest = sim.cloth.positions, sim.cloth.springs.ends, sim.cloth.springs.rest
    ratio = np.linalg.norm(X[ends[:, 0]] - X[ends[:, 1]], axis=1) / rest
    assert ratio.max() < 1.1 * (1 + 1e-3)
    assert sim.stats["counters"]["strain_corrections"] > 0
    p1 = sim.cloth.masses @ sim.cloth.velocities
    assert np.abs(p1 - p0).max() < 1e-10 * np.abs(cloth.masses @ np.abs(cloth.velocities)).max()
    # without limiting the same run stretches further
    free = yore.Cloth(V, F, masses=0.01, stretch_stiffness=5.0, bend_stiffness=0.0)
    free.velocities = cloth.velocities
    loose = yore.Simulation(free, dt=sim.dt, gravity=NO_GRAVITY)
    loose.step(200)
    Y = loose.cloth.positions
    assert (np.linalg.norm(Y[ends[:, 0]] - Y[ends[:, 1]], axis=1) / rest).max() > 1.15


def test_hanging_chain_settles_to_the_exact_static_stretch():
    count, m, k, g = 10, 0.01, 10.0, 9.81
    V = np.column_stack([np.zeros(count + 1), -0.1 * np.arange(count + 1), np.zeros(count + 1)])
    edges = np.column_stack([np.arange(count), np.arange(1, count + 1)])
    # drag damps every mode, spring damping the fast ones; neither changes the equilibrium
    chain = yore.Cloth.from_springs(V, edges, masses=m, stiffness=k, damping=0.05, drag=10.0)
    chain.fix([0])
    sim = yore.Simulation(chain, dt=2e-3, gravity=(0.0, -g, 0.0))
    sim.advance(10.0)
    X = sim.cloth.positions
    stretch = np.linalg.norm(X[1:] - X[:-1], axis=1) - 0.1
    below = count - np.arange(count)  # masses hanging below each spring
    expected = below * m * g / k
    assert np.abs(stretch - expected).max() < 1e-6 * expected.min()
    assert np.abs(X[:, [0, 2]]).max() == 0.0  # stays on the vertical line


def test_dt_far_above_the_estimate_raises_with_a_suggestion_and_restores_the_state():
    sim = yore.scenes.hanging_cloth(resolution=9)
    sim.step(10)
    stable = sim.stable_dt()
    bad = yore.Simulation(sim.cloth, dt=20 * stable)
    before = sim.cloth.positions.copy(), sim.time
    with pytest.raises(yore.SimulationDiverged) as info:
        bad.step(500)
    error = info.value
    assert isinstance(error, RuntimeError)
    # the estimate at the state the failing batch started from (the tight estimate depends on
    # the state: a stretched cloth has a lower limit), never below the state-independent bound
    assert sim.cloth.stable_time_step_bound() * (1 - 1e-9) <= error.stable_dt <= 1.5 * stable
    assert error.dt == pytest.approx(20 * stable)
    assert error.step >= 0 and error.time > before[1]
    assert "stable time step" in str(error) and "dt <=" in str(error)
    assert "restored to t = " in str(error)
    # the cloth is back at its state before the failing call, bit for bit
    assert np.array_equal(sim.cloth.positions, before[0]) and sim.time == before[1]
    assert np.all(np.isfinite(sim.cloth.velocities))


def test_fixed_vertices_never_move_and_constrained_velocities_are_kept():
    cloth = small_cloth()
    fixed = cloth.fixed_vertices
    before = cloth.positions[fixed].copy()
    sim = yore.Simulation(cloth, dt=0.2 * cloth.stable_time_step())
    sim.step(300)
    assert np.array_equal(sim.cloth.positions[fixed], before)
    assert np.array_equal(sim.cloth.velocities[fixed], np.zeros_like(before))
