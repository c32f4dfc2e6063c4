"""A run's record (`RunRecord`): what a run has done so far — its step, the strokes drawn,
the frames written, timings — as a state file's metadata holds it, with the checks a record
read back from a file must pass (a tampered record is refused, never half-used)."""

from __future__ import annotations

import re
from dataclasses import dataclass, field as _field, fields, replace
from pathlib import Path

import numpy as np

from .. import rules
from ..results import ClothState, FrameMeasure, StrokeEntry
from ..options import FIXED_DT, GRAVITY, INTEGRATOR_SPECS, options_in_force, resolve_options
from .loading import step_of
from .schedule import frame_due

__all__ = [
    "RunRecord",
    "Before",
    "FRAMES_DIR",
    "BEFORE_NAME",
    "check_metadata",
    "check_against",
    "check_settings",
]

#: The run folder's frames folder and its "before" mesh (relative to the run folder).
FRAMES_DIR = "frames"
BEFORE_NAME = "before.vtu"

#: The record written before [simulation] settle existed has no "settle" key.
_NO_SETTLE = object()


@dataclass(frozen=True)
class Before:
    """The mesh saved just before the first stroke: its time, s, and its file (relative to the
    run folder)."""

    time: float
    file: str

    def as_dict(self) -> dict:
        return {"time": self.time, "file": self.file}


@dataclass
class RunRecord:
    """What a run has done, field by field, in the order a state file's metadata lists them.

    scene_text, scene_path, overrides: the scene as run. step: steps taken. next_stroke:
    strokes drawn (the index of the next). frames: [time, path] of each frame written (paths
    relative to the run folder). records: one measure per frame (time, energies, areas,
    counts). strokes: one entry per stroke drawn. before: {time, file} of the mesh just before
    the first stroke, or None. wall_seconds: over all parts. resumed_from: the state files the
    run was resumed from. phases: wall time per phase over all parts. settle: the relaxation's
    figures before t = 0, or None (absent from records written before it existed).
    """

    scene_text: str
    scene_path: object
    overrides: dict
    step: int = 0
    next_stroke: int = 0
    frames: list = _field(default_factory=list)
    records: list = _field(default_factory=list)
    strokes: list = _field(default_factory=list)
    before: Before | None = None
    wall_seconds: float = 0.0
    resumed_from: list = _field(default_factory=list)
    phases: dict = _field(default_factory=dict)
    settle: object = _NO_SETTLE

    @classmethod
    def new(cls, scene, settle) -> "RunRecord":
        """The record of a run of ``scene`` about to start (``settle``: its relaxation's)."""
        return cls(
            scene_text=scene.text,
            scene_path=str(scene.path) if scene.path is not None else None,
            overrides=scene.overrides,
            settle=settle,
        )

    @classmethod
    def from_metadata(cls, state_path, metadata) -> "RunRecord":
        """The record a state file holds, checked field by field (`check_metadata`)."""
        check_metadata(state_path, metadata)
        before = metadata["before"]
        if before is not None:  # (a table with time and file, checked above)
            before = Before(before["time"], before["file"])
        return cls(
            **{
                **metadata,
                "before": before,
                "records": [FrameMeasure(entry) for entry in metadata["records"]],
                "strokes": [StrokeEntry(entry) for entry in metadata["strokes"]],
            }
        )

    def to_dict(self) -> dict:
        """The record as a state file's metadata holds it (the same keys in the same order)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        if self.settle is _NO_SETTLE:
            del out["settle"]
        if self.before is not None:
            out.update(before=self.before.as_dict())
        return out

    def settled(self):
        """The relaxation's figures, or None (also for records from before settle)."""
        return None if self.settle is _NO_SETTLE else self.settle

    def with_wall_time(self, seconds) -> "RunRecord":
        """A copy whose wall time includes ``seconds`` more (the record as saved now)."""
        return replace(self, wall_seconds=self.wall_seconds + seconds)


# -- the record's fields as a state file holds them -------------------------------------------------
# A record read back from a file is checked field by field, in this order; each field's rule
# (`yore.rules`) names what it expects, and the first that fails is the error. Numbers are
# JSON's own: Python ints and finite floats, never bools.
_COUNT = rules.count(0, python_types=True)
_NUMBER = rules.real(python_types=True)
_SECONDS = rules.real(0, low_open=False, python_types=True)


