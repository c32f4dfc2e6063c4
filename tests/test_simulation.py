"""The Simulation front end: options, argument checks, stats."""

import numpy as np
import pytest

import yore


@pytest.fixture
def cloth():
    return yore.Cloth(*yore.grid_mesh(4, 4), mass=0.01)


def test_unknown_integrator_and_option_names_list_the_valid_ones(cloth):
    with pytest.raises(ValueError, match="valid: explicit, implicit, bdf2, local-global"):
        yore.Simulation(cloth, integrator="rk4")
    with pytest.raises(ValueError, match="'strain_limt'.*valid: divergence_energy_factor, "
                                         "strain_limit, strain_limit_passes"):
        yore.Simulation(cloth, strain_limt=1.1)


@pytest.mark.parametrize("dt", [-1e-3, 0.0, float("nan"), float("inf"), "fast"])
def test_bad_dt_is_a_value_error(cloth, dt):
    with pytest.raises(ValueError, match="dt"):
        yore.Simulation(cloth, dt=dt)


@pytest.mark.parametrize("gravity", [(0, -9.81), (0, float("nan"), 0)])
def test_bad_gravity_is_a_value_error(cloth, gravity):
    with pytest.raises(ValueError, match="gravity"):
        yore.Simulation(cloth, gravity=gravity)


@pytest.mark.parametrize("options, message", [({"strain_limit": 0.9}, "strain_limit"),
                                              ({"strain_limit_passes": 0}, "passes")])
def test_bad_option_values_are_value_errors(cloth, options, message):
    with pytest.raises(ValueError, match=message):
        yore.Simulation(cloth, **options)


def test_step_and_advance_check_their_arguments_and_count_time(cloth):
    sim = yore.Simulation(cloth, dt=1e-3)
    with pytest.raises(ValueError):
        sim.step(-1)
    with pytest.raises(ValueError):
        sim.step(1.5)
    with pytest.raises(ValueError):
        sim.advance(-1.0)
    assert sim.advance(0.25) == 250
    assert sim.time == pytest.approx(0.25, abs=1e-15)
    sim.step(10)
    assert sim.stats["steps"] == 260
    assert sim.time == pytest.approx(0.26, abs=1e-15)


def test_default_dt_is_stable_and_a_whole_fraction_of_a_second(cloth):
    sim = yore.Simulation(cloth)
    assert sim.dt <= 0.5 * cloth.stable_time_step()
    assert abs(1.0 / sim.dt - round(1.0 / sim.dt)) < 1e-9


def test_stats_report_active_terms_and_phase_times(cloth):
    cloth.fix([0])
    sim = yore.Simulation(cloth, dt=1e-4, gravity=(0, 0, 0))
    sim.step(100)
    stats = sim.stats
    assert stats["active_terms"] == {
        "gravity": False, "spring_damping": False, "drag": False,
        "bending_springs": int(np.count_nonzero(cloth.springs.kind == 1)),
        "strain_limiting": False, "fixed_vertices": 1, "driven_vertices": 0}
    # phases are wall time: check their names, never their values (they vary with load)
    assert set(stats["phases"]) == {"forces_seconds", "update_seconds", "constraints_seconds",
                                    "checks_seconds"}
    assert stats["steps"] == 100 and stats["counters"]["strain_corrections"] == 0
    assert stats["vertices"] == 16 and stats["springs"] == cloth.spring_count


def test_energy_terms_add_up(cloth):
    cloth.velocities = np.full((16, 3), 0.5)
    sim = yore.Simulation(cloth, dt=1e-4)
    e = sim.energy()
    assert e["total"] == pytest.approx(e["kinetic"] + e["spring"] + e["gravity"])
    assert e["kinetic"] == pytest.approx(0.5 * 0.01 * 16 * 3 * 0.25)
    assert e["gravity"] == pytest.approx(-(cloth.masses * cloth.positions[:, 1]).sum() * -9.81)


def test_build_info_names_the_linked_libraries():
    info = yore.build_info()
    assert info["eigen"].startswith("3.4")
    assert info["cholmod"].split(".")[0] == "3"  # SuiteSparse 5.x ships CHOLMOD 3
    assert info["cgal"].split(".")[0] == "5"
    assert info["threads"] >= 1


def test_thread_count_can_be_set_and_is_checked():
    before = yore.build_info()["threads"]
    yore.set_num_threads(1)
    assert yore.build_info()["threads"] == 1
    yore.set_num_threads(before)
    with pytest.raises(ValueError):
        yore.set_num_threads(0)


def test_repeated_advance_tracks_frame_times_without_drift(cloth):
    dt = 1.0 / 1150.0  # does not divide a frame of 1/30 s
    sim = yore.Simulation(cloth, dt=dt)
    for frame in range(1, 91):
        sim.advance(1.0 / 30.0)
        assert abs(sim.time - frame / 30.0) <= 0.5 * dt + 1e-12
