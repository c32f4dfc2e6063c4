"""Sweeps on Dask: a 2-worker local cluster gives each cell's numbers exactly as a run of that
cell alone; a diverging cell is a result; an interrupted sweep resumes with only the rest; a bad
axis fails before anything runs; the client's memory does not grow with the cells."""

from __future__ import annotations

import json
import os
import re
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import yore
from yore.cli import main
from yore.runs import load_scene, run_scene
from yore.sweep import SweepError, load_sweep, open_results, resume, run
from yore.sweep.cell import OUTPUT_OVERRIDES, null_cell

SMALL = """
[sweep]
scene = "hanging"
[sweep.set]
"mesh.nx" = 7
"mesh.ny" = 7
"simulation.duration" = 0.1
"simulation.settle" = 0
"strokes.0.time" = 0.05
"strokes.0.refine" = 0
"""


def write(tmp_path, text, name="sweep.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    """A 2 × 3 sweep (stiffness × a zip of integrator and dt, the last one diverging) run on a
    2-worker local cluster."""
    tmp_path = tmp_path_factory.mktemp("grid")
    path = write(
        tmp_path,
        SMALL
        + """
[axes]
"material.stretch_stiffness" = [100.0, 1000.0]
[zip.method]
"simulation.integrator" = ["explicit", "implicit", "explicit"]
"simulation.dt" = [1e-4, 1e-2, 0.05]
[record]
reference = { "simulation.dt" = 1e-4 }
frames = true
""",
    )
    results = run(path, tmp_path / "out", workers=2, quiet=True)
    return load_sweep(path), tmp_path / "out", results


@pytest.mark.slow
def test_each_cell_gives_the_numbers_of_its_run_alone(grid, tmp_path):
    sweep, out, _ = grid
    dataset = open_results(out)
    assert dataset["status"].shape == (2, 3)
    for cell in sweep.cells():
        if cell.position[1] == 2:
            continue  # the diverging one, below
        scene = load_scene(
            None, text=sweep.scene_text, overrides={**cell.overrides, **OUTPUT_OVERRIDES}
        )
        alone = tmp_path / f"alone-{cell.key}"
        yore.set_num_threads(1)
        summary = run_scene(scene, alone, render=False, quiet=True)
        sim, _ = yore.load_state(alone / "state.npz")
        with np.load(out / "cells" / f"{cell.key}.npz") as final:
            assert np.array_equal(final["positions"], sim.cloth.positions)  # bit for bit
            assert np.array_equal(final["faces"], sim.cloth.faces)
        here = dataset.isel(
            {"material.stretch_stiffness": cell.position[0], "method": cell.position[1]}
        )
        assert str(here["status"].values) == "done"
        assert float(here["steps"]) == summary["steps"]
        assert float(here["final_total"]) == summary["records"][-1]["total"]
        assert float(here["stroke_faces_split"]) == summary["strokes"][0]["faces_split"]
        assert float(here["wrinkle_measure"]) == pytest.approx(
            yore.metrics.wrinkle_measure(sim.cloth.positions, sim.cloth.faces), rel=1e-12
        )
        # frames = true: the final frame as a mesh file
        V, F = yore.load_mesh(out / "cells" / f"{cell.key}.vtu")
        assert np.allclose(V, sim.cloth.positions) and np.array_equal(F, sim.cloth.faces)


def test_errors_are_against_the_reference_cell(grid):
    _, out, _ = grid
    dataset = open_results(out)
    error = dataset["error_rms"].values
    assert np.all(error[:, 0] == 0.0)  # the references themselves
    assert np.all(error[:, 1] > 0.0) and np.all(np.isfinite(error[:, 1]))
    # against an independent computation from the saved final positions
    for k in range(2):
        with (
            np.load(out / "cells" / f"{3 * k:06d}.npz") as a,
            np.load(out / "cells" / f"{3 * k + 1:06d}.npz") as b,
        ):
            distance = np.linalg.norm(a["positions"] - b["positions"], axis=1)
        assert error[k, 1] == pytest.approx(np.sqrt(np.mean(distance**2)), rel=1e-12)
        assert dataset["error_max"].values[k, 1] == pytest.approx(distance.max(), rel=1e-12)


def test_a_diverging_cell_is_recorded_not_fatal(grid):
    _, out, results = grid
    dataset = open_results(out)
    status = dataset["status"].values
    assert list(status[:, 2]) == ["diverged", "diverged"]
    assert np.all(status[:, :2] == "done")
    assert np.all(dataset["diverged_time"].values[:, 2] >= 0.0)
    assert np.all(np.isfinite(dataset["suggested_dt"].values[:, 2]))
    assert np.all(dataset["suggested_dt"].values[:, 2] < 0.05)
    for message in dataset["message"].values[:, 2]:
        assert "diverged" in message and "use dt <=" in message and "State kept" not in message
    assert np.isnan(dataset["error_rms"].values[:, 2]).all()  # no error for a failed cell
    assert results.counts() == {"done": 4, "diverged": 2}


@pytest.mark.slow
def test_an_interrupted_sweep_resumes_with_only_the_rest(tmp_path, monkeypatch):
    path = write(
        tmp_path,
        SMALL
        + """
[axes]
"material.stretch_stiffness" = [100.0, 300.0, 1000.0, 3000.0]
"simulation.dt" = [1e-4, 2e-4]
""",
    )
    out = tmp_path / "out"
    import yore.sweep.results as results_module

    original = results_module.Results.add
    calls = {"n": 0}

    def interrupting(self, cell, result):
        if calls["n"] == 3:
            raise KeyboardInterrupt
        calls["n"] += 1
        original(self, cell, result)

    monkeypatch.setattr(results_module.Results, "add", interrupting)
    with pytest.raises(KeyboardInterrupt):
        run(path, out, workers=2, quiet=True)
    monkeypatch.setattr(results_module.Results, "add", original)
    before = {
        p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in (out / "cells").glob("*.json")
    }
    assert len(before) == 3
    partial = open_results(out)
    assert int(np.count_nonzero(partial["status"].values != "")) == 3
    resumed = resume(out, workers=2, quiet=True)
    after = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in (out / "cells").glob("*.json")}
    assert len(after) == 8
    assert all(after[name] == before[name] for name in before)  # not computed again
    assert resumed.counts() == {"done": 8}
    # resuming a finished sweep runs nothing
    assert resume(out, workers=2, quiet=True).counts() == {"done": 8}
    assert {p.name: p.stat().st_mtime_ns for p in (out / "cells").glob("*.json")} == {
        name: value[0] for name, value in after.items()
    }


@pytest.mark.parametrize(
    "extra, named",
    [
        ('[axes]\n"material.stiffnes" = [1.0, 2.0]\n', "material.stiffnes"),
        ('[axes]\n"simulation.integrator" = ["explicit", "rk4"]\n', "simulation.integrator"),
        ('[axes]\n"mesh.nx" = []\n', "axes.mesh.nx"),
        ('[zip.m]\n"mesh.nx" = [5, 7]\n"mesh.ny" = [5]\n', "zip.m"),
        (
            '[axes]\n"material.mass" = [0.1, 0.2]\n[record]\nreference = { "material.mass" = 0.3 }\n',
            "record.reference.material.mass",
        ),
        (
            '[axes]\n"material.mass" = [0.1, 0.2]\n[record]\nreference = { "mesh.ny" = 7 }\n',
            "record.reference.mesh.ny",
        ),
        ('[axes]\n"material.mass" = [0.1, 0.2]\n[recrod]\n', "recrod"),
        ('[axes]\n"mesh.nx" = [5, 9]\n', "sweep.set.mesh.nx"),
        # a [sweep.set] that conflicts with the base scene is named as the set's (it was named as
        # the first axis value; issue 22, item 16)
        (
            '"output.format" = "none"\n"output.animation" = "gif"\n[axes]\n"material.mass" = [0.1]\n',
            "sweep.set.output.animation",
        ),
    ],
)
def test_a_bad_sweep_fails_before_anything_runs_naming_the_key(tmp_path, capsys, extra, named):
    path = write(tmp_path, SMALL + extra)
    with pytest.raises(SweepError, match=named.replace(".", r"\.")):
        load_sweep(path)
    out = tmp_path / "out"
    assert main(["sweep", str(path), "-o", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("yore: error:") and err.count("\n") == 1 and named in err
    assert not out.exists()


def test_a_cell_whose_scene_is_wrong_is_found_before_running(tmp_path):
    # each value is fine alone; together nx × ny passes the 1 000 000-vertex limit
    path = write(
        tmp_path,
        SMALL.replace('"mesh.nx" = 7\n"mesh.ny" = 7\n', "")
        + '[axes]\n"mesh.nx" = [7, 1001]\n"mesh.ny" = [7, 1001]\n',
    )
    with pytest.raises(SweepError, match="cell 3 .*mesh.nx = 1001, mesh.ny = 1001"):
        load_sweep(path)


PACKAGE_FILES = str(Path(yore.__file__).parent / "*")


@pytest.mark.slow
def test_the_client_memory_does_not_grow_with_the_cells(tmp_path):
    """What yore's code holds in the client after a sweep (traced allocations made in yore's
    files and still alive) for 100 and for 500 cells: results are streamed to disk, so five
    times the cells keep about the same memory. (The local cluster's scheduler runs in this
    process too; its own logs are Dask's and bounded by Dask's settings.)"""

    def held(count):
        path = write(
            tmp_path,
            SMALL + f'[axes]\n"material.mass" = {[0.1 + 1e-4 * k for k in range(count)]}\n',
            f"s{count}.toml",
        )
        sweep = load_sweep(path, check_cells=False)
        tracemalloc.start(5)
        try:
            results = run(
                sweep, tmp_path / f"out{count}", workers=2, quiet=True, cell_function=null_cell
            )
            snapshot = tracemalloc.take_snapshot()
        finally:
            tracemalloc.stop()
        # the installed package's own files (a pattern like */yore/* would also match every
        # library of a venv inside a checkout named yore)
        mine = snapshot.filter_traces([tracemalloc.Filter(True, PACKAGE_FILES)])
        del results
        return sum(stat.size for stat in mine.statistics("filename"))

    small, large = held(100), held(500)
    assert len(list((tmp_path / "out500" / "cells").glob("*.json"))) == 500
    # what grows is the per-cell status and values arrays: well under 200 bytes per cell (a cell's positions alone would be 1 kB)
    assert large - small < 400 * 200, (small, large)


@pytest.mark.slow
def test_sweep_plot_draws_a_heat_map_and_names_bad_dimensions(grid, capsys):
    _, out, _ = grid
    picture = out / "map.png"
    assert (
        main(
            [
                "sweep",
                "plot",
                str(out),
                "--x",
                "method",
                "--y",
                "material.stretch_stiffness",
                "--value",
                "wall_seconds",
                "-o",
                str(picture),
            ]
        )
        == 0
    )
    assert picture.read_bytes()[:4] == b"\x89PNG"
    assert (
        main(
            [
                "sweep",
                "plot",
                str(out),
                "--x",
                "methd",
                "--y",
                "material.stretch_stiffness",
                "--value",
                "wall_seconds",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "methd" in err and "dimensions: material.stretch_stiffness, method" in err
    assert (
        main(
            [
                "sweep",
                "plot",
                str(out),
                "--x",
                "method",
                "--y",
                "material.stretch_stiffness",
                "--value",
                "speed",
            ]
        )
        == 2
    )
    assert "recorded:" in capsys.readouterr().err


def test_a_folder_holding_a_sweep_is_not_overwritten_by_accident(grid, capsys):
    sweep, out, _ = grid
    assert main(["sweep", str(sweep.path), "-o", str(out), "--quiet"]) == 2
    assert "--resume" in capsys.readouterr().err
    assert json.loads((out / "sweep.json").read_text())["cells"] == 6


def test_variants_set_only_their_own_keys_and_can_be_the_reference(tmp_path):
    path = write(
        tmp_path,
        SMALL
        + """
