"""`yore run` as a transaction: interrupts injected at chosen points (never by timing) lose and
double nothing, non-finite runs stop with their last good state, folders never mix two runs."""

import json
import signal
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

import yore
import yore.io
import yore.runs.output
import yore.runs.runner
import yore.runs.stepping
from yore.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# The demo scene at a few hundred vertices: a stroke (at 0.1 s) with rest-length smoothing,
# and frames every 0.05 s.
HANGING = [
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
    "strokes.0.smooth={iterations = 5, strength = 0.5}",
    "--set",
    "output.fps=20",
    "--no-render",
    "--quiet",
]


def strict_json(path):
    """The JSON document at path; fails on NaN/Infinity, which strict JSON does not have."""

    def refuse(name):
        raise AssertionError(f"{path} holds {name}")

    return json.loads(Path(path).read_text(), parse_constant=refuse)


def run_hanging(out, *extra):
    return main(["run", str(EXAMPLES / "hanging_paper.toml"), "-o", str(out), *HANGING, *extra])


def resume(out):
    return main(["run", "--resume", str(out / "state.npz"), "--quiet", "--no-render"])


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    out = tmp_path_factory.mktemp("straight")
    assert run_hanging(out) == 0
    return out


def assert_same_run(straight, split):
    """Same final state bit for bit, same frames (times, files, contents) and records."""
    a, _ = yore.load_state(straight / "state.npz")
    b, _ = yore.load_state(split / "state.npz")
    assert b.cloth.vertex_count == a.cloth.vertex_count
    assert np.array_equal(a.cloth.positions, b.cloth.positions)
    sa, sb = strict_json(straight / "summary.json"), strict_json(split / "summary.json")
    assert [f["time"] for f in sa["frames"]] == [f["time"] for f in sb["frames"]]
    assert [f["file"] for f in sa["frames"]] == [f["file"] for f in sb["frames"]]
    keys = ("time", "kinetic", "spring", "gravity", "total", "vertices")
    assert [[r[k] for k in keys] for r in sa["records"]] == [
        [r[k] for k in keys] for r in sb["records"]
    ]
    assert len(sb["strokes"]) == len(sa["strokes"]) == 1
    for fa, fb in zip(sa["frames"], sb["frames"]):
        assert np.array_equal(
            meshio.read(straight / fa["file"]).points, meshio.read(split / fb["file"]).points
        )
    frame_files = sorted(p.name for p in (split / "frames").iterdir())
    assert frame_files == sorted(p.name for p in (straight / "frames").iterdir())
    assert sb["status"] == "finished"


def interrupt_on_call(monkeypatch, owner, name, number, before=False, by_signal=False):
    """Makes call `number` of owner.name raise KeyboardInterrupt, after (or before) doing its
    work; with by_signal, SIGINT is sent to the process instead, inside the call."""
    original = getattr(owner, name)
    calls = {"count": 0}

    def wrapper(*args, **kwargs):
        calls["count"] += 1
        hit = calls["count"] == number
        if hit and before:
            raise KeyboardInterrupt
        result = original(*args, **kwargs)
        if hit:
            if by_signal:
                signal.raise_signal(signal.SIGINT)
            else:
                raise KeyboardInterrupt
        return result

    monkeypatch.setattr(owner, name, wrapper)
    return calls


@pytest.mark.parametrize(
    "point",
    ["file written, before its record", "before the rename", "Ctrl-C while the frame is written"],
)
def test_an_interrupt_while_a_frame_is_written_loses_no_frame(
    tmp_path, monkeypatch, straight, capsys, point
):
    if point == "before the rename":
        # meshio has written the temporary file; the rename to the frame's name never happens
        interrupt_on_call(monkeypatch, yore.io.meshio, "write", 3)
    else:
        interrupt_on_call(
            monkeypatch, yore.io.FrameSeries, "write", 3, by_signal=point.startswith("Ctrl-C")
        )
    assert run_hanging(tmp_path) == 130
    assert "--resume" in capsys.readouterr().err
    monkeypatch.undo()
    summary = strict_json(tmp_path / "summary.json")
    assert summary["status"] == "interrupted"
    # the record lists only frames that exist, and no temporary file is left behind
    assert all((tmp_path / f["file"]).is_file() for f in summary["frames"])
    assert not list((tmp_path / "frames").glob(".*"))
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


