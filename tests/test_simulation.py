"""The Simulation front end: options, argument checks, stats."""

import numpy as np
import pytest

import yore


@pytest.fixture
def cloth():
    return yore.Cloth(*yore.grid_mesh(4, 4), masses=0.01)


def test_unknown_integrator_and_option_names_list_the_valid_ones(cloth):
    with pytest.raises(
        ValueError,
        match="valid: explicit, implicit, bdf2, generalized-alpha, tr-bdf2, implicit-midpoint, "
        "local-global",
    ):
        yore.Simulation(cloth, integrator="rk4")
    with pytest.raises(
        ValueError,
        match="'strain_limt'.*valid: divergence_energy_factor, "
        "energy_growth_tolerance, strain_limit, "
        "strain_limit_passes",
    ):
        yore.Simulation(cloth, strain_limt=1.1)


@pytest.mark.parametrize("dt", [-1e-3, 0.0, float("nan"), float("inf"), "fast"])
def test_bad_dt_is_a_value_error(cloth, dt):
    with pytest.raises(ValueError, match="dt"):
        yore.Simulation(cloth, dt=dt)


@pytest.mark.parametrize("gravity", [(0, -9.81), (0, float("nan"), 0)])
def test_bad_gravity_is_a_value_error(cloth, gravity):
    with pytest.raises(ValueError, match="gravity"):
        yore.Simulation(cloth, gravity=gravity)


@pytest.mark.parametrize(
    "options, message",
    [({"strain_limit": 0.9}, "strain_limit"), ({"strain_limit_passes": 0}, "passes")],
)
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
    # 1e308 s overflowed the step count (OverflowError, issue 41 class 12)
    with pytest.raises(ValueError, match="more than the limit of 100000000 per call"):
        sim.advance(1e308)
    assert sim.advance(0.25) == 250
    assert sim.time == pytest.approx(0.25, abs=1e-15)
    sim.step(10)
    assert sim.stats["steps"] == 260
    assert sim.time == pytest.approx(0.26, abs=1e-15)


def test_default_dt_is_stable_and_a_whole_fraction_of_a_second(cloth):
    sim = yore.Simulation(cloth)
    assert sim.dt <= 0.98 * cloth.stable_time_step_bound()
    assert abs(1.0 / sim.dt - round(1.0 / sim.dt)) < 1e-9


def test_stats_report_active_terms_and_phase_times(cloth):
    cloth.fix([0])
    sim = yore.Simulation(cloth, dt=1e-4, gravity=(0, 0, 0))
    sim.step(100)
    stats = sim.stats
    assert stats["active_terms"] == {
        "gravity": False,
        "spring_damping": False,
        "drag": False,
        "bending_springs": int(np.count_nonzero(cloth.springs.kind == 1)),
        "strain_limiting": False,
        "fixed_vertices": 1,
        "driven_vertices": 0,
    }
    # phases are wall time: check their names, never their values (they vary with load)
    assert set(stats["phases"]) == {
        "forces_seconds",
        "update_seconds",
        "constraints_seconds",
        "checks_seconds",
    }
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


# -- options are type-checked, not coerced ------------------------------------------------------


@pytest.mark.parametrize(
    "integrator, option, value",
    [
        ("implicit", "linearized", "no"),
        ("implicit", "linearized", 0),
        ("implicit", "max_newton", 2.9),
        ("implicit", "max_newton", True),
        ("implicit", "max_newton", 10**9),
        ("implicit", "lag_cg_tol", float("inf")),
        ("implicit", "newton_tol", float("nan")),
        ("implicit", "solver", "cholesky"),
        ("implicit", "pcg_max_iterations", 10**7),
        ("implicit", "adaptive_projection", "yes"),
        ("local-global", "iterations", 10**9),
        ("local-global", "iterations", 10.0),
        ("local-global", "chebyshev_rho", 1.0),
        ("local-global", "record_objective", 1),
        ("explicit", "strain_limit", 0.9),
        ("explicit", "strain_limit", "1.1"),
        ("explicit", "divergence_energy_factor", float("inf")),
    ],
)
def test_an_option_of_the_wrong_type_or_range_is_refused_naming_it(
    cloth, integrator, option, value
):
    with pytest.raises(ValueError, match=f"option {option}: got {type(value).__name__} ") as e:
        yore.Simulation(cloth, integrator=integrator, **{option: value})
    assert "expected" in str(e.value) and "\n" not in str(e.value)


