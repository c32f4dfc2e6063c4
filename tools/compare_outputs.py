"""Evidence that a refactoring kept yore's behaviour bit for bit: run a fixed set of scenes,
scripted strokes and quick benchmarks with one installed yore, digest everything they produce
that is not wall time, and compare two digests.

    # in each checkout (examples/, benchmarks/, python/yore/data/), with its own interpreter:
    python tools/compare_outputs.py digest --out /tmp/new.json
    /tmp/oldvenv/bin/python tools/compare_outputs.py digest --out /tmp/old.json   # (cwd: old)
    python tools/compare_outputs.py compare /tmp/old.json /tmp/new.json

A digest holds, per item, the SHA-256 of every array of a state file (positions, velocities,
rest lengths, masses, faces, ...) and the JSON numbers of summaries, run records and benchmark
results with the wall-time fields left out (anything named *seconds*, *_ms, per_second,
wall, yore's build info), and the command line's output with its timing lines left out.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import re
import subprocess
import sys
import tempfile
import warnings
import zipfile
from pathlib import Path

import numpy as np

#: Scenes run with `yore run` (the first part of each; until past the first stroke).
SCENES = {
    "hanging.toml": 0.7,
    "hanging_paper.toml": 0.7,
    "cylinder.toml": 1.2,
    "cylinder_paper.toml": 1.2,
    "stiff.toml": 1.2,
}
#: Quick benchmarks whose results (less wall time) must not move.
BENCHMARKS = ("wrinkles", "numerical_damping")
TIMING = re.compile(
    r"seconds|_ms$|per_second|wall|^yore$|cpu|^threads$|speed|^date$|"
    r"^machine$|^python$|^numpy$|^versions?$|^host"
)


def _strip(value):
    """``value`` with its wall-time fields removed (recursively) and floats as hex."""
    if isinstance(value, dict):
        return {k: _strip(v) for k, v in value.items() if not TIMING.search(str(k))}
    if isinstance(value, list):
        return [_strip(v) for v in value]
    if isinstance(value, float):
        return value.hex()
    return value


def _state_digest(path):
    """SHA-256 of each array of a state file, and its JSON document (stored as an array of
    text) without wall time."""
    out = {}
    with zipfile.ZipFile(path) as archive:
        for name in sorted(archive.namelist()):
            data = archive.read(name)
            if name.startswith("__document__"):
                document = np.load(io.BytesIO(data), allow_pickle=False)
                out[name] = _strip(json.loads(str(document)))
            else:
                out[name] = hashlib.sha256(data).hexdigest()
    return out


def _without_root(item, root):
    """``item`` with the checkout's own path written as <root> (no output of yore's)."""
    return json.loads(json.dumps(item).replace(str(root), "<root>"))


def _run(command, cwd):
    done = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False)
    # the checkout's own path is no output of yore's
    stdout, stderr = (text.replace(str(cwd), "<root>") for text in (done.stdout, done.stderr))
    lines = [
        line
        for line in stdout.splitlines()
        if not re.search(r"\d+(\.\d+)? ?(s|ms)\b.*(wall|took|elapsed)|wall|seconds", line)
    ]
    return {
        "code": done.returncode,
        "stdout": lines,
        "stderr": stderr.strip().splitlines()[-1:] if done.returncode else [],
    }


def _scenes(root, work):
    out = {}
    for name, until in SCENES.items():
        folder = work / name
        command = [
            sys.executable,
            "-m",
            "yore",
            "run",
            str(root / "examples" / name),
            "-o",
            str(folder),
            "--until",
            str(until),
            "--quiet",
            "--no-render",
        ]
        out[f"run {name}"] = _run(command, root)
        if (folder / "state.npz").is_file():
            out[f"state {name}"] = _state_digest(folder / "state.npz")
            summary = json.loads((folder / "summary.json").read_text())
            out[f"summary {name}"] = _strip(
                {k: v for k, v in summary.items() if k not in ("settings", "counters")}
            )
        out[f"check {name}"] = _run(
            [sys.executable, "-m", "yore", "check", str(root / "examples" / name)], root
        )
    return out


def _scripted():
    """Strokes of every kind and option through the Python API, with the methods both the old
    and the new code have (the old stroke_* methods are the new one's deprecated wrappers)."""
    import yore

    out = {}
    for integrator in ("explicit", "implicit", "bdf2"):
        sim = yore.scenes.hanging_cloth(resolution=11, integrator=integrator)
        sim.advance(0.2)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            sim.stroke_material([[0.2, 0.7], [0.8, 0.65]])
            sim.stroke_material(
                [[0.2, 0.4], [0.8, 0.45]], growth="isotropic", width=0.2, refine=1, expansion=1.2
            )
            camera = yore.Camera(
                eye=(0.5, -0.3, 2.5), target=(0.5, -0.4, 0.0), width=320, height=240
            )
            pixels = camera.project(sim.cloth.positions[[11 * 5 + 2, 11 * 6 + 8]])
            sim.stroke_screen(pixels, camera, growth="along", width=0.15)
        X = sim.cloth.positions
        sim.stroke(0.5 * (X[11 + 2 : 22 - 2] + X[22 + 2 : 33 - 2]), mass_scale="conserve")
        smoothing = sim.smooth_rest_lengths(iterations=7, strength=0.4)
        sim.advance(0.2)
        cloth = sim.cloth
        out[f"scripted {integrator}"] = {
            name: hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()
            for name, value in (
                ("positions", cloth.positions),
                ("velocities", cloth.velocities),
                ("masses", cloth.masses),
                ("faces", cloth.faces),
                ("rest", cloth.springs.rest),
            )
        }
        out[f"smoothing {integrator}"] = _strip(smoothing)
        settled = yore.scenes.hanging_cloth(resolution=9, integrator=integrator)
        out[f"settle {integrator}"] = _strip(settled.settle(2.0, progress=False))
    return out


#: Every Newton time scheme, fixed and error-controlled, with the predictors that read a
#: scheme's history (issue 54: the time schemes moved out of the Newton solver).
SCHEMES = (
    ("implicit", {}),
    ("bdf2", {}),
    ("bdf2", {"predictor": "extrapolated"}),
    ("bdf2", {"dt": "auto", "rtol": 1e-3}),
    ("generalized-alpha", {}),
    ("generalized-alpha", {"predictor": "extrapolated"}),
    ("tr-bdf2", {}),
    ("tr-bdf2", {"predictor": "extrapolated"}),
    ("tr-bdf2", {"dt": "auto", "rtol": 1e-3}),
    ("quasi-newton", {"method": "bdf2"}),
    # the Hessian projections (each takes its own path through Newton's assembly and solve)
    ("implicit", {"projection": "steihaug"}),
    ("bdf2", {"projection": "exact"}),
    ("bdf2", {"projection": "abs"}),
    ("bdf2", {"projection": "shifted"}),
    ("bdf2", {"projection": "trust-region"}),
    ("bdf2", {"lagged_factorization": True}),
    # the continuum terms: quadratic bending and the membrane in Newton's assembly
    ("bdf2", {"bending": "quadratic", "bending_modulus": 1e-4}),
    (
        "implicit",
        {"stretch": "membrane", "young_modulus": 1e3, "poisson_ratio": 0.3, "projection": "abs"},
    ),
    ("explicit", {"stretch": "membrane", "young_modulus": 1e3, "poisson_ratio": 0.3, "dt": 2e-4}),
)


def _scheme_run(sim, work):
    import yore

    sim.advance(0.1)
    sim.stroke(yore.StrokePath.material([[0.2, 0.7], [0.8, 0.65]]))
    sim.advance(0.05)
    path = work / "scheme-state.npz"
    yore.save_state(path, sim)
    resumed = yore.load_state(path)[0]
    for s in (sim, resumed):
        s.advance(0.1)
    digests = {}
    for name, s in (("run", sim), ("resumed", resumed)):
        for field in ("positions", "velocities"):
            value = np.ascontiguousarray(getattr(s.cloth, field))
            digests[f"{name} {field}"] = hashlib.sha256(value.tobytes()).hexdigest()
    digests["stats"] = _strip(sim.stats)
    return digests


def _schemes(work):
    """Each scheme through a stroke and a save/resume of its history: positions, velocities,
    the history's arrays and the counters (wall time left out)."""
    import yore

    out = {}
    for integrator, options in SCHEMES:
        key = f"scheme {integrator} " + json.dumps(options, sort_keys=True)
        options = dict(options)
        dt = options.pop("dt", 1 / 60)
        sim = yore.scenes.hanging_cloth(resolution=9, integrator=integrator, dt=dt, **options)
        try:
            out[key] = _scheme_run(sim, work)
        except (RuntimeError, ValueError) as error:  # a run that stops is an output too
            out[key] = {"error": str(error)}
    return out


#: Cloths whose stable explicit steps (Lanczos at the state and for every state, and
#: Gershgorin's bound) are digested: springs, quadratic bending, the membrane.
STABLE_STEP_SCENES = (
    {},
    {"bending": "quadratic", "bending_modulus": 1e-4, "damping": 0.05},
    {"stretch": "membrane", "young_modulus": 1e3, "poisson_ratio": 0.3},
)


def _stable_steps():
    import yore

    out = {}
    for options in STABLE_STEP_SCENES:
        sim = yore.scenes.hanging_cloth(resolution=9, integrator="implicit", **options)
        sim.advance(0.1)  # a stretched state: the Hessian differs from the bound's
        cloth = sim.cloth
        out["stable steps " + json.dumps(options, sort_keys=True)] = _strip(
            [cloth.stable_time_step(), cloth.stable_time_step_bound(), cloth.gershgorin_time_step()]
        )
    return out


def _benchmarks(root, work):
    out = {}
    for name in BENCHMARKS:
        folder = work / f"bench-{name}"
        result = _run(
            [sys.executable, "-m", f"benchmarks.{name}", "--quick", "--out", str(folder)], root
        )
        out[f"bench {name} run"] = {"code": result["code"]}
        path = folder / f"{name}.json"
        if path.is_file():
            out[f"bench {name}"] = _strip(json.loads(path.read_text()))
    return out


def digest(out):
    root = Path.cwd()
    with tempfile.TemporaryDirectory() as temporary:
        work = Path(temporary)
        found = {
            **_scenes(root, work),
            **_scripted(),
            **_schemes(work),
            **_stable_steps(),
            **_benchmarks(root, work),
        }
        found = _without_root(_without_root(found, root), work)
    Path(out).write_text(json.dumps(found, indent=1, sort_keys=True) + "\n")


def compare(old, new):
    a, b = json.loads(Path(old).read_text()), json.loads(Path(new).read_text())
    differ = [key for key in sorted(set(a) | set(b)) if a.get(key) != b.get(key)]
    for key in differ:
        print(f"differs: {key}")
    print(f"{len(set(a) | set(b)) - len(differ)} of {len(set(a) | set(b))} items identical")
    return 1 if differ else 0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    one = commands.add_parser("digest")
    one.add_argument("--out", required=True)
    two = commands.add_parser("compare")
    two.add_argument("old")
    two.add_argument("new")
    args = parser.parse_args(argv)
    if args.command == "digest":
        digest(args.out)
        return 0
    return compare(args.old, args.new)


if __name__ == "__main__":
    sys.exit(main())