@pytest.mark.parametrize(
    "point", ["during the stroke's smoothing", "before it is counted", "Ctrl-C during the stroke"]
)
def test_an_interrupt_during_a_stroke_applies_it_exactly_once(
    tmp_path, monkeypatch, straight, point
):
    # call 1 of the stroke functions is the check before the run (on a copy of the cloth)
    if point == "during the stroke's smoothing":
        interrupt_on_call(monkeypatch, yore.Simulation, "smooth_rest_lengths", 2)
    elif point == "before it is counted":
        interrupt_on_call(monkeypatch, yore.runs.stepping, "stroke_record", 1, before=True)
    else:
        interrupt_on_call(monkeypatch, yore.Simulation, "stroke", 2, by_signal=True)
    assert run_hanging(tmp_path) == 130
    monkeypatch.undo()
    sim, record = yore.load_state(tmp_path / "state.npz")
    # the stroke is undone as a whole: the saved cloth and record are those before it
    assert record["next_stroke"] == 0 and record["strokes"] == []
    assert sim.cloth.vertex_count == 81
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


def test_a_stroke_whose_expansion_would_overflow_is_refused_before_the_run(tmp_path, capsys):
    # 1e100 once ran until the stroke made the energy non-finite; expansion is now bounded
    # (at most 10, the paper's 1.1) and refused as bad input before anything runs
    code = run_hanging(tmp_path, "--set", "strokes.0.expansion=1e100")
    assert code == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error:") and "\n" not in error
    assert "strokes[0].expansion" in error and "<= 10" in error
    assert not (tmp_path / "state.npz").exists() and not (tmp_path / "summary.json").exists()


def test_a_run_whose_energy_becomes_non_finite_stops_at_its_last_good_frame(
    tmp_path, monkeypatch, capsys
):
    # The integrators' own bound cannot see an energy that overflows (the bound overflows with
    # it); the run checks every frame. The frame at t = 0.2 s (after the stroke) is made to overflow.
    original = yore.runs.stepping.measure_frame
    calls = {"count": 0}

    def overflowing(sim):
        calls["count"] += 1
        entry = original(sim)
        # the initial check, frames at 0, 0.05, 0.1, the stroke's check, frames at 0.15, 0.2
        if calls["count"] == 7:
            entry["spring"] = entry["total"] = float("inf")
        return entry

    monkeypatch.setattr(yore.runs.stepping, "measure_frame", overflowing)
    assert run_hanging(tmp_path) == 1
    error = capsys.readouterr().err
    assert "non-finite" in error and "spring inf" in error and "dt" in error
    summary = strict_json(tmp_path / "summary.json")
    assert summary["status"] == "diverged"
    assert [f["time"] for f in summary["frames"]] == pytest.approx([0.0, 0.05, 0.1, 0.15], abs=1e-3)
    sim, record = yore.load_state(tmp_path / "state.npz")
    assert sim.time == pytest.approx(0.15, abs=1e-3) and len(record["records"]) == 4
    assert len(record["strokes"]) == 1 and sim.cloth.vertex_count > 81


def test_a_scene_that_starts_non_finite_is_bad_input(tmp_path, capsys):
    scene = tmp_path / "spin.toml"
    scene.write_text(
        '[mesh]\ngenerator = "cylinder"\nrings = 4\nsegments = 8\n'
        '[[driven]]\nset = "top rim"\nmotion = "rotation"\ncenter = [0, 0, 0]\n'
        "axis = [0, 1, 0]\nomega = 1e300\n"
        '[simulation]\nduration = 0.1\n[output]\nformat = "none"\n'
    )
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "--quiet"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error:") and "\n" not in error
    assert not (tmp_path / "out" / "state.npz").exists()


