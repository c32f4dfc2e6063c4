"""Scene files: checking (key named, line, expected), overrides, and what build() makes."""

import os
from pathlib import Path

import numpy as np
import pytest

import yore
from yore.runs import SceneError, load_scene, parse_override

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

MINIMAL = """\
[mesh]
generator = "grid"
nx = 5
ny = 4

[simulation]
duration = 0.1
"""


def error_of(text, **kwargs):
    with pytest.raises(SceneError) as caught:
        load_scene(Path("scene.toml"), text=text, **kwargs).check_strokes()
    return caught.value


def test_the_toml_hanging_cloth_is_the_python_scene_exactly():
    # An independent construction of the same cloth: yore.scenes.hanging_cloth's defaults.
    sim, sets = load_scene(EXAMPLES / "hanging_paper.toml").build()
    reference = yore.scenes.hanging_cloth()
    a, b = sim.cloth.state(), reference.cloth.state()
    for key in (
        "positions",
        "velocities",
        "masses",
        "faces",
        "spring_ends",
        "spring_rest",
        "spring_stiffness",
        "spring_damping",
        "vertex_states",
        "material_coordinates",
    ):
        assert np.array_equal(a[key], b[key]), key
    assert sim.dt == reference.dt and sim.integrator == reference.integrator
    assert list(sets["bottom corners"]) == [0, 20]


def test_the_demo_scene_is_examples_hanging_toml():
    from yore.cli import demo_scene_text

    assert demo_scene_text() == (EXAMPLES / "hanging.toml").read_text(encoding="utf-8")


def test_defaults_are_filled_in_and_named_sets_select_the_right_vertices():
    scene = load_scene(text=MINIMAL + '[[fixed]]\nset = "top edge"\n')
    data = scene.data
    assert data["material"]["mass"] == 0.1 and data["simulation"]["integrator"] == "explicit"
    assert data["output"]["format"] == "vtu" and scene.frame_interval(1 / 300) == 10
    sim, sets = scene.build()
    assert list(sim.cloth.fixed_vertices) == [15, 16, 17, 18, 19]  # row j = 3 of a 5×4 grid
    assert np.allclose(sim.cloth.masses, 0.1 / 20)
    assert list(sets["left edge"]) == [0, 5, 10, 15]


def test_a_misspelt_key_is_named_with_its_line_and_a_suggestion():
    error = error_of(MINIMAL.replace("ny = 4", "ny = 4\nwidht = 2.0"))
    assert error.key == "mesh.widht" and error.line == 5
    assert "did you mean 'width'" in str(error) and "scene.toml:5" in str(error)
    error = error_of(MINIMAL + "[material]\nstifness = 3\n")
    assert error.key == "material.stifness" and error.line == 9
    assert "stretch_stiffness" in error.expected  # what was expected: the valid keys
    error = error_of(MINIMAL + "[outptu]\nformat = 'vtu'\n")
    assert error.key == "outptu" and "did you mean 'output'" in str(error)


def test_a_wrong_type_or_range_is_named_with_what_was_expected():
    error = error_of(MINIMAL.replace("nx = 5", 'nx = "five"'))
    assert error.key == "mesh.nx" and error.line == 3 and error.expected == "an integer >= 2"
    error = error_of(MINIMAL + "[material]\ndamping = -1.0\n")
    assert error.key == "material.damping" and ">= 0" in error.expected
    error = error_of(MINIMAL.replace("duration = 0.1", "duration = 0.1\ngravity = [0, -9.81]"))
    assert error.key == "simulation.gravity" and "3 numbers" in error.expected
    error = error_of(MINIMAL + "[integrator]\nstrain_limit = 'tight'\n")
    assert error.key == "integrator.strain_limit"
    error = error_of(MINIMAL + "[integrator]\nnewton_tol = 1e-6\n")  # not an explicit option
    assert error.key == "integrator.newton_tol" and "strain_limit" in error.expected


def test_missing_tables_and_keys_and_contradictions_are_named():
    assert error_of('[mesh]\ngenerator = "grid"\n').key == "simulation"
    assert error_of("[mesh]\nnx = 3\n[simulation]\nduration = 1.0\n").key == "mesh.generator"
    error = error_of(MINIMAL + "[material]\nmass = 1.0\ndensity = 0.2\n")
    assert error.key == "material.density"
    error = error_of(MINIMAL + "[[strokes]]\ntime = 0.05\n")
    assert error.key == "strokes[0]" and "exactly one" in error.expected
    error = error_of(MINIMAL + "[[strokes]]\ntime = 0.5\nmaterial = [[0.1, 0.5], [0.9, 0.5]]\n")
    assert error.key == "strokes[0].time" and "not before the end" in error.problem


