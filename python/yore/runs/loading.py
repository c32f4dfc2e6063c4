"""Scene files: a TOML description of a whole run, checked before anything runs.

A scene file names the mesh (a generator with its sizes, or a mesh file), the material, fixed
and driven vertices, gravity, the integrator with its options and dt, the duration, strokes at
given times with their options and rest-length smoothing, the camera and the outputs. The
tables and keys are documented in README.md ("Scene files") and in `SCHEMA` below; the example
scenes in ``examples/*.toml`` use all of them.

Every key is checked when the file is loaded: an unknown key (with a "did you mean"), a wrong
type, a value out of range, a missing required key, vertex indices out of range, a selection
that selects nothing and a stroke that misses the cloth (material strokes at any time, 3-D and
screen strokes at time 0 — later ones depend on the motion) raise `SceneError`, which names the
key, its line in the file and what was expected.

Limits, checked before anything is built or allocated: a scene file is a regular file of at
most `MAX_SCENE_FILE_BYTES`; TOML nested deeper than Python can parse is refused (in the file
and in ``--set`` values); every integer is at most `MAX_INTEGER` (2^31 - 1, so vertex indices
fit the core's int32); a generated mesh has at most `yore.meshes.MAX_MESH_VERTICES` vertices
(nx·ny or rings·segments); the camera image at most `yore.stroke.MAX_IMAGE_SIDE` pixels a side
and `yore.stroke.MAX_IMAGE_PIXELS` in all; integrator options follow
`yore.simulation.check_option` (iteration counts up to `MAX_STEP_ITERATIONS`); smoothing
iterations at most `MAX_SMOOTHING_ITERATIONS`; floats are finite.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - older Pythons use the backport
    import tomli as tomllib

from .._core import Cloth
from ..io import load_mesh
from ..meshes import MAX_MESH_VERTICES, cylinder_mesh, cylinder_ring, grid_mesh
from ..simulation import (_OPTIONS, INTEGRATORS, MAX_SMOOTHING_ITERATIONS, OptionError,
                         Simulation, check_option)
from ..stroke import (GROWTH_MODES, MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_REFINE, Camera,
                     StrokeMissed)

__all__ = ["Scene", "SceneError", "load_scene", "parse_override"]

#: Largest scene file read, bytes.
MAX_SCENE_FILE_BYTES = 16 * 2**20
#: Largest integer any key takes (vertex indices, sizes, counts): the core's int32 range.
MAX_INTEGER = 2**31 - 1


class SceneError(ValueError):
    """A scene file is wrong. ``key`` is the dotted key (e.g. ``strokes[1].time``), ``line``
    its line in the file (None when unknown or given on the command line), ``expected`` what
    would have been accepted."""

    def __init__(self, source, key, problem, expected=None, line=None):
        self.source, self.key, self.problem = source, key, problem
        self.expected, self.line = expected, line
        place = f"{source}:{line}" if line else str(source)
        text = f"{place}: {key}: {problem}" if key else f"{place}: {problem}"
        if expected:
            text += f"; expected {expected}"
        super().__init__(text)


# -- the schema ----------------------------------------------------------------------------------
# Each key maps to (checker, default, description). A checker takes a value and returns
# the checked value or raises _Invalid(problem, expected). A default of _REQUIRED means the key
# must be given; None means "absent unless given".

_REQUIRED = object()


class _Invalid(Exception):
    def __init__(self, problem, expected):
        super().__init__(problem)
        self.problem, self.expected = problem, expected


def _describe(value):
    if isinstance(value, (dict, list)):
        return f"a {'table' if isinstance(value, dict) else 'list'}"
    text = repr(value)
    if len(text) > 60:  # one readable line, whatever was given
        text = text[:57] + "..."
    return f"{type(value).__name__} {text}"


def _number(minimum=None, maximum=None, strict_minimum=False, unit=""):
    bounds = []
    if minimum is not None:
        bounds.append(f"{'>' if strict_minimum else '>='} {minimum:g}")
    if maximum is not None:
        bounds.append(f"<= {maximum:g}")
    expected = "a number" + (f" {' and '.join(bounds)}" if bounds else "") + \
        (f" ({unit})" if unit else "")

    def check(value):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _Invalid(f"got {_describe(value)}", expected)
        value = float(value)
        if not math.isfinite(value):
            raise _Invalid(f"got {value}", expected)
        if minimum is not None and (value < minimum or (strict_minimum and value == minimum)):
            raise _Invalid(f"got {value:g}", expected)
        if maximum is not None and value > maximum:
            raise _Invalid(f"got {value:g}", expected)
        return value
    check.expected = expected
    return check


def _integer(minimum, maximum=MAX_INTEGER):
    expected = (f"an integer >= {minimum}" if maximum == MAX_INTEGER else
                f"an integer in [{minimum}, {maximum}]")

    def check(value):
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise _Invalid(f"got {_describe(value)}", expected)
        if value > maximum:
            raise _Invalid(f"got {_describe(value)}, more than the limit {maximum}", expected)
        return value
    check.expected = expected
    return check


def _boolean(value):
    if not isinstance(value, bool):
        raise _Invalid(f"got {_describe(value)}", "true or false")
    return value


_boolean.expected = "true or false"


def _string(value):
    if not isinstance(value, str):
        raise _Invalid(f"got {_describe(value)}", "a string")
    return value


_string.expected = "a string"


def _choice(*choices):
    expected = "one of " + ", ".join(repr(c) for c in choices)

    def check(value):
        if value not in choices:
            raise _Invalid(f"got {_describe(value)}", expected)
        return value
    check.expected = expected
    return check


def _points(dimension, what):
    expected = f"a list of {what} points"

    def check(value):
        if not isinstance(value, list) or not value:
            raise _Invalid(f"got {_describe(value)}", expected)
        for point in value:
            if (not isinstance(point, list) or len(point) != dimension or
                    any(isinstance(c, bool) or not isinstance(c, (int, float)) or
                        not math.isfinite(c) for c in point)):
                raise _Invalid(f"got the point {point!r}", expected)
        return np.asarray(value, dtype=np.float64)
    check.expected = expected
    return check


def _vector3(value):
    if (not isinstance(value, list) or len(value) != 3 or
            any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
                for c in value)):
        raise _Invalid(f"got {_describe(value)}", "3 numbers [x, y, z]")
    return np.asarray(value, dtype=np.float64)


_vector3.expected = "3 numbers [x, y, z]"


def _indices(value):
    expected = _indices.expected
    if not isinstance(value, list) or not value:
        raise _Invalid(f"got {_describe(value)}", expected)
    for i in value:
        if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i <= MAX_INTEGER:
            raise _Invalid(f"got the index {_describe(i)}", expected)
    return np.asarray(value, dtype=np.int32)


_indices.expected = "a list of vertex indices (integers in [0, 2147483647])"

_GENERATOR_KEYS = {
    "grid": {
        "nx": (_integer(2), 21, "vertices along the pattern's u (width) direction"),
        "ny": (_integer(2), 21, "vertices along the pattern's v (height) direction"),
        "width": (_number(0, strict_minimum=True, unit="m"), 1.0, "pattern size along u"),
        "height": (_number(0, strict_minimum=True, unit="m"), 1.0, "pattern size along v"),
        "plane": (_choice("xy", "xz"), "xy",
                  "xy: upright, (u, v) -> (x, y, 0); xz: flat, (u, v) -> (u, 0, v)"),
        "gather": (_number(0, 1, strict_minimum=True), 1.0,
                   "start gathered along u to this fraction of the width (rest lengths stay "
                   "those of the flat pattern)"),
    },
    "cylinder": {
        "radius": (_number(0, strict_minimum=True, unit="m"), 0.25, "tube radius"),
        "height": (_number(0, strict_minimum=True, unit="m"), 0.5, "tube length along y"),
        "rings": (_integer(2), 13, "vertex rings"),
        "segments": (_integer(3), 32, "vertices per ring"),
    },
    "file": {
        "path": (_string, _REQUIRED, "mesh file (any meshio format), relative to the scene"),
        "scale": (_number(0, strict_minimum=True), 1.0, "factor applied to the coordinates"),
    },
}

_SELECTION = {
    "indices": (_indices, None, "vertex indices"),
    "box": ("box", None, "{min = [x, y, z], max = [x, y, z]}: vertices inside at t = 0, m"),
    "set": (_string, None, "a named set of the mesh generator (see README)"),
}

_STROKE_FORMS = ("points", "material", "screen")


def _mass_scale(value):
    if value == "conserve" and isinstance(value, str):
        return value
    try:
        return _positive_factor(value)
    except _Invalid as error:
        raise _Invalid(error.problem, _mass_scale.expected) from None


_positive_factor = _number(0, strict_minimum=True)
_mass_scale.expected = "a number > 0 or 'conserve'"
_SCHEMA_GENERATOR_EXPECTED = "one of " + ", ".join(repr(g) for g in _GENERATOR_KEYS)

SCHEMA = {
    "scene": ({
        "name": (_string, None, "a title"),
        "description": (_string, None, "free text"),
    }, "table"),
    "mesh": ({
        "generator": (_choice(*_GENERATOR_KEYS), _REQUIRED, "grid, cylinder or file"),
    }, "table"),
    "material": ({
        "mass": (_number(0, strict_minimum=True, unit="kg"), None,
                 "total mass, spread uniformly over the vertices (the paper's choice)"),
        "mass_per_vertex": (_number(0, strict_minimum=True, unit="kg"), None, "per vertex"),
        "density": (_number(0, strict_minimum=True, unit="kg/m²"), None,
                    "areal density, lumped to the vertices by area"),
        "stretch_stiffness": (_number(0, strict_minimum=True, unit="N/m"), 200.0,
                              "structural springs"),
        "bend_stiffness": (_number(0, unit="N/m"), None,
                           "bending springs (default 200; 0: none; not with quadratic bending)"),
        "bending": (_choice("springs", "quadratic"), "springs",
                    "bending model: the paper's springs or Bergou et al. 2006's quadratic energy"),
        "bending_modulus": (_number(0, unit="N·m"), None,
                            "quadratic bending's modulus (required with bending = quadratic)"),
        "damping": (_number(0, unit="N·s/m"), 0.02, "along each spring"),
        "drag": (_number(0, unit="1/s"), 0.3, "still air"),
    }, "table"),
    "fixed": (dict(_SELECTION), "array"),
    "driven": ({
        **_SELECTION,
        "motion": (_choice("rotation"), "rotation", "the kind of prescribed motion"),
        "center": (_vector3, _REQUIRED, "a point on the rotation axis, m"),
        "axis": (_vector3, _REQUIRED, "axis direction"),
        "omega": (_number(unit="rad/s"), _REQUIRED, "angular speed, right-handed about axis"),
    }, "array"),
    "simulation": ({
        "integrator": (_choice(*INTEGRATORS), "explicit", "the time integrator"),
        "dt": (_number(0, strict_minimum=True, unit="s"), None,
               "time step; default: below the stable step (explicit) or 1/60 s"),
        "duration": (_number(0, strict_minimum=True, unit="s"), _REQUIRED, "simulated time"),
        "gravity": (_vector3, None, "m/s², default [0, -9.81, 0]"),
        "settle": (_number(0, unit="s"), 0.0, "at most this much pseudo-time of relaxation "
                   "to a static equilibrium before t = 0 (Simulation.settle; no driven "
                   "vertices); 0: start as built"),
        "threads": (_integer(1), None, "threads of the core's loops and of BLAS "
                    "(yore.set_num_threads); default: the machine's cores"),
    }, "table"),
    "integrator": (None, "table"),  # options of the chosen integrator, checked separately
    "strokes": ({
        "time": (_number(0, unit="s"), _REQUIRED, "when the stroke is drawn"),
        "points": (_points(3, "[x, y, z] (m)"), None, "3-D polyline near the surface"),
        "material": (_points(2, "[u, v] (m)"), None, "polyline in rest-pattern coordinates"),
        "screen": (_points(2, "[x, y] pixel"), None, "polyline in pixels of [camera]"),
        "expansion": (_number(0, strict_minimum=True), 1.1, "rest length / current length of "
                      "new springs (eq. (1))"),
        "mass_scale": (_mass_scale, 0.95, "new vertex mass / corners' mean, or 'conserve' "
                       "(taken from the corners; total mass unchanged)"),
        "width": (_number(0, strict_minimum=True, unit="m"), None,
                  "band around the stroke with a smooth falloff (default: the crossed faces)"),
        "growth": (_choice(*GROWTH_MODES), "paper",
                   "paper (eq. (1) on new springs), isotropic, along or across the stroke"),
        "refine": (_integer(0, MAX_REFINE), 0, "1→4 refinement passes of the band first"),
        "max_distance": (_number(0, strict_minimum=True, unit="m"), None,
                         "points only: farthest a point may be from the surface"),
        "smooth": ("smooth", None, "{iterations, strength, region}: rest-length smoothing "
                   "right after the stroke"),
    }, "array"),
    "camera": ({
        "eye": (_vector3, None, "m; default: fitted to the cloth at t = 0"),
        "target": (_vector3, None, "m; default: the cloth's centre at t = 0"),
        "up": (_vector3, [0.0, 1.0, 0.0], "up direction"),
        "fov_degrees": (_number(0, 180, strict_minimum=True), 35.0, "vertical field of view"),
        "width": (_integer(16, MAX_IMAGE_SIDE), 800, "image width, pixels"),
        "height": (_integer(16, MAX_IMAGE_SIDE), 600, "image height, pixels"),
    }, "table"),
    "output": ({
        "format": (_choice("vtu", "vtk", "ply", "obj", "none"), "vtu", "frame file format"),
        "fps": (_number(0, strict_minimum=True), None,
                "frames per simulated second (default 30 unless every_steps is given)"),
        "every_steps": (_integer(1), None, "a frame every this many steps"),
        "pictures": (_boolean, True, "before/after PNG (before = just before the first stroke)"),
        "animation": (_choice("none", "gif", "mp4"), "none", "an animation of the frames"),
        "color_by": (_choice("none", "expansion"), "none",
                     "colour pictures by rest-length expansion"),
    }, "table"),
}

_SMOOTH = {
    "iterations": (_integer(0, MAX_SMOOTHING_ITERATIONS), 10, "smoothing iterations"),
    "strength": (_number(0, 1, strict_minimum=True), 0.5, "fraction moved per iteration"),
    "region": (_choice("stroke", "all"), "stroke", "the stroke's region and one ring, or all"),
    "conserve": (_boolean, True, "keep the region's added rest length (redistribute only)"),
}
_BOX = {
    "min": (_vector3, _REQUIRED, "lower corner, m"),
    "max": (_vector3, _REQUIRED, "upper corner, m"),
}


# -- the scene ------------------------------------------------------------------------------------
@dataclass
class Scene:
    """A checked scene: ``data`` holds every table with defaults filled in (numpy arrays for
    points and vectors), ``text`` the file's text, ``path`` where it came from (None for a
    string), ``overrides`` the dotted keys set from outside the file."""

    data: dict
    text: str
    path: Path | None = None
    overrides: dict = field(default_factory=dict)
    override_keys: set = field(default_factory=set)  # the same keys as errors name them

    @property
    def source(self) -> str:
        return str(self.path) if self.path is not None else "<scene>"

    @property
    def base_dir(self) -> Path:
        return self.path.parent if self.path is not None else Path.cwd()

    def error(self, key, problem, expected=None) -> SceneError:
        """A SceneError for ``key`` (dotted, with [k] for array entries) at its line."""
        overridden = key in self.override_keys
        line = None if overridden else _find_line(self.text, key)
        source = self.source + (" (set on the command line)" if overridden else "")
        return SceneError(source, key, problem, expected, line)

    def build(self) -> tuple[Simulation, dict]:
        """The simulation the scene describes at t = 0, and the named vertex sets of its mesh.

        Raises SceneError for anything the static checks could not see: vertex indices out
        of range, a selection that selects nothing, a vertex both fixed and driven, integrator
        options the integrator rejects, a mesh file that cannot be read."""
        return _build(self)

    def check_strokes(self, sim=None) -> None:
        """Tries the strokes that can be tried before the run on a copy of the cloth (of
        ``sim``, a simulation this scene built, or of a new one): material strokes at any time,
        3-D and screen strokes at time 0 (later ones depend on the motion, which only the run
        knows). Raises SceneError naming the stroke that misses."""
        if sim is None:
            sim, _ = self.build()
        probe = Simulation(Cloth.from_state(sim.cloth.state()), integrator="explicit",
                           dt=sim.dt, gravity=sim.gravity)
        for index, stroke in sorted(enumerate(self.data["strokes"]), key=lambda s: s[1]["time"]):
            if "material" in stroke or stroke["time"] == 0.0:
                apply_scene_stroke(self, probe, index)

    def frame_interval(self, dt: float) -> int:
        """Steps between frames."""
        output = self.data["output"]
        if output.get("every_steps") is not None:
            return int(output["every_steps"])
        return max(1, round(1.0 / (output["fps"] * dt)))


def load_scene(path=None, text=None, overrides=None) -> Scene:
    """Reads and checks a scene file (or ``text``); ``overrides`` maps dotted keys (e.g.
    ``"mesh.nx"``, ``"strokes.0.time"``) to values that replace the file's. Raises SceneError
    (a ValueError) naming the first problem, its key, line and what was expected."""
    if text is None:
        if path is None:
            raise ValueError("give a scene file path or its text")
        path = Path(os.fspath(path))
        text = _read_scene_text(path)
    elif path is not None:
        path = Path(os.fspath(path))
    source = str(path) if path is not None else "<scene>"
    if not isinstance(text, str):
        raise ValueError(f"scene text must be a str, got {type(text).__name__}")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        match = re.search(r"line (\d+)", str(error))
        raise SceneError(source, None, f"not valid TOML: {' '.join(str(error).split())}",
                         line=int(match.group(1)) if match else None) from None
    except RecursionError:
        raise SceneError(source, None, "not readable TOML: arrays or tables are nested too "
                         "deeply", "a scene file (no key takes values nested more than 2 "
                         "levels deep)") from None
    scene = Scene(data={}, text=text, path=path)
    for dotted, value in (overrides or {}).items():
        _apply_override(scene, raw, dotted, value)
    scene.data = _check(scene, raw)
    return scene


def _read_scene_text(path):
    """The text of scene file ``path``; SceneError if it is not a regular file (a FIFO would
    block), is larger than MAX_SCENE_FILE_BYTES or is not UTF-8."""
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise SceneError(path, None, "cannot read the scene file: not a regular file")
        if info.st_size > MAX_SCENE_FILE_BYTES:
            raise SceneError(path, None, f"cannot read the scene file: {info.st_size} bytes "
                             f"is more than the limit of {MAX_SCENE_FILE_BYTES} bytes")
        return path.read_text(encoding="utf-8")
    except OSError as error:
        raise SceneError(path, None, f"cannot read the scene file ({error.strerror})") \
            from None
    except UnicodeDecodeError as error:
        raise SceneError(path, None, f"cannot read the scene file: not UTF-8 text (byte "
                         f"{error.start})") from None


def parse_override(text: str):
    """``KEY=VALUE`` from the command line: VALUE is read as TOML (numbers, booleans, lists,
    quoted strings); anything that is not TOML is taken as a plain string."""
    if "=" not in text:
        raise ValueError(f"--set needs KEY=VALUE, got {text!r}")
    key, value = text.split("=", 1)
    key = key.strip()
    try:
        parsed = tomllib.loads(f"value = {value.strip()}")["value"]
    except tomllib.TOMLDecodeError:
        parsed = value.strip()
    except RecursionError:
        raise SceneError("--set", key, "the value is nested too deeply",
                         "a number, boolean, string or a list of them") from None
    return key, parsed


# -- checking -------------------------------------------------------------------------------------
def _apply_override(scene, raw, dotted, value):
    parts = [int(p) if p.isdigit() else p for p in dotted.split(".")]
    if not parts or any(p == "" for p in parts):
        raise SceneError("--set", dotted, "not a dotted key", "e.g. mesh.nx or strokes.0.time")
    node = raw
    for depth, part in enumerate(parts[:-1]):
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                raise SceneError("--set", dotted, f"there is no entry {part} to change")
            node = node[part]
        else:
            if not isinstance(node, dict):
                raise SceneError("--set", dotted, f"{'.'.join(map(str, parts[:depth]))} is "
                                 "not a table")
            node = node.setdefault(part, {})
    last = parts[-1]
    if isinstance(last, int) or not isinstance(node, dict):
        raise SceneError("--set", dotted, "can only set a key of a table")
    node[last] = value
    scene.overrides[dotted] = value
    scene.override_keys.add(_dotted(parts))


def _dotted(parts):
    text = ""
    for part in parts:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else part)
    return text


def _check(scene, raw):
    unknown = [key for key in raw if key not in SCHEMA]
    if unknown:
        key = unknown[0]
        raise scene.error(key, f"unknown table or key{_did_you_mean(key, SCHEMA)}",
                          "one of the tables " + ", ".join(f"[{k}]" for k in SCHEMA))
    data = {}
    for name, (keys, kind) in SCHEMA.items():
        value = raw.get(name)
        if name == "integrator":
            continue
        if kind == "array":
            if value is None:
                value = []
            if not isinstance(value, list) or any(not isinstance(v, dict) for v in value):
                raise scene.error(name, f"got {_describe(value)}",
                                  f"[[{name}]] tables (an array of tables)")
            data[name] = [_check_table(scene, f"{name}[{k}]", entry, keys)
                          for k, entry in enumerate(value)]
        else:
            if value is None:
                if name in ("mesh", "simulation"):
                    raise scene.error(name, "missing", f"a [{name}] table")
                value = {}
            if not isinstance(value, dict):
                raise scene.error(name, f"got {_describe(value)}", f"a [{name}] table")
            if name == "mesh":
                generator = value.get("generator")
                if generator is None:
                    raise scene.error("mesh.generator", "missing",
                                      _SCHEMA_GENERATOR_EXPECTED)
                keys = dict(keys)
                if isinstance(generator, str) and generator in _GENERATOR_KEYS:
                    keys.update(_GENERATOR_KEYS[generator])
            data[name] = _check_table(scene, name, value, keys)
            if name == "mesh":
                _check_mesh_size(scene, data[name])
            if name == "camera":
                _check_camera_size(scene, data[name])
    material = data["material"]
    given = [k for k in ("mass", "mass_per_vertex", "density") if k in material]
    if len(given) > 1:
        raise scene.error(f"material.{given[1]}", f"given together with material.{given[0]}",
                          "one of mass (total), mass_per_vertex or density")
    if not given:
        material["mass"] = 0.1
    if material["bending"] == "quadratic":
        if "bending_modulus" not in material:
            raise scene.error("material.bending_modulus", "missing with bending = \"quadratic\"",
                              "a number >= 0 (N·m)")
        if material.get("bend_stiffness", 0.0) != 0.0:
            raise scene.error("material.bend_stiffness", "given with bending = \"quadratic\", "
                              "which creates no bending springs", "no bend_stiffness (or 0)")
        material.pop("bend_stiffness", None)
    else:
        if "bending_modulus" in material:
            raise scene.error("material.bending_modulus", "given with bending = \"springs\"",
                              "bending = \"quadratic\", or bend_stiffness for the springs")
        material.setdefault("bend_stiffness", 200.0)
    for k, entry in enumerate(data["fixed"]):
        _check_selection(scene, f"fixed[{k}]", entry)
    for k, entry in enumerate(data["driven"]):
        _check_selection(scene, f"driven[{k}]", entry)
    for k, stroke in enumerate(data["strokes"]):
        forms = [f for f in _STROKE_FORMS if f in stroke]
        if len(forms) != 1:
            raise scene.error(f"strokes[{k}]", f"gives {len(forms)} of points, material, screen",
                              "exactly one of them")
        if "max_distance" in stroke and forms[0] != "points":
            raise scene.error(f"strokes[{k}].max_distance", f"given for a {forms[0]} stroke",
                              "max_distance only with points")
        if stroke["time"] >= data["simulation"]["duration"]:
            raise scene.error(f"strokes[{k}].time", f"{stroke['time']:g} s is not before the "
                              f"end of the run ({data['simulation']['duration']:g} s)",
                              "a time before simulation.duration")
    output = data["output"]
    if output.get("fps") is not None and output.get("every_steps") is not None:
        raise scene.error("output.every_steps", "given together with output.fps",
                          "one of fps or every_steps")
    if output.get("every_steps") is None and output.get("fps") is None:
        output["fps"] = 30.0
    if output["animation"] != "none" and output["format"] == "none":
        raise scene.error("output.animation", "an animation needs frames, but output.format "
                          "is 'none'", "format = 'vtu', 'vtk', 'ply' or 'obj'")
    if data["simulation"]["settle"] > 0.0 and data["driven"]:
        raise scene.error("simulation.settle", "given for a scene with [[driven]] vertices, "
                          "which keep moving and have no rest to settle to", "settle = 0")
    data["integrator"] = _check_integrator(scene, raw.get("integrator", {}),
                                           data["simulation"]["integrator"])
    return data


def _check_mesh_size(scene, mesh):
    """The generated mesh's vertex count, estimated before anything is built."""
    sizes = {"grid": ("nx", "ny"), "cylinder": ("rings", "segments")}.get(mesh["generator"])
    if sizes is None:
        return
    count = mesh[sizes[0]] * mesh[sizes[1]]
    if count > MAX_MESH_VERTICES:
        key = sizes[0] if mesh[sizes[0]] >= mesh[sizes[1]] else sizes[1]
        raise scene.error(f"mesh.{key}", f"{sizes[0]} × {sizes[1]} = {mesh[sizes[0]]} × "
                          f"{mesh[sizes[1]]} = {count} vertices",
                          f"at most {MAX_MESH_VERTICES} vertices")