def test_non_finite_numbers_reach_json_as_null_with_the_reason():
    document, found = yore.runs.output._finite_json(
        {"records": [{"area": 1.0, "rest_area": float("inf")}], "x": float("nan")}
    )
    assert document == {"records": [{"area": 1.0, "rest_area": None}], "x": None}
    assert found == [
        {"field": "records.0.rest_area", "value": "inf"},
        {"field": "x", "value": "nan"},
    ]


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["stiff", "hanging"])
def test_resuming_a_finished_run_changes_nothing(tmp_path, scene):
    small = {
        "stiff": [
            "--set",
            "mesh.nx=9",
            "--set",
            "mesh.ny=9",
            "--set",
            "fixed.1.indices=[8]",
            "--set",
            "simulation.duration=0.1",
            "--set",
            "strokes.0.time=0.05",
            "--set",
            "strokes.0.material=[[0.1, 0.2], [0.9, 0.2]]",
            "--no-render",
            "--quiet",
        ],
        "hanging": HANGING,
    }[scene]
    assert main(["run", str(EXAMPLES / f"{scene}.toml"), "-o", str(tmp_path), *small]) == 0
    before, _ = yore.load_state(tmp_path / "state.npz")
    first = strict_json(tmp_path / "summary.json")
    assert resume(tmp_path) == 0
    after, _ = yore.load_state(tmp_path / "state.npz")
    assert np.array_equal(before.cloth.positions, after.cloth.positions)
    second = strict_json(tmp_path / "summary.json")
    assert second["status"] == "finished" and second["steps"] == first["steps"]
    assert second["frames"] == first["frames"]


def test_a_folder_holding_another_run_is_refused_unless_overwrite(tmp_path, capsys):
    assert run_hanging(tmp_path) == 0
    stale = tmp_path / "frames" / "frame_00099.vtu"  # a frame the next run would not write
    stale.write_bytes((tmp_path / "frames" / "frame_00000.vtu").read_bytes())
    other = [
        "run",
        str(EXAMPLES / "cylinder_paper.toml"),
        "-o",
        str(tmp_path),
        "--quiet",
        "--no-render",
        "--set",
        "mesh.rings=4",
        "--set",
        "mesh.segments=8",
        "--set",
        "simulation.duration=0.05",
        "--set",
        "strokes=[]",
    ]
    assert main(other) == 2
    error = capsys.readouterr().err
    assert "already holds another run" in error and "--overwrite" in error
    mine = tmp_path / "notes.txt"
    mine.write_text("not yore's")
    assert main(other + ["--overwrite"]) == 0
    summary = strict_json(tmp_path / "summary.json")
    listed = sorted(Path(f["file"]).name for f in summary["frames"])
    assert sorted(p.name for p in (tmp_path / "frames").glob("frame_*")) == listed
    assert mine.read_text() == "not yore's"  # only the run's own files are removed


@pytest.mark.slow
def test_the_same_finished_run_repeats_but_an_unfinished_one_is_kept(tmp_path, capsys):
    assert run_hanging(tmp_path) == 0
    assert run_hanging(tmp_path) == 0  # the same scene, finished: running it again repeats it
    other = tmp_path / "part"
    assert run_hanging(other, "--until", "0.15") == 0
    assert run_hanging(other) == 2
    error = capsys.readouterr().err
    assert "unfinished run of the same scene" in error and "--resume" in error


def test_a_resume_checks_that_the_frames_it_lists_exist(tmp_path, capsys):
    assert run_hanging(tmp_path, "--until", "0.15") == 0
    frames = strict_json(tmp_path / "summary.json")["frames"]
    (tmp_path / frames[1]["file"]).unlink()
    assert resume(tmp_path) == 2
    error = capsys.readouterr().err
    assert "no longer exist" in error and Path(frames[1]["file"]).name in error


@pytest.mark.slow
@pytest.mark.parametrize(
    "field, value",
    [
        ("step", -1),
        ("step", 3.5),
        ("step", 10**6),
        ("next_stroke", 7),
        ("frames", [[0.0]]),
        ("records", "x"),
        ("before", {"time": "now"}),
        ("wall_seconds", -1.0),
        ("phases", []),
        ("overrides", [1]),
        ("scene_text", None),
        ("settle", {"seconds": "long"}),
        # issue 22, item 13: accepted, then a KeyError or a system file taken for a frame
        ("records", [{}]),
        ("records", [{"time": 0.0, "total": "x"}]),
        ("frames", [[0.0, "/etc/passwd"]]),
        ("before", {"time": 0.0, "file": "/etc/passwd"}),
    ],
)
def test_a_tampered_run_record_is_refused_naming_the_field(tmp_path, capsys, field, value):
    assert run_hanging(tmp_path, "--until", "0.15") == 0
    sim, record = yore.load_state(tmp_path / "state.npz")
    record[field] = value
    if field == "next_stroke":  # consistent with its list, but more than the scene has
        record["strokes"] = [{}] * value
    yore.save_state(tmp_path / "state.npz", sim, metadata=record)
    assert resume(tmp_path) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error:") and "\n" not in error
    assert f"metadata.{field}" in error