[zip]
method = [
  { label = "explicit", "simulation.integrator" = "explicit" },
  { label = "strain limited", "simulation.integrator" = "explicit", "integrator.strain_limit" = 1.1 },
  { label = "BE", "simulation.integrator" = "implicit", "integrator.linearized" = true },
]
[axes]
"material.mass" = [0.1, 0.2]
[record]
reference = { method = "BE" }
""",
    )
    sweep = load_sweep(path)
    assert sweep.shape == (2, 3)  # [axes] first, then the zips
    cells = list(sweep.cells())
    assert "integrator.strain_limit" not in cells[0].overrides
    assert cells[1].overrides["integrator.strain_limit"] == 1.1
    assert "integrator.strain_limit" not in cells[2].overrides  # BE: its own keys only
    assert cells[2].overrides["integrator.linearized"] is True
    assert sweep.reference_position((1, 0)) == (1, 2)
    with pytest.raises(SweepError, match="record.reference.method"):
        load_sweep(path, text=path.read_text().replace('{ method = "BE" }', '{ method = "RK4" }'))


@pytest.mark.slow
def test_a_sweep_leaves_the_callers_environment_as_it_was(tmp_path):
    import os

    before = dict(os.environ)
    path = write(tmp_path, SMALL + '[axes]\n"material.mass" = [0.1, 0.2]\n')
    run(load_sweep(path), tmp_path / "out", workers=1, quiet=True, cell_function=null_cell)
    # Dask's settings for its workers (OMP_NUM_THREADS=1, ...) do not leak into the caller
    assert dict(os.environ) == before


NULL_SWEEP = (
    SMALL
    + """