def test_options_given_correctly_are_kept_as_given(cloth):
    sim = yore.Simulation(
        cloth,
        integrator="implicit",
        linearized=True,
        max_newton=np.int64(3),
        newton_tol=1,
        adaptive_projection=None,
    )
    options = sim.state()["options"]
    assert options["linearized"] is True and options["max_newton"] == 3
    assert type(options["max_newton"]) is int and type(options["newton_tol"]) is float


# -- issue 53: an option of a mode not in use is refused, not ignored -------------------------
@pytest.mark.parametrize(
    "integrator, options, option, needs",
    [
        ("tr-bdf2", {"dt": 0.01, "rtol": 1e-3}, "rtol", 'dt="auto"'),
        ("bdf2", {"atol": 1e-6}, "atol", 'dt="auto"'),
        ("tr-bdf2", {"max_steps": 10}, "max_steps", 'dt="auto"'),
        ("implicit", {"lag_cg_tol": 1e-6}, "lag_cg_tol", "lagged_factorization=True"),
        (
            "generalized-alpha",
            {"lagged_factorization": False, "lag_max_cg_iterations": 5},
            "lag_max_cg_iterations",
            "lagged_factorization=True",
        ),
        ("implicit", {"pcg_tol": 1e-6}, "pcg_tol", 'solver="pcg"'),
        (
            "implicit",
            {"solver": "eigen-ldlt", "pcg_max_iterations": 10},
            "pcg_max_iterations",
            'solver="pcg"',
        ),
        (
            "implicit",
            {"solver": "pcg", "factorization": "simplicial"},
            "factorization",
            'solver="cholmod"',
        ),
        ("explicit", {"strain_limit_passes": 8}, "strain_limit_passes", "a strain_limit"),
        ("local-global", {"stale_pcg_tol": 1e-6}, "stale_pcg_tol", 'rebuild="stale-pcg"'),
        (
            "local-global",
            {"acceleration": "none", "chebyshev_rho": 0.9},
            "chebyshev_rho",
            'acceleration="chebyshev"',
        ),
    ],
)
def test_an_option_of_a_mode_not_in_use_is_refused_naming_the_mode(
    cloth, integrator, options, option, needs
):
    with pytest.raises(yore.options.InactiveOptionError) as caught:
        yore.Simulation(cloth, integrator=integrator, **options)
    message = str(caught.value)
    assert message.startswith(f"{option} acts only with {needs}") and "\n" not in message
    assert "would be ignored" in message and caught.value.option == option
    assert isinstance(caught.value, ValueError)


@pytest.mark.parametrize(
    "integrator, options",
    [
        ("tr-bdf2", {"dt": "auto", "rtol": 1e-4, "atol": 1e-6, "max_steps": 100}),
        ("bdf2", {"dt": "auto", "rtol": 1e-4}),
        ("implicit", {"lagged_factorization": True, "lag_cg_tol": 1e-8}),
        ("implicit", {"solver": "pcg", "pcg_tol": 1e-8, "pcg_max_iterations": 100}),
        ("implicit", {"solver": "cholmod", "factorization": "simplicial"}),
        ("explicit", {"strain_limit": 1.1, "strain_limit_passes": 8}),
        ("local-global", {"rebuild": "stale-pcg", "stale_pcg_tol": 1e-8, "chebyshev_rho": 0.9}),
    ],
)
def test_the_same_options_in_their_mode_are_taken(cloth, integrator, options):
    sim = yore.Simulation(cloth, integrator=integrator, **options)
    given = {name: value for name, value in options.items() if name != "dt"}
    assert {name: sim.options[name] for name in given} == given


