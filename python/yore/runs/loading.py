"""Loading a scene file: `load_scene` reads the text, applies ``--set`` overrides
(`parse_override`) and checks every key against `yore.runs.schema.SCHEMA`, giving a `Scene`.

Every key is checked when the file is loaded: an unknown key (with a "did you mean"), a wrong
type, a value out of range, a missing required key, vertex indices out of range, a selection
that selects nothing and a stroke that misses the cloth (material strokes at any time, 3-D and
screen strokes at time 0 — later ones depend on the motion) raise `SceneError`, which names the
key, its line in the file and what was expected. The limits are those of `yore.runs.schema`.
"""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - older Pythons use the backport
    import tomli as tomllib

from .._core import Cloth
from ..meshes import MAX_MESH_VERTICES
from ..options import (
    FRAMES_PER_SECOND,
    INTEGRATOR_OPTIONS,
    MASS,
    POISSON_RATIO,
    REFERENCE_INTEGRATOR,
    STIFFNESS,
    OptionError,
    check_option,
)
from ..simulation import Simulation
from ..checks import MAX_IMAGE_PIXELS
from .building import build_simulation, apply_scene_stroke
from .scene_tables import TABLES, BoxTable, SceneData, SmoothTable
from .schema import (
    BOX,
    GENERATOR_KEYS,
    REQUIRED,
    SCHEMA_GENERATOR_EXPECTED,
    SELECTION,
    SMOOTH,
    STROKE_FORMS,
    MAX_SCENE_FILE_BYTES,
    SCHEMA,
    SceneError,
    describe_value,
    did_you_mean,
    Invalid,
)

__all__ = ["Scene", "load_scene", "parse_override"]


# -- the scene ------------------------------------------------------------------------------------
def step_of(seconds, dt):
    """The step (from 0) a time falls on at step dt: the nearest, as the run counts them.
    ValueError for a time that no step count reaches (|seconds / dt| over 2^62)."""
    ratio = seconds / dt
    if not abs(ratio) <= 2.0**62:  # (also NaN)
        raise ValueError(
            f"t = {seconds:g} s is {ratio:g} steps of dt = {dt:g} s, more than a "
            "run can count (2^62)"
        )
    return int(round(ratio))


@dataclass
class Scene:
    """A checked scene: ``data`` holds every table with defaults filled in (a `SceneData`
    tree, read by attribute; numpy arrays for points and vectors), ``text`` the file's text, ``path`` where it came from (None for a
    string), ``overrides`` the dotted keys set from outside the file."""

    data: SceneData
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
        return build_simulation(self)

    def check_strokes(self, sim=None) -> None:
        """Tries the strokes that can be tried before the run on a copy of the cloth (of
        ``sim``, a simulation this scene built, or of a new one): material strokes at any time,
        3-D and screen strokes at time 0 (later ones depend on the motion, which only the run
        knows). Raises SceneError naming the stroke that misses."""
        if sim is None:
            sim, _ = self.build()
        # A stroke is drawn before the step it rounds to; one that rounds to the run's last step
        # (or past it) would never be drawn.
        duration = self.data.simulation.duration
        last = step_of(duration, sim.dt)
        for index, stroke in enumerate(self.data.strokes):
            at = step_of(stroke.time, sim.dt)
            if at >= last:
                raise self.error(
                    f"strokes[{index}].time",
                    f"{stroke.time:g} s rounds to step {at} of dt = {sim.dt:.6g} s, the run's "
                    f"last step ({last}, t = {duration:g} s), after which nothing is drawn",
                    f"a time at most {(last - 1) * sim.dt:.6g} s (the duration less one step)",
                )
        probe = Simulation(
            Cloth.from_state(sim.cloth.state()),
            integrator=REFERENCE_INTEGRATOR,
            dt=sim.dt,
            gravity=sim.gravity,
        )
        for index, stroke in sorted(enumerate(self.data.strokes), key=lambda s: s[1].time):
            if stroke.material is not None or stroke.time == 0.0:
                apply_scene_stroke(self, probe, index)

    def frame_interval(self, dt: float) -> int:
        """Steps between frames."""
        output = self.data.output
        if output.every_steps is not None:
            return int(output.every_steps)
        per_frame = output.fps * dt  # (0 when fps is tiny: no frame but the first and last)
        if not per_frame * 2.0**62 > 1.0:
            return 2**62
        return max(1, round(1.0 / per_frame))