[axes]
"material.stretch_stiffness" = [100.0, 300.0]
"simulation.dt" = [1e-4, 2e-4]
"""
)


def _status_cell(scene_text, scene_path, overrides):
    # a cell function recording a quantity named like the Dataset's own status variable
    return {
        "status": "done",
        "message": "",
        "values": {"status": 1.0, "message": 2.0},
        "positions": None,
        "faces": None,
    }


@pytest.mark.slow
def test_resume_refuses_an_edited_sweep_or_records_that_are_not_its_cells(tmp_path, capsys):
    # issue 22, items 1 and 11: resume relabelled old cells with new values, took a status
    # recorded as a value, and tracebacked on records of the wrong kind
    path = write(tmp_path, NULL_SWEEP)
    out = tmp_path / "out"
    run(path, out, workers=1, quiet=True, cell_function=null_cell)
    pristine = {
        p: p.read_bytes()
        for p in [out / "sweep.toml", out / "sweep.json", *sorted((out / "cells").glob("*.json"))]
    }

    def refused(match):
        with pytest.raises(ValueError, match=match):
            resume(out, workers=1, quiet=True, cell_function=null_cell)
        assert main(["sweep", "--resume", str(out), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("yore: error:") and err.count("\n") == 1, err
        for file, data in pristine.items():  # put everything back for the next case
            file.write_bytes(data)

    edited = NULL_SWEEP.replace("[100.0, 300.0]", "[100.0, 999.0]")
    (out / "sweep.toml").write_text(edited)
    refused("was changed since the sweep started")
    # a folder from before the identity was recorded: each record is checked against its cell
    meta = json.loads(pristine[out / "sweep.json"])
    del meta["identity"]
    (out / "sweep.json").write_text(json.dumps(meta))
    (out / "sweep.toml").write_text(edited)
    refused("written for other settings")
    record = out / "cells" / "000000.json"
    good = json.loads(pristine[record])
    for bad, match in [
        ([1, 2], "not a table"),
        ("done", "not a table"),
        ({**good, "status": 3}, "status 3"),
        ({**good, "message": None}, "message"),
        ({**good, "values": {"x": "1"}}, "finite numbers"),
        ({**good, "overrides": {}}, "other settings"),
    ]:
        record.write_text(json.dumps(bad))
        refused(f"000000.json: .*{match}")
    record.write_text("[" * 100_000 + "]" * 100_000)
    refused("000000.json: nested too deeply")
    with open(record, "wb") as handle:  # 3 GB, sparse
        handle.truncate(3 * 2**30)
    refused("000000.json: 3221225472 bytes")
    for bad in ("[1, 2]", "{", json.dumps({"cells": 4})):
        (out / "sweep.json").write_text(bad)
        refused("sweep.json: not a sweep record")
    assert resume(out, workers=1, quiet=True, cell_function=null_cell).counts() == {"done": 4}


@pytest.mark.slow
def test_a_recorded_value_never_replaces_the_status_or_a_coordinate(tmp_path):
    out = tmp_path / "out"
    run(write(tmp_path, NULL_SWEEP), out, workers=1, quiet=True, cell_function=_status_cell)
    dataset = open_results(out)
    assert set(np.unique(dataset["status"].values)) == {"done"}
    assert float(dataset["recorded_status"].max()) == 1.0
    assert float(dataset["recorded_message"].max()) == 2.0


@pytest.mark.parametrize(
    "extra, named",
    [
        ('[zip.status]\n"material.mass" = [0.1, 0.2]\n"mesh.nx" = [5, 7]\n', "zip.status"),
        ('[zip.message]\n"material.mass" = [0.1, 0.2]\n"mesh.nx" = [5, 7]\n', "zip.message"),
        ('[zip]\n"a/b" = [{ "material.mass" = 0.1 }, { "material.mass" = 0.2 }]\n', "zip.a/b"),
        ('[zip]\n"" = [{ "material.mass" = 0.1 }, { "material.mass" = 0.2 }]\n', "zip."),
        ('[zip]\n"." = [{ "material.mass" = 0.1 }, { "material.mass" = 0.2 }]\n', "zip.."),
        ('[axes]\n"error_rms" = [1, 2]\n', "axes.error_rms"),
    ],
)
def test_names_results_nc_cannot_hold_are_refused_before_running(tmp_path, extra, named):
    # issue 22, item 3: every cell ran, then results.nc could not be written
    path = write(tmp_path, SMALL.replace('"mesh.nx" = 7\n', "") + extra)
    with pytest.raises(SweepError, match="results.nc") as caught:
        load_sweep(path)
    assert named in str(caught.value)


def test_a_sweeps_base_scene_has_the_scene_file_limits(tmp_path, capsys):
    # issue 22, item 8: a 20 MiB scene was accepted, a 2 GB sparse one read whole, a symlink
    # loop a traceback
    (tmp_path / "loop.toml").symlink_to("loop.toml")
    with open(tmp_path / "big.toml", "wb") as handle:
        handle.truncate(20 * 2**20)
    with open(tmp_path / "sparse.toml", "wb") as handle:
        handle.truncate(2 * 2**30)
    for name, match in [
        ("loop.toml", "symbolic links"),
        ("big.toml", "more than the limit"),
        ("sparse.toml", "more than the limit"),
    ]:
        path = write(
            tmp_path,
            f'[sweep]\nscene = "{name}"\n[axes]\n"mesh.nx" = [5, 7]\n',
            name=f"sweep_{name}",
        )
        with pytest.raises(SweepError, match=match):
            load_sweep(path)
        assert main(["sweep", str(path), "-o", str(tmp_path / f"out_{name}"), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("yore: error:") and err.count("\n") == 1 and "sweep.scene" in err


@pytest.mark.slow
def test_sweep_plot_refuses_a_folder_as_picture_and_results_without_status(tmp_path, capsys):
    # issue 22, item 15: a KeyError traceback, and -o DIR silently wrote DIR.png
    import xarray as xr

    out = tmp_path / "out"
    run(write(tmp_path, NULL_SWEEP), out, workers=1, quiet=True, cell_function=null_cell)
    plot = [
        "sweep",
        "plot",
        str(out),
        "--x",
        "material.stretch_stiffness",
        "--y",
        "simulation.dt",
        "--value",
        "overrides",
    ]
    folder = tmp_path / "pictures"
    folder.mkdir()
    for target in (folder, tmp_path / "picture"):
        assert main([*plot, "-o", str(target)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and ".png file" in err
    assert not (tmp_path / "pictures.png").exists() and not (tmp_path / "picture.png").exists()
    assert main([*plot, "-o", str(tmp_path / "map.png")]) == 0
    xr.Dataset({"other": ("x", np.arange(3.0))}).to_netcdf(out / "results.nc", engine="h5netcdf")
    assert main(plot) == 2
    assert "no status per cell" in capsys.readouterr().err
    (out / "results.nc").write_bytes(b"not netcdf")
    assert main(plot) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot be read" in err


@pytest.mark.slow
def test_a_scheduler_that_is_not_one_is_one_line_within_the_timeout(tmp_path, capsys):
    # issue 22, item 9: a silent or HTTP server hung the sweep for over 11 minutes, ucx:// and
    # tls:// gave TypeError tracebacks, a refused connection took 30 s
    import socket

    path = write(tmp_path, NULL_SWEEP)
    silent = socket.socket()
    silent.bind(("127.0.0.1", 0))
    silent.listen(8)  # accepts connections (the kernel does) and never says a word
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))
    refused_port = closed.getsockname()[1]
    closed.close()
    try:
        for address, match in [
            (
                f"tcp://127.0.0.1:{silent.getsockname()[1]}",
                "did not answer within 1 s|cannot reach",
            ),
            (f"tcp://127.0.0.1:{refused_port}", "cannot reach"),
            ("ucx://127.0.0.1:8786", "tcp://HOST:PORT"),
            ("tls://127.0.0.1:8786", "tcp://HOST:PORT"),
            ("http://127.0.0.1:80/", "tcp://HOST:PORT"),
        ]:
            out = tmp_path / f"out{len(match)}"
            code = main(
                [
                    "sweep",
                    str(path),
                    "-o",
                    str(out),
                    "--quiet",
                    "--scheduler",
                    address,
                    "--connect-timeout",
                    "1",
                ]
            )
            err = capsys.readouterr().err
            assert code == 2 and err.startswith("yore: error:") and err.count("\n") == 1, err
            assert re.search(match, err), err
            assert not out.exists()  # nothing written before the scheduler answered
    finally:
        silent.close()


@pytest.mark.slow
def test_ctrl_c_during_a_sweep_is_one_line_exit_130_and_resumable(tmp_path):
    # issue 22, item 10: multi-line Dask tracebacks in 10 of 11 trials, one never exited. The
    # terminal's Ctrl-C goes to the whole process group: the workers must leave it to the client.
    import os
    import signal
    import subprocess
    import sys

    path = write(
        tmp_path,
        SMALL.replace('"simulation.duration" = 0.1', '"simulation.duration" = 30.0')
        + """