def test_a_crash_loses_at_most_the_steps_since_the_last_state_save(
    tmp_path, monkeypatch, straight, capsys
):
    # A state file after every frame; the process then "dies" (SystemExit, which the run does
    # not catch, like a kill) while writing the 5th frame, after the stroke.
    monkeypatch.setattr(yore.runs.stepping, "CHECKPOINT_SECONDS", 0.0)
    monkeypatch.setattr(yore.runs.stepping, "CHECKPOINT_SHARE", float("inf"))
    original = yore.io.FrameSeries.write
    calls = {"count": 0}

    def dying(self, *args, **kwargs):
        calls["count"] += 1
        path = original(self, *args, **kwargs)
        if calls["count"] == 5:
            raise SystemExit("killed")
        return path

    monkeypatch.setattr(yore.io.FrameSeries, "write", dying)
    with pytest.raises(SystemExit):
        run_hanging(tmp_path)
    monkeypatch.undo()
    assert not (tmp_path / "summary.json").exists()
    sim, record = yore.load_state(tmp_path / "state.npz")
    assert len(record["frames"]) == 4 and len(record["strokes"]) == 1
    assert run_hanging(tmp_path) == 2  # an unfinished run: resume it, or overwrite
    assert "--resume" in capsys.readouterr().err
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


def test_a_settled_run_starts_at_rest_at_time_zero_and_says_so(tmp_path, capsys):
    assert run_hanging(tmp_path, "--set", "simulation.settle=8", "--until", "0.15") == 0
    summary = strict_json(tmp_path / "summary.json")
    settle = summary["settle"]
    assert settle["converged"] and settle["residual_acceleration"] <= 0.02
    first = summary["records"][0]
    assert first["time"] == 0.0 and first["kinetic"] == 0.0
    # the record with its settle entry resumes, and the resumed part does not settle again
    assert resume(tmp_path) == 0
    resumed = strict_json(tmp_path / "summary.json")
    assert resumed["settle"] == settle and resumed["finished"]
    # a driven scene has no rest: one error line, exit code 2
    assert (
        main(
            [
                "run",
                str(EXAMPLES / "cylinder_paper.toml"),
                "-o",
                str(tmp_path / "c"),
                "--quiet",
                "--no-render",
                "--set",
                "simulation.settle=1",
            ]
        )
        == 2
    )
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error:") and "\n" not in error and "settle" in error


def test_a_second_ctrl_c_while_the_state_is_saved_still_gives_the_resume_hint(
    tmp_path, monkeypatch, straight, capsys
):
    # issue 22, item 18: the second interrupt replaced the first's hint with "interrupted"
    interrupt_on_call(monkeypatch, yore.io.FrameSeries, "write", 3, by_signal=True)
    interrupt_on_call(monkeypatch, yore.runs.stepping, "run_summary", 1, by_signal=True)
    assert run_hanging(tmp_path) == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "yore run --resume" in err and "state.npz" in err
    monkeypatch.undo()
    assert strict_json(tmp_path / "summary.json")["status"] == "interrupted"
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


def test_a_run_started_with_sigint_ignored_is_not_stopped_by_one(
    tmp_path, monkeypatch, straight, capsys
):
    # as under nohup: the deferral around a frame's bookkeeping installed its own handler, so
    # a SIGINT then stopped the run
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        interrupt_on_call(monkeypatch, yore.io.FrameSeries, "write", 3, by_signal=True)
        assert run_hanging(tmp_path) == 0
    finally:
        signal.signal(signal.SIGINT, previous)
    monkeypatch.undo()
    assert strict_json(tmp_path / "summary.json")["status"] == "finished"
    assert_same_run(straight, tmp_path)


# -- issue 41: a Ctrl-C never changes the answer, a run folder can move -----------------------