def load_scene(path=None, text=None, overrides=None) -> Scene:
    """Reads and checks a scene file (or ``text``); ``overrides`` maps dotted keys (e.g.
    ``"mesh.nx"``, ``"strokes.0.time"``) to values that replace the file's. Raises SceneError
    (a ValueError) naming the first problem, its key, line and what was expected."""
    if text is None:
        if path is None:
            raise ValueError("give a scene file path or its text")
        path = Path(os.fspath(path))
        text = read_scene_text(path)
    elif path is not None:
        path = Path(os.fspath(path))
    source = str(path) if path is not None else "<scene>"
    if not isinstance(text, str):
        raise ValueError(f"scene text must be a str, got {type(text).__name__}")
    try:
        # (a byte-order mark, as some editors write one, is not part of the TOML)
        raw = tomllib.loads(text.removeprefix("\ufeff"))
    except tomllib.TOMLDecodeError as error:
        match = re.search(r"line (\d+)", str(error))
        raise SceneError(
            source,
            None,
            f"not valid TOML: {' '.join(str(error).split())}",
            line=int(match.group(1)) if match else None,
        ) from None
    except RecursionError:
        raise SceneError(
            source,
            None,
            "not readable TOML: arrays or tables are nested too deeply",
            "a scene file (no key takes values nested more than 2 levels deep)",
        ) from None
    scene = Scene(data=SceneData(), text=text, path=path)
    for dotted, value in (overrides or {}).items():
        _apply_override(scene, raw, dotted, value)
    scene.data = _check(scene, raw)
    return scene


def read_scene_text(path):
    """The text of scene file ``path``; SceneError if it is not a regular file (a FIFO would
    block), is larger than MAX_SCENE_FILE_BYTES or is not UTF-8."""
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise SceneError(path, None, "cannot read the scene file: not a regular file")
        if info.st_size > MAX_SCENE_FILE_BYTES:
            raise SceneError(
                path,
                None,
                f"cannot read the scene file: {info.st_size} bytes "
                f"is more than the limit of {MAX_SCENE_FILE_BYTES} bytes",
            )
        return path.read_text(encoding="utf-8")
    except OSError as error:
        raise SceneError(path, None, f"cannot read the scene file ({error.strerror})") from None
    except UnicodeDecodeError as error:
        raise SceneError(
            path, None, f"cannot read the scene file: not UTF-8 text (byte {error.start})"
        ) from None


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
        raise SceneError(
            "--set",
            key,
            "the value is nested too deeply",
            "a number, boolean, string or a list of them",
        ) from None
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
                raise SceneError(
                    "--set", dotted, f"{'.'.join(map(str, parts[:depth]))} is not a table"
                )
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
    data = _check_tables(scene, raw)
    _check_material(scene, data.material, raw)
    _check_vertices_and_strokes(scene, data)
    _check_output(scene, data)
    data.integrator = _check_integrator(
        scene, raw.get("integrator", {}), data.simulation.integrator
    )
    return data


def _check_tables(scene, raw):
    """Every table of the schema, checked key by key (the [integrator] table aside)."""
    unknown = [key for key in raw if key not in SCHEMA]
    if unknown:
        key = unknown[0]
        raise scene.error(
            key,
            f"unknown table or key{did_you_mean(key, SCHEMA)}",
            "one of the tables " + ", ".join(f"[{k}]" for k in SCHEMA),
        )
    data = SceneData()
    for name, (keys, kind) in SCHEMA.items():
        value = raw.get(name)
        if name == "integrator":
            continue
        if kind == "array":
            if value is None:
                value = []
            if not isinstance(value, list) or any(not isinstance(v, dict) for v in value):
                raise scene.error(
                    name, f"got {describe_value(value)}", f"[[{name}]] tables (an array of tables)"
                )
            setattr(
                data,
                name,
                [
                    _check_table(scene, f"{name}[{k}]", entry, keys, TABLES[name])
                    for k, entry in enumerate(value)
                ],
            )
        else:
            if value is None:
                if name in ("mesh", "simulation"):
                    raise scene.error(name, "missing", f"a [{name}] table")
                value = {}
            if not isinstance(value, dict):
                raise scene.error(name, f"got {describe_value(value)}", f"a [{name}] table")
            if name == "mesh":
                generator = value.get("generator")
                if generator is None:
                    raise scene.error("mesh.generator", "missing", SCHEMA_GENERATOR_EXPECTED)
                keys = dict(keys)
                if isinstance(generator, str) and generator in GENERATOR_KEYS:
                    keys.update(GENERATOR_KEYS[generator])
            setattr(data, name, _check_table(scene, name, value, keys, TABLES[name]))
            if name == "mesh":
                _check_mesh_size(scene, data.mesh)
            if name == "camera":
                _check_camera_size(scene, data.camera)
    return data