def _check_camera_size(scene, camera):
    pixels = camera["width"] * camera["height"]
    if pixels > MAX_IMAGE_PIXELS:
        key = "width" if camera["width"] >= camera["height"] else "height"
        raise scene.error(f"camera.{key}", f"{camera['width']} × {camera['height']} = "
                          f"{pixels} pixels", f"at most {MAX_IMAGE_PIXELS} pixels in all")


def _check_table(scene, where, table, keys):
    checked = {}
    for key, value in table.items():
        if key not in keys:
            raise scene.error(f"{where}.{key}", f"unknown key{_did_you_mean(key, keys)}",
                              "one of " + ", ".join(keys))
        checker = keys[key][0]
        if checker == "box":
            checked[key] = _check_table(scene, f"{where}.{key}", _as_table(scene, where, key,
                                                                             value), _BOX)
            continue
        if checker == "smooth":
            checked[key] = _check_table(scene, f"{where}.{key}", _as_table(scene, where, key,
                                                                             value), _SMOOTH)
            continue
        try:
            checked[key] = checker(value)
        except _Invalid as invalid:
            raise scene.error(f"{where}.{key}", invalid.problem, invalid.expected) from None
    for key, (checker, default, _) in keys.items():
        if key in checked:
            continue
        if default is _REQUIRED:
            expected = getattr(checker, "expected", "a value")
            raise scene.error(f"{where}.{key}", "missing", expected)
        if default is not None and checker not in ("box", "smooth"):
            checked[key] = checker(default) if isinstance(default, list) else default
    return checked