def test_a_run_split_between_frames_writes_the_frames_of_a_straight_run(tmp_path, straight, capsys):
    # 0.12 s lies between the frames at 0.1 and 0.15 s: the part writes none there (class 5)
    assert run_hanging(tmp_path, "--until", "0.12") == 0
    part = strict_json(tmp_path / "summary.json")
    assert part["status"] == "stopped at --until"
    assert [round(f["time"], 2) for f in part["frames"]] == [0.0, 0.05, 0.1]
    # a time the state has already passed is refused, and nothing changes
    stamp = (tmp_path / "state.npz").stat().st_mtime_ns
    assert (
        main(
            [
                "run",
                "--resume",
                str(tmp_path / "state.npz"),
                "--until",
                "0.05",
                "--quiet",
                "--no-render",
            ]
        )
        == 2
    )
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error: --until 0.05 s is not after the state's time")
    assert (tmp_path / "state.npz").stat().st_mtime_ns == stamp
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


def test_a_run_folder_can_be_moved_or_copied_and_resumed(tmp_path, straight):
    import shutil

    first = tmp_path / "first"
    assert run_hanging(first, "--until", "0.15") == 0
    _, record = yore.load_state(first / "state.npz")
    # the record holds paths relative to the run folder (class 3)
    assert all(not Path(path).is_absolute() for _, path in record["frames"])
    moved = tmp_path / "moved"
    copy = tmp_path / "copy"
    shutil.copytree(first, copy)
    first.rename(moved)
    for folder in (moved, copy):
        assert resume(folder) == 0
        assert_same_run(straight, folder)
        # the collection lists the folder's own frames only
        listed = [
            element.get("file")
            for element in ET.parse(folder / "frames" / "frame.pvd").getroot().iter("DataSet")
        ]
        assert listed == [
            Path(f["file"]).name for f in strict_json(folder / "summary.json")["frames"]
        ]
        assert all((folder / "frames" / name).is_file() for name in listed)


def test_a_resume_into_another_folder_keeps_the_first_frames_where_they_are(tmp_path, straight):
    first, second = tmp_path / "first", tmp_path / "second"
    assert run_hanging(first, "--until", "0.15") == 0
    assert (
        main(
            [
                "run",
                "--resume",
                str(first / "state.npz"),
                "-o",
                str(second),
                "--quiet",
                "--no-render",
            ]
        )
        == 0
    )
    summary = strict_json(second / "summary.json")
    files = [second / f["file"] for f in summary["frames"]]
    assert all(path.is_file() for path in files)
    assert files[0].resolve().parent == (first / "frames").resolve()  # not copied
    assert files[-1].resolve().parent == (second / "frames").resolve()
    assert len(files) == len(strict_json(straight / "summary.json")["frames"])


def test_ctrl_c_just_after_the_first_frame_leaves_a_run_to_resume(
    tmp_path, monkeypatch, straight, capsys
):
    interrupt_on_call(monkeypatch, yore.io.FrameSeries, "write", 1, by_signal=True)
    assert run_hanging(tmp_path) == 130
    monkeypatch.undo()
    assert (tmp_path / "state.npz").is_file()  # (class 4: there was none)
    capsys.readouterr()
    assert run_hanging(tmp_path) == 2  # the same scene, unfinished: resume it
    error = capsys.readouterr().err
    assert "unfinished run of the same scene" in error and "--resume" in error
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


def test_an_interrupt_before_the_first_frame_also_leaves_a_state(tmp_path, monkeypatch, straight):
    interrupt_on_call(monkeypatch, yore.io.FrameSeries, "write", 1, before=True)
    assert run_hanging(tmp_path) == 130
    monkeypatch.undo()
    _, record = yore.load_state(tmp_path / "state.npz")
    assert record["frames"] == [] and record["step"] == 0
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


@pytest.mark.parametrize(
    "edit, field",
    [
        ("integrator", "metadata.scene_text"),  # the record's scene says explicit, the state bdf2
        ("no frames", "metadata.records"),  # an emptied list would overwrite frame_00000
        ("no frame files", "metadata.frames"),  # records kept, frames emptied
        ("frames reordered", "metadata.frames"),
    ],
)
def test_a_record_that_does_not_match_its_run_is_refused(tmp_path, capsys, edit, field):
    assert run_hanging(tmp_path, "--until", "0.15") == 0
    sim, record = yore.load_state(tmp_path / "state.npz")
    if edit == "integrator":
        text = record["scene_text"]
        assert 'integrator = "explicit"' in text
        record["scene_text"] = text.replace('integrator = "explicit"', 'integrator = "bdf2"')
    elif edit == "no frames":
        record["frames"], record["records"] = [], []
    elif edit == "no frame files":
        record["frames"] = []
    else:
        record["frames"][0], record["frames"][1] = record["frames"][1], record["frames"][0]
    yore.save_state(tmp_path / "state.npz", sim, metadata=record)
    frame = (tmp_path / "frames" / "frame_00000.vtu").read_bytes()
    assert resume(tmp_path) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error:") and "\n" not in error and field in error
    assert (tmp_path / "frames" / "frame_00000.vtu").read_bytes() == frame


