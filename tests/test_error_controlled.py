"""The error-controlled integrators on SUNDIALS (cvode: BDF; arkode: ESDIRK): tolerance in,
steps out, on yore's own CHOLMOD factor, which is made only when SUNDIALS asks for it."""

import _thread
import math
import threading

import numpy as np
import pytest

import yore
from test_integrators import chain as linear_chain

ERROR_CONTROLLED = ["cvode", "arkode"]


def chain():
    """test_integrators' linear chain, at an amplitude (1 cm) where atol matters."""
    return linear_chain(amplitude=1e-2)


def interrupt_while_running(sim, call, spin=0):
    """Runs call() on this thread; a helper waits until the cloth is busy, spins `spin` loop
    turns (letting some work run first; the tests' assertions hold wherever it lands), and
    interrupts as Ctrl-C would. Fails unless the interrupt arrived while the call ran."""
    record = {}

    def helper():
        for _ in range(10**8):
            if sim.cloth.busy:
                break
        for _ in range(spin):
            pass
        record["busy"] = sim.cloth.busy
        if sim.cloth.busy:
            _thread.interrupt_main()

    thread = threading.Thread(target=helper)
    thread.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
    finally:
        thread.join()
    assert record["busy"], "the call ended before the interrupt"


def chain_error(integrator, duration=0.5, **options):
    net, rest, shape, omega = chain()
    sim = yore.Simulation(net, integrator=integrator, dt=1 / 60, gravity=(0, 0, 0), **options)
    sim.advance(duration)
    exact = rest + shape * math.cos(omega * duration)
    return np.abs(sim.cloth.positions[:, 0] - exact).max(), sim


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_the_error_falls_with_the_tolerance_against_the_analytic_solution(integrator):
    # rtol = atol = atol_velocity = tol (amplitude 1 cm, so atol matters): the global error
    # of a linear mode over ~3 periods follows the tolerance, within a small multiple of it
    errors = []
    for tol in (1e-4, 1e-6, 1e-8):
        error, sim = chain_error(integrator, rtol=tol, atol=tol, atol_velocity=tol)
        errors.append(error)
        assert error < 200 * tol, (tol, error)
    slopes = [math.log10(errors[k] / errors[k + 1]) / 2 for k in range(2)]
    assert all(0.5 < slope < 1.5 for slope in slopes), (errors, slopes)


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_factors_are_kept_across_steps_and_every_counter_agrees(integrator):
    error, sim = chain_error(integrator, rtol=1e-6, atol=1e-6)
    counters = sim.stats["counters"]
    # one factorization per setup SUNDIALS asked for, and far fewer than its Newton iterations
    assert counters["factorizations"] == counters["linear_setups"] > 0
    assert counters["factorizations"] < counters["nonlinear_iterations"] / 3
    assert counters["jacobian_evaluations"] <= counters["linear_setups"]
    # one solve per Newton iteration at most (SUNDIALS skips it when the residual is already
    # below its linear tolerance)
    assert 0 < counters["linear_solves"] <= counters["nonlinear_iterations"]
    assert counters["internal_steps"] > sim.stats["steps"]  # 1/60 s is more than one step
    assert counters["analyses"] == 1 and counters["restarts"] == 1
    assert counters["last_internal_dt"] > 0 and counters["current_order"] >= 1


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_frames_and_advance_land_exactly_on_the_requested_times(integrator):
    net, *_ = chain()
    sim = yore.Simulation(net, integrator=integrator, dt=1 / 60, gravity=(0, 0, 0))
    sim.advance(0.1)
    assert sim.time == pytest.approx(0.1, abs=1e-15)
    sim.advance(0.0123)  # not a whole number of intervals: the last one is shortened
    assert sim.time == pytest.approx(0.1123, abs=1e-15)
    sim.step(3)
    assert sim.time == pytest.approx(0.1123 + 3 / 60, abs=1e-14)


def converged_reference(make, duration):
    """The explicit integrator at 1e-6 s, and its own error: the distance to 2e-6 s (first
    order, so about its error)."""
    fine, finer = make("explicit", dt=2e-6), make("explicit", dt=1e-6)
    fine.advance(duration)
    finer.advance(duration)
    floor = np.abs(fine.cloth.positions - finer.cloth.positions).max()
    return finer, floor


