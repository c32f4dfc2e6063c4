"""Saving and restoring: Cloth.state / from_state, pickle, state files, and bit-exact resume."""

import pickle

import numpy as np
import pytest

import yore


def stroked_hanging(integrator="explicit", **options):
    sim = yore.scenes.hanging_cloth(resolution=9, integrator=integrator, **options)
    sim.step(5)
    sim.stroke_material([[0.2, 0.3], [0.8, 0.45]])
    return sim


def assert_same_state(a, b):
    assert a.keys() == b.keys()
    for key in a:
        if key == "drivers":
            assert len(a[key]) == len(b[key])
            for da, db in zip(a[key], b[key]):
                for name in da:
                    assert np.array_equal(da[name], db[name]), f"driver {name}"
        elif isinstance(a[key], np.ndarray):
            assert a[key].dtype == b[key].dtype, key
            assert np.array_equal(a[key], b[key]), key
        else:
            assert a[key] == b[key], key


def test_cloth_state_round_trips_exactly_after_a_stroke_and_with_drivers():
    for sim in (stroked_hanging(), yore.scenes.rotating_cylinder(rings=5, segments=8)):
        sim.step(3)
        state = sim.cloth.state()
        copy = yore.Cloth.from_state(state)
        assert_same_state(state, copy.state())
        assert copy.topology_version != sim.cloth.topology_version  # caches cannot mix them up
        assert_same_state(state, pickle.loads(pickle.dumps(sim.cloth)).state())


def test_clock_does_not_depend_on_how_a_run_is_split():
    # origin + steps × dt: the same bits whether 100 steps come as one call or as 37 + 63.
    a = yore.scenes.rotating_cylinder(rings=5, segments=8)
    b = yore.scenes.rotating_cylinder(rings=5, segments=8)
    a.step(100)
    b.step(37)
    b.step(63)
    assert a.time == b.time == 100 * a.dt
    assert np.array_equal(a.cloth.positions, b.cloth.positions)


@pytest.mark.parametrize("integrator", ["explicit", "implicit", "bdf2", "local-global"])
def test_a_restored_simulation_continues_bit_for_bit(tmp_path, integrator):
    straight = stroked_hanging(integrator)
    resumed = stroked_hanging(integrator)
    straight.step(12)
    resumed.step(5)
    path = yore.save_state(tmp_path / "state.npz", resumed, metadata={"note": [1, 2.5]})
    del resumed
    restored, metadata = yore.load_state(path)
    assert metadata == {"note": [1, 2.5]}
    assert restored.integrator == integrator and restored.options == straight.options
    restored.step(7)
    assert restored.time == straight.time
    assert np.array_equal(restored.cloth.positions, straight.cloth.positions)
    assert np.array_equal(restored.cloth.velocities, straight.cloth.velocities)


def test_bdf2_history_is_what_makes_the_resume_exact():
    # Without its one-step history BDF2 restarts with a backward-Euler step: a different result.
    straight = stroked_hanging("bdf2")
    straight.step(8)
    sim = stroked_hanging("bdf2")
    sim.step(4)
    state = sim.state()
    assert state["history"] is not None
    state["history"] = None
    forgetful = yore.Simulation.from_state(state)
    forgetful.step(4)
    assert not np.array_equal(forgetful.cloth.positions, straight.cloth.positions)


def test_bad_states_and_files_are_value_errors_naming_the_problem(tmp_path):
    state = stroked_hanging().cloth.state()
    with pytest.raises(ValueError, match="unknown key"):
        yore.Cloth.from_state({**state, "colour": 1})
    with pytest.raises(ValueError, match="missing key.*masses"):
        yore.Cloth.from_state({k: v for k, v in state.items() if k != "masses"})
    ends = state["spring_ends"].copy()
    ends[3, 1] = 10_000
    with pytest.raises(ValueError, match="spring 3"):
        yore.Cloth.from_state({**state, "spring_ends": ends})
    rest = state["spring_rest"].copy()
    rest[2] = np.nan
    with pytest.raises(ValueError, match="spring 2"):
        yore.Cloth.from_state({**state, "spring_rest": rest})
    vertex_states = state["vertex_states"].copy()
    vertex_states[4] = 2  # driven, but no driver moves it
    with pytest.raises(ValueError, match="vertex 4"):
        yore.Cloth.from_state({**state, "vertex_states": vertex_states})
    with pytest.raises(ValueError, match="does not exist"):
        yore.load_state(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a yore state"):
        yore.load_state(tmp_path / "other.npz")
    with pytest.raises(ValueError, match="JSON"):
        yore.save_state(tmp_path / "s.npz", stroked_hanging(), metadata={"f": object()})
