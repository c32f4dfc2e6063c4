"""yore.blas: the BLAS kernels CHOLMOD runs on, chosen before the library loads. The decision is
tested on made-up CPUs (a pure function); the import's effect in fresh processes, some with a
made-up CPU put in place of yore._cpu, so that no test relies on this machine's processor."""

import json
import os
import subprocess
import sys
import textwrap

import pytest

import yore
from yore import _cpu, blas

AVX512 = [
    "sse3",
    "ssse3",
    "sse4_1",
    "sse4_2",
    "avx",
    "fma",
    "avx2",
    "avx512f",
    "avx512cd",
    "avx512bw",
    "avx512dq",
    "avx512vl",
]
AVX2 = AVX512[:7]
SSE = AVX512[:4]
HERE = set(_cpu.cpu_features().extensions)
OPENBLAS = yore.build_info()["blas"].startswith("OpenBLAS")


# -- the decision, on made-up CPUs -----------------------------------------------------------
@pytest.mark.parametrize(
    "extensions, native, expected",
    [
        (AVX512, "Prescott", ("SkylakeX", "yore")),  # Debian 0.3.21 on an Emerald Rapids Xeon
        (AVX512, "Haswell", ("SkylakeX", "yore")),
        (AVX512, "Cooperlake", (None, "openblas")),  # same tier: OpenBLAS's own choice stays
        (AVX512, "SkylakeX", (None, "openblas")),
        (AVX2, "Prescott", ("Haswell", "yore")),
        (AVX2, "Zen", (None, "openblas")),
        (AVX2 + ["fma4"], "Excavator", (None, "openblas")),
        (AVX2[:5], "Nehalem", ("Sandybridge", "yore")),  # AVX without AVX2
        (SSE, "Prescott", (None, "openblas")),  # nothing wider to choose
        (AVX512, "", (None, "openblas")),  # not OpenBLAS: its kernels are its own
        (AVX512, None, ("SkylakeX", "yore")),  # the probe failed: the CPU runs SkylakeX
        (AVX512[:-1], "Prescott", ("Haswell", "yore")),  # AVX-512 without VL: not SkylakeX's
    ],
)
def test_an_unset_coretype_gets_the_widest_kernels_the_cpu_runs(extensions, native, expected):
    choice = blas.decide(extensions, None, native)
    assert (choice.coretype, choice.chosen_by) == expected and choice.warning is None


@pytest.mark.parametrize(
    "requested, extensions",
    [
        ("Haswell", AVX512),
        ("haswell", AVX512),
        ("SANDYBRIDGE", AVX2),
        ("Prescott", AVX512),
        ("SkylakeX", AVX512),
        ("NoSuchCore", SSE),
        ("", AVX512),
    ],
)
def test_a_users_coretype_the_cpu_runs_wins(requested, extensions):
    # unknown names included: OpenBLAS refuses them itself and detects the CPU
    choice = blas.decide(extensions, requested, native="Prescott")
    assert choice == blas.KernelChoice(None, "user")


@pytest.mark.parametrize(
    "requested, extensions, instead, missing",
    [
        ("SkylakeX", AVX2, "Haswell", "avx512bw, avx512cd, avx512dq, avx512f, avx512vl"),
        ("skylakex", SSE, "Prescott", "avx512bw, avx512cd, avx512dq, avx512f, avx512vl"),
        ("Cooperlake", AVX512, "SkylakeX", "avx512_bf16"),
        ("Bulldozer", AVX512, "SkylakeX", "fma4"),  # AMD's FMA4 kernels on an Intel CPU
        ("Haswell", AVX2[:5], "Sandybridge", "avx2"),
    ],
)
def test_a_users_coretype_the_cpu_cannot_run_is_one_warning_and_the_best_it_runs(
    requested, extensions, instead, missing
):
    choice = blas.decide(extensions, requested, native="Prescott")
    assert (choice.coretype, choice.chosen_by) == (instead, "yore")
    assert f"OPENBLAS_CORETYPE={requested} needs {missing}," in choice.warning
    assert "SIGILL" in choice.warning and "\n" not in choice.warning