@pytest.mark.parametrize("integrator", yore.simulation.INTEGRATORS)
def test_defaults_of_modes_not_in_use_are_never_judged(cloth, integrator):
    # every integrator at its defaults, and with a mode switched off: its other modes'
    # defaults stay silent, and a state (which holds them all) continues
    switches = {
        "implicit": {"solver": "pcg"},
        "bdf2": {"solver": "eigen-ldlt"},
        "tr-bdf2": {"solver": "pcg"},
        "explicit": {"strain_limit": None},
        "local-global": {"acceleration": "none"},
    }
    for options in ({}, switches.get(integrator, {})):
        sim = yore.Simulation(cloth, integrator=integrator, **options)
        again = yore.Simulation.from_state(sim.state())
        assert again.resolved_options == sim.resolved_options


def test_every_mode_only_option_and_its_setting_belong_to_one_integrator():
    tables = yore.options.INTEGRATOR_OPTIONS
    for option, mode in yore.options.MODE_ONLY.items():
        together = [
            name for name, table in tables.items() if option in table and mode.setting in table
        ]
        assert together, option  # an entry no integrator can act on would be dead


@pytest.mark.parametrize(
    "arguments, match",
    [
        ({"region": [0.5, 1.7]}, "region: got list"),
        ({"region": True}, "region: got bool"),
        ({"region": "some"}, "region"),
        ({"region": [[0, 1]]}, "region: got an array of shape"),
        ({"region": [10**6]}, "region: vertex 1000000 is out of range"),
        ({"region": "all", "iterations": 2.9}, "iterations: got float 2.9"),
        ({"region": "all", "iterations": 10**9}, "iterations: got int"),
        ({"region": "all", "iterations": True}, "iterations: got bool"),
        ({"region": "all", "strength": float("nan")}, "strength: got float nan"),
        ({"region": "all", "strength": "0.5"}, "strength: got str"),
    ],
)
def test_smooth_rest_lengths_refuses_what_it_would_have_coerced(cloth, arguments, match):
    sim = yore.Simulation(cloth)
    with pytest.raises(ValueError, match=match):
        sim.smooth_rest_lengths(**arguments)


def test_smooth_rest_lengths_takes_integer_regions(cloth):
    sim = yore.Simulation(cloth)
    assert (
        sim.smooth_rest_lengths(iterations=1, region=np.array([0, 1], dtype=np.uint8))["springs"]
        > 0
    )
    assert sim.smooth_rest_lengths(iterations=0, region=[])["springs"] == 0


@pytest.mark.parametrize(
    "core", ["ExplicitIntegrator", "ImplicitIntegrator", "LocalGlobalIntegrator"]
)
def test_core_option_tables_round_trip_and_name_unknown_options(core):
    from yore import _core

    cls = getattr(_core, core)
    defaults = dict(cls.defaults)
    cls(**defaults)  # every name the table lists is accepted with its own default
    with pytest.raises(
        ValueError, match="unknown option 'no_such_option'; valid: .*" + next(iter(defaults))
    ):
        cls(no_such_option=1)


def test_python_option_defaults_come_from_the_core_structs():
    from yore import _core
    from yore.simulation import INTEGRATOR_OPTIONS

    core = _core.ImplicitIntegrator.defaults
    # Newton's numbers are the struct's; quasi-Newton overrides only its cap and factorization
    for name in ("newton_tol", "max_newton", "pcg_tol", "lag_cg_tol", "ordering"):
        assert INTEGRATOR_OPTIONS["implicit"][name] == core[name]
    assert INTEGRATOR_OPTIONS["quasi-newton"]["lbfgs_history"] == core["lbfgs_history"]
    assert (
        INTEGRATOR_OPTIONS["local-global"]["chebyshev_rho"]
        == _core.LocalGlobalIntegrator.defaults["chebyshev_rho"]
    )


def _hanging(integrator="explicit", **options):
    return yore.scenes.hanging_cloth(resolution=9, integrator=integrator, **options)