def _as_table(scene, where, key, value):
    if not isinstance(value, dict):
        raise scene.error(f"{where}.{key}", f"got {_describe(value)}", "an inline table {...}")
    return value


def _check_selection(scene, where, entry):
    given = [k for k in _SELECTION if k in entry]
    if len(given) != 1:
        raise scene.error(where, f"selects vertices by {len(given)} of indices, box, set",
                          "exactly one of them")


def _check_integrator(scene, options, integrator):
    if not isinstance(options, dict):
        raise scene.error("integrator", f"got {_describe(options)}", "an [integrator] table")
    table = _OPTIONS.get(integrator, {})
    checked = {}
    for key, value in options.items():
        if key not in table:
            raise scene.error(f"integrator.{key}",
                              f"unknown option of the {integrator!r} integrator"
                              f"{_did_you_mean(key, table)}",
                              "one of " + (", ".join(sorted(table)) or "no options"))
        try:
            checked[key] = check_option(integrator, key, value)
        except OptionError as invalid:
            raise scene.error(f"integrator.{key}", f"got {invalid.got}",
                              invalid.expected) from None
    return checked


def _did_you_mean(key, candidates):
    close = difflib.get_close_matches(str(key), [str(c) for c in candidates], n=2, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


def _find_line(text, key):
    """Line (1-based) of a dotted key such as ``strokes[1].time`` or ``mesh.nx`` in TOML text:
    the key's own line if it is found in its table, else the table's header line."""
    parts = re.findall(r"[^.\[\]]+|\[\d+\]", key)
    if not parts:
        return None
    table, index, rest = parts[0], 0, parts[1:]
    if rest and rest[0].startswith("["):
        index, rest = int(rest[0][1:-1]), rest[1:]
    name = rest[0] if rest else None
    header = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?")
    assignment = re.compile(r"^\s*\"?([A-Za-z0-9_\-]+)\"?\s*=")
    current, seen, header_line = None, -1, None
    for number, line in enumerate(text.splitlines(), start=1):
        match = header.match(line)
        if match:
            current = match.group(1).strip()
            if current == table:
                seen += 1
                if seen == index:
                    header_line = number
                    if name is None:
                        return number
            continue
        found = assignment.match(line)
        if not found:
            continue
        if current is None and found.group(1) == table:
            return number  # a top-level key, or an inline table
        if current == table and seen == index and found.group(1) == name:
            return number
    return header_line


# -- building -------------------------------------------------------------------------------------
def _build(scene):
    data = scene.data
    mesh = data["mesh"]
    generator = mesh["generator"]
    uv = None
    if generator == "grid":
        V, F = grid_mesh(mesh["nx"], mesh["ny"], width=mesh["width"], height=mesh["height"])
        uv = V[:, :2].copy()
        pattern = V if mesh["plane"] == "xy" else np.column_stack(
            [uv[:, 0], np.zeros(len(uv)), uv[:, 1]])
        sets = _grid_sets(mesh["nx"], mesh["ny"])
    elif generator == "cylinder":
        pattern, F = cylinder_mesh(mesh["radius"], mesh["height"], mesh["rings"],
                                   mesh["segments"])
        sets = {"bottom rim": cylinder_ring(mesh["rings"], mesh["segments"], 0),
                "top rim": cylinder_ring(mesh["rings"], mesh["segments"], -1)}
    else:
        path = Path(mesh["path"])
        if not path.is_absolute():
            path = scene.base_dir / path
        try:
            pattern, F = load_mesh(path)
        except (ValueError, OSError) as error:
            raise scene.error("mesh.path", str(error), "a readable triangle mesh file") from None
        pattern = pattern * mesh["scale"]
        sets = {}
    sets["all"] = np.arange(len(pattern), dtype=np.int32)

    material = data["material"]
    n = len(pattern)
    if "density" in material:
        mass_arguments = {"density": material["density"]}
    elif "mass_per_vertex" in material:
        mass_arguments = {"mass": material["mass_per_vertex"]}
    else:
        mass_arguments = {"mass": material["mass"] / n}
    try:
        bending_arguments = (
            {"bending": "quadratic", "bending_modulus": material["bending_modulus"]}
            if material["bending"] == "quadratic"
            else {"bend_stiffness": material["bend_stiffness"]})
        cloth = Cloth(pattern, F, stretch_stiffness=material["stretch_stiffness"],
                      damping=material["damping"], drag=material["drag"], **mass_arguments,
                      **bending_arguments)
    except ValueError as error:
        # The core checks the mesh and the per-vertex masses; name the table the value came from.
        if "mass" in str(error):
            raise scene.error("material", str(error), "masses that are normal numbers > 0 per "
                              "vertex") from None
        raise scene.error("mesh", str(error), "a valid triangle mesh") from None
    if generator == "grid" and mesh["gather"] != 1.0:
        gathered = pattern.copy()
        middle = 0.5 * mesh["width"]
        gathered[:, 0] = middle + mesh["gather"] * (pattern[:, 0] - middle)
        cloth.positions = gathered
    if uv is not None:
        cloth.material_coordinates = uv

    positions = cloth.positions
    for k, entry in enumerate(data["fixed"]):
        vertices = _select(scene, f"fixed[{k}]", entry, sets, positions)
        try:
            cloth.fix(vertices)
        except ValueError as error:
            raise scene.error(f"fixed[{k}]", str(error)) from None
    for k, entry in enumerate(data["driven"]):
        vertices = _select(scene, f"driven[{k}]", entry, sets, positions)
        try:
            cloth.drive_rotation(vertices, center=entry["center"], axis=entry["axis"],
                                 omega=entry["omega"])
        except ValueError as error:
            raise scene.error(f"driven[{k}]", str(error)) from None

    simulation = data["simulation"]
    gravity = simulation.get("gravity")
    try:
        sim = Simulation(cloth, integrator=simulation["integrator"], dt=simulation.get("dt"),
                         gravity=(0.0, -9.81, 0.0) if gravity is None else gravity,
                         **data["integrator"])
    except ValueError as error:
        raise scene.error("integrator", str(error)) from None
    # A run schedules strokes and frames in steps of one dt: it keeps its dt after strokes (an
    # explicit scene that refines gives its [simulation] dt, else the run stops with advice).
    sim._dt_follows_cloth = False
    sim.scene = {"name": data["scene"].get("name", scene.source), "sets": sets, "uv": uv}
    return sim, sets


def _grid_sets(nx, ny):
    index = np.arange(nx * ny, dtype=np.int32).reshape(ny, nx)  # [j, i] = j*nx + i
    sets = {"bottom edge": index[0, :], "top edge": index[-1, :], "left edge": index[:, 0],
            "right edge": index[:, -1]}
    for name in ("bottom", "top", "left", "right"):
        edge = sets[f"{name} edge"]
        sets[f"{name} corners"] = np.array([edge[0], edge[-1]], dtype=np.int32)
    sets["corners"] = np.array(sorted({index[0, 0], index[0, -1], index[-1, 0], index[-1, -1]}),
                               dtype=np.int32)
    return sets


def _select(scene, where, entry, sets, positions):
    if "indices" in entry:
        vertices = entry["indices"]
        bad = vertices[vertices >= len(positions)]
        if bad.size:
            raise scene.error(f"{where}.indices", f"vertex {int(bad[0])} is out of range",
                              f"indices in [0, {len(positions)})")
        return vertices
    if "set" in entry:
        name = entry["set"]
        if name not in sets:
            raise scene.error(f"{where}.set", f"unknown set {name!r}{_did_you_mean(name, sets)}",
                              "one of " + ", ".join(repr(s) for s in sets))
        return sets[name]
    box = entry["box"]
    inside = np.all((positions >= box["min"]) & (positions <= box["max"]), axis=1)
    if not inside.any():
        raise scene.error(f"{where}.box", "selects no vertex",
                          "a box that contains vertices of the cloth at t = 0")
    return np.flatnonzero(inside).astype(np.int32)


# -- strokes --------------------------------------------------------------------------------------
def scene_camera(scene, positions) -> Camera:
    """The scene's [camera]: as given, with eye/target fitted to ``positions`` when absent."""
    from ..render_run import camera_from_settings

    try:
        return camera_from_settings(scene.data["camera"], positions)
    except ValueError as error:
        raise scene.error("camera", str(error)) from None


def apply_scene_stroke(scene, sim, index, camera=None):
    """Draws stroke ``index`` of the scene on ``sim`` now (and smooths if asked); returns the
    report. A stroke that misses raises SceneError naming it."""
    stroke = scene.data["strokes"][index]
    where = f"strokes[{index}]"
    options = {"expansion": stroke["expansion"], "mass_scale": stroke["mass_scale"],
               "width": stroke.get("width"), "growth": stroke["growth"],
               "refine": stroke["refine"]}
    try:
        if "material" in stroke:
            report = sim.stroke_material(stroke["material"], **options)
        elif "points" in stroke:
            report = sim.stroke(stroke["points"], max_distance=stroke.get("max_distance"),
                                **options)
        else:
            if "eye" not in scene.data["camera"]:
                raise scene.error(f"{where}.screen", "a screen stroke needs a camera",
                                  "a [camera] table with eye and target")
            camera = camera or scene_camera(scene, sim.cloth.positions)
            report = sim.stroke_screen(stroke["screen"], camera, **options)
    except StrokeMissed as error:
        form = next(f for f in _STROKE_FORMS if f in stroke)
        raise scene.error(f"{where}.{form}", f"the stroke misses the cloth at t = "
                          f"{sim.time:.4g} s ({error})", "a polyline over the cloth") from None
    smooth = stroke.get("smooth")
    if smooth is not None:
        sim.smooth_rest_lengths(iterations=smooth["iterations"], strength=smooth["strength"],
                                region="all" if smooth["region"] == "all" else None,
                                conserve=smooth["conserve"])
    return report