[axes]
"material.stretch_stiffness" = [100.0, 300.0, 1000.0, 3000.0]
""",
    )
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "yore", "sweep", str(path), "-o", str(out), "--workers", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        first = process.stdout.readline()  # printed once the cluster runs the cells
        assert first.startswith("yore sweep: 4 of 4 cells"), first
        os.killpg(process.pid, signal.SIGINT)
        _, err = process.communicate(timeout=300)  # a guard against a hang, not a measure
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert process.returncode == 130
    assert err.count("\n") == 1 and err.startswith("yore: interrupted;"), err
    assert f"yore sweep --resume {out}" in err
    assert (out / "results.nc").is_file() and (out / "sweep.json").is_file()


def test_the_sweep_refuses_up_front_the_cells_yore_check_refuses(tmp_path, capsys):
    # issue 41, class 14: a mass of 5e-324 passed the sweep's check (the scene's schema), then
    # its cell ran and ended "failed" with exit 0; now one check (yore.runs.check_scene) for all
    path = write(tmp_path, SMALL + '[axes]\n"material.mass" = [0.1, 5e-324]\n')
    with pytest.raises(SweepError, match=r"cell 1 \(material.mass = 5e-324\).*mass of vertex"):
        load_sweep(path)
    scene = tmp_path / "scene.toml"
    scene.write_text(
        load_sweep(
            write(tmp_path, SMALL + '[axes]\n"material.mass" = [0.1]\n', "ok.toml")
        ).scene_text
    )
    assert main(["check", str(scene), "--set", "material.mass=5e-324"]) == 2
    assert "mass of vertex" in capsys.readouterr().err


def test_a_ctrl_c_while_the_cluster_starts_stops_the_sweep_before_any_cell(tmp_path):
    """Issue 41, class 10: 13 of 14 SIGINTs sent while the local cluster started were lost
    (SIGINT was ignored then, so that the workers inherit the ignoring): every cell ran, exit
    0. The Ctrl-C is sent here from inside the cluster's start, to the whole process as the
    terminal sends it, in a fresh `yore sweep` process (no timing involved)."""
    import subprocess
    import sys

    path = write(tmp_path, SMALL + '[axes]\n"material.mass" = [0.1, 0.2]\n')
    program = f"""