def test_a_state_no_file_may_hold_ends_the_run_failed_not_finished(tmp_path, monkeypatch, capsys):
    # class 2: a run whose state save_state refuses ends "failed" (exit 1), with a summary
    calls = {"count": 0}
    original = yore.runs.output.save_state

    def refusing(path, sim, metadata=None):
        calls["count"] += 1
        if calls["count"] > 1:  # the state before the first frame is fine; the last is not
            raise ValueError(f"{path} (not written): field simulation.cloth.masses: too heavy")
        return original(path, sim, metadata=metadata)

    monkeypatch.setattr(yore.runs.output, "save_state", refusing)
    assert run_hanging(tmp_path) == 1
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error: the run stopped at t = ") and "masses" in error
    summary = strict_json(tmp_path / "summary.json")
    assert summary["status"] == "failed" and summary["outputs"]["state"] is None


def test_a_frame_interval_longer_than_one_call_may_step_is_run_in_pieces(
    tmp_path, monkeypatch, capsys
):
    # class 15: with --allow-long, a frame interval over MAX_STEPS failed after starting
    # ("call step repeatedly"); the limit is lowered here to keep the run short
    monkeypatch.setattr(yore.runs.stepping, "MAX_STEPS", 5)
    monkeypatch.setattr(yore.simulation_checks, "MAX_STEPS", 5)
    scene = [
        "run",
        str(EXAMPLES / "hanging_paper.toml"),
        "-o",
        str(tmp_path),
        "--set",
        "mesh.nx=5",
        "--set",
        "mesh.ny=5",
        "--set",
        "strokes=[]",
        "--set",
        "simulation.dt=0.001",
        "--set",
        "simulation.duration=0.03",
        "--set",
        f"output.fps={1 / 0.012!r}",
        "--no-render",
        "--quiet",
    ]  # 12 steps
    assert main(scene) == 2  # 30 steps > 5: refused up front without --allow-long
    assert "--allow-long" in capsys.readouterr().err
    assert main(scene + ["--allow-long"]) == 0
    summary = strict_json(tmp_path / "summary.json")
    assert summary["steps"] == 30 and summary["status"] == "finished"
    assert [round(f["time"], 6) for f in summary["frames"]] == [0.0, 0.012, 0.024, 0.03]


def test_out_of_memory_ends_the_run_failed_with_its_last_frame_kept(
    tmp_path, monkeypatch, straight, capsys
):
    # issue 41, class 8: CHOLMOD's out of memory (MemoryError in Python) was a traceback that
    # kept only before.vtu; now the run goes back to its last frame, saves it, and says so
    original = yore.Simulation.step
    calls = {"count": 0}

    def exhausted(self, *args, **kwargs):
        calls["count"] += 1
        if calls["count"] == 4:
            original(self, 1, progress=False)  # some work done, then the allocation fails
            raise MemoryError
        return original(self, *args, **kwargs)

    monkeypatch.setattr(yore.Simulation, "step", exhausted)
    assert run_hanging(tmp_path) == 1
    monkeypatch.undo()
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error: out of memory between t = ") and "\n" not in error
    assert "State kept" in error
    summary = strict_json(tmp_path / "summary.json")
    assert summary["status"] == "failed" and summary["outputs"]["state"] == "state.npz"
    sim, record = yore.load_state(tmp_path / "state.npz")
    assert record["frames"] and sim.time == pytest.approx(record["frames"][-1][0])
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


def test_a_state_from_before_relative_paths_still_resumes_in_place(tmp_path, straight):
    # records written before issue 41 hold absolute paths of the frames and of before.vtu
    assert run_hanging(tmp_path, "--until", "0.15") == 0
    sim, record = yore.load_state(tmp_path / "state.npz")
    record["frames"] = [[t, str((tmp_path / path).resolve())] for t, path in record["frames"]]
    if record["before"] is not None:
        record["before"]["file"] = str((tmp_path / record["before"]["file"]).resolve())
    yore.save_state(tmp_path / "state.npz", sim, metadata=record)
    assert resume(tmp_path) == 0
    assert_same_run(straight, tmp_path)


