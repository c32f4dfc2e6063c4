"""Real Ctrl-Cs at random moments of `yore run`, then `--resume`: does every interrupted run end
bit for bit where a straight run ends? (Issue 41's acceptance: 30 trials per integrator; issue
53 added every other integrator, the error-controlled steps and a growing stroke.)

For each integrator, one straight run of a small scene (the paper's hanging cloth at 15×15 or
21×21, a stroke at 0.5 s, frames every 0.05 s, 2–5 s in all: SIZES) is the reference. Each trial starts the same
run as a process, sends it SIGINT after a delay drawn uniformly from (0, the straight run's wall
time) — so the signal lands anywhere: while Python starts, while the scene is checked, in a step,
in the stroke, while a frame or the state is written — and then resumes it (`yore run --resume`)
until it finishes. A trial passes when the final state (positions, velocities, time), the frame
list, every frame file's points and the per-frame records equal the reference's exactly. A
signal that lands before the run folder holds a state ends the process with exit 130 and
nothing to resume: the trial then starts the run again (counted as "before the state").

The outcome must not depend on when the signals land (every trial must pass); only which parts
are hit does. This is a tool, not a test: its timing is random on purpose.

    python tools/interrupt_trials.py [--trials 30] [--integrators explicit implicit ...]
                                     [--out bench-results/interrupt_trials.json]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import meshio

ROOT = Path(__file__).resolve().parents[1]
YORE = str(Path(sys.executable).with_name("yore"))  # the command users run
SCENE = ROOT / "examples" / "hanging_paper.toml"
SETTINGS = [
    "--set",
    "strokes.0.time=0.5",
    "--set",
    "simulation.settle=0",
    "--set",
    "strokes.0.material=[[0.1, 0.2], [0.9, 0.2]]",
    "--set",
    "output.fps=20",
    "--no-render",
    "--quiet",
]
INTEGRATORS = (
    "explicit",
    "implicit",
    "bdf2",
    "local-global",
    "quasi-newton",
    "generalized-alpha",
    "tr-bdf2",
    "tr-bdf2 auto",
    "bdf2 auto",
    "cvode",
    "arkode",
    "quasi-newton, growing stroke",
)
# per trial kind, a run of a few seconds here (so that most signals land in the stepping):
# (nx = ny, duration s, dt s or default, "auto" for error-controlled steps)
SIZES = {
    "explicit": ("31", "5.0", None),
    "implicit": ("15", "2.0", "0.0005"),
    "bdf2": ("15", "2.0", "0.0005"),
    "local-global": ("15", "2.0", "0.0005"),
    "quasi-newton": ("15", "2.0", "0.0001"),
    "generalized-alpha": ("15", "2.0", "0.002"),
    "tr-bdf2": ("15", "2.0", "0.002"),
    "tr-bdf2 auto": ("15", "2.0", '"auto"'),
    "bdf2 auto": ("15", "2.0", '"auto"'),
    "cvode": ("15", "2.0", None),
    "arkode": ("15", "2.0", None),
    "quasi-newton, growing stroke": ("15", "2.0", "0.0001"),
}
# kinds that are an integrator with more settings (issue 53: a stroke that grows rest lengths
# tenfold changed the quasi-Newton stopping scale unseen)
VARIANTS = {
    "tr-bdf2 auto": ("tr-bdf2", []),
    "bdf2 auto": ("bdf2", []),
    "quasi-newton, growing stroke": (
        "quasi-newton",
        [
            "--set",
            'strokes.0.growth="isotropic"',
            "--set",
            "strokes.0.width=0.5",
            "--set",
            "strokes.0.expansion=10",
        ],
    ),
}


def command(kind, out, *extra):
    size, duration, dt = SIZES[kind]
    integrator, more = VARIANTS.get(kind, (kind, []))
    settings = [
        "--set",
        f'simulation.integrator="{integrator}"',
        "--set",
        f"mesh.nx={size}",
        "--set",
        f"mesh.ny={size}",
        "--set",
        f"simulation.duration={duration}",
        *more,
    ]
    if dt is not None:
        settings += ["--set", f"simulation.dt={dt}"]
    return [YORE, "run", str(SCENE), "-o", str(out), *SETTINGS, *settings, *extra]


def fingerprint(folder):
    """What must be equal: the final state's arrays, frames (times, names, points), records."""
    import yore

    sim, _ = yore.load_state(folder / "state.npz")
    summary = json.loads((folder / "summary.json").read_text())
    frames = [
        (f["time"], Path(f["file"]).name, meshio.read(folder / f["file"]).points.tobytes())
        for f in summary["frames"]
    ]
    keys = ("time", "kinetic", "spring", "gravity", "total", "vertices")
    records = [[r[k] for k in keys] for r in summary["records"]]
    return {
        "positions": sim.cloth.positions.tobytes(),
        "velocities": sim.cloth.velocities.tobytes(),
        "time": sim.time,
        "status": summary["status"],
        "frames": frames,
        "records": records,
        "files": sorted(p.name for p in (folder / "frames").iterdir()),
    }


