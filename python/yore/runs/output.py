"""What a run writes and records (`yore.runs.stepping` steps it): a frame's measures and
file, the state file, the stroke reports, the summary, and the JSON with non-finite numbers
named."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from .. import metrics
from ..options import INTEGRATOR_SPECS
from ..io import save_mesh
from ..results import FrameMeasure, StrokeEntry
from ..runtime import deferred_interrupt
from ..state import save_state
from .folder import STATE_NAME, SUMMARY_NAME
from .record import BEFORE_NAME, Before


class UnsaveableState(ValueError):
    """The simulation reached a state no state file may hold (`yore.save_state` refused it).
    A ValueError: before the run starts (its first state) it is bad input."""


class NonFiniteEnergy(Exception):
    """The cloth's energy or area became non-finite: a divergence the integrators' own bound
    cannot see, because the bound itself is then infinite."""


def stable_advice(sim):
    stable = sim.stable_dt()
    if (
        INTEGRATOR_SPECS[sim.integrator].conditionally_stable
        and math.isfinite(stable)
        and stable > 0
    ):
        return (
            f"The estimated stable time step is {stable:.3g} s: use dt <= "
            f"{0.9 * stable:.3g} s or an implicit integrator."
        )
    return f"Try a smaller dt, e.g. {sim.dt / 4:.3g} s."


def measure_frame(sim):
    """The record of a frame: time, energies (J), area and rest area (m²), counts."""
    cloth = sim.cloth
    energy = sim.energy()
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported, not warned
        area, rest_area = metrics.area(cloth.positions, cloth.faces), metrics.rest_area(cloth)
    record = FrameMeasure(
        time=sim.time,
        kinetic=energy.kinetic,
        spring=energy.spring,
        gravity=energy.gravity,
        total=energy.total,
        area=area,
        rest_area=rest_area,
        vertices=cloth.vertex_count,
        faces=cloth.face_count,
    )
    if cloth.bending == "quadratic":  # (part of total; recorded for the cloths that have it)
        record.update(bending=energy.bending)
    if cloth.stretch == "membrane":  # likewise
        status = cloth.membrane_status()
        record.update(
            membrane=energy.membrane, membrane_collapsed_faces=int(status["collapsed_faces"])
        )
    return record


def non_finite_names(entry):
    """'name value, ...' of the non-finite quantities of a `measure_frame` record ('' if none)."""
    return ", ".join(
        f"{name} {value}"
        for name, value in entry.items()
        if isinstance(value, float) and not math.isfinite(value)
    )


def write_frame(sim, frames, record, fmt, entry):
    """Writes the frame file (atomically), then records it: an interruption before the record
    is complete leaves no trace in the record, and the resumed run writes the frame again."""
    cloth = sim.cloth
    with deferred_interrupt():
        if frames is not None:
            point_data = (
                None
                if fmt == "obj"
                else {"velocity": cloth.velocities, "expansion": metrics.vertex_expansion(cloth)}
            )
            path = frames.write(sim.time, cloth.positions, cloth.faces, point_data=point_data)
            # relative to the run folder, so the folder can be moved
            record.frames.append((sim.time, relative_path(path, frames.folder.parent)))
        record.records.append(entry)


def save_before(sim, out, record):
    cloth = sim.cloth
    path = out / BEFORE_NAME
    save_mesh(
        path,
        cloth.positions,
        cloth.faces,
        point_data={"expansion": metrics.vertex_expansion(cloth)},
    )
    record.before = Before(sim.time, BEFORE_NAME)  # relative to the run folder


def stroke_record(index, time, report):
    return StrokeEntry(
        stroke=index,
        time=time,
        faces_split=report.faces_split,
        faces_skipped=int(len(report.faces_skipped)),
        vertices_added=report.vertices_added,
        springs_added=report.springs_added,
        springs_removed=report.springs_removed,
        area_before=report.area_before,
        rest_area_before=report.rest_area_before,
        rest_area_after=report.rest_area_after,
        missed_fraction=report.missed_fraction,
        locate_seconds=report.locate_seconds,
        subdivide_seconds=report.subdivide_seconds,
        growth=report.growth,
        width=report.width,
        refine=report.refine,
        faces_refined=report.faces_refined,
        faces_bisected=report.faces_bisected,
        springs_grown=report.springs_grown,
        rest_length_added=report.rest_length_added,
        mass_added=report.mass_added,
        new_vertices=[int(v) for v in report.new_vertices],
        region_faces=[int(f) for f in report.region_faces],
        # vertices along the stroke in stroke order: its polyline in pictures (the paper's
        # new vertices in the order it crossed their faces)
        line_vertices=[int(v) for v in report.line_vertices],
    )


def save_run_state(out, sim, record, previous_phases, phases=None):
    """Saves the state with the record; ``phases``: this part's wall time per phase (default:
    ``sim``'s, unless a rollback replaced the simulation that ran)."""
    phases = sim.stats.phases if phases is None else phases
    record.phases = {
        name: previous_phases.get(name, 0.0) + phases.get(name, 0.0)
        for name in set(previous_phases) | set(phases)
    }
    try:
        return save_state(out / STATE_NAME, sim, metadata=_finite_json(record.to_dict())[0])
    except ValueError as error:
        raise UnsaveableState(
            f"the run stopped at t = {sim.time:.6g} s: {error}. Nothing can "
            "continue it; check the scene's extreme values"
        ) from None


