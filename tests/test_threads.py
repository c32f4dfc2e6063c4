"""yore.set_num_threads is the one place the thread count is set; the explicit step's result
does not depend on it; stats report the threads used. (No test here depends on wall time.)"""

import numpy as np
import pytest

import yore
from yore import _core


@pytest.fixture
def restore_threads():
    before, blas = yore.build_info()["threads"], _core.blas_threads()
    yield
    yore.set_num_threads(before)
    if blas:
        _core.set_blas_threads(blas)


def grid_simulation(n):
    V, F = yore.grid_mesh(n, n)
    cloth = yore.Cloth(
        V, F, masses=0.1, stretch_stiffness=200.0, bend_stiffness=200.0, damping=0.02, drag=0.3
    )
    cloth.fix([0, n - 1])
    return yore.Simulation(cloth)


@pytest.mark.parametrize("bad", [0, -1, True, False, 1.5, 2.0, "2", None])
def test_set_num_threads_refuses_anything_but_an_int_of_at_least_one(bad, restore_threads):
    with pytest.raises(ValueError, match="threads"):
        yore.set_num_threads(bad)


def test_set_num_threads_sets_the_core_and_openblas(restore_threads):
    yore.set_num_threads(np.int64(3))  # any integral type
    assert yore.build_info()["threads"] == 3
    if yore.build_info()["blas"].startswith("OpenBLAS"):
        assert _core.blas_threads() == 3
    yore.set_num_threads(1)
    assert yore.build_info()["threads"] == 1 and _core.blas_threads() in (0, 1)


def test_the_command_and_use_thread_defaults_run_one_blas_thread_unless_asked():
    """yore's thread defaults (issue 54: set by the `yore` command and by an explicit call,
    not by ``import yore``): one BLAS thread unless the environment chose."""
    import os
    import subprocess
    import sys

    if not yore.build_info()["blas"].startswith("OpenBLAS"):
        pytest.skip("the loaded BLAS is not OpenBLAS")
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    called = subprocess.run(
        [
            sys.executable,
            "-c",
            "import yore; yore.use_thread_defaults(); print(yore._core.blas_threads())",
        ],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    ).stdout
    assert int(called) == 1
    info = subprocess.run(
        [sys.executable, "-m", "yore", "info"], capture_output=True, text=True, check=True, env=env
    ).stdout
    assert "blas_threads" in info and _info_value(info, "blas_threads") == "1"
    # the environment's choice stands: the command's count is the one OpenBLAS took from it
    chosen_env = {**env, "OPENBLAS_NUM_THREADS": "2"}
    chosen = subprocess.run(
        [sys.executable, "-m", "yore", "info"],
        capture_output=True,
        text=True,
        check=True,
        env=chosen_env,
    ).stdout
    alone = subprocess.run(
        [sys.executable, "-c", "import yore; print(yore._core.blas_threads())"],
        capture_output=True,
        text=True,
        check=True,
        env=chosen_env,
    ).stdout
    assert _info_value(chosen, "blas_threads") == alone.strip()


def _info_value(text, key):
    return next(line.split()[1] for line in text.splitlines() if line.split()[:1] == [key])


def test_one_thread_runs_every_step_serially_and_reports_it(restore_threads):
    yore.set_num_threads(1)
    sim = grid_simulation(48)  # large enough that its loops would fork with more threads
    sim.step(30, progress=False)
    threads = sim.stats["threads"]
    assert threads["configured"] == 1
    assert threads["last_step"] == 1
    assert threads["parallel_steps"] == 0 and threads["serial_steps"] == 30
    assert threads["probes"] == 0


def test_small_cloths_never_fork(restore_threads):
    yore.set_num_threads(2)
    sim = grid_simulation(8)  # 64 vertices: below every loop's threshold
    sim.step(200, progress=False)
    threads = sim.stats["threads"]
    assert threads["configured"] == 2
    assert threads["parallel_steps"] == 0 and threads["probes"] == 0
    assert threads["last_step"] == 1


def test_large_cloths_may_use_every_configured_thread(restore_threads):
    yore.set_num_threads(2)
    sim = grid_simulation(48)
    sim.step(300, progress=False)
    threads = sim.stats["threads"]
    # which choice wins depends on the load; that both are counted does not
    assert threads["parallel_steps"] + threads["serial_steps"] == 300
    assert threads["parallel_steps"] >= 1  # the second block re-times every thread
    assert threads["probes"] >= 1
    assert threads["last_step"] in (1, 2)


def test_positions_do_not_depend_on_the_thread_count(restore_threads):
    results = []
    for threads in (1, 2, 3):
        yore.set_num_threads(threads)
        sim = grid_simulation(40)
        sim.step(200, progress=False)
        results.append((sim.cloth.positions.copy(), sim.cloth.velocities.copy()))
    for positions, velocities in results[1:]:
        assert np.array_equal(positions, results[0][0])
        assert np.array_equal(velocities, results[0][1])


def test_implicit_stats_report_the_blas_threads(restore_threads):
    yore.set_num_threads(1)
    sim = yore.scenes.hanging_cloth(resolution=7, integrator="implicit")
    sim.step(1, progress=False)
    threads = sim.stats["threads"]
    assert threads["configured"] == 1 and threads["blas"] in (0, 1)
    assert "last_step" not in threads  # the implicit step's parallelism is the BLAS's


def _under_address_space_limit(gib, *arguments):
    """Runs ``python -c ...`` (or the `yore` command) under RLIMIT_AS = ``gib`` GiB."""
    import resource
    import subprocess
    import sys

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (int(gib * 2**30), int(gib * 2**30)))

    command = (
        [sys.executable, "-m", "yore", *arguments]
        if arguments[0] != "-c"
        else [sys.executable, *arguments]
    )
    return subprocess.run(command, preexec_fn=limit, capture_output=True, text=True, timeout=300)


def test_threads_that_the_address_space_cannot_hold_are_refused_in_one_line(tmp_path):
    """Issue 41, class 11: `--threads 32` under a 3–4 GB address-space limit never exited (the
    threads' creation hung). Threads are now bounded by the limit: (3 GiB − 1 GiB) / 256 MiB
    = 8 fit (measured: 12 ran, 16 hung), and OpenMP's default is clamped likewise."""
    from yore.runtime import threads_the_address_space_holds

    assert threads_the_address_space_holds() is None  # no limit in the test process
    scene = tmp_path / "scene.toml"
    scene.write_text(
        '[mesh]\ngenerator = "grid"\nnx = 5\nny = 5\n[[fixed]]\n'
        'set = "top corners"\n[simulation]\nintegrator = "implicit"\ndt = 0.01\n'
        'duration = 0.02\n[output]\nformat = "none"\n'
    )
    refused = _under_address_space_limit(
        3, "run", str(scene), "-o", str(tmp_path / "a"), "--quiet", "--threads", "32"
    )
    assert refused.returncode == 2
    assert (
        refused.stderr.startswith(
            "yore: error: 32 threads do not fit in this process's address-space limit"
        )
        and refused.stderr.count("\n") == 1
    )
    assert "use at most 8 threads" in refused.stderr
    ran = _under_address_space_limit(
        3, "run", str(scene), "-o", str(tmp_path / "b"), "--quiet", "--threads", "8"
    )
    assert ran.returncode == 0, ran.stderr
    clamped = _under_address_space_limit(
        1.25, "-c", "import yore; yore.use_thread_defaults(); print(yore._core.max_threads())"
    )
    assert clamped.returncode == 0 and clamped.stdout.strip() == "1", clamped.stderr