def damped_sheet(integrator, **options):
    return yore.scenes.hanging_cloth(
        resolution=8,
        pin_spacing=1.0,
        mass=0.1,
        stretch_stiffness=200.0,
        damping=0.05,
        drag=0.2,
        bending="quadratic",
        bending_modulus=1e-3,
        integrator=integrator,
        **options,
    )


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_damping_drag_bending_and_gravity_match_the_explicit_forces(integrator):
    # the right-hand side is the explicit integrator's forces: a tight tolerance reproduces a
    # converged explicit run on a sheet with every term
    duration = 0.1
    reference, floor = converged_reference(damped_sheet, duration)
    assert floor < 2e-6
    sim = damped_sheet(integrator, rtol=1e-7, atol=1e-8)
    sim.advance(duration)
    assert np.abs(sim.cloth.positions - reference.cloth.positions).max() < 1e-5


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_driven_vertices_follow_their_drivers_and_the_rest_converges(integrator):
    def make(name, **options):
        return yore.scenes.rotating_cylinder(rings=4, segments=8, integrator=name, **options)

    reference, floor = converged_reference(make, 0.1)
    sim = make(integrator, dt=1 / 60, rtol=1e-7, atol=1e-8)
    sim.advance(0.1)
    driven = sim.cloth.driven_vertices
    assert driven.size
    probe = make("explicit")
    probe.cloth.time = sim.time  # moves the driven vertices there without stepping
    assert np.array_equal(sim.cloth.positions[driven], probe.cloth.positions[driven])
    assert np.abs(sim.cloth.positions - reference.cloth.positions).max() < 1e-5 + 10 * floor


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_a_stroke_restarts_the_integrator_at_the_new_size(integrator):
    sim = yore.scenes.hanging_cloth(resolution=9, integrator=integrator)
    sim.step(3)
    before = sim.cloth.vertex_count
    sim.stroke(yore.StrokePath.material([[0.2, 0.3], [0.8, 0.45]]))
    sim.step(3)
    counters = sim.stats["counters"]
    assert sim.cloth.vertex_count > before
    assert counters["restarts"] == 2 and counters["analyses"] == 2
    assert np.all(np.isfinite(sim.cloth.positions))


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_a_resumed_state_restarts_the_integrator_within_the_tolerance(integrator, tmp_path):
    tol = 1e-6
    straight = yore.Simulation(
        chain()[0], integrator=integrator, dt=1 / 60, gravity=(0, 0, 0), rtol=tol, atol=tol
    )
    straight.step(30)
    sim = yore.Simulation(
        chain()[0], integrator=integrator, dt=1 / 60, gravity=(0, 0, 0), rtol=tol, atol=tol
    )
    sim.step(15)
    state = sim.state()
    # SUNDIALS' memory cannot be saved: the state says the resumed run restarts
    assert state["integrator_restarts"] is True and state["history"] is None
    resumed, _ = yore.load_state(yore.save_state(tmp_path / "resume.npz", sim))
    resumed.step(15)
    assert resumed.time == straight.time
    assert resumed.stats["counters"]["restarts"] == 1
    # both are within the tolerance's reach of the exact solution, so of each other
    difference = np.abs(resumed.cloth.positions - straight.cloth.positions).max()
    assert 0 < difference < 200 * tol


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_too_many_internal_steps_is_a_divergence_that_says_when_and_restores(integrator):
    sim = yore.scenes.hanging_cloth(
        resolution=9, integrator=integrator, rtol=1e-9, atol=1e-10, max_steps=3
    )
    with pytest.raises(
        yore.SimulationDiverged,
        match=r"at step 0 \(t = .*more than "
        r"max_steps = 3 internal steps.*restored to t = 0 s",
    ) as info:
        sim.step(2)
    assert info.value.time >= 0
    assert sim.time == 0.0 and np.array_equal(
        sim.cloth.positions, yore.scenes.hanging_cloth(resolution=9).cloth.positions
    )


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("rtol", 0.0),
        ("rtol", -1e-3),
        ("rtol", float("nan")),
        ("rtol", 1.0),
        ("atol", 0.0),
        ("atol", float("inf")),
        ("atol_velocity", -1.0),
        ("max_dt", -1.0),
        ("max_steps", 0),
    ],
)
@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_a_bad_tolerance_is_one_value_error_naming_it(integrator, name, value):
    with pytest.raises(ValueError, match=name):
        yore.scenes.hanging_cloth(resolution=5, integrator=integrator, **{name: value})