@pytest.mark.parametrize(
    "integrator, bending",
    [
        ("explicit", {}),
        ("implicit", {}),
        ("explicit", {"bending": "quadratic", "bending_modulus": 3e-3}),
    ],
)
def test_settle_brings_the_hanging_cloth_to_rest_and_keeps_the_clock(integrator, bending):
    sim = _hanging(integrator, **bending)
    before = sim.energy()
    dt = sim.dt
    info = sim.settle(max_seconds=10.0, tolerance=0.02)
    assert info["converged"] and info["residual_acceleration"] <= 0.02
    assert 1 <= info["steps"] and info["seconds"] <= 10.0
    assert sim.time == 0.0 and not np.any(sim.cloth.velocities) and sim.dt == dt
    after = sim.energy()
    # it fell and stretched to rest: the potential dropped, nothing is moving
    potential = ("gravity", "spring", "bending")
    assert sum(after.get(k, 0.0) for k in potential) < sum(before.get(k, 0.0) for k in potential)
    assert after["kinetic"] == 0.0
    # Independently of settle's own measure: one explicit step of 1 µs from rest gives
    # v = dt M⁻¹ f (symplectic Euler, no damping at v = 0), whose RMS over dt is the residual.
    probe = yore.Simulation(
        yore.Cloth.from_state(sim.cloth.state()), integrator="explicit", dt=1e-6
    )
    probe.step(1)
    v, m = probe.cloth.velocities, probe.cloth.masses
    assert np.sqrt((m[:, None] * v**2).sum() / m.sum()) / 1e-6 <= 0.02 * (1 + 1e-6)
    # At rest near equilibrium the cloth stays nearly put, while as built it swings off by
    # tens of centimetres.
    x0 = sim.cloth.positions.copy()
    sim.advance(0.5)
    unsettled = _hanging(integrator, **bending)
    start = unsettled.cloth.positions.copy()
    unsettled.advance(0.5)
    assert (
        np.abs(sim.cloth.positions - x0).max()
        < 0.05 * np.abs(unsettled.cloth.positions - start).max()
    )


def _compressed_strip(shortening=0.01):
    """A 0.3 m × 0.05 m membrane strip, clamped at its ends, started exactly flat and shortened
    by `shortening` of its length: a flat saddle (it is in balance, and it buckles)."""
    V, F = yore.pattern_mesh([[0, 0], [0.3, 0], [0.3, 0.05], [0, 0.05]], edge_length=0.01)
    cloth = yore.Cloth(
        V,
        F,
        density=0.1,
        stretch="membrane",
        young_modulus=1e4,
        poisson_ratio=0.3,
        bending="quadratic",
        bending_modulus=1e-4,
    )
    X = V.copy()
    X[:, 0] *= 1 - shortening
    cloth.positions = X
    cloth.fix(np.flatnonzero((V[:, 0] <= 0.0) | (V[:, 0] >= 0.3)))
    return yore.Simulation(cloth, integrator="implicit", gravity=(0.0, 0.0, 0.0))


def test_settle_does_not_mistake_a_saddle_for_rest():
    # Newton leaves a residual force of ~1e-7 of the sheet's, 0.2–0.4 m/s² on this light strip:
    # a tolerance of 1 m/s² is met at once by the flat state
    flat = _compressed_strip()
    info = flat.settle(max_seconds=30.0, tolerance=1.0, check_stability=False)
    assert info["converged"] and info["stable"] is None
    assert np.abs(flat.cloth.positions[:, 2]).max() == 0.0  # the saddle, taken for rest
    sim = _compressed_strip()
    info = sim.settle(max_seconds=30.0, tolerance=1.0)
    assert info["converged"] and info["stable"] is True and info["saddles_escaped"] >= 1
    # the clamped strip buckled into the Euler mode w = A/2 (1 − cos 2πx/L), whose excess arc
    # length A²π²/4L takes up the shortening Δ (the membrane barely stretches at Y = 1e4 N/m):
    # A = 2 √(L Δ) / π
    amplitude = np.abs(sim.cloth.positions[:, 2]).max()
    expected = 2.0 * np.sqrt(0.3 * 0.003) / np.pi
    assert amplitude == pytest.approx(expected, rel=0.05)
    # and it is a minimum: the true Hessian is positive definite there
    assert not yore.settling.is_saddle(sim.cloth, (0.0, 0.0, 0.0))
    assert yore.settling.is_saddle(flat.cloth, (0.0, 0.0, 0.0))