def test_every_kernel_yore_sets_is_one_openblas_knows_and_ranks_in_its_tier():
    for tier, (name, needs) in zip((3, 2, 1), blas.TIER_KERNELS):
        assert blas.KERNEL_NEEDS[name.lower()] == needs and blas.kernel_tier(name) == tier
    assert blas.kernel_tier("Prescott") == blas.kernel_tier("nonsense") == 0
    assert blas.best_kernel(SSE) is None


@pytest.mark.parametrize(
    "variable, value, replaced",
    [
        ("OMP_NUM_THREADS", "100000", "256"),
        ("OPENBLAS_NUM_THREADS", "0", None),
        ("GOTO_NUM_THREADS", "many", None),
        ("OMP_NUM_THREADS", "-2", None),
    ],
)
def test_thread_settings_no_machine_runs_are_named(variable, value, replaced):
    problems = blas.thread_setting_problems({variable: value, "OMP_NUM_THREADS_X": "0"})
    assert list(problems) == [variable]
    assert problems[variable][0] == replaced and f"{variable}=" in problems[variable][1]


def test_thread_settings_machines_run_are_left_alone():
    assert (
        blas.thread_setting_problems(
            {"OMP_NUM_THREADS": "4,2", "OPENBLAS_NUM_THREADS": "1", "GOTO_NUM_THREADS": "256"}
        )
        == {}
    )