def _check_material(scene, material, raw):
    """One way to give the mass; bending and stretching models with their own keys."""
    given = material.given("mass", "mass_per_vertex", "density")
    if len(given) > 1:
        raise scene.error(
            f"material.{given[1]}",
            f"given together with material.{given[0]}",
            "one of mass (total), mass_per_vertex or density",
        )
    if not given:
        material.mass = MASS
    model = material.bending
    if model in ("quadratic", "hinge"):
        if material.bending_modulus is None:
            raise scene.error(
                "material.bending_modulus",
                f'missing with bending = "{model}"',
                "a number >= 0 (N·m)",
            )
        if material.bend_stiffness not in (None, 0.0):
            raise scene.error(
                "material.bend_stiffness",
                f'given with bending = "{model}", which creates no bending springs',
                "no bend_stiffness (or 0)",
            )
        material.bend_stiffness = None
    else:
        if material.bending_modulus is not None:
            raise scene.error(
                "material.bending_modulus",
                'given with bending = "springs"',
                'bending = "quadratic", or bend_stiffness for the springs',
            )
        if material.bend_stiffness is None:
            material.bend_stiffness = STIFFNESS
    _check_stretch(scene, material, raw.get("material", {}))


def _check_vertices_and_strokes(scene, data):
    """Fixed and driven selections; each stroke one form, before the run's end."""
    for k, entry in enumerate(data.fixed):
        _check_selection(scene, f"fixed[{k}]", entry)
    for k, entry in enumerate(data.driven):
        _check_selection(scene, f"driven[{k}]", entry)
    duration = data.simulation.duration
    for k, stroke in enumerate(data.strokes):
        forms = stroke.given(*STROKE_FORMS)
        if len(forms) != 1:
            raise scene.error(
                f"strokes[{k}]",
                f"gives {len(forms)} of points, material, screen",
                "exactly one of them",
            )
        if stroke.max_distance is not None and forms[0] != "points":
            raise scene.error(
                f"strokes[{k}].max_distance",
                f"given for a {forms[0]} stroke",
                "max_distance only with points",
            )
        if stroke.time >= duration:
            raise scene.error(
                f"strokes[{k}].time",
                f"{stroke.time:g} s is not before the end of the run ({duration:g} s)",
                "a time before simulation.duration",
            )


def _check_output(scene, data):
    """Frames, pictures and animations that fit together; settle without driven vertices."""
    output = data.output
    if output.fps is not None and output.every_steps is not None:
        raise scene.error(
            "output.every_steps", "given together with output.fps", "one of fps or every_steps"
        )
    if output.every_steps is None and output.fps is None:
        output.fps = FRAMES_PER_SECOND
    if output.animation != "none" and output.format == "none":
        raise scene.error(
            "output.animation",
            "an animation needs frames, but output.format is 'none'",
            "format = 'vtu', 'vtk', 'ply' or 'obj'",
        )
    if output.pictures and output.format != "none":
        _check_pictures_size(scene, data.camera)
    if data.simulation.settle > 0.0 and data.driven:
        raise scene.error(
            "simulation.settle",
            "given for a scene with [[driven]] vertices, "
            "which keep moving and have no rest to settle to",
            "settle = 0",
        )


def _check_mesh_size(scene, mesh):
    """The generated mesh's vertex count, estimated before anything is built."""
    sizes = {"grid": ("nx", "ny"), "cylinder": ("rings", "segments")}.get(mesh.generator)
    if sizes is None:
        return
    first, second = (getattr(mesh, key) for key in sizes)
    count = first * second
    if count > MAX_MESH_VERTICES:
        key = sizes[0] if first >= second else sizes[1]
        raise scene.error(
            f"mesh.{key}",
            f"{sizes[0]} × {sizes[1]} = {first} × {second} = {count} vertices",
            f"at most {MAX_MESH_VERTICES} vertices",
        )


def _check_camera_size(scene, camera):
    pixels = camera.width * camera.height
    if pixels > MAX_IMAGE_PIXELS:
        key = "width" if camera.width >= camera.height else "height"
        raise scene.error(
            f"camera.{key}",
            f"{camera.width} × {camera.height} = {pixels} pixels",
            f"at most {MAX_IMAGE_PIXELS} pixels in all",
        )