def test_a_stroke_that_rounds_to_the_last_step_is_refused_before_running(tmp_path):
    # duration 0.05 s at dt 1 ms: a stroke at 0.0496 s rounds to step 50, the last, after which
    # the run draws nothing; 0.049 s (step 49) is drawn before the last step
    late = MINIMAL.replace("duration = 0.1", "duration = 0.05\ndt = 0.001") + (
        "[[strokes]]\ntime = 0.0496\nmaterial = [[0.1, 0.5], [0.9, 0.5]]\n"
    )
    error = error_of(late)
    assert error.key == "strokes[0].time" and error.line == 10
    assert "step 50" in error.problem and "0.049" in error.expected
    ok = late.replace("time = 0.0496", "time = 0.049")
    summary = yore.run_scene(
        load_scene(Path("scene.toml"), text=ok), tmp_path / "run", quiet=True, render=False
    )
    assert summary["finished"] and len(summary["strokes"]) == 1


def test_selections_out_of_range_or_empty_fail_before_running():
    error = error_of(MINIMAL + "[[fixed]]\nindices = [3, 20]\n")
    assert error.key == "fixed[0].indices" and "vertex 20" in error.problem
    error = error_of(MINIMAL + "[[fixed]]\nbox = { min = [5, 5, 5], max = [6, 6, 6] }\n")
    assert error.key == "fixed[0].box" and "no vertex" in error.problem
    error = error_of(MINIMAL + '[[fixed]]\nset = "top rim"\n')
    assert error.key == "fixed[0].set" and "top edge" in error.expected
    error = error_of(
        MINIMAL + '[[fixed]]\nset = "top edge"\n'
        '[[driven]]\nset = "top edge"\ncenter = [0, 0, 0]\naxis = [0, 1, 0]\n'
        "omega = 1.0\n"
    )
    assert error.key == "driven[0]" and "fixed" in error.problem


def test_a_stroke_that_misses_fails_before_simulating_naming_the_stroke():
    miss = MINIMAL + "[[strokes]]\ntime = 0.05\nmaterial = [[5.0, 5.0], [6.0, 5.0]]\n"
    error = error_of(miss)
    assert error.key == "strokes[0].material" and error.line == 10
    assert "misses" in error.problem
    # a 3-D stroke at t = 0 is tried on the initial cloth too
    miss3d = MINIMAL + "[[strokes]]\ntime = 0.0\npoints = [[0.5, 0.5, 3.0], [0.6, 0.5, 3.0]]\n"
    assert error_of(miss3d).key == "strokes[0].points"
    # a screen stroke needs a camera with an eye
    screen = MINIMAL + "[[strokes]]\ntime = 0.0\nscreen = [[10, 10], [50, 50]]\n"
    assert error_of(screen).key == "strokes[0].screen"


def test_overrides_replace_values_and_are_checked_like_the_file():
    scene = load_scene(text=MINIMAL, overrides={"mesh.nx": 7, "output.fps": 10.0})
    assert scene.data["mesh"]["nx"] == 7 and scene.data["output"]["fps"] == 10.0
    error = error_of(MINIMAL, overrides={"mesh.nx": 1})
    assert error.key == "mesh.nx" and error.line is None and "command line" in str(error)
    assert parse_override("simulation.dt=1e-3") == ("simulation.dt", 1e-3)
    assert parse_override("mesh.generator=grid") == ("mesh.generator", "grid")
    assert parse_override("strokes.0.material=[[0.1, 0.2], [0.3, 0.4]]")[1] == [
        [0.1, 0.2],
        [0.3, 0.4],
    ]


def test_invalid_toml_reports_the_line():
    error = error_of(MINIMAL + "[material\nmass = 1\n")
    assert error.line == 8 and "not valid TOML" in str(error)