def _is(rule):
    return lambda value: rule.test(value)[0]


def _settle_ok(settle):
    # saddles_escaped and stable came with settle's saddle test: absent from older records
    basic = {"seconds", "steps", "converged", "residual_acceleration"}
    return settle is None or (
        isinstance(settle, dict)
        and basic <= set(settle) <= basic | {"saddles_escaped", "stable"}
        and _NUMBER.test(settle.get("seconds"))[0]
        and _COUNT.test(settle.get("steps"))[0]
        and isinstance(settle.get("converged"), bool)
        and isinstance(settle.get("residual_acceleration"), (int, float))
        and _COUNT.test(settle.get("saddles_escaped", 0))[0]
        and settle.get("stable") in (None, True, False)
    )


def _frames_ok(frames):
    return isinstance(frames, list) and all(
        isinstance(f, list)
        and len(f) == 2
        and _NUMBER.test(f[0])[0]
        and isinstance(f[1], str)
        and _is_frame_path(f[1])
        for f in frames
    )


def _tables_ok(entries):
    return isinstance(entries, list) and all(isinstance(entry, dict) for entry in entries)


def _measures_ok(entries):
    return all(
        _NUMBER.test(entry.get("time"))[0]
        and all(
            isinstance(key, str) and (_NUMBER.test(value)[0] or isinstance(value, float))
            for key, value in entry.items()
        )
        for entry in entries
    )


def _before_ok(before):
    return before is None or (
        isinstance(before, dict)
        and _NUMBER.test(before.get("time"))[0]
        and isinstance(before.get("file"), str)
        and Path(before.get("file")).name == BEFORE_NAME
    )


#: (field, test, expected) in the order a record is checked; a test takes the field's value.
RECORD_CHECKS = (
    (
        "settle",
        _settle_ok,
        "null or a table with seconds, steps, converged, "
        "residual_acceleration (and saddles_escaped, stable)",
    ),
    ("scene_text", _is(rules.text()), "the scene file's text"),
    ("scene_path", _is(rules.text().or_none()), "a path or null"),
    (
        "overrides",
        lambda value: isinstance(value, dict) and all(isinstance(key, str) for key in value),
        "a table of dotted keys",
    ),
    ("step", _is(_COUNT), "an integer >= 0"),
    ("next_stroke", _is(_COUNT), "an integer >= 0"),
    (
        "frames",
        _frames_ok,
        f"a list of [time, path] pairs, each path a {FRAMES_DIR}/frame_NNNNN file of a run",
    ),
    ("records", _tables_ok, "a list of tables"),
    ("strokes", _tables_ok, "a list of tables"),
    ("records", _measures_ok, "a list of tables of numbers, each with its time"),
)
#: The checks after the strokes' count (which the record's next_stroke sets).
RECORD_CHECKS_AFTER = (
    ("before", _before_ok, f"null or a table with time and file (a run's {BEFORE_NAME})"),
    ("wall_seconds", _is(_SECONDS), "a number >= 0"),
    (
        "resumed_from",
        lambda value: isinstance(value, list) and all(isinstance(p, str) for p in value),
        "a list of paths",
    ),
    (
        "phases",
        lambda value: (
            isinstance(value, dict)
            and all(isinstance(k, str) and _NUMBER.test(v)[0] for k, v in value.items())
        ),
        "a table of seconds per phase",
    ),
)


def check_metadata(state_path, record):
    """The run's record in a state file (its metadata), checked field by field: ValueError
    naming the field, so a tampered record can only be refused, never half-used."""

    def fail(field, expected):
        raise ValueError(f"{state_path}: field metadata.{field}: expected {expected}")

    keys = {f.name for f in fields(RunRecord)} - {"settle"}
    # settle: absent from records written before it existed
    if not keys <= set(record) <= keys | {"settle"}:
        fail("(keys)", f"the keys {sorted(keys)} (and settle) of a run's record")
    for field, test, expected in RECORD_CHECKS:
        if not test(record.get(field)):
            fail(field, expected)
    strokes, done = record.get("strokes"), record.get("next_stroke")
    if len(strokes) != done:
        fail("strokes", f"one entry per stroke done ({done})")
    for field, test, expected in RECORD_CHECKS_AFTER:
        if not test(record.get(field)):
            fail(field, expected)


