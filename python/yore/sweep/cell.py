"""One cell of a sweep, as a Dask task: run the cell's scene in a scratch folder on the worker
and send back what is recorded (scalars, the final positions and faces), so the client needs no
shared file system with its workers.

Statuses: "done" (the run reached its duration), "diverged" (the run stopped on a divergence;
its time and the stable-dt estimate there are recorded), "stroke missed", "failed" (anything
else: the message is recorded). A cell never raises: a failure is a result.
"""

from __future__ import annotations

import json
import math
import re
import tempfile
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

__all__ = ["run_cell", "null_cell", "STATUSES", "OUTPUT_OVERRIDES"]

STATUSES = ("done", "diverged", "stroke missed", "failed")
#: Every cell runs without frames or pictures (its final frame comes back as arrays).
OUTPUT_OVERRIDES = {"output.format": "none", "output.pictures": False, "output.animation": "none"}
_ENERGIES = ("kinetic", "spring", "gravity", "total", "area", "rest_area")


def run_cell(scene_text, scene_path, overrides) -> dict:
    """Runs one cell; returns {"status", "message", "values": {name: float}, "positions",
    "faces"} (positions/faces None when no state was reached)."""
    from ..runtime import set_num_threads
    from ..runs import RunError, SceneError, load_scene, run_scene

    set_num_threads(1)  # one thread per worker process: no oversubscription
    started = time.perf_counter()
    status, message = "done", ""
    with tempfile.TemporaryDirectory(prefix="yore-cell-") as folder:
        out = Path(folder) / "run"
        try:
            scene = load_scene(
                scene_path, text=scene_text, overrides={**overrides, **OUTPUT_OVERRIDES}
            )
            with warnings.catch_warnings():
                # unconverged steps are recorded (unconverged_steps), not warned per cell
                warnings.simplefilter("ignore", RuntimeWarning)
                run_scene(scene, out, render=False, quiet=True)
        except RunError as error:
            # the scratch folder's state file goes with the folder: not worth naming
            status = "diverged"
            message = re.sub(r"\s*State kept: .*$", "", " ".join(str(error).split()))
        except SceneError as error:
            status = "stroke missed" if (out / "summary.json").is_file() else "failed"
            message = " ".join(str(error).split())
        except Exception as error:  # noqa: BLE001 - a cell's failure is its result
            status = "failed"
            message = f"{type(error).__name__}: {' '.join(str(error).split())}"
            last = traceback.extract_tb(error.__traceback__)[-1:]
            if last:
                message += f" (at {Path(last[0].filename).name}:{last[0].lineno})"
        values = {"cell_wall_seconds": time.perf_counter() - started}
        positions = faces = None
        if (out / "summary.json").is_file():
            summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
            values.update(_summary_values(summary))
            if status == "done" and not summary.get("finished", False):
                status, message = "failed", f"stopped at t = {summary.get('time')} s"
        if (out / "state.npz").is_file():
            from ..state import load_state

            sim, _ = load_state(out / "state.npz")
            positions, faces = sim.cloth.positions, sim.cloth.faces
            values.update(_state_values(sim, summary if (out / "summary.json").is_file() else {}))
            if status == "diverged":
                values["diverged_time"] = sim.time
                values["suggested_dt"] = _suggested_dt(sim)
    return {
        "status": status,
        "message": message,
        "values": values,
        "positions": positions,
        "faces": faces,
    }


def null_cell(scene_text, scene_path, overrides) -> dict:
    """A stand-in for `run_cell` that runs nothing: a "done" result with one value (the
    number of overrides). It measures the sweep machinery alone (Dask, records, results.nc)."""
    return {
        "status": "done",
        "message": "",
        "values": {"overrides": float(len(overrides))},
        "positions": None,
        "faces": None,
    }


def _number(value):
    if isinstance(value, bool):
        return float(value)
    if isinstance(value, (int, float)) and math.isfinite(float(value)):
        return float(value)
    return None


def _add_numbers(values, pairs, prefix=""):
    """values[prefix + name] = each value of (name, value) pairs that is a finite number."""
    for name, value in pairs:
        number = _number(value)
        if number is not None:
            values[prefix + name] = number


def _summary_values(summary) -> dict:
    values = {}
    _add_numbers(
        values,
        (
            (n, summary.get(n))
            for n in ("time", "steps", "dt", "wall_seconds", "vertices", "springs")
        ),
    )
    _add_numbers(values, (summary.get("counters") or {}).items())
    _add_numbers(values, (summary.get("phases") or {}).items())
    records = summary.get("records") or []
    if records:
        _add_energy_values(values, records)
    if values.get("time"):
        values["wall_seconds_per_simulated_second"] = (
            values.get("wall_seconds", math.nan) / values["time"]
        )
    strokes = summary.get("strokes") or []
    values["strokes"] = float(len(strokes))
    if strokes:
        _add_numbers(values, ((n, strokes[0].get(n)) for n in _STROKE_VALUES), prefix="stroke_")
    return values


#: The first stroke's figures a cell records (as stroke_<name>).
_STROKE_VALUES = (
    "faces_split",
    "vertices_added",
    "springs_grown",
    "rest_length_added",
    "mass_added",
    "rest_area_before",
    "rest_area_after",
)


def _add_energy_values(values, records):
    """The last frame's energies (final_<name>), and over the recorded frames the total
    energy's change, its largest rise and the gravitational energy released."""
    _add_numbers(values, ((n, records[-1].get(n)) for n in _ENERGIES), prefix="final_")
    first, last = _number(records[0].get("total")), _number(records[-1].get("total"))
    if first is None or last is None:
        return
    values["energy_gain"] = last - first
    totals = [_number(r.get("total")) for r in records]
    gravity = [_number(r.get("gravity")) for r in records]
    if None not in totals and None not in gravity:
        # over the recorded frames: the largest rise of the total energy, and the
        # gravitational energy released (what the stability map compares)
        values["max_energy_gain"] = max(totals) - first
        values["gravity_released"] = max(gravity[0] - g for g in gravity)


def _state_values(sim, summary) -> dict:
    """The metrics of issues 9 and 10 on the final state."""
    from .. import metrics

    cloth = sim.cloth
    V, F = cloth.positions, cloth.faces
    values = {"wrinkle_measure": metrics.wrinkle_measure(V, F)}
    strokes = summary.get("strokes") or []
    if strokes:
        stroke = strokes[0]
        region = np.asarray(stroke.get("region_faces") or [], dtype=np.int64)
        region = region[region < len(F)]
        if region.size:
            values["stroke_wrinkle_measure"] = metrics.wrinkle_measure(V, F, region)
        marked = stroke.get("new_vertices") or stroke.get("line_vertices") or []
        marked = np.asarray(marked, dtype=np.int64)
        marked = marked[marked < len(V)]
        if marked.size:
            values["spike_index"] = metrics.spike_index(V, F, marked)
    return values


def _suggested_dt(sim) -> float:
    try:
        stable = float(sim.stable_dt())
    except Exception:  # noqa: BLE001
        return math.nan
    return 0.9 * stable if math.isfinite(stable) and stable > 0 else math.nan
