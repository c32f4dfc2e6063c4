"""No call sequence crashes: a cloth or an integrator in use by a call that released the GIL
refuses every other use with RuntimeError, and long core calls answer Ctrl-C.

Synchronisation is by state, never by time: the main thread runs a step that cannot finish on
its own (2**31 - 1 local/global iterations); a helper thread waits until the cloth reports busy,
tries everything, then interrupts the main thread as Ctrl-C would.
"""

import _thread
import threading

import numpy as np
import pytest

import yore


def small_cloth():
    V, F = yore.grid_mesh(5, 5, width=0.2, height=0.2)
    cloth = yore.Cloth(V, F, masses=0.005, stretch_stiffness=50.0, bend_stiffness=20.0)
    cloth.fix([0, 4])
    cloth.material_coordinates = V[:, :2]
    return cloth


def endless_simulation(integrator="local-global"):
    sim = yore.Simulation(small_cloth(), integrator=integrator, dt=1 / 60)
    # Past the Python API's cap on iterations per step (MAX_STEP_ITERATIONS), up to the core's
    # own int32 limit: a step that cannot finish on its own, which only Ctrl-C ends.
    sim._integrator = {
        "local-global": lambda: yore._core.LocalGlobalIntegrator(
            iterations=2**31 - 1, tolerance=0.0
        ),
        # a Newton solve that never converges by its own tolerance
        "implicit": lambda: yore._core.ImplicitIntegrator(
            max_newton=2**31 - 1,
            newton_tol=1e-300,
            truncation_fraction=0.0,
            adaptive_projection=False,
        ),
    }[integrator]()
    return sim


def wait_until(condition):
    # Polls a state flag; the bound only turns a broken guard into a failure instead of a hang.
    for _ in range(10**8):
        if condition():
            return True
    return False


def interrupt_while_busy(sim, attempts):
    """Runs sim.step(1) on this thread; a helper runs attempts(sim) while the cloth is busy and
    then interrupts. Returns what the helper recorded."""
    record = {}

    def helper():
        try:
            record["busy"] = wait_until(lambda: sim.cloth.busy)
            if record["busy"]:
                attempts(sim, record)
        except BaseException as error:  # reported by the test, never lost in the thread
            record["error"] = error
        finally:
            # Only a step still running may be interrupted: a Ctrl-C sent after it ended would
            # land in whatever test runs next.
            if sim.cloth.busy:
                _thread.interrupt_main()
            else:
                record.setdefault("error", AssertionError("the endless step ended on its own"))

    thread = threading.Thread(target=helper)
    thread.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            sim.step(1)
    finally:
        thread.join()
    assert record.get("busy"), "the cloth never reported busy"
    if "error" in record:
        raise record["error"]
    return record


def refused(call):
    with pytest.raises(RuntimeError, match="in use by another thread") as info:
        call()
    return str(info.value)


def test_a_busy_cloth_refuses_every_other_use_and_a_ctrl_c_undoes_the_interrupted_step():
    sim = endless_simulation()
    before = sim.cloth.state()
    V = sim.cloth.positions

    def attempts(sim, record):
        cloth = sim.cloth
        record["messages"] = [
            refused(lambda: sim.stroke(yore.StrokePath.material([[0.05, 0.1], [0.15, 0.1]]))),
            refused(lambda: sim.stroke([[0.05, 0.1, 0.0], [0.15, 0.1, 0.0]])),
            refused(lambda: setattr(cloth, "positions", V)),
            refused(lambda: cloth.positions),
            refused(lambda: sim.energy()),
            refused(lambda: sim.step(1)),
            refused(lambda: cloth.fix([1])),
            refused(lambda: cloth.springs),
            refused(lambda: cloth.state()),
            refused(lambda: sim.stats),
            refused(lambda: yore.Simulation(cloth, integrator="explicit", dt=1e-4).step(1)),
        ]
        # a second integrator on the same cloth is refused too, and so is another cloth's use
        # of the busy integrator
        other = small_cloth()
        record["messages"].append(
            refused(lambda: sim._integrator.advance(other, sim.gravity, sim.dt, 1))
        )
        record["repr"] = repr(cloth)

    record = interrupt_while_busy(sim, attempts)
    assert "Cloth is in use" in record["messages"][0]
    assert "integrator is in use" in record["messages"][-1]
    assert "in use" in record["repr"]
    # the interrupted step is undone: the cloth is exactly as before, and usable again
    assert not sim.cloth.busy and not sim._integrator.busy
    after = sim.cloth.state()
    for key in ("positions", "velocities", "clock_steps", "clock_origin"):
        np.testing.assert_array_equal(after[key], before[key])
    assert sim.time == 0.0
    sim.cloth.fix([1])
    sim.stroke(yore.StrokePath.material([[0.05, 0.1], [0.15, 0.1]]))
    assert sim.cloth.topology_version != before


def test_a_newton_loop_of_a_user_typed_length_answers_ctrl_c():
    # (CG loops poll the same way, but CG on an SPD system always ends: no endless test case)
    sim = endless_simulation("implicit")
    before = sim.cloth.positions
    interrupt_while_busy(sim, lambda sim, record: None)
    np.testing.assert_array_equal(sim.cloth.positions, before)
    assert not sim.cloth.busy
    assert sim.cloth.energy(sim.gravity)["total"] == pytest.approx(sim.energy()["total"])


def test_guards_are_released_after_errors():
    sim = yore.Simulation(small_cloth(), integrator="implicit", dt=1 / 60)
    with pytest.raises(ValueError):
        sim._integrator.advance(sim.cloth, sim.gravity, -1.0, 1)
    assert not sim.cloth.busy and not sim._integrator.busy
    sim.step(2)
    assert sim.time == pytest.approx(2 / 60)