def test_each_takes_its_own_order_option_in_its_range():
    for value in (0, 6, 2.5):
        with pytest.raises(ValueError, match="max_order"):
            yore.scenes.hanging_cloth(resolution=5, integrator="cvode", max_order=value)
    for value in (1, 5):
        with pytest.raises(ValueError, match="order"):
            yore.scenes.hanging_cloth(resolution=5, integrator="arkode", order=value)
    with pytest.raises(ValueError, match="unknown option.*'order'"):
        yore.scenes.hanging_cloth(resolution=5, integrator="cvode", order=3)
    with pytest.raises(ValueError, match="unknown option.*'max_order'"):
        yore.scenes.hanging_cloth(resolution=5, integrator="arkode", max_order=3)


@pytest.mark.parametrize("order", [2, 3, 4])
def test_every_esdirk_order_converges_on_the_linear_mode(order):
    error, _ = chain_error("arkode", order=order, rtol=1e-7, atol=1e-7, atol_velocity=1e-7)
    assert error < 2e-5


def test_a_ctrl_c_inside_an_interval_leaves_the_simulation_as_it_was():
    # An interval SUNDIALS cannot finish soon (a driven cylinder for 1e5 s at a tight
    # tolerance); a helper waits until the cloth is busy and interrupts, as Ctrl-C would.
    sim = yore.scenes.rotating_cylinder(
        rings=4, segments=8, integrator="cvode", dt=1e5, rtol=1e-10, atol=1e-12, max_steps=10**7
    )
    before = sim.cloth.state()
    interrupt_while_running(sim, lambda: sim.step(1))
    assert sim.time == 0.0
    assert np.array_equal(sim.cloth.positions, before["positions"])
    assert np.array_equal(sim.cloth.velocities, before["velocities"])
    # and the next call restarts SUNDIALS at that state
    sim._integrator.advance(sim.cloth, sim.gravity, 1 / 60, 2)
    assert sim.stats["counters"]["restarts"] == 2 and np.all(np.isfinite(sim.cloth.positions))