def test_a_screen_stroke_through_the_scene_camera_splits_the_faces_under_it(tmp_path):
    camera = yore.Camera(eye=(0.5, 0.5, 2.0), target=(0.5, 0.5, 0.0), width=400, height=300)
    pixels = camera.project([[0.2, 0.45, 0.0], [0.8, 0.45, 0.0]])
    text = MINIMAL + (
        "[camera]\neye = [0.5, 0.5, 2.0]\ntarget = [0.5, 0.5, 0.0]\nwidth = 400\nheight = 300\n"
        f"[[strokes]]\ntime = 0.0\nscreen = {pixels.tolist()}\n"
        '[output]\nformat = "none"\n'
    )
    scene = load_scene(text=text)
    scene.check_strokes()
    summary = yore.run_scene(scene, tmp_path, quiet=True)
    (stroke,) = summary["strokes"]
    # the line y = 0.45 runs inside the middle row of quads of the 5×4 grid (y from 1/3 to
    # 2/3): it crosses both triangles of the inner quads
    assert stroke["faces_split"] >= 4 and stroke["missed_fraction"] == 0.0
    sim, _ = yore.load_state(tmp_path / "state.npz")
    assert sim.cloth.vertex_count == 20 + stroke["vertices_added"]


# -- limits: every bad input is one SceneError line, before anything is allocated ---------------


@pytest.mark.parametrize("nested", ["[" * 1000 + "]" * 1000, "{a = " * 1000 + "1" + "}" * 1000])
def test_toml_nested_a_thousand_levels_is_a_scene_error(nested):
    error = error_of(MINIMAL + f"[scene]\nname = {nested}\n")
    assert "nested too deeply" in str(error) and "\n" not in str(error)


def test_a_set_value_nested_a_thousand_levels_is_a_scene_error():
    with pytest.raises(SceneError, match="mesh.nx: the value is nested too deeply"):
        parse_override("mesh.nx=" + "[" * 1000 + "]" * 1000)


@pytest.mark.parametrize("nx", [2**63 - 1, 2**31])
def test_an_integer_beyond_int32_is_refused_naming_the_key(nx):
    error = error_of(MINIMAL.replace("nx = 5", f"nx = {nx}"))
    assert error.key == "mesh.nx" and "more than the limit 2147483647" in error.problem


def test_a_generated_mesh_too_large_is_refused_before_it_is_built():
    error = error_of(MINIMAL.replace("nx = 5", "nx = 100000").replace("ny = 4", "ny = 21"))
    assert error.key == "mesh.nx" and "2100000 vertices" in error.problem
    assert error.expected == f"at most {yore.meshes.MAX_MESH_VERTICES} vertices"
    error = error_of(
        '[mesh]\ngenerator = "cylinder"\nrings = 2000\nsegments = 2000\n'
        "[simulation]\nduration = 0.1\n"
    )
    assert error.key in ("mesh.rings", "mesh.segments")


def test_a_vertex_index_above_2_31_is_named():
    error = error_of(MINIMAL + "[[fixed]]\nindices = [1, 2147483648]\n")
    assert error.key == "fixed[0].indices" and "2147483648" in error.problem


def test_a_camera_too_large_is_refused():
    error = error_of(MINIMAL + "[camera]\nwidth = 30000\n")
    assert error.key == "camera.width" and "30000" in error.problem
    error = error_of(MINIMAL + "[camera]\nwidth = 16000\nheight = 16000\n")
    assert error.key == "camera.width" and "256000000 pixels" in error.problem


@pytest.mark.parametrize(
    "option, value",
    [
        ("max_newton", "2.9"),
        ("max_newton", "1000000000"),
        ("linearized", '"no"'),
        ("linearized", "1"),
        ("lag_cg_tol", "inf"),
        ("newton_tol", "nan"),
        ("solver", '"cholesky"'),
    ],
)
def test_integrator_options_are_checked_by_the_simulation_rules(option, value):
    text = MINIMAL.replace("duration = 0.1", 'duration = 0.1\nintegrator = "implicit"')
    error = error_of(text + f"[integrator]\n{option} = {value}\n")
    assert error.key == f"integrator.{option}" and error.line is not None


def test_an_option_the_scene_does_not_use_is_named_with_its_line():
    # issue 53: rtol with a fixed dt was accepted and ignored; defaults never count
    text = MINIMAL.replace("duration = 0.1", 'duration = 0.1\nintegrator = "tr-bdf2"\ndt = 0.01')
    error = error_of(text + "[integrator]\nnewton_tol = 1e-6\nrtol = 1e-3\n")
    assert error.key == "integrator.rtol" and error.line == 12
    assert 'acts only with dt="auto"' in error.problem and "with a fixed dt" in error.problem
    scene = load_scene(
        text=text.replace("dt = 0.01", 'dt = "auto"') + "[integrator]\nrtol = 1e-3\n"
    )
    sim, _ = scene.build()
    assert sim.options["rtol"] == 1e-3 and sim.options["adaptive"] is True
    error = error_of(
        text.replace("tr-bdf2", "local-global")
        + '[integrator]\nacceleration = "none"\nchebyshev_rho = 0.5\n'
    )
    assert error.key == "integrator.chebyshev_rho" and 'acceleration="chebyshev"' in str(error)