import os, signal, sys
import dask.distributed
from yore.cli import main

real = dask.distributed.LocalCluster

def starting(*args, **kwargs):
    os.kill(os.getpid(), signal.SIGINT)
    return real(*args, **kwargs)

dask.distributed.LocalCluster = starting
sys.exit(main(["sweep", {str(path)!r}, "-o", {str(tmp_path / "out")!r}, "--workers", "1",
               "--quiet"]))
"""
    result = subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 130, result.stderr
    assert result.stderr.strip().splitlines()[-1].startswith("yore: interrupted")
    assert not list((tmp_path / "out" / "cells").glob("*.json"))  # no cell ran
    assert open_results(tmp_path / "out")["status"].values.tolist() == ["", ""]


def test_workers_are_bounded_by_the_machines_cores(tmp_path):
    from yore.sweep.run import max_local_workers

    most = max_local_workers()
    assert most == 2 * len(os.sched_getaffinity(0))
    path = write(tmp_path, SMALL + '[axes]\n"material.mass" = [0.1]\n')
    with pytest.raises(
        SweepError,
        match=rf"workers must be an integer in \[1, {most}\], got "
        rf"{most + 1}: at most twice this machine's",
    ):
        run(path, tmp_path / "out", workers=most + 1, quiet=True)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("failure", ["KeyboardInterrupt", "NameError", "AttributeError"])
def test_ctrl_c_during_a_sweeps_start_up_is_one_line_and_exit_130(
    tmp_path, capsys, monkeypatch, failure
):
    # Issue 53, R03: a Ctrl-C inside dask's imports left half-initialised modules whose next
    # use raised NameError/AttributeError (a traceback, exit 1), or the message named an output
    # folder that was never created
    import yore.sweep

    def start_up(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            if failure == "NameError":
                raise NameError("name 'coroutines' is not defined")
            if failure == "AttributeError":
                raise AttributeError("module 'dask' has no attribute 'utils'")
            raise

    monkeypatch.setattr(yore.sweep, "run", start_up)
    out = tmp_path / "out"
    assert main(["sweep", str(write(tmp_path, SMALL)), "-o", str(out), "--quiet"]) == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("yore: interrupted")
    assert str(out) not in err and not out.exists()
