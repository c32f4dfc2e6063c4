"""The `yore` command: example scenes, outputs, exit codes, render, exact resume, .pvd."""

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest
from PIL import Image

import yore
from yore.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# Reduced sizes: a few hundred vertices, 0.3 s, the stroke at 0.1 s — every output still made.
SMALL = {
    "hanging_paper": [
        "--set",
        "mesh.nx=9",
        "--set",
        "mesh.ny=9",
        "--set",
        "simulation.duration=0.3",
        "--set",
        "strokes.0.time=0.1",
        "--set",
        "strokes.0.material=[[0.1, 0.2], [0.9, 0.2]]",
        "--set",
        "output.fps=20",
        "--set",
        "camera.width=160",
        "--set",
        "camera.height=120",
    ],
    "cylinder_paper": [
        "--set",
        "mesh.rings=6",
        "--set",
        "mesh.segments=12",
        "--set",
        "simulation.duration=0.3",
        "--set",
        "strokes.0.time=0.1",
        "--set",
        "output.fps=20",
        "--set",
        "camera.width=160",
        "--set",
        "camera.height=120",
    ],
    "stiff": [
        "--set",
        "mesh.nx=9",
        "--set",
        "mesh.ny=9",
        "--set",
        "simulation.duration=0.3",
        "--set",
        "strokes.0.time=0.1",
        "--set",
        "strokes.0.material=[[0.1, 0.2], [0.9, 0.2]]",
        "--set",
        "fixed.1.indices=[8]",
    ],
}
# yore's reproductions of the two experiments take the same reductions as the paper's
SMALL["hanging"] = SMALL["hanging_paper"]
SMALL["cylinder"] = SMALL["cylinder_paper"]


def run(name, out, *extra):
    code = main(
        ["run", str(EXAMPLES / f"{name}.toml"), "-o", str(out), "--quiet", *SMALL[name], *extra]
    )
    assert code == 0
    return json.loads((out / "summary.json").read_text())


def pvd_entries(path):
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


@pytest.mark.slow
@pytest.mark.parametrize(
    "name", ["hanging", "hanging_paper", "cylinder", "cylinder_paper", "stiff"]
)
def test_every_example_scene_runs_at_reduced_size_and_writes_what_it_promises(tmp_path, name):
    summary = run(name, tmp_path)
    scene = yore.runs.load_scene(EXAMPLES / f"{name}.toml")
    output = scene.data["output"]
    assert summary["finished"] and summary["time"] == pytest.approx(0.3, abs=summary["dt"])
    assert summary["integrator"] == scene.data["simulation"]["integrator"]
    # frames: the first, one per interval, and the last when it falls between
    written = summary["settings"]["output"]
    every = written.get("every_steps") or max(1, round(1.0 / (written["fps"] * summary["dt"])))
    steps = summary["steps"]
    assert len(summary["frames"]) == steps // every + 1 + (steps % every != 0)
    for frame in summary["frames"]:
        assert (tmp_path / frame["file"]).is_file()
    assert [f for _, f in pvd_entries(tmp_path / "frames" / "frame.pvd")] == [
        str(Path(f["file"]).relative_to("frames")) for f in summary["frames"]
    ]
    # records per frame; energies and areas are finite numbers
    assert len(summary["records"]) == len(summary["frames"])
    assert all(np.isfinite(r["total"]) and r["area"] > 0 for r in summary["records"])
    # the stroke did what its growth mode says and is reported; the rest area grew
    (stroke,) = summary["strokes"]
    assert len(stroke["new_vertices"]) == stroke["vertices_added"]
    if stroke["growth"] == "paper":
        assert stroke["faces_split"] > 0
    else:  # yore's: refined the band and grew its springs, split nothing
        assert stroke["faces_split"] == 0 and stroke["springs_grown"] > 0
        assert stroke["faces_refined"] > 0 and stroke["vertices_added"] > 0
    assert stroke["rest_area_after"] > stroke["rest_area_before"]
    assert (
        summary["records"][-1]["vertices"]
        == summary["records"][0]["vertices"] + stroke["vertices_added"]
    )
    # timings per phase and the settings actually used
    assert summary["phases"] and all(isinstance(v, float) for v in summary["phases"].values())
    assert summary["settings"]["simulation"]["dt"] == summary["dt"]
    # the state file continues the run; pictures as asked
    sim, record = yore.load_state(tmp_path / "state.npz")
    assert sim.time == summary["time"] and record["step"] == summary["steps"]
    if output["pictures"]:
        with Image.open(tmp_path / "before_after.png") as image:
            camera = summary["camera"]
            assert image.size == (2 * camera["width"] + 8, camera["height"] + 28)
    assert (tmp_path / "animation.gif").exists() == (output["animation"] == "gif")