# -- the import, in fresh processes ------------------------------------------------------------
def _fresh(code, environment=None, fake_cpu=None, fake_native=None):
    """Runs `code` in a fresh interpreter after the optional stand-ins: a yore._cpu whose CPU
    has `fake_cpu` extensions, a yore.blas whose probe answers `fake_native`."""
    prelude = ["import importlib.util, json, os, sys, types"]
    if fake_cpu is not None:
        prelude.append(
            textwrap.dedent(f"""
            fake = types.ModuleType("yore._cpu")
            fake.cpu_features = lambda: types.SimpleNamespace(extensions={fake_cpu!r})
            fake.limits = {dict(_cpu.limits)!r}  # (the module holds the limits' table too)
            sys.modules["yore._cpu"] = fake""")
        )
    if fake_native is not None:
        prelude.append(
            textwrap.dedent(f"""
            spec = importlib.util.spec_from_file_location("yore.blas", {blas.__file__!r})
            module = importlib.util.module_from_spec(spec)
            sys.modules["yore.blas"] = module
            spec.loader.exec_module(module)
            module.native_kernel = lambda: {fake_native!r}""")
        )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    env.update(environment or {})
    return subprocess.run(
        [sys.executable, "-c", "\n".join(prelude + [textwrap.dedent(code)])],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


REPORT = """
import yore
yore._core  # the core's load, which the choice precedes
print(json.dumps({**sys.modules["yore.blas"].report(),
                  "environment": os.environ.get("OPENBLAS_CORETYPE")}))
"""

needs_openblas = pytest.mark.skipif(not OPENBLAS, reason="the loaded BLAS is not OpenBLAS")


@needs_openblas
def test_by_default_the_kernels_in_use_are_of_the_widest_tier_the_cpu_runs():
    # on any machine: OpenBLAS's own choice when it is good enough, else yore's
    done = _fresh(REPORT)
    assert done.returncode == 0 and done.stderr == ""
    info = json.loads(done.stdout)
    best = blas.best_kernel(HERE)
    assert info["cpu_kernel"] == best
    if best is not None:
        assert blas.kernel_tier(info["kernel"]) >= blas.kernel_tier(best)
    assert info["environment"] is None  # nothing left behind for other libraries or children


@needs_openblas
@pytest.mark.skipif(not {"avx2", "fma"} <= HERE, reason="this CPU has no AVX2")
def test_yore_sets_the_kernels_when_openblas_would_pick_narrower_ones():
    # OpenBLAS 0.3.21's answer on an Emerald Rapids Xeon, made up
    done = _fresh(REPORT, fake_cpu=AVX2, fake_native="Prescott")
    assert done.returncode == 0 and done.stderr == ""
    info = json.loads(done.stdout)
    assert (info["kernel"], info["chosen_by"], info["environment"]) == ("Haswell", "yore", None)


@needs_openblas
@pytest.mark.skipif(not {"avx2", "fma"} <= HERE, reason="this CPU has no AVX2")
def test_a_users_coretype_wins():
    done = _fresh(REPORT, {"OPENBLAS_CORETYPE": "Haswell"})
    info = json.loads(done.stdout)
    assert (info["kernel"], info["chosen_by"], info["requested"]) == ("Haswell", "user", "Haswell")
    assert info["environment"] == "Haswell" and done.stderr == ""


@needs_openblas
@pytest.mark.skipif(not {"avx2", "fma"} <= HERE, reason="this CPU has no AVX2")
def test_a_coretype_the_cpu_cannot_run_is_one_warning_line_never_sigill():
    # a made-up CPU without AVX-512, and a user asking for AVX-512 kernels: on such a CPU
    # OpenBLAS would load them and die at the first multiply
    # (an implicit step: CHOLMOD's supernodal factorization multiplies with those kernels)
    done = _fresh(
        REPORT + "sim = yore.scenes.hanging_cloth(resolution=24, integrator='implicit')"
        "\nsim.step(2, progress=False)\nprint(sim.stats['counters']['factorizations'])",
        {"OPENBLAS_CORETYPE": "SkylakeX"},
        fake_cpu=AVX2,
    )
    assert done.returncode == 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "OPENBLAS_CORETYPE=SkylakeX needs avx512" in lines[0]
    info = json.loads(done.stdout.splitlines()[0])
    assert (info["kernel"], info["chosen_by"]) == ("Haswell", "yore")


@needs_openblas
@pytest.mark.skipif(not {"avx2", "fma"} <= HERE, reason="this CPU has no AVX2")
def test_the_command_says_it_in_one_yore_warning_line_and_yore_info_shows_the_kernels():
    done = _fresh(
        "sys.argv = ['yore', 'info']\nfrom yore.cli import main\nsys.exit(main())",
        {"OPENBLAS_CORETYPE": "SkylakeX"},
        fake_cpu=AVX2,
    )
    assert done.returncode == 0
    assert done.stderr.startswith("yore: warning: OPENBLAS_CORETYPE=SkylakeX needs")
    assert done.stderr.count("\n") == 1
    assert "Haswell kernels (AVX2), chosen by yore" in done.stdout
    assert "blas_kernel            Haswell" in done.stdout


def test_a_thread_count_no_machine_runs_is_one_warning_and_the_limit(tmp_path):
    done = _fresh(
        "import yore\nthreads = yore.build_info()['threads']\n"
        "print(os.environ['OMP_NUM_THREADS'], threads)",
        {"OMP_NUM_THREADS": "100000"},
    )
    assert done.returncode == 0
    assert done.stdout.split() == ["256", "256"]
    assert done.stderr.count("BlasWarning: OMP_NUM_THREADS=100000 is more threads") == 1


def test_yore_info_names_the_kernels_in_use(capsys):
    from yore.cli import main

    assert main(["info"]) == 0
    out = capsys.readouterr().out
    info = yore.build_info()
    assert any(
        line.split()[:1] == ["BLAS"] and line.endswith(blas.describe()) for line in out.splitlines()
    )
    for key in ("blas_kernel", "blas_kernel_chosen_by", "cholmod", "threads"):
        assert any(line.split()[:1] == [key] for line in out.splitlines()), key
    assert info["blas_kernel_chosen_by"] in ("user", "yore", "openblas")


def test_the_viewer_panel_shows_the_kernels():
    from yore.viz.viewer import _statistics_lines
    from yore.viz.viewer_model import ViewerModel

    model = ViewerModel(yore.scenes.hanging_cloth(resolution=6))
    figures = model.statistics()
    assert figures["blas"] == blas.describe()
    assert f"BLAS: {blas.describe()}" in _statistics_lines(figures)


def test_every_benchmark_records_the_kernels():
    from benchmarks.common import machine_info

    machine = machine_info()
    assert machine["blas_kernels"] == blas.report()
    assert machine["yore"]["blas_kernel"] == blas.report()["kernel"]