def test_non_finite_numbers_are_refused_where_they_make_no_sense():
    for text in (
        MINIMAL.replace("duration = 0.1", "duration = inf"),
        MINIMAL + "[[strokes]]\ntime = 0.0\nmaterial = [[0.1, nan], [0.5, 0.5]]\n",
        MINIMAL + "[material]\nmass = nan\n",
    ):
        assert "\n" not in str(error_of(text))


def test_a_fifo_as_scene_path_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    with pytest.raises(SceneError, match="not a regular file"):
        load_scene(fifo)


def test_a_generator_of_the_wrong_type_is_a_scene_error():
    error = error_of(MINIMAL.replace('generator = "grid"', "generator = [1]"))
    assert error.key == "mesh.generator"


def test_a_subnormal_mass_is_named_in_material_and_no_nan_step_is_suggested():
    scene = load_scene(EXAMPLES / "hanging_paper.toml", overrides={"material.mass": 1e-320})
    with pytest.raises(SceneError, match=r"material: mass of vertex 0") as info:
        scene.build()
    assert "nan" not in str(info.value)


# -- issue 41, classes 12 and 16: huge and tiny numbers are named, not tracebacks -------------


def test_a_duration_past_the_time_limit_is_named():
    with pytest.raises(
        SceneError,
        match=r"simulation.duration: got 1e\+308; expected a number "
        r"> 0 and <= 1e\+09",
    ):
        load_scene(Path("scene.toml"), text=MINIMAL.replace("duration = 0.1", "duration = 1e308"))


@pytest.mark.parametrize("fps", [5e-324, 1e-310, 1e-300])
def test_a_tiny_frame_rate_writes_the_first_and_last_frames(tmp_path, fps):
    # 1 / (fps × dt) overflowed (OverflowError) or divided by zero (ZeroDivisionError)
    text = (
        MINIMAL.replace("duration = 0.1", "duration = 0.05\ndt = 0.01")
        + f'[output]\nformat = "vtu"\nfps = {fps!r}\n'
    )
    summary = yore.run_scene(
        load_scene(Path("scene.toml"), text=text), tmp_path / "run", quiet=True, render=False
    )
    assert summary["finished"] and [f["time"] for f in summary["frames"]] == [0.0, 0.05]


def test_a_run_shorter_than_half_a_step_is_named_not_a_negative_time(tmp_path):
    # a stroke then said "expected a time at most -1 s"
    text = (
        MINIMAL.replace("duration = 0.1", "duration = 0.004\ndt = 0.01")
        + "[[strokes]]\ntime = 0.0\nmaterial = [[0.1, 0.5], [0.9, 0.5]]\n"
    )
    with pytest.raises(
        ValueError,
        match=r"the run has no step: 0.004 s is less than half of "
        r"dt = 0.01 s",
    ) as caught:
        yore.run_scene(load_scene(Path("scene.toml"), text=text), tmp_path / "run", quiet=True)
    assert "-1" not in str(caught.value) and not (tmp_path / "run").exists()


def test_a_scene_file_with_a_byte_order_mark_loads(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_bytes(b"\xef\xbb\xbf" + MINIMAL.encode())  # as some editors save UTF-8
    assert load_scene(path).data["mesh"]["nx"] == 5


def test_a_camera_that_cannot_make_the_pictures_is_refused_before_the_run():
    # issue 41, class 15: a camera eye at 1e300 printed numpy warnings and exited 0; a
    # 4096×2048 camera failed only after the run, when the before/after picture was made
    far = MINIMAL + "[camera]\neye = [1e300, 0.0, 1.0]\ntarget = [0.5, 0.5, 0.0]\n"
    error = error_of(far)
    assert error.key == "camera.eye" and "within ±1e+12" in error.expected
    with pytest.raises(ValueError, match=r"camera eye must be 3 finite numbers within ±1e\+12"):
        yore.Camera(eye=(1e300, 0.0, 1.0), target=(0.5, 0.5, 0.0))
    wide = MINIMAL + "[camera]\nwidth = 4096\nheight = 2048\n[output]\npictures = true\n"
    error = error_of(wide)
    assert error.key == "camera.width" and "8200 × 2076" in error.problem
    # the same camera without pictures is fine (one image of 2^23 pixels)
    load_scene(Path("scene.toml"), text=wide.replace("pictures = true", "pictures = false"))