def trial(integrator, reference, delay, folder):
    """One interrupted run, resumed to its end; returns (passed, where, resumes)."""
    process = subprocess.Popen(
        command(integrator, folder), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    _, error = process.communicate(timeout=600)
    where = {0: "finished first", 130: "interrupted"}.get(
        process.returncode, f"exit {process.returncode}"
    )
    resumes = 0
    if process.returncode == 130 and not (folder / "state.npz").is_file():
        where = "before the state"
        done = subprocess.run(
            command(integrator, folder), capture_output=True, text=True, timeout=600
        )
        if done.returncode != 0:
            return False, f"{where}; the new run: exit {done.returncode} {done.stderr}", 0
    elif process.returncode == 130:
        while True:
            resumes += 1
            done = subprocess.run(
                [YORE, "run", "--resume", str(folder / "state.npz"), "--quiet", "--no-render"],
                capture_output=True,
                text=True,
                timeout=600,
            )
            if done.returncode == 0:
                break
            if resumes > 3 or done.returncode != 130:
                return False, f"{where}; resume: exit {done.returncode} {done.stderr}", resumes
    elif process.returncode != 0:
        return False, f"{where}: {error}", 0
    got = fingerprint(folder)
    differing = [key for key in reference if got[key] != reference[key]]
    return not differing, where + (f"; differs in {differing}" if differing else ""), resumes


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=30)
    parser.add_argument("--integrators", nargs="+", default=list(INTEGRATORS), choices=INTEGRATORS)
    parser.add_argument(
        "--out", type=Path, default=ROOT / "bench-results" / "interrupt_trials.json"
    )
    parser.add_argument("--seed", type=int, default=41)
    arguments = parser.parse_args()
    if arguments.trials < 1:
        parser.error("--trials must be at least 1")
    rng = random.Random(arguments.seed)
    results = {
        "trials_per_integrator": arguments.trials,
        "seed": arguments.seed,
        "scene": str(SCENE.relative_to(ROOT)),
        "settings": SETTINGS,
        "sizes": SIZES,
        "integrators": {},
    }
    with tempfile.TemporaryDirectory(prefix="yore-interrupts-") as scratch:
        scratch = Path(scratch)
        for integrator in arguments.integrators:
            straight = scratch / f"{integrator.replace(' ', '_')}-straight"
            started = time.perf_counter()
            subprocess.run(command(integrator, straight), check=True, timeout=600)
            wall = time.perf_counter() - started
            reference = fingerprint(straight)
            rows = []
            for number in range(arguments.trials):
                folder = scratch / f"{integrator.replace(' ', '_')}-{number}"
                delay = rng.uniform(0.0, wall)
                passed, where, resumes = trial(integrator, reference, delay, folder)
                rows.append(
                    {
                        "delay_seconds": round(delay, 3),
                        "passed": passed,
                        "where": where,
                        "resumes": resumes,
                    }
                )
                shutil.rmtree(folder, ignore_errors=True)
                print(
                    f"{integrator:28s} trial {number + 1:2d}: "
                    f"{'same' if passed else 'DIFFERENT'} ({where}, signal at {delay:.2f} s)",
                    flush=True,
                )
            results["integrators"][integrator] = {
                "straight_wall_seconds": round(wall, 2),
                "passed": sum(row["passed"] for row in rows),
                "trials": rows,
                "outcomes": {
                    kind: sum(row["where"].startswith(kind) for row in rows)
                    for kind in ("interrupted", "before the state", "finished first")
                },
            }
    arguments.out.parent.mkdir(parents=True, exist_ok=True)
    partial = arguments.out.with_name(arguments.out.name + ".part")
    partial.write_text(json.dumps(results, indent=1) + "\n")
    os.replace(partial, arguments.out)
    failed = {
        name: entry["trials"] and len(entry["trials"]) - entry["passed"]
        for name, entry in results["integrators"].items()
    }
    print("all trials passed" if not any(failed.values()) else f"FAILED: {failed}")
    return 0 if not any(failed.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