def _check_pictures_size(scene, camera):
    """The before/after picture (two camera images side by side, titled) within the image
    limit, before the run (a 4096×2048 camera failed only after it)."""
    from ..viz.images import side_by_side_shape

    height, width = side_by_side_shape([camera.width] * 2, camera.height, titled=True)
    if width * height > 2 * MAX_IMAGE_PIXELS:
        key = "width" if camera.width >= camera.height else "height"
        raise scene.error(
            f"camera.{key}",
            f"{camera.width} × {camera.height} makes the "
            f"before/after picture {width} × {height} = {width * height} pixels",
            f"at most {2 * MAX_IMAGE_PIXELS} pixels (two images of at most "
            f"{MAX_IMAGE_PIXELS} side by side), or output.pictures = false",
        )


def _check_table(scene, where, table, keys, kind):
    """``table`` (the file's dict) checked against ``keys`` (the schema's), as a ``kind``."""
    checked = kind()
    for key, value in table.items():
        if key not in keys:
            raise scene.error(
                f"{where}.{key}",
                f"unknown key{did_you_mean(key, keys)}",
                "one of " + ", ".join(keys),
            )
        checker = keys[key][0]
        if checker in ("box", "smooth"):
            subtable = {"box": (BOX, BoxTable), "smooth": (SMOOTH, SmoothTable)}[checker]
            value = _check_table(
                scene, f"{where}.{key}", _as_table(scene, where, key, value), *subtable
            )
            setattr(checked, key, value)
            continue
        try:
            setattr(checked, key, checker(value))
        except Invalid as invalid:
            raise scene.error(f"{where}.{key}", invalid.problem, invalid.expected) from None
    for key, (checker, default, _) in keys.items():
        if getattr(checked, key) is not None:
            continue
        if default is REQUIRED:
            expected = getattr(checker, "expected", "a value")
            raise scene.error(f"{where}.{key}", "missing", expected)
        if default is not None and checker not in ("box", "smooth"):
            setattr(checked, key, checker(default) if isinstance(default, list) else default)
    return checked


def _as_table(scene, where, key, value):
    if not isinstance(value, dict):
        raise scene.error(f"{where}.{key}", f"got {describe_value(value)}", "an inline table {...}")
    return value


def _check_selection(scene, where, entry):
    given = entry.given(*SELECTION)
    if len(given) != 1:
        raise scene.error(
            where, f"selects vertices by {len(given)} of indices, box, set", "exactly one of them"
        )


def _check_integrator(scene, options, integrator):
    if not isinstance(options, dict):
        raise scene.error("integrator", f"got {describe_value(options)}", "an [integrator] table")
    table = INTEGRATOR_OPTIONS.get(integrator, {})
    checked = {}
    for key, value in options.items():
        if key not in table:
            raise scene.error(
                f"integrator.{key}",
                f"unknown option of the {integrator!r} integrator{did_you_mean(key, table)}",
                "one of " + (", ".join(sorted(table)) or "no options"),
            )
        try:
            checked[key] = check_option(integrator, key, value)
        except OptionError as invalid:
            raise scene.error(f"integrator.{key}", f"got {invalid.got}", invalid.expected) from None
    return checked


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


def _check_stretch(scene, material, given):
    """stretch = "membrane" needs young_modulus and takes no stretch_stiffness; springs take
    neither young_modulus nor poisson_ratio. `material` has the defaults applied; `given` is
    the file's own table, which tells a stretch_stiffness the file gave from the default."""
    if material.stretch == "membrane":
        if material.young_modulus is None:
            raise scene.error(
                "material.young_modulus", 'missing with stretch = "membrane"', "a number > 0 (N/m)"
            )
        if "stretch_stiffness" in given:
            raise scene.error(
                "material.stretch_stiffness",
                'given with stretch = "membrane", whose structural springs carry no stiffness',
                "no stretch_stiffness",
            )
        material.stretch_stiffness = None
        if material.poisson_ratio is None:
            material.poisson_ratio = POISSON_RATIO
    else:
        extra = material.given("young_modulus", "poisson_ratio", "membrane_strain")
        if extra:
            raise scene.error(
                f"material.{extra[0]}",
                'given with stretch = "springs"',
                'stretch = "membrane", or stretch_stiffness for the springs',
            )