def test_settle_checks_its_arguments_and_refuses_a_driven_cloth():
    sim = _hanging()
    for bad in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="max_seconds"):
            sim.settle(max_seconds=bad)
    with pytest.raises(ValueError, match="tolerance"):
        sim.settle(tolerance=0.0)
    spinning = yore.scenes.rotating_cylinder(rings=4, segments=8)
    with pytest.raises(ValueError, match="driven"):
        spinning.settle()
    with pytest.raises(ValueError, match="check_stability"):
        sim.settle(check_stability="yes")
    # zero seconds: nothing but the velocities (already zero) changes
    x = sim.cloth.positions.copy()
    info = sim.settle(max_seconds=0.0)
    assert info == {
        "seconds": 0.0,
        "steps": 0,
        "converged": False,
        "residual_acceleration": float("inf"),
        "saddles_escaped": 0,
        "stable": None,
    }
    assert np.array_equal(sim.cloth.positions, x)


def test_api_values_of_the_wrong_kind_or_out_of_range_are_value_errors_naming_them():
    # issue 22, item 17: each was accepted, or raised something other than a ValueError
    sim = yore.scenes.hanging_cloth(resolution=5)
    sim.stroke(yore.StrokePath.material([[0.1, 0.5], [0.9, 0.5]]))
    for conserve in ("yes", None, 1):
        with pytest.raises(ValueError, match="conserve"):
            sim.smooth_rest_lengths(conserve=conserve)
    for modulus in (True, "1e-3", np.bool_(True)):
        with pytest.raises(ValueError, match="bending_modulus"):
            yore.scenes.hanging_cloth(resolution=5, bending="quadratic", bending_modulus=modulus)
    with pytest.raises(ValueError, match="bend_stiffness"):
        yore.Cloth(*yore.grid_mesh(3, 3), bend_stiffness="stiff")
    for option in ("tolerance", "step_tol"):
        integrator = "local-global" if option == "tolerance" else "implicit"
        with pytest.raises(ValueError, match=option):
            yore.scenes.hanging_cloth(resolution=5, integrator=integrator, **{option: 1})
    with pytest.raises(ValueError, match="stretch_stiffness .*1e\\+12"):
        yore.scenes.hanging_cloth(resolution=5, stretch_stiffness=1.7e308)
    with pytest.raises(ValueError, match="mass of vertex 0 .*1e\\+12"):
        yore.Cloth(*yore.grid_mesh(3, 3), masses=1e300)
    for seconds in (None, "1", float("nan"), -1.0):
        with pytest.raises(ValueError, match="seconds"):
            sim.advance(seconds)
    # the limit itself is accepted
    yore.Cloth(*yore.grid_mesh(3, 3), masses=1e12, stretch_stiffness=1e12, bend_stiffness=1e12)


def test_work_beyond_the_documented_limits_is_refused_before_it_starts():
    # issue 22, item 7: each of these was hours of work accepted silently
    from yore.checks import MAX_SETTLE_SECONDS, MAX_STEPS

    sim = yore.scenes.hanging_cloth(resolution=4)
    with pytest.raises(ValueError, match=f"more than the limit of {MAX_STEPS}"):
        sim.step(2**63)
    with pytest.raises(ValueError, match="steps, more than the limit"):
        sim.advance(1e9)
    with pytest.raises(ValueError, match="max_seconds must be in"):
        sim.settle(MAX_SETTLE_SECONDS * 2)
    assert sim.time == 0.0 and sim.stats["steps"] == 0  # nothing ran
    free = yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3)))
    with pytest.raises(ValueError, match="settle needs a fixed vertex"):
        free.settle()
    yore.Simulation(yore.Cloth(*yore.grid_mesh(3, 3)), gravity=[0, 0, 0]).settle(1.0)