@pytest.mark.parametrize("integrator", ["cvode", "arkode"])
def test_an_interrupted_sundials_run_resumes_bit_for_bit(tmp_path, monkeypatch, integrator):
    """Issue 53: SUNDIALS' step history is not in a state, so a resumed run restarts it; 14 of
    20 interrupted runs ended 0.5–7 cm from the straight one. Now every run restarts it at every
    frame, and an interruption between frames goes back to the last one."""
    extra = ["--set", f'simulation.integrator="{integrator}"']
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert run_hanging(straight, *extra) == 0
    # the 7th interval batch: past a frame, before the next (batches of 1, 2 intervals a frame)
    interrupt_on_call(monkeypatch, yore._core.ErrorControlledIntegrator, "advance", 7)
    assert run_hanging(split, *extra) == 130
    monkeypatch.undo()
    summary = strict_json(split / "summary.json")
    assert summary["status"] == "interrupted"
    assert summary["time"] == summary["frames"][-1]["time"]  # back at its last frame
    assert resume(split) == 0
    assert_same_run(straight, split)


# -- issue 53, R07: a state's settings are its scene's ------------------------------------------
SMALL_SCENE = """\
[mesh]
generator = "grid"
nx = 6
ny = 6
plane = "xz"

[material]
{material}

[[fixed]]
set = "bottom corners"

[simulation]
integrator = "{integrator}"
duration = 0.2
{simulation}

[integrator]
{options}

[[strokes]]
time = 0.05
material = [[0.1, 0.3], [0.9, 0.3]]

[output]
fps = 20
"""


def _edit_option(name, value):
    def edit(state):
        state["options"] = {**state["options"], name: value}

    return edit


def _edit_cloth(name, value):
    def edit(state):
        state["cloth"] = {**state["cloth"], name: value}

    return edit


def _edit_array(name, index, factor):
    def edit(state):
        values = state["cloth"][name].copy()
        values[index] *= factor
        state["cloth"] = {**state["cloth"], name: values}

    return edit


def _gravity(state):
    state["gravity"] = np.array([0.0, -1.62, 0.0])


@pytest.mark.parametrize(
    "scene, edit, until, key, expected, got",
    [
        # the three: error control switched off, ρ∞ raised, ν near its limit
        (
            {"integrator": "tr-bdf2", "simulation": 'dt = "auto"'},
            _edit_option("adaptive", False),
            0.1,
            "simulation.dt",
            '"auto" (error-controlled steps)',
            "a fixed step",
        ),
        (
            {"integrator": "generalized-alpha", "options": "rho_infinity = 0.5"},
            _edit_option("rho_infinity", 1.0),
            0.1,
            "integrator.rho_infinity",
            "0.5",
            "1.0",
        ),
        (
            {"material": 'stretch = "membrane"\nyoung_modulus = 100.0'},
            _edit_cloth("poisson_ratio", 0.99999),
            0.1,
            "material.poisson_ratio",
            "0.3",
            "0.99999",
        ),
        # a default the scene leaves alone, the other constants, a spring, gravity, the masses
        (
            {},
            _edit_option("newton_tol", 1e-3),
            0.1,
            "integrator.newton_tol (not given: the default)",
            "1e-05",
            "0.001",
        ),
        (
            {"material": "bend_stiffness = 50.0"},
            _edit_cloth("bend_stiffness", 5.0),
            0.1,
            "material.bend_stiffness",
            "50.0",
            "5.0",
        ),
        (
            {"material": 'bending = "quadratic"\nbending_modulus = 1e-4'},
            _edit_cloth("bending_modulus", 1e-2),
            0.1,
            "material.bending_modulus",
            "0.0001",
            "0.01",
        ),
        ({}, _edit_cloth("drag", 0.0), 0.1, "material.drag", "0.3", "0.0"),
        (
            {"material": "damping = 0.05"},
            _edit_cloth("damping", 0.5),
            0.1,
            "material.damping",
            "0.05",
            "0.5",
        ),
        (
            {},
            _edit_array("spring_stiffness", 3, 0.5),
            0.1,
            "material.stretch_stiffness",
            "200.0",
            "100.0",
        ),
        ({}, _gravity, 0.1, "simulation.gravity", "[0.0, -9.81, 0.0]", "[0.0, -1.62, 0.0]"),
        (
            {"material": "mass_per_vertex = 0.01"},
            _edit_array("masses", 7, 2.0),
            0.03,
            "material.mass_per_vertex",
            "0.01",
            "0.02",
        ),
        # the membrane's strain (issue 52): a state switched to the smoothed strain
        (
            {
                "material": 'stretch = "membrane"\nyoung_modulus = 100.0\nbending = "quadratic"\n'
                "bending_modulus = 1e-4"
            },
            _edit_cloth("membrane_strain", "smoothed"),
            0.1,
            "material.membrane_strain",
            "'faces'",
            "'smoothed'",
        ),
    ],
)
def test_a_state_whose_settings_were_edited_is_refused_naming_both_values(
    tmp_path, capsys, scene, edit, until, key, expected, got
):
    settings = {"material": "", "integrator": "implicit", "simulation": "", "options": "", **scene}
    path = tmp_path / "scene.toml"
    path.write_text(SMALL_SCENE.format(**settings), encoding="utf-8")
    assert (
        main(
            ["run", str(path), "-o", str(tmp_path), "--until", str(until), "--quiet", "--no-render"]
        )
        == 0
    )
    capsys.readouterr()
    sim, record = yore.load_state(tmp_path / "state.npz")
    state = sim.state()
    edit(state)
    yore.save_state(tmp_path / "state.npz", yore.Simulation.from_state(state), metadata=record)
    written = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert resume(tmp_path) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("yore: error:") and "\n" not in error
    assert f"{key} is {expected} in its scene but {got} in the state" in error
    # nothing written: the state, the summary and the frames are as they were
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == written