def check_against(state_path, record, scene, sim):
    """The record against the scene it holds and the state beside it: the same integrator,
    and the frames and records a run of that scene writes up to the record's step (numbered
    0, 1, ... in order). ValueError naming the field otherwise: a hand-edited record is
    refused, never half-used (an emptied frame list would overwrite the first frames)."""

    def fail(field, problem):
        raise ValueError(
            f"{state_path}: field metadata.{field}: {problem}; the record does not "
            "match the run (was it edited?): start the run again with --overwrite"
        )

    integrator = scene.data.simulation.integrator
    if integrator != sim.integrator:
        fail(
            "scene_text",
            f"its scene's integrator is {integrator!r}, the state's is {sim.integrator!r}",
        )
    check_settings(state_path, scene, sim, record.next_stroke)
    every = scene.frame_interval(sim.dt)
    step = record.step
    due = step // every + 1  # frames at 0, every, 2 every, ... up to step
    if frame_due(step, every, step_of(scene.data.simulation.duration, sim.dt)):
        if step % every:
            due += 1  # the scene's end
        # an interruption may come between the steps to a frame and the frame
        allowed = (due - 1, due)
    else:
        # states written before runs stopped by --until wrote no frame there have one more
        allowed = (due, due + 1)
    if len(record.records) not in allowed:
        fail("records", f"{len(record.records)} entries, but the run writes {due} by step {step}")
    if scene.data.output.format != "none":
        if len(record.frames) != len(record.records):
            fail(
                "frames",
                f"{len(record.frames)} frames for {len(record.records)} records (one per frame)",
            )
        for number, (_, path) in enumerate(record.frames):
            if not Path(path).name.startswith(f"frame_{number:05d}."):
                fail("frames", f"entry {number} is {Path(path).name}, expected frame {number:05d}")


def check_settings(state_path, scene, sim, strokes_done):
    """The state's settings against its scene's (the integrator being the same): every
    integrator option as resolved, dt where the scene sets it, gravity, and the material —
    stretching and bending models and constants, damping, drag, each spring's stiffness and
    damping (a stroke's springs take the cloth's constants), and while no stroke is drawn
    (``strokes_done`` 0; strokes move mass) the masses of a scene that gives ``mass`` or
    ``mass_per_vertex``. Only settings are compared, never what a run changes (positions, rest
    lengths, topology). ValueError naming the scene's key, its value and the state's."""

    def fail(key, field, expected, got):
        raise ValueError(
            f"{state_path}: {key} is {_shown(expected)} in its scene but "
            f"{_shown(got)} in the state (field simulation.{field}); the state "
            "does not match its scene (was it edited?): start the run again "
            "with --overwrite"
        )

    def steps(adaptive):
        return _Shown('"auto" (error-controlled steps)' if adaptive else "a fixed step")

    data = scene.data
    simulation = data.simulation
    integrator = simulation.integrator
    expected = resolve_options(
        integrator, options_in_force(integrator, data.integrator, simulation.dt)
    )
    options = sim.resolved_options
    for name, value in expected.items():
        got = options.get(name)
        if got == value and type(got) is type(value):
            continue
        if name == "adaptive" and name not in data.integrator:  # what dt = "auto" sets
            fail("simulation.dt", "options.adaptive", steps(value), steps(got))
        fail(
            f"integrator.{name}"
            if name in data.integrator
            else f"integrator.{name} (not given: the default)",
            f"options.{name}",
            value,
            got,
        )
    dt = simulation.dt
    if dt == "auto" or (dt is None and not INTEGRATOR_SPECS[integrator].conditionally_stable):
        dt = FIXED_DT  # (an explicit scene's default dt follows its cloth: not checked)
    if dt is not None and sim.dt != dt:
        fail("simulation.dt", "dt", dt, sim.dt)
    gravity = GRAVITY if simulation.gravity is None else simulation.gravity
    if not np.array_equal(np.asarray(gravity, dtype=np.float64), sim.gravity):
        fail("simulation.gravity", "gravity", list(map(float, gravity)), sim.gravity.tolist())
    _check_material(data.material, sim.cloth, strokes_done, fail)