@pytest.mark.slow
def test_the_python_scripting_example_runs(tmp_path):
    completed = subprocess.run(
        [
            sys.executable,
            str(EXAMPLES / "scripted_scene.py"),
            "--out",
            str(tmp_path),
            "--resolution",
            "7",
            "--seconds",
            "0.2",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert completed.returncode == 0, completed.stderr
    assert (tmp_path / "summary.json").is_file() and (tmp_path / "frames" / "frame.pvd").is_file()


def test_bad_scenes_fail_before_simulating_with_exit_code_2_and_one_line(tmp_path, capsys):
    scene = tmp_path / "bad.toml"
    text = (EXAMPLES / "hanging_paper.toml").read_text()
    cases = {
        "material.stifness": text.replace("stretch_stiffness = 200.0", "stifness = 200.0"),
        "mesh.nx": text.replace("nx = 21", 'nx = "21"'),
        "strokes[0].material": text.replace(
            "[[0.15, 0.075], [0.85, 0.075]]", "[[3.0, 3.0], [4.0, 3.0]]"
        ),
    }
    for key, body in cases.items():
        scene.write_text(body)
        out = tmp_path / f"out-{key}"
        assert main(["run", str(scene), "-o", str(out)]) == 2
        message = capsys.readouterr().err
        assert message.startswith("yore: error:") and message.count("\n") == 1
        assert key in message and "bad.toml:" in message
        assert not out.exists()  # nothing ran, nothing was written


@pytest.mark.slow
def test_the_console_script_exits_non_zero_on_errors_and_zero_on_check(tmp_path):
    yore_command = Path(sys.executable).with_name("yore")
    completed = subprocess.run(
        [str(yore_command), "run", str(tmp_path / "missing.toml")], capture_output=True, text=True
    )
    assert completed.returncode == 2 and "cannot read the scene file" in completed.stderr
    completed = subprocess.run(
        [sys.executable, "-m", "yore", "check", str(EXAMPLES / "hanging_paper.toml")],
        capture_output=True,
        text=True,
    )
    assert completed.returncode == 0 and "OK" in completed.stdout
    completed = subprocess.run(
        [str(yore_command), "run", "--bogus"], capture_output=True, text=True
    )
    assert completed.returncode == 2 and completed.stderr.startswith("yore: error:")


def test_a_diverging_run_exits_1_saying_when_and_suggesting_a_step(tmp_path, capsys):
    code = main(
        [
            "run",
            str(EXAMPLES / "stiff.toml"),
            "-o",
            str(tmp_path),
            "--quiet",
            *SMALL["stiff"],
            "--set",
            'simulation.integrator="explicit"',
            "--set",
            "simulation.dt=0.01",
            "--set",
            "integrator={}",
        ]
    )
    assert code == 1
    message = capsys.readouterr().err
    assert "diverged at step" in message and "stable time step" in message
    assert (tmp_path / "state.npz").is_file()  # the last good state is kept


def test_a_refused_matrix_mid_run_is_a_failed_run_with_state_and_summary(
    tmp_path, capsys, monkeypatch
):
    # Whatever makes the linear solver refuse a matrix mid-run (extreme values that pass the
    # checks, round-off) ends the run as a failure: one line, exit 1, state and summary kept.
    calls = []
    step = yore.Simulation.step

    def refusing_step(self, n=1, progress=None):
        calls.append(n)
        if len(calls) == 2:
            raise yore.NotPositiveDefinite("CHOLMOD: the matrix is not positive definite")
        return step(self, n, progress)

    monkeypatch.setattr(yore.Simulation, "step", refusing_step)
    code = main(
        ["run", str(EXAMPLES / "stiff.toml"), "-o", str(tmp_path), "--quiet", *SMALL["stiff"]]
    )
    error = capsys.readouterr().err
    assert code == 1 and error.count("\n") == 1 and error.startswith("yore: error:")
    assert "refused a step's matrix" in error and "smaller dt" in error
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "diverged" and not summary["finished"]
    assert (tmp_path / "state.npz").is_file()


def test_material_values_past_their_limit_fail_the_check_naming_the_key(tmp_path, capsys):
    code = main(
        ["check", str(EXAMPLES / "stiff.toml"), "--set", "material.stretch_stiffness=1e300"]
    )
    error = capsys.readouterr().err
    assert code == 2 and "material.stretch_stiffness" in error and "1e+12" in error


@pytest.mark.parametrize(
    "scene, setting, key",
    [
        # issue 53, N17: a 1e150 m grid failed as "degenerate" naming no key; a driver's centre at
        # 1e300 m passed the check and made the run's first positions infinite
        ("hanging_paper.toml", "mesh.width=1e150", "mesh.width"),
        ("cylinder.toml", "mesh.radius=1e150", "mesh.radius"),
        ("cylinder.toml", "driven.0.center=[1e300, 0.5, 0.0]", "driven[0].center"),
    ],
)
def test_sizes_and_points_past_a_thousand_kilometres_fail_the_check_naming_the_key(
    capsys, scene, setting, key
):
    code = main(["check", str(EXAMPLES / scene), "--set", setting])
    error = capsys.readouterr().err
    assert code == 2 and error.count("\n") == 1 and error.startswith("yore: error:")
    assert f"{key}:" in error and "1e+06" in error


@pytest.mark.parametrize(
    "settings, key, needs",
    [
        (["--set", "integrator.rtol=1e-3"], "integrator.rtol", 'dt="auto"'),
        (
            [
                "--set",
                'integrator.solver="eigen-ldlt"',
                "--set",
                'integrator.factorization="simplicial"',
            ],
            "integrator.factorization",
            'solver="cholmod"',
        ),
        (["--set", "integrator.pcg_tol=1e-8"], "integrator.pcg_tol", 'solver="pcg"'),
    ],
)
def test_check_and_run_refuse_an_option_the_scene_would_ignore_alike(
    tmp_path, capsys, settings, key, needs
):
    # issue 53 (and R04): the stiff scene's bdf2 has a fixed dt and Newton's tolerance given
    scene = str(EXAMPLES / "stiff.toml")
    errors = []
    for command in (["check", scene], ["run", scene, "-o", str(tmp_path / "out"), "--quiet"]):
        assert main([*command, *settings]) == 2
        error = capsys.readouterr().err
        assert error.startswith("yore: error:") and error.count("\n") == 1
        assert f"{key}: {key.split('.')[1]} acts only with {needs}" in error
        errors.append(error)
    assert errors[0] == errors[1]  # the check says what the run would
    assert not (tmp_path / "out").exists()
    assert main(["check", scene, "--set", 'simulation.dt="auto"', *settings]) == (
        0 if key == "integrator.rtol" else 2
    )


@pytest.mark.slow
def test_render_writes_a_png_of_the_requested_size_showing_the_cloth(tmp_path, capsys):
    run("hanging", tmp_path)
    frame = tmp_path / "frames" / "frame_00003.vtu"
    picture = tmp_path / "picture.png"
    assert (
        main(
            [
                "render",
                str(frame),
                "-o",
                str(picture),
                "--width",
                "320",
                "--height",
                "200",
                "--color-by",
                "expansion",
            ]
        )
        == 0
    )
    with Image.open(picture) as image:
        assert image.size == (320, 200)
        pixels = np.asarray(image.convert("RGB")).reshape(-1, 3)
    background = np.all(pixels == 255, axis=1)
    # the cloth covers a real part of the picture, and not all of it (fitted with a margin)
    assert 0.05 < 1.0 - background.mean() < 0.95
    # the stroke of the run is drawn over the cloth, in the colour chosen to stand out from
    # the colour map (unlit, so its pixels have that colour up to anti-aliasing at the rim)
    from yore.viz.render import colormap_table, stroke_color

    ink = np.asarray(stroke_color(colormap_table("viridis"))) * 255.0
    assert np.sum(np.abs(pixels - ink).max(axis=1) < 40) > 10
    # a whole run: before/after side by side and the animation
    assert main(["render", str(tmp_path), "-o", str(tmp_path / "pictures"), "--quiet"]) == 0
    with Image.open(tmp_path / "pictures" / "before_after.png") as image:
        assert image.size[0] == 2 * 160 + 8 and image.size[1] == 120 + 28
    with Image.open(tmp_path / "pictures" / "animation.gif") as gif:
        assert gif.n_frames >= 2


@pytest.mark.parametrize(
    "name, stroke_time", [("hanging", 0.1), ("hanging", 0.25), ("cylinder", 0.1), ("stiff", 0.1)]
)
def test_run_straight_equals_run_save_resume_bit_for_bit(tmp_path, name, stroke_time):
    # 0.3 s straight vs 0.15 s, save, resume to 0.3 s — the stroke before or after the split.
    extra = ["--set", f"strokes.0.time={stroke_time}", "--no-render"]
    run(name, tmp_path / "straight", *extra)
    run(name, tmp_path / "split", *extra, "--until", "0.15")
    assert (
        main(["run", "--resume", str(tmp_path / "split" / "state.npz"), "--quiet", "--no-render"])
        == 0
    )
    straight, _ = yore.load_state(tmp_path / "straight" / "state.npz")
    resumed, record = yore.load_state(tmp_path / "split" / "state.npz")
    assert record["resumed_from"]
    assert resumed.time == straight.time
    a, b = straight.cloth.state(), resumed.cloth.state()
    for key in ("positions", "velocities", "masses", "spring_rest", "spring_ends", "faces"):
        assert a[key].shape == b[key].shape and np.array_equal(a[key], b[key]), key


def test_pvd_lists_every_frame_across_a_stroke_and_a_resume(tmp_path):
    first = run("hanging", tmp_path, "--until", "0.15", "--no-render")
    assert main(["run", "--resume", str(tmp_path / "state.npz"), "--quiet"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    # phases are summed over both parts (wall time: the names and the steps are checked)
    assert summary["phases"].keys() == first["phases"].keys()
    assert summary["steps"] > first["steps"]
    entries = pvd_entries(tmp_path / "frames" / "frame.pvd")
    assert len(entries) == len(summary["frames"]) == len(summary["records"])
    times = [t for t, _ in entries]
    assert times == sorted(times) and len(set(times)) == len(times)
    assert times[-1] == pytest.approx(0.3, abs=summary["dt"])
    counts = []
    for _, file in entries:
        mesh = meshio.read(tmp_path / "frames" / file)
        counts.append(len(mesh.points))
    # the stroke at 0.1 s adds vertices: frames before and after it differ, both are listed
    stroke = summary["strokes"][0]
    assert counts[0] < counts[-1] == counts[0] + stroke["vertices_added"]
    assert sorted(set(counts)) == [counts[0], counts[-1]]
    assert os.path.samefile(
        tmp_path / "frames" / entries[-1][1], tmp_path / summary["frames"][-1]["file"]
    )


@pytest.mark.slow
def test_yore_demo_writes_frames_pictures_and_an_animation_and_says_where(tmp_path, capsys):
    out = tmp_path / "yore-out"
    assert main(["demo", "-o", str(out), *SMALL["hanging"]]) == 0
    printed = capsys.readouterr().out
    for name in (
        "frames/frame.pvd",
        "before_after.png",
        "animation.gif",
        "summary.json",
        "state.npz",
    ):
        assert (out / name).is_file(), name
        assert str((out / name).resolve()) in printed  # the report says where it went


@pytest.mark.parametrize("fmt", ["ply", "obj"])
def test_ply_and_obj_frames_are_written_and_rendered(tmp_path, fmt):
    summary = run("hanging", tmp_path, "--set", f'output.format="{fmt}"', "--no-render")
    files = [tmp_path / f["file"] for f in summary["frames"]]
    assert all(f.suffix == f".{fmt}" and f.is_file() for f in files)
    V, F = yore.load_mesh(files[-1])
    sim, _ = yore.load_state(tmp_path / "state.npz")
    assert np.allclose(V, sim.cloth.positions) and np.array_equal(F, sim.cloth.faces)
    assert main(["render", str(tmp_path), "--quiet", "--animation", "none"]) == 0
    assert (tmp_path / "before_after.png").is_file()
    colour = main(["render", str(files[-1]), "--color-by", "expansion"])
    assert colour == (0 if fmt == "ply" else 2)  # OBJ holds no point data to colour by


def test_a_scene_on_a_mesh_file_with_box_and_index_selections(tmp_path):
    V, F = yore.grid_mesh(6, 6, width=0.5, height=0.5)
    yore.save_mesh(tmp_path / "patch.obj", V, F)
    (tmp_path / "patch.toml").write_text(
        '[mesh]\ngenerator = "file"\npath = "patch.obj"\nscale = 2.0\n'
        "[[fixed]]\nbox = { min = [-0.01, 0.99, -0.01], max = [1.01, 1.01, 0.01] }\n"
        '[simulation]\nintegrator = "implicit"\nduration = 0.05\n'
        "[[strokes]]\ntime = 0.0\npoints = [[0.1, 0.5, 0.0], [0.9, 0.5, 0.0]]\n"
        '[output]\nformat = "none"\n'
    )
    assert main(["run", str(tmp_path / "patch.toml"), "-o", str(tmp_path / "out"), "--quiet"]) == 0
    sim, _ = yore.load_state(tmp_path / "out" / "state.npz")
    assert list(sim.cloth.fixed_vertices) == list(range(30, 36))  # the scaled top row, y = 1
    assert sim.cloth.vertex_count > 36  # the stroke added vertices
    (tmp_path / "broken.toml").write_text(
        '[mesh]\ngenerator = "file"\npath = "nowhere.obj"\n[simulation]\nduration = 1.0\n'
    )
    with pytest.raises(yore.SceneError, match="mesh.path"):
        yore.load_scene(tmp_path / "broken.toml").build()


def test_an_interrupted_run_saves_its_state_and_resumes_exactly(tmp_path, monkeypatch, capsys):
    run("hanging_paper", tmp_path / "straight", "--no-render")
    original_step = yore.Simulation.step
    calls = {"count": 0}

    def interrupted_step(self, n=1, progress=None):
        calls["count"] += 1
        if calls["count"] == 4:  # Ctrl-C in the middle of the run (after the stroke)
            original_step(self, n // 2, progress=False)
            raise KeyboardInterrupt
        original_step(self, n, progress)

    monkeypatch.setattr(yore.Simulation, "step", interrupted_step)
    code = main(
        [
            "run",
            str(EXAMPLES / "hanging_paper.toml"),
            "-o",
            str(tmp_path / "split"),
            "--quiet",
            "--no-render",
            *SMALL["hanging_paper"],
        ]
    )
    assert code == 130 and "--resume" in capsys.readouterr().err
    monkeypatch.setattr(yore.Simulation, "step", original_step)
    assert (
        main(["run", "--resume", str(tmp_path / "split" / "state.npz"), "--quiet", "--no-render"])
        == 0
    )
    straight, _ = yore.load_state(tmp_path / "straight" / "state.npz")
    resumed, _ = yore.load_state(tmp_path / "split" / "state.npz")
    assert np.array_equal(straight.cloth.positions, resumed.cloth.positions)
    a = json.loads((tmp_path / "straight" / "summary.json").read_text())
    b = json.loads((tmp_path / "split" / "summary.json").read_text())
    assert [f["time"] for f in a["frames"]] == [f["time"] for f in b["frames"]]


def test_version_and_help_for_every_argument(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0 and capsys.readouterr().out.strip() == f"yore {yore.__version__}"
    from yore.cli import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    for name, command in commands.items():
        for action in command._actions:
            assert action.help, f"yore {name} {action.option_strings or action.dest}: no help"
        assert any("--threads" in a.option_strings for a in command._actions), name


@pytest.mark.parametrize("where", ["--threads", "scene"])
def test_threads_are_set_by_the_command_line_or_the_scene(tmp_path, where):
    before = yore._core.max_threads()
    try:
        extra = ["--threads", "1"] if where == "--threads" else ["--set", "simulation.threads=1"]
        yore.set_num_threads(2)
        summary = run("hanging", tmp_path, "--no-render", *extra)
        assert yore._core.max_threads() == 1
        assert summary["yore"]["threads"] == 1
    finally:
        yore.set_num_threads(before)


def test_bad_thread_counts_are_bad_input(tmp_path, capsys):
    assert main(["check", str(EXAMPLES / "hanging_paper.toml"), "--threads", "0"]) == 2
    assert "threads" in capsys.readouterr().err
    assert (
        main(["check", str(EXAMPLES / "hanging_paper.toml"), "--set", "simulation.threads=0"]) == 2
    )
    assert "simulation.threads" in capsys.readouterr().err


def test_the_command_in_the_stiff_example_header_runs_and_diverges_as_it_says(tmp_path, capsys):
    header = [
        line.lstrip("# ")
        for line in (EXAMPLES / "stiff.toml").read_text().splitlines()
        if line.startswith("#   yore run")
    ]
    assert len(header) == 1
    import shlex

    words = shlex.split(header[0])
    assert words[:3] == ["yore", "run", "examples/stiff.toml"]
    code = main(
        [
            "run",
            str(EXAMPLES / "stiff.toml"),
            *words[3:],
            "-o",
            str(tmp_path),
            "--quiet",
            "--no-render",
            "--set",
            "simulation.duration=0.5",
            "--set",
            "strokes=[]",
        ]
    )
    error = capsys.readouterr().err
    assert code == 1 and "diverged" in error and "use dt <=" in error


@pytest.mark.slow
def test_render_mp4_without_ffmpeg_fails_before_touching_the_run(tmp_path, monkeypatch, capsys):
    run("hanging", tmp_path, "--no-render")
    import shutil

    monkeypatch.setattr(shutil, "which", lambda name: None)
    assert main(["render", str(tmp_path), "--animation", "mp4", "--quiet"]) == 2
    assert "ffmpeg" in capsys.readouterr().err
    assert not (tmp_path / "before_after.png").exists() and not (tmp_path / "last.png").exists()


def test_render_colours_by_the_scene_unless_told_otherwise(tmp_path, monkeypatch):
    run("hanging", tmp_path, "--no-render", "--set", 'output.color_by="expansion"')
    import yore.viz.pictures

    seen = []
    original = yore.viz.pictures.render_image

    def recording(V, F, camera, vertex_values=None, **kwargs):
        seen.append(vertex_values is not None)
        return original(V, F, camera, vertex_values=vertex_values, **kwargs)

    monkeypatch.setattr(yore.viz.pictures, "render_image", recording)
    assert main(["render", str(tmp_path), "--animation", "none", "--quiet"]) == 0
    assert seen and all(seen)
    seen.clear()
    assert (
        main(["render", str(tmp_path), "--animation", "none", "--quiet", "--color-by", "none"]) == 0
    )
    assert seen and not any(seen)


def test_no_progress_bar_reaches_a_log_file(monkeypatch, capsys):
    import yore.progress
    import yore.step_runner

    # a bar is due at once (every batch is "slow"); stderr here is not a terminal
    monkeypatch.setattr(yore.progress, "AFTER_SECONDS", 0.0)
    monkeypatch.setattr(yore.step_runner, "BATCH_SECONDS", 0.0)
    sim = yore.scenes.hanging_cloth(resolution=7)
    sim.step(40)
    assert capsys.readouterr().err == ""
    sim.step(5, progress=True)  # asked for: shown anyway
    assert "yore" in capsys.readouterr().err


def test_a_run_past_the_step_limit_needs_allow_long_and_check_says_the_steps(tmp_path, capsys):
    scene = str(EXAMPLES / "stiff.toml")
    assert main(["check", scene, "--set", "simulation.dt=0.01"]) == 0
    out = capsys.readouterr().out
    assert " steps," in out and "allow-long" not in out
    tiny = ["--set", "simulation.dt=1e-12"]
    assert main(["check", scene, *tiny]) == 0
    assert "yore run needs --allow-long" in capsys.readouterr().out
    code = main(["run", scene, "-o", str(tmp_path / "long"), "--quiet", *tiny])
    err = capsys.readouterr().err
    assert code == 2 and "more than the limit of 100000000" in err and "--allow-long" in err
    assert not (tmp_path / "long").exists()  # refused before the folder was claimed
    code = main(["run", scene, "-o", str(tmp_path / "until"), "--quiet", "--until", "1e6"])
    err = capsys.readouterr().err
    assert code == 2 and "after the scene's end" in err
    for key, value, match in [
        ("simulation.settle", "1e9", "simulation.settle"),
        ("simulation.threads", "1000000", "simulation.threads"),
    ]:
        assert main(["check", scene, "--set", f"{key}={value}"]) == 2
        assert match in capsys.readouterr().err


def _interrupted_before_yore_ran(returncode, err):
    """A Ctrl-C that ended the process in Python's own start (its initialization, ``site``,
    ``runpy`` finding the package): a KeyboardInterrupt whose traceback shows no file of the
    yore package."""
    import re
    import signal

    return (
        returncode in (1, -signal.SIGINT)
        and err.rstrip().endswith("KeyboardInterrupt")
        and re.search(r'File "[^"]*[/\\]yore[/\\][^"/\\]+\.py"', err) is None
    )


def test_an_interrupt_in_yores_own_import_is_not_excused():
    # the failure the guard fixed: a traceback through yore/__init__.py is yore's to prevent
    seen = (
        "Traceback (most recent call last):\n"
        '  File "/x/site-packages/yore/__init__.py", line 16, in <module>\n'
        '  File "/x/site-packages/yore/runtime.py", line 11, in <module>\n'
        "KeyboardInterrupt\n"
    )
    assert not _interrupted_before_yore_ran(-2, seen)
    python_alone = (
        "Fatal Python error: init_sys_streams: can't initialize sys standard streams\n"
        "Traceback (most recent call last):\n"
        '  File "<frozen abc>", line 107, in __new__\n'
        "KeyboardInterrupt\n"
    )
    assert _interrupted_before_yore_ran(1, python_alone)


@pytest.mark.parametrize("delay", [0.05, 0.2, 0.4])
@pytest.mark.parametrize("how", ["yore", "python -m yore"])
def test_ctrl_c_while_the_command_starts_is_one_line(delay, how):
    # issue 22, item 18: a Ctrl-C during `import yore` printed a 20-line traceback (and with
    # `python -m yore` it still did, issue 41). Whenever the interrupt lands (starting,
    # running or after the end), the command says at most one line and never a traceback.
    import signal
    import time

    command = (
        [str(Path(sys.executable).with_name("yore"))]
        if how == "yore"
        else [sys.executable, "-m", "yore"]
    )
    process = subprocess.Popen(
        [*command, "check", str(EXAMPLES / "stiff.toml")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    time.sleep(delay)  # where the interrupt lands, not a measure
    try:
        os.killpg(process.pid, signal.SIGINT)
    except ProcessLookupError:
        pass
    _, err = process.communicate(timeout=300)
    # -SIGINT: it landed while the interpreter itself starts or shuts down, which Python's
    # default disposition ends silently; or it landed in Python's own start before any of yore
    # ran (on a loaded machine 50 ms can still be inside it): Python's traceback, with no frame
    # of yore's, which yore cannot guard (docs/limitations.md, Robustness)
    assert (process.returncode, err) in (
        (130, "yore: interrupted\n"),
        (0, ""),
        (-signal.SIGINT, ""),
    ) or _interrupted_before_yore_ran(process.returncode, err), err


def test_ctrl_c_while_the_parser_is_built_is_one_line(monkeypatch, capsys):
    # the interrupt that test_ctrl_c_while_the_command_starts_is_one_line can only hit by
    # timing, made certain: it lands inside the parser's construction
    from yore import cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert cli.main(["check", str(EXAMPLES / "stiff.toml")]) == cli.EXIT_INTERRUPTED
    assert capsys.readouterr().err == "yore: interrupted\n"


def test_ctrl_c_in_the_command_shutdown_prints_nothing(tmp_path):
    # the interrupt that test_ctrl_c_while_the_command_starts_is_one_line hit once by timing:
    # after main() returned, in the interpreter's shutdown, Python printed "Exception ignored
    # in ..." with a traceback. Made certain: an exit handler registered before the command
    # runs (so it runs last) sends the Ctrl-C to its own process.
    import signal
    import textwrap

    script = tmp_path / "yore"  # as the command's script: yore._entry.command is its entry point
    script.write_text(
        textwrap.dedent("""\
        import atexit, os, signal, sys
        atexit.register(lambda: os.kill(os.getpid(), signal.SIGINT))
        from yore._entry import command
        sys.exit(command())
        """)
    )
    process = subprocess.run(
        [sys.executable, str(script), "check", str(EXAMPLES / "stiff.toml")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert (process.returncode, process.stderr) == (0, ""), process.stderr
    assert process.stdout  # the check itself ran and reported
    # and a program that imports yore keeps Python's own handling after main() returns
    from yore import cli

    assert cli.main(["check", str(EXAMPLES / "stiff.toml")]) == cli.EXIT_OK
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_warning_is_one_line_without_the_source_line(tmp_path):
    # issue 41, class 16: warnings were printed with the Python source line that warned
    scene = tmp_path / "scene.toml"
    scene.write_text(
        '[mesh]\ngenerator = "grid"\nnx = 5\nny = 5\n[[fixed]]\n'
        'set = "top corners"\n[simulation]\nintegrator = "local-global"\n'
        "dt = 0.01\nduration = 0.02\ngravity = [0.0, -1e15, 0.0]\n"
        '[output]\nformat = "none"\n'
    )
    result = subprocess.run(
        [sys.executable, "-m", "yore", "run", str(scene), "-o", str(tmp_path / "out"), "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    assert lines and all(line.startswith("yore: warning: ") for line in lines), lines
    assert any("iteration cap" in line for line in lines)


def test_a_usage_error_points_at_the_help_of_the_command_as_typed(capsys):
    # "see `yore plot --help`" named a command that does not exist
    with pytest.raises(SystemExit) as exit_:
        main(["sweep", "plot", "--no-such-option"])
    assert exit_.value.code == 2
    assert "(see `yore sweep plot --help`)" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", "--no-such-option"])
    assert "(see `yore run --help`)" in capsys.readouterr().err


def test_the_yore_command_guards_its_start(monkeypatch):
    """`start_command` (the command's script and ``python -m yore`` call it before anything
    heavy loads) makes a Ctrl-C one line until `end_command_start` hands it to main()."""
    import signal

    from yore import runtime

    monkeypatch.setattr(runtime, "_command", [False])
    monkeypatch.setattr(runtime, "_guarding", [False])
    before = signal.getsignal(signal.SIGINT)
    if before is not signal.default_int_handler:
        pytest.skip("SIGINT is not Python's default handler in this process")
    try:
        runtime.start_command()
        assert signal.getsignal(signal.SIGINT) is runtime._interrupted_while_starting
        assert runtime.is_command()
        runtime.end_command_start()
        assert signal.getsignal(signal.SIGINT) is before
    finally:
        signal.signal(signal.SIGINT, before)


_PROBE = """
import json, os, signal, sys
environ = dict(os.environ)
import yore
loaded = yore.Cloth, yore.Simulation, yore._core  # the core's load included
print(json.dumps({
    "sigint_default": signal.getsignal(signal.SIGINT) is signal.default_int_handler,
    "environ_kept": dict(os.environ) == environ,
    "blas_threads": yore._core.blas_threads(),
    "library": yore.blas.report()["library"],
    "command": yore.runtime.is_command(),
}))
"""


def test_importing_yore_changes_nothing_in_the_process():
    """Issue 54: ``import yore`` (and loading its core) installs no signal handler, leaves the
    environment and the BLAS's thread count as they were, even when the interpreter was
    started as ``python -m yore``-like; the BLAS's count is the one the library picks by itself
    (read by loading it alone, with ctypes, in another process)."""
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    env.pop("YORE_SWEEP_WORKER", None)
    done = subprocess.run(
        [sys.executable, "-c", _PROBE], capture_output=True, text=True, env=env, check=True
    )
    probe = json.loads(done.stdout)
    assert probe["sigint_default"] and probe["environ_kept"] and not probe["command"]
    openblas = [p for p in probe["library"] if "openblas" in p.lower()]
    if not openblas:
        pytest.skip("the BLAS CHOLMOD calls is not OpenBLAS")
    alone = subprocess.run(
        [
            sys.executable,
            "-c",
            f"import ctypes; print(ctypes.CDLL({openblas[-1]!r}).openblas_get_num_threads())",
        ],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    assert probe["blas_threads"] == int(alone.stdout)


def test_a_runs_report_says_its_largest_energy_rise(tmp_path, capsys):
    # issue 53: the growth check's measure is in the summary's counters and the report
    code = main(
        [
            "run",
            str(EXAMPLES / "hanging_paper.toml"),
            "-o",
            str(tmp_path),
            "--no-render",
            "--set",
            "mesh.nx=7",
            "--set",
            "mesh.ny=7",
            "--set",
            "simulation.duration=0.2",
            "--set",
            "strokes.0.time=0.1",
            "--set",
            "simulation.settle=0",
        ]
    )
    out = capsys.readouterr().out
    gain = json.loads((tmp_path / "summary.json").read_text())["counters"]["energy_gain"]
    assert code == 0 and gain > 0
    assert f"largest energy rise above its lowest: {gain:.3g} J" in out


def test_the_commands_own_import_of_yore_guards_ctrl_c_from_its_first_line(monkeypatch):
    """A Ctrl-C landing while ``python -m yore`` imported the package (in ``import signal``)
    printed Python's traceback: the package's first lines now guard the command's own import,
    and only it (`yore._start_guard`); `start_command` takes the guard over."""
    import signal

    from yore import _start_guard, runtime

    for argv, orig, command in (
        (["/usr/local/bin/yore", "run"], ["python3", "/usr/local/bin/yore", "run"], True),
        (["-m"], ["python3", "-m", "yore", "run", "x.toml"], True),
        (["-m"], ["python3", "-X", "dev", "-m", "yore"], True),
        (["-c"], ["python3", "-c", "import yore", "-m", "yore"], False),
        (["-m"], ["python3", "-m", "pytest", "-m", "yore"], False),
        (["prog.py"], ["python3", "prog.py"], False),
    ):
        monkeypatch.setattr(sys, "argv", argv)
        monkeypatch.setattr(sys, "orig_argv", orig, raising=False)
        assert _start_guard.is_command_import() is command, orig
    before = signal.getsignal(signal.SIGINT)
    if before is not signal.default_int_handler:
        pytest.skip("SIGINT is not Python's default handler in this process")
    monkeypatch.setattr(runtime, "_command", [False])
    monkeypatch.setattr(runtime, "_guarding", [False])
    try:
        _start_guard.guard()
        assert signal.getsignal(signal.SIGINT) is _start_guard.interrupted
        runtime.start_command()  # takes over from the early guard
        assert signal.getsignal(signal.SIGINT) is runtime._interrupted_while_starting
        runtime.end_command_start()
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, before)
