"""Loading a scene file: `load_scene` reads the text, applies ``--set`` overrides
(`parse_override`) and checks every key against `yore.runs.schema.SCHEMA`, giving a `Scene`.

Every key is checked when the file is loaded: an unknown key (with a "did you mean"), a wrong
type, a value out of range, a missing required key, vertex indices out of range, a selection
that selects nothing and a stroke that misses the cloth (material strokes at any time, 3-D and
screen strokes at time 0 — later ones depend on the motion) raise `SceneError`, which names the
key, its line in the file and what was expected. The limits are those of `yore.runs.schema`;
the checks themselves are `yore.runs.scene_checks`.
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
from ..options import (
    INTEGRATOR_SPECS,
    REFERENCE_INTEGRATOR,
)
from ..simulation import Simulation
from ..simulation_checks import default_explicit_dt
from .building import build_simulation, apply_scene_stroke
from .scene_checks import checked_data
from .scene_tables import SceneData
from .schema import (
    MAX_SCENE_FILE_BYTES,
    SceneError,
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

    def build(self, dt=None) -> tuple[Simulation, dict]:
        """The simulation the scene describes at t = 0, and the named vertex sets of its mesh;
        ``dt`` replaces an explicit scene's default step (see `check_strokes`).

        Raises SceneError for anything the static checks could not see: vertex indices out
        of range, a selection that selects nothing, a vertex both fixed and driven, integrator
        options the integrator rejects, a mesh file that cannot be read."""
        return build_simulation(self, dt)

    def check_strokes(self, sim=None) -> float | None:
        """Tries the strokes that can be tried before the run on a copy of the cloth (of
        ``sim``, a simulation this scene built, or of a new one): material strokes at any time,
        3-D and screen strokes at time 0 (later ones depend on the motion, which only the run
        knows). Raises SceneError naming the stroke that misses.

        A run keeps its dt after strokes (it counts time in steps). For a scene whose step is
        the explicit default (no [simulation] dt), returns the default step of the cloth
        after those strokes when they lower it below ``sim.dt`` (a refined band's small faces
        and grown springs have a smaller stable step), else None: the run should take that
        step from the start (`yore.runs.runner.check_scene` does)."""
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
        follows = (
            self.data.simulation.dt is None
            and INTEGRATOR_SPECS[sim.integrator].conditionally_stable
        )
        lowest = sim.dt
        for index, stroke in sorted(enumerate(self.data.strokes), key=lambda s: s[1].time):
            if stroke.material is not None or stroke.time == 0.0:
                apply_scene_stroke(self, probe, index)
                if follows:
                    lowest = min(lowest, default_explicit_dt(probe.cloth))
        return lowest if lowest < sim.dt else None

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
    scene.data = checked_data(scene, raw)
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