def test_option_checks_come_from_the_core_tables_and_shared_names_agree():
    from yore import _core
    from yore.options import CORE_RULES, check_option

    tables = [
        cls.option_rules
        for cls in (_core.ExplicitIntegrator, _core.ImplicitIntegrator, _core.LocalGlobalIntegrator)
    ]
    for name in {n for table in tables for n in table}:
        rules = [table[name] for table in tables if name in table]
        assert all(rule == rules[0] for rule in rules), name  # one rule per name
    assert CORE_RULES["step_tol"] == {
        "kind": "real",
        "low": 0.0,
        "high": 1.0,
        "low_open": False,
        "high_open": True,
        "choices": (),
    }
    assert CORE_RULES["solver"]["choices"] == ("cholmod", "eigen-ldlt", "pcg")
    top = int(CORE_RULES["max_newton"]["high"])
    assert check_option("implicit", "max_newton", top) == top
    with pytest.raises(ValueError, match=rf"max_newton.*\[1, {top}\]"):
        check_option("implicit", "max_newton", top + 1)
    # the Python side adds only None ("decide from the others") where the core has none
    assert check_option("bdf2", "projection", None) is None
    with pytest.raises(ValueError, match="steihaug"):
        check_option("bdf2", "projection", "newton")


@pytest.mark.parametrize(
    "name,value",
    [("max_seconds", None), ("max_seconds", "5"), ("tolerance", None), ("tolerance", "0.02")],
)
def test_settle_takes_numbers_only_and_names_the_argument(name, value):
    # a string or None is refused, not coerced by float() or passed on as a TypeError
    sim = yore.scenes.hanging_cloth(resolution=5)
    with pytest.raises(ValueError, match=f"{name} must be a finite number"):
        sim.settle(**{name: value})


@pytest.mark.parametrize(
    "name, value, bound",
    [
        ("expansion", 10.5, 10.0),
        ("expansion", 1e300, 10.0),
        # issue 41, class 2: these gave states no file could hold (rest lengths 0, masses 2e305)
        ("expansion", 5e-324, 0.1),
        ("expansion", 0.09, 0.1),
        ("mass_scale", 1e308, 10.0),
        ("mass_scale", 10.5, 10.0),
    ],
)
def test_a_strokes_factors_out_of_range_are_refused_before_the_cloth_changes(
    tmp_path, name, value, bound
):
    # an expansion of 1e300 used to return with an infinite spring energy
    sim = yore.scenes.hanging_cloth(resolution=9)
    before = sim.cloth.vertex_count
    limit = "in \\[0.1, 10\\]" if name == "expansion" else "at most 10"
    with pytest.raises(ValueError, match=f"{name} must be {limit}"):
        sim.stroke(yore.StrokePath.material([[0.2, 0.3], [0.8, 0.4]]), **{name: value})
    assert sim.cloth.vertex_count == before
    sim.stroke(
        yore.StrokePath.material([[0.2, 0.3], [0.8, 0.4]]), **{name: bound}
    )  # the bound itself is taken
    assert np.isfinite(sim.energy()["total"])
    path = yore.save_state(tmp_path / "state.npz", sim)
    assert yore.load_state(path)[0].cloth.vertex_count == sim.cloth.vertex_count


@pytest.mark.parametrize(
    "arguments,name",
    [({"density": "1"}, "density"), ({"density": True}, "density"), ({"masses": True}, "masses")],
)
def test_a_cloths_mass_or_density_of_the_wrong_type_is_a_value_error_naming_it(arguments, name):
    # not pybind11's "Unable to cast" RuntimeError, and a bool is not silently 1 kg
    V, F = yore.grid_mesh(4, 4)
    with pytest.raises(ValueError, match=f"{name} must be a number"):
        yore.Cloth(V, F, **arguments)
    assert yore.Cloth(V, F, density=np.float64(0.2)).vertex_count == 16  # numpy numbers pass