def test_the_viewer_panel_and_a_runs_summary_show_what_sundials_counted(tmp_path):
    import json
    from pathlib import Path

    from yore.cli import main
    from yore.viz.viewer import Viewer

    viewer = Viewer(yore.scenes.hanging_cloth(resolution=6, integrator="cvode"), headless=True)
    viewer.advance(0.05)
    figures = viewer.statistics()
    counters = viewer.sim.stats["counters"]
    assert figures["internal_steps"] == counters["internal_steps"] > 0
    assert figures["linear_setups"] == counters["factorizations"]
    lines = yore.viz.viewer._statistics_lines(figures)
    assert any(f"internal steps {counters['internal_steps']}" in line for line in lines)

    scene = Path(__file__).resolve().parents[1] / "examples" / "hanging_paper.toml"
    assert (
        main(
            [
                "run",
                str(scene),
                "-o",
                str(tmp_path),
                "--set",
                "mesh.nx=6",
                "--set",
                "mesh.ny=6",
                "--set",
                "simulation.duration=0.05",
                "--set",
                "strokes.0.time=0.025",
                "--set",
                'simulation.integrator="cvode"',
                "--set",
                "simulation.dt=0.025",
                "--no-render",
                "--quiet",
            ]
        )
        == 0
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["counters"]["internal_steps"] > 0
    assert summary["counters"]["factorizations"] == summary["counters"]["linear_setups"]


@pytest.mark.parametrize("integrator", ["tr-bdf2", "bdf2"])
def test_auto_steps_are_chosen_by_the_local_error_estimate(integrator):
    # the linear mode: the error falls with the tolerance, rejected steps are retaken, and the
    # frames land exactly (TR-BDF2: its embedded estimate; BDF2: variable-step BDF2's)
    errors, steps = [], []
    for tol in (1e-5, 1e-7, 1e-9):  # looser, the 1/60 s output interval caps the steps
        net, rest, shape, omega = chain()
        sim = yore.Simulation(
            net,
            integrator=integrator,
            dt="auto",
            gravity=(0, 0, 0),
            rtol=tol,
            atol=tol,
            newton_tol=1e-12,
            truncation_fraction=0.0,
        )
        assert sim.dt == yore.options.FIXED_DT
        sim.advance(0.5)
        assert sim.time == pytest.approx(0.5, abs=1e-15)
        errors.append(
            np.abs(sim.cloth.positions[:, 0] - rest - shape * math.cos(omega * 0.5)).max()
        )
        steps.append(sim.stats["steps"])
        counters = sim.stats["counters"]
        assert counters["intervals"] == 30 and counters["rejected_steps"] < steps[-1] / 4
    # error per step ∝ h³ held at the tolerance, global error ∝ h²: error ∝ tol^(2/3)
    slopes = [math.log10(a / b) / 2 for a, b in zip(errors, errors[1:])]
    assert all(0.5 < slope < 0.9 for slope in slopes) and errors[2] < 1e-6, (errors, slopes)
    # a local tolerance 100× tighter takes about 100^(1/3) ≈ 4.6× the steps (third-order
    # local error); more than 3×, fewer than 8×
    assert all(3 < b / a < 8 for a, b in zip(steps, steps[1:])), steps


@pytest.mark.parametrize("integrator", ["tr-bdf2", "bdf2"])
def test_auto_steps_resume_bit_for_bit_the_step_carried_over_is_the_historys_dt(
    tmp_path, integrator
):
    def make():
        return yore.scenes.hanging_cloth(
            resolution=8, integrator=integrator, dt="auto", rtol=1e-4, atol=1e-5
        )

    straight = make()
    straight.step(12)
    sim = make()
    sim.step(6)
    state = sim.state()
    assert state["options"]["adaptive"] is True and state["history"]["dt"] > 0
    assert state["integrator_restarts"] is False
    resumed, _ = yore.load_state(yore.save_state(tmp_path / "auto.npz", sim))
    resumed.step(6)
    assert np.array_equal(resumed.cloth.positions, straight.cloth.positions)
    assert resumed.time == straight.time


def test_dt_auto_needs_an_integrator_with_error_control():
    with pytest.raises(ValueError, match="dt='auto'.*'implicit'.*bdf2, tr-bdf2, cvode, arkode"):
        yore.scenes.hanging_cloth(resolution=5, integrator="implicit", dt="auto")
    with pytest.raises(ValueError, match="dt must be a number of seconds or 'auto'"):
        yore.scenes.hanging_cloth(resolution=5, integrator="tr-bdf2", dt="fast")
    # cvode and arkode take "auto" as the default output interval
    sim = yore.scenes.hanging_cloth(resolution=5, integrator="cvode", dt="auto")
    assert sim.dt == yore.options.FIXED_DT


@pytest.mark.parametrize("integrator", ["tr-bdf2", "bdf2"])
def test_auto_steps_too_many_is_a_divergence_that_says_so(integrator):
    sim = yore.scenes.hanging_cloth(
        resolution=8, integrator=integrator, dt="auto", rtol=1e-9, atol=1e-10, max_steps=2
    )
    with pytest.raises(
        yore.SimulationDiverged,
        match=r"more than max_steps = 2 steps in one "
        r"output interval.*restored to t = 0 s",
    ):
        sim.step(1)
    assert sim.time == 0.0


def test_a_scene_file_takes_dt_auto_and_refuses_other_words(tmp_path):
    from pathlib import Path

    from yore.cli import main

    scene = Path(__file__).resolve().parents[1] / "examples" / "hanging_paper.toml"
    common = [
        str(scene),
        "--set",
        "mesh.nx=6",
        "--set",
        "mesh.ny=6",
        "--set",
        "simulation.duration=0.05",
        "--set",
        "strokes.0.time=0.025",
        "--set",
        'simulation.integrator="tr-bdf2"',
        "--no-render",
        "--quiet",
    ]
    assert (
        main(["run", *common, "-o", str(tmp_path / "auto"), "--set", 'simulation.dt="auto"']) == 0
    )
    import json

    summary = json.loads((tmp_path / "auto" / "summary.json").read_text())
    assert summary["counters"]["intervals"] >= 3 and summary["dt"] == yore.options.FIXED_DT
    assert main(["run", *common, "-o", str(tmp_path / "bad"), "--set", 'simulation.dt="fast"']) == 2


def test_the_reduced_newton_system_is_exact_on_a_linear_problem():
    # On the linear chain the iteration matrix is the exact Jacobian's (collinear stretched
    # springs, no damping): CVODE's Newton then converges in about one iteration a step and
    # never fails. A wrong reduction of (I − γJ) z = r to the 3n system would show here.
    for tol in (1e-4, 1e-6):
        _, sim = chain_error("cvode", rtol=tol, atol=tol, atol_velocity=tol)
        counters = sim.stats["counters"]
        assert counters["nonlinear_failures"] == 0
        assert counters["nonlinear_iterations"] <= 1.3 * counters["internal_steps"], counters


@pytest.mark.parametrize(
    "integrator,options",
    [
        ("bdf2", {}),
        ("tr-bdf2", {"dt": "auto"}),
        ("bdf2", {"dt": "auto"}),
        ("generalized-alpha", {}),
        ("quasi-newton", {"method": "bdf2"}),
    ],
)
def test_a_ctrl_c_keeps_the_history_so_the_run_continues_bit_for_bit(integrator, options):
    # `step` runs its steps in batches (one core call each); a Ctrl-C inside a batch leaves
    # the simulation as it was before that batch, its history (and the step the controller
    # proposes) included, so finishing the steps gives the uninterrupted run's numbers exactly.
    def make():
        return yore.scenes.hanging_cloth(
            resolution=12, pin_spacing=1.0, stretch_stiffness=2e3, integrator=integrator, **options
        )

    total = 90
    straight = make()
    straight.step(6)
    straight.step(total)
    sim = make()
    sim.step(6)
    start = sim.time
    interrupt_while_running(sim, lambda: sim.step(total), spin=10**6)
    done = round((sim.time - start) / sim.dt)
    assert 0 <= done < total
    assert sim.state()["history"] is not None  # kept, not dropped
    sim.step(total - done)
    assert sim.time == straight.time
    assert np.array_equal(sim.cloth.positions, straight.cloth.positions)
    assert np.array_equal(sim.cloth.velocities, straight.cloth.velocities)


def test_auto_bdf2_starts_again_after_a_stroke_and_keeps_going():
    # a stroke changes the topology: the history (and its proposed step) is dropped, the next
    # step is backward Euler's at a tenth of the output interval, and the control goes on
    sim = yore.scenes.hanging_cloth(
        resolution=9, integrator="bdf2", dt="auto", rtol=1e-4, atol=1e-5
    )
    sim.step(3)
    assert sim.state()["history"]["next_dt"] > 0
    restarts = sim.stats["counters"]["history_restarts"]
    sim.stroke(yore.StrokePath.material([[0.2, 0.3], [0.8, 0.45]]))
    assert sim.state()["history"] is None
    sim.step(3)
    # (a restarting step the controller retakes shorter counts again)
    assert sim.stats["counters"]["history_restarts"] > restarts
    assert sim.time == pytest.approx(6 / 60, abs=1e-12)
    assert np.all(np.isfinite(sim.cloth.positions)) and sim.state()["history"]["next_dt"] > 0


@pytest.mark.parametrize(
    "integrator, extra",
    [("cvode", {}), ("arkode", {}), ("tr-bdf2", {"dt": "auto"}), ("bdf2", {"dt": "auto"})],
)
def test_a_tolerance_below_round_off_is_refused_naming_rtol(integrator, extra):
    # Issue 53, R06: rtol 1e-14 (atol 1e-300, max_steps 1e7) kept CVODE in a 6×6 cloth's first
    # 1/60 s interval for minutes; below 1e-12 the error test measures round-off
    with pytest.raises(ValueError, match=r"option rtol: got float 1e-14; expected .*\[1e-12, 1\)"):
        yore.scenes.hanging_cloth(
            resolution=6,
            integrator=integrator,
            rtol=1e-14,
            atol=1e-300,
            max_steps=10_000_000,
            **extra,
        )
    sim = yore.scenes.hanging_cloth(resolution=6, integrator=integrator, rtol=1e-12, **extra)
    assert sim.resolved_options["rtol"] == 1e-12


@pytest.mark.parametrize("integrator", ERROR_CONTROLLED)
def test_a_run_restarted_where_another_resumed_takes_the_same_steps(integrator, tmp_path):
    # restart_integrator() at the state's time: the run that goes on and the one resumed from
    # the state start SUNDIALS afresh at the same point, so they agree bit for bit
    sim = yore.Simulation(
        chain()[0], integrator=integrator, dt=1 / 60, gravity=(0, 0, 0), rtol=1e-4, atol=1e-6
    )
    sim.step(15)
    resumed, _ = yore.load_state(yore.save_state(tmp_path / "resume.npz", sim))
    assert resumed.restarts_on_resume and sim.restarts_on_resume
    sim.restart_integrator()
    sim.step(15)
    resumed.step(15)
    assert np.array_equal(sim.cloth.positions, resumed.cloth.positions)
    assert np.array_equal(sim.cloth.velocities, resumed.cloth.velocities)
    assert sim.stats["counters"]["restarts"] == 2


def test_restarting_is_a_no_op_for_integrators_whose_history_the_state_keeps():
    sim = yore.scenes.hanging_cloth(resolution=5, integrator="bdf2")
    assert not sim.restarts_on_resume
    sim.step(2)
    sim.restart_integrator()
    sim.step(1)
    assert sim.stats["counters"]["history_restarts"] == 1  # the first step only