def run_summary(scene, sim, record, out, state_path, status, message):
    from ..runtime import build_info

    stats = sim.stats
    # the scene as run (copied into JSON types by _finite_json below)
    settings = {
        **scene.data.as_dict(),
        "simulation": {**scene.data.simulation.as_dict(), "dt": sim.dt},
        "integrator": sim.options,
    }
    # Paths in the summary are relative to the run folder, so the folder can be moved.
    outputs = {
        "state": None if state_path is None else relative_path(state_path, out),
        "summary": SUMMARY_NAME,
    }
    if record.frames:
        outputs["frames"] = relative_path((out / record.frames[-1][1]).parent, out)
        pvd = out / "frames" / "frame.pvd"
        if pvd.exists():
            outputs["pvd"] = relative_path(pvd, out)
    before = None
    if record.before is not None:
        file = relative_path(out / record.before.file, out)
        before = {"time": record.before.time, "file": file}
        outputs["before"] = file
    summary = {
        "yore": build_info(),
        # finished | stopped at --until | interrupted | diverged | stroke missed | failed
        "status": status,
        "message": message,
        "scene": record.scene_path,
        "overrides": record.overrides,
        "resumed_from": record.resumed_from,
        "finished": sim.time >= scene.data.simulation.duration - 0.5 * sim.dt,
        "time": sim.time,
        "steps": record.step,
        "dt": sim.dt,
        "integrator": sim.integrator,
        "wall_seconds": record.wall_seconds,
        # wall time per phase over the whole run (all resumed parts); counters of the last part
        "phases": record.phases,
        "counters": stats.counters,
        "active_terms": stats.active_terms,
        "vertices": stats.vertices,
        "springs": stats.springs,
        "settings": settings,
        "records": record.records,
        "strokes": record.strokes,
        # relaxation to rest before t = 0 ([simulation] settle), or null
        "settle": record.settled(),
        "before": before,
        "frames": [{"time": t, "file": relative_path(out / p, out)} for t, p in record.frames],
        "camera": scene.data.camera.as_dict(),
        "outputs": outputs,
    }
    summary, non_finite = _finite_json(summary)
    # JSON has no inf or nan: such a number is written as null, and listed here with its value
    summary["non_finite"] = non_finite
    return summary


def relative_path(path, folder):
    return Path(os.path.relpath(os.path.abspath(path), os.path.abspath(folder))).as_posix()


def _finite_json(value, where=""):
    """(a copy of ``value`` in JSON types — numpy arrays and scalars as lists and numbers, keys
    as text — with every non-finite float replaced by None, [{"field": dotted name, "value":
    "inf" | "-inf" | "nan"}, ...])."""
    found = []

    def visit(item, name):
        if isinstance(item, dict):
            return {
                str(key): visit(child, f"{name}.{key}" if name else str(key))
                for key, child in item.items()
            }
        if isinstance(item, np.ndarray):
            item = item.tolist()
        elif isinstance(item, np.generic):
            item = item.item()
        if isinstance(item, (list, tuple)):
            return [visit(child, f"{name}.{index}") for index, child in enumerate(item)]
        if isinstance(item, float) and not math.isfinite(item):
            found.append({"field": name, "value": repr(item)})
            return None
        return item

    return visit(value, where), found


def write_json(path, document):
    partial = path.with_name(path.name + ".part")
    partial.write_text(json.dumps(document, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    os.replace(partial, path)