def _check_material(material, cloth, strokes_done, fail):
    """The scene's [material] against the cloth: models, constants, springs, masses."""
    state = ClothState(cloth.state())
    _check_constants(material, cloth, state, fail)
    _check_springs(material, state, fail)
    if strokes_done == 0:  # (strokes move mass)
        _check_masses(material, cloth.vertex_count, state, fail)


def _check_constants(material, cloth, state, fail):
    """The stretching and bending models and the material's constants."""
    membrane = material.stretch == "membrane"
    quadratic = material.bending in ("quadratic", "hinge")
    if cloth.stretch != material.stretch:
        fail("material.stretch", "cloth.young_modulus", material.stretch, cloth.stretch)
    if cloth.bending != material.bending:
        fail("material.bending", "cloth.bending", material.bending, cloth.bending)
    constants = {"damping": state.damping, "drag": state.drag}
    if membrane:
        constants.update(young_modulus=state.young_modulus, poisson_ratio=state.poisson_ratio)
        strain = state.membrane_strain or "faces"
        if (material.membrane_strain or "faces") != strain:
            fail(
                "material.membrane_strain",
                "cloth.membrane_strain",
                material.membrane_strain or "faces",
                strain,
            )
    else:
        constants["stretch_stiffness"] = state.stretch_stiffness
    if quadratic:
        constants["bending_modulus"] = state.bending_modulus
    else:
        constants["bend_stiffness"] = state.bend_stiffness
    for key, value in constants.items():
        if float(getattr(material, key)) != value:
            fail(f"material.{key}", f"cloth.{key}", float(getattr(material, key)), value)


def _check_springs(material, state, fail):
    """Each spring's stiffness and damping as made."""
    membrane = material.stretch == "membrane"
    quadratic = material.bending in ("quadratic", "hinge")
    # each spring as made: structural ones at stretch_stiffness (0 under a membrane), bending
    # ones at bend_stiffness, all at the damping
    stiffness = {
        0: 0.0 if membrane else float(material.stretch_stiffness),
        1: 0.0 if quadratic else float(material.bend_stiffness),
    }
    names = {0: "stretch_stiffness", 1: "bend_stiffness"}
    for kind, value in stiffness.items():
        chosen = state.spring_kind == kind
        wrong = np.flatnonzero(state.spring_stiffness[chosen] != value)
        if wrong.size:
            index = int(np.flatnonzero(chosen)[wrong[0]])
            fail(
                f"material.{names[kind]}",
                f"cloth.spring_stiffness[{index}]",
                value,
                float(state.spring_stiffness[index]),
            )
    wrong = np.flatnonzero(state.spring_damping != float(material.damping))
    if wrong.size:
        index = int(wrong[0])
        fail(
            "material.damping",
            f"cloth.spring_damping[{index}]",
            float(material.damping),
            float(state.spring_damping[index]),
        )


def _check_masses(material, n, state, fail):
    """The masses of a scene that gives mass or mass_per_vertex (density: lumped by area)."""
    if material.mass is not None or material.mass_per_vertex is not None:
        key = "mass" if material.mass is not None else "mass_per_vertex"
        per_vertex = material.mass / n if key == "mass" else material.mass_per_vertex
        wrong = np.flatnonzero(state.masses != per_vertex)
        if wrong.size:
            index = int(wrong[0])
            scene_value = getattr(material, key)
            got = float(state.masses.sum()) if key == "mass" else float(state.masses[index])
            fail(
                f"material.{key}",
                "cloth.masses" if key == "mass" else f"cloth.masses[{index}]",
                scene_value,
                got,
            )


class _Shown(str):
    """Text that error messages quote as it is."""


def _shown(value):
    return (
        str(value)
        if isinstance(value, _Shown)
        else repr(value)
        if isinstance(value, str)
        else str(value)
    )


def _is_frame_path(text):
    """A frame file as a run writes it: OUT/frames/frame_NNNNN.EXT."""
    path = Path(text)
    return (
        path.parent.name == FRAMES_DIR
        and re.fullmatch(r"frame_\d{5,}\.(vtu|vtk|ply|obj)", path.name) is not None
    )