@pytest.mark.parametrize(
    "scene",
    [
        {"integrator": "tr-bdf2", "simulation": 'dt = "auto"', "options": "rtol = 1e-4"},
        {"integrator": "explicit", "options": "strain_limit = 1.1"},
        {"integrator": "local-global", "options": 'rebuild = "stale-pcg"'},
        {
            "integrator": "generalized-alpha",
            "material": 'stretch = "membrane"\nyoung_modulus = 100.0\ndensity = 0.2',
        },
        {
            "integrator": "bdf2",
            "options": "linearized = true",
            "material": 'bending = "quadratic"\nbending_modulus = 1e-4',
        },
    ],
)
def test_an_unedited_state_resumes_past_its_strokes_with_every_setting_checked(tmp_path, scene):
    # the check compares settings only: the stroke's new springs, vertices and masses pass
    settings = {"material": "", "integrator": "implicit", "simulation": "", "options": "", **scene}
    path = tmp_path / "scene.toml"
    path.write_text(SMALL_SCENE.format(**settings), encoding="utf-8")
    assert (
        main(["run", str(path), "-o", str(tmp_path), "--until", "0.1", "--quiet", "--no-render"])
        == 0
    )
    sim, record = yore.load_state(tmp_path / "state.npz")
    assert record["next_stroke"] == 1 and sim.cloth.vertex_count > 36
    assert resume(tmp_path) == 0
    assert strict_json(tmp_path / "summary.json")["status"] == "finished"


def test_a_run_whose_scene_gives_an_idle_option_still_resumes(tmp_path):
    # runs started before such options were refused hold them in their scene: a resume
    # continues what ran (rtol with a fixed dt did nothing then and does nothing now)
    path = tmp_path / "scene.toml"
    path.write_text(
        SMALL_SCENE.format(material="", integrator="tr-bdf2", simulation="dt = 0.02", options=""),
        encoding="utf-8",
    )
    assert (
        main(["run", str(path), "-o", str(tmp_path), "--until", "0.1", "--quiet", "--no-render"])
        == 0
    )
    sim, record = yore.load_state(tmp_path / "state.npz")
    record["scene_text"] = record["scene_text"].replace(
        "[integrator]\n", "[integrator]\nrtol = 0.001\n"
    )
    with pytest.raises(yore.runs.SceneError, match="integrator.rtol: rtol acts only with"):
        yore.load_scene(text=record["scene_text"]).build()
    yore.save_state(tmp_path / "state.npz", sim, metadata=record)
    assert resume(tmp_path) == 0
    assert strict_json(tmp_path / "summary.json")["status"] == "finished"
