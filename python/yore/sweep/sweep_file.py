"""Reading a sweep file (`load_sweep`): its [sweep], [axes], [zip] and [record] tables checked
key by key, the base scene found, every swept key tried on it and, unless asked not to, every
cell's scene loaded and checked like a scene file, before anything runs. The file's format is
`yore.sweep.spec`'s docstring; what comes out is its `Sweep`."""

from __future__ import annotations

import os

try:
    import tomllib
except ImportError:  # Python < 3.11
    import tomli as tomllib
from importlib import resources
from pathlib import Path

from ..runs import SceneError, load_scene
from ..runs.loading import read_scene_text
from .spec import (
    BUILTIN_SCENES,
    MAX_CELLS,
    MAX_REPEATS,
    MAX_SWEEP_FILE_BYTES,
    Dimension,
    Sweep,
    SweepError,
    same_value,
)

__all__ = ["load_sweep"]

_TOP = {"sweep", "axes", "zip", "record"}
_SWEEP_KEYS = {"scene", "repeats", "set"}
_RECORD_KEYS = {"frames", "reference"}


def _error(source, key, problem, expected=None):
    where = f"{source}: {key}: " if key else f"{source}: "
    return SweepError(where + problem + (f"; expected {expected}" if expected else ""))


def load_sweep(path=None, text=None, check_cells=True) -> Sweep:
    """Reads and checks a sweep file (or ``text``, relative paths then from the current folder
    or ``path``'s). ``check_cells``: load every cell's scene too (the default; a resumed sweep
    was checked when it started). Raises SweepError (a ValueError) naming the problem."""
    source, path, text, raw = _read(path, text)
    scene_text, scene_path, repeats, sets = _sweep_table(source, path, raw)
    dimensions = _dimensions(source, raw, sets, repeats)
    frames, reference = _record_table(source, raw, dimensions)
    sweep = Sweep(
        text=text,
        path=path,
        scene_text=scene_text,
        scene_path=scene_path,
        sets=dict(sets),
        dimensions=dimensions,
        repeats=repeats,
        frames=frames,
        reference=dict(reference),
    )
    if sweep.cell_count > MAX_CELLS:
        raise _error(source, "axes", f"{sweep.cell_count} cells", f"at most {MAX_CELLS}")
    _try_set_and_values(sweep, source, dimensions)
    if check_cells:
        _check_cells(sweep, source)
    return sweep


def _read(path, text):
    """(source name, path, text, parsed TOML) of a sweep file or text; SweepError."""
    if text is None:
        if path is None:
            raise ValueError("give a sweep file path or its text")
        path = Path(os.fspath(path))
        if not path.is_file():
            raise SweepError(f"{path}: no such sweep file")
        if path.stat().st_size > MAX_SWEEP_FILE_BYTES:
            raise SweepError(f"{path}: larger than {MAX_SWEEP_FILE_BYTES} bytes; not a sweep file")
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as error:
            raise SweepError(f"{path}: cannot be read ({error})") from None
    elif path is not None:
        path = Path(os.fspath(path))
    source = str(path) if path is not None else "<sweep>"
    try:
        raw = tomllib.loads(text.removeprefix("\ufeff"))  # (an editor's byte-order mark)
    except tomllib.TOMLDecodeError as error:
        raise SweepError(f"{source}: not valid TOML: {' '.join(str(error).split())}") from None
    except RecursionError:
        raise SweepError(f"{source}: nested too deeply to be a sweep file") from None
    return source, path, text, raw


def _sweep_table(source, path, raw):
    """(scene text, scene path, repeats, [sweep.set]) of the [sweep] table."""
    unknown = sorted(set(raw) - _TOP)
    if unknown:
        raise _error(source, unknown[0], "unknown table", "one of " + ", ".join(sorted(_TOP)))
    sweep_table = _table(source, raw, "sweep", required=True)
    unknown = sorted(set(sweep_table) - _SWEEP_KEYS)
    if unknown:
        raise _error(
            source, f"sweep.{unknown[0]}", "unknown key", "one of " + ", ".join(sorted(_SWEEP_KEYS))
        )
    scene_text, scene_path = _scene(source, path, sweep_table.get("scene"))
    repeats = sweep_table.get("repeats", 1)
    if isinstance(repeats, bool) or not isinstance(repeats, int) or not 1 <= repeats <= MAX_REPEATS:
        raise _error(
            source, "sweep.repeats", f"got {repeats!r}", f"an integer in [1, {MAX_REPEATS}]"
        )
    sets = _table(source, sweep_table, "set", where="sweep.set")
    return scene_text, scene_path, repeats, sets


def _dimensions(source, raw, sets, repeats):
    """The dimensions of [axes], [zip] and repeats, with names results.nc can hold."""
    dimensions = []
    axes = _table(source, raw, "axes")
    for key, values in axes.items():
        _check_values(source, f"axes.{key}", values)
        dimensions.append(Dimension(key, (key,), tuple((v,) for v in values)))
    for name, members in _table(source, raw, "zip").items():
        dimensions.append(_zip_dimension(source, name, members))
    _check_distinct(source, dimensions, sets)
    # Dimension names and the keys along zips become names in results.nc: refuse now what the
    # file cannot hold, before any cell runs
    for dimension in dimensions:
        _check_dimension_names(source, dimension)
    if repeats > 1:
        dimensions.append(Dimension("repeat", ("repeat",), tuple((k,) for k in range(repeats))))
    if not dimensions:
        raise _error(source, "axes", "no axis, zip or repeat", "at least one axis to sweep")
    return dimensions


def _zip_dimension(source, name, members):
    """[zip.name]: a list of variants, or a table of keys whose lists vary together."""
    if isinstance(members, list):
        return _variants(source, name, members)
    if not isinstance(members, dict) or not members:
        raise _error(
            source,
            f"zip.{name}",
            "is not a table of keys",
            'a table like [zip.method] with "simulation.dt" = [...] lines',
        )
    lengths = set()
    for key, values in members.items():
        _check_values(source, f"zip.{name}.{key}", values)
        lengths.add(len(values))
    if len(lengths) != 1:
        raise _error(
            source,
            f"zip.{name}",
            f"its lists have lengths {sorted(lengths)}",
            "lists of one length (the keys vary together)",
        )
    return Dimension(name, tuple(members), tuple(zip(*members.values())))


def _check_distinct(source, dimensions, sets):
    """Each key swept in one place and not also set; distinct dimension names."""
    keys = [key for d in dimensions for key in d.keys]
    names = [d.name for d in dimensions]
    for duplicate in {k for k in keys if keys.count(k) > 1}:
        raise _error(
            source,
            duplicate,
            "is swept twice (in [axes] and a [zip], or two zips)",
            "each key in one place",
        )
    for duplicate in {k for k in names if names.count(k) > 1} | ({"repeat"} & set(names)):
        raise _error(source, duplicate, "names two dimensions", "distinct names")
    for key in set(sets) & set(keys):
        raise _error(source, f"sweep.set.{key}", "is also swept", "a key set or swept, not both")


def _check_dimension_names(source, dimension):
    """A dimension's name, and a zip's keys, as names results.nc can hold."""
    where = (
        f"zip.{dimension.name}"
        if dimension.name not in dimension.keys or len(dimension.keys) > 1 or dimension.labels
        else f"axes.{dimension.name}"
    )
    _check_result_name(source, where, dimension.name)
    if len(dimension.keys) > 1 and not dimension.labels:
        for key in dimension.keys:
            _check_result_name(source, f"{where}.{key}", key)


def _record_table(source, raw, dimensions):
    """(frames, reference) of the [record] table, the reference one of the swept values."""
    record = _table(source, raw, "record")
    unknown = sorted(set(record) - _RECORD_KEYS)
    if unknown:
        raise _error(
            source,
            f"record.{unknown[0]}",
            "unknown key",
            "one of " + ", ".join(sorted(_RECORD_KEYS)),
        )
    frames = record.get("frames", False)
    if not isinstance(frames, bool):
        raise _error(source, "record.frames", f"got {frames!r}", "true or false")
    reference = record.get("reference", {})
    if not isinstance(reference, dict):
        raise _error(
            source,
            "record.reference",
            f"got {reference!r}",
            'a table of swept keys and values, e.g. { "simulation.dt" = 1e-4 }',
        )
    for key, value in reference.items():
        _check_reference_value(source, dimensions, key, value)
    return frames, reference


def _swept_names(dimensions):
    """ "one of" the swept keys and the variants' names."""
    return "one of " + ", ".join(
        [k for d in dimensions if not d.labels for k in d.keys]
        + [d.name for d in dimensions if d.labels]
    )


def _check_reference_value(source, dimensions, key, value):
    """One key of [record.reference]: a variant's label, or one of a swept key's values."""
    variants = next((d for d in dimensions if d.labels and d.name == key), None)
    if variants is not None:
        if value not in variants.labels:
            raise _error(
                source,
                f"record.reference.{key}",
                f"{value!r} is not one of its labels",
                ", ".join(repr(label) for label in variants.labels),
            )
        return
    dimension = next((d for d in dimensions if key in d.keys and not d.labels), None)
    if dimension is None:
        raise _error(
            source, f"record.reference.{key}", "is not a swept key", _swept_names(dimensions)
        )
    column = dimension.keys.index(key)
    if not any(same_value(value, values[column]) for values in dimension.values):
        raise _error(
            source,
            f"record.reference.{key}",
            f"{value!r} is not one of its values",
            ", ".join(repr(v[column]) for v in dimension.values),
        )


def _try_set_and_values(sweep, source, dimensions):
    """[sweep.set] with the base scene, then every swept value alone."""
    # [sweep.set] on the base scene alone first: a conflict there is named as the set's, not
    # as the first axis value's
    try:
        load_scene(sweep.scene_path, text=sweep.scene_text, overrides=dict(sweep.sets))
    except SceneError as error:
        key = f"sweep.set.{error.key}" if error.key in sweep.sets else "sweep.set"
        raise _error(source, key, "with the base scene: " + " ".join(str(error).split())) from None
    for dimension in dimensions:
        if dimension.name == "repeat":
            continue
        for k in range(dimension.size):
            if dimension.labels:  # a variant's keys belong together: tried together
                _try_overrides(sweep, source, f"zip.{dimension.name}[{k}]", dimension.overrides(k))
                continue
            for key, value in dimension.overrides(k).items():
                _try_overrides(sweep, source, key, {key: value})


def _check_cells(sweep, source):
    """Every cell's scene, checked as its run would check it."""
    from ..runs.runner import check_scene
    from .cell import OUTPUT_OVERRIDES

    for cell in sweep.cells():
        try:
            # what a cell's run checks before it runs (the same as `yore check`): a cell
            # that would only end "failed" is refused up front
            check_scene(
                load_scene(
                    sweep.scene_path,
                    text=sweep.scene_text,
                    overrides={**cell.overrides, **OUTPUT_OVERRIDES},
                )
            )
        except (SceneError, ValueError) as error:
            raise _error(
                source,
                f"cell {cell.index} ({describe_value(sweep, cell)})",
                " ".join(str(error).split()),
            ) from None


#: Variable names results.nc always holds (a dimension or zip key may not take them).
RESERVED_RESULT_NAMES = ("status", "message", "error_rms", "error_max")


def _check_result_name(source, where, name):
    """A dimension's (or a zip key's) name must be one results.nc can hold and not one of its
    variables."""
    if not name or name in (".", "..") or "/" in name or any(ord(c) < 32 for c in name):
        raise _error(
            source,
            where,
            f"{name!r} cannot name a variable of results.nc",
            "a non-empty name without '/' or control characters, not '.' or '..'",
        )
    if name in RESERVED_RESULT_NAMES:
        raise _error(
            source,
            where,
            f"{name!r} is a variable results.nc always holds",
            "a name other than " + ", ".join(RESERVED_RESULT_NAMES),
        )


def _variants(source, name, entries) -> Dimension:
    """A dimension of override tables (see the module docstring)."""
    if not entries:
        raise _error(source, f"zip.{name}", "is an empty list", "override tables")
    labels, keys, values = [], [], []
    for k, entry in enumerate(entries):
        if not isinstance(entry, dict) or not entry:
            raise _error(
                source,
                f"zip.{name}[{k}]",
                f"got {entry!r}",
                'a table of scene keys, e.g. { "simulation.integrator" = "bdf2" }',
            )
        entry = dict(entry)
        label = entry.pop("label", None)
        if label is not None and not isinstance(label, str):
            raise _error(source, f"zip.{name}[{k}].label", f"got {label!r}", "a string")
        for key, value in entry.items():
            if isinstance(value, (dict, list)):
                raise _error(
                    source,
                    f"zip.{name}[{k}].{key}",
                    f"holds {value!r}",
                    "a number, string or boolean",
                )
        labels.append(label or ", ".join(f"{key}={value}" for key, value in entry.items()))
        keys.append(tuple(entry))
        values.append(tuple(entry.values()))
    if len(set(labels)) != len(labels):
        raise _error(source, f"zip.{name}", "two variants have one label", "distinct labels")
    every = tuple(dict.fromkeys(key for group in keys for key in group))
    return Dimension(name, every, tuple(values), labels=tuple(labels), variant_keys=tuple(keys))


def describe_value(sweep, cell) -> str:
    return ", ".join(
        f"{key} = {value!r}" for key, value in cell.overrides.items() if key not in sweep.sets
    )


def _try_overrides(sweep, source, where, overrides):
    """A swept key must be a scene key: tried alone (a variant: its keys together) on the base
    scene, so an unknown axis is named as such before the (slower) check of every cell."""
    try:
        load_scene(sweep.scene_path, text=sweep.scene_text, overrides={**sweep.sets, **overrides})
    except SceneError as error:
        shown = ", ".join(f"{key} = {value!r}" for key, value in overrides.items())
        raise _error(
            source, where, f"{shown} is not valid in the scene: " + " ".join(str(error).split())
        ) from None


def _table(source, parent, name, required=False, where=None):
    value = parent.get(name)
    if value is None:
        if required:
            raise _error(source, name, "missing", f"a [{name}] table")
        return {}
    if not isinstance(value, dict):
        raise _error(source, where or name, f"got {value!r}", "a table")
    return value


def _check_values(source, key, values):
    if not isinstance(values, list) or not values:
        raise _error(source, key, f"got {values!r}", "a non-empty list of values")
    for value in values:
        if isinstance(value, (dict, list)) and key.split(".")[1:2] != ["strokes"]:
            raise _error(source, key, f"holds {value!r}", "numbers, strings or booleans")
    if len(values) > MAX_CELLS:
        raise _error(source, key, f"{len(values)} values", f"at most {MAX_CELLS}")


def _scene(source, path, scene):
    """(text, path) of the sweep's base scene."""
    if not isinstance(scene, str) or not scene:
        raise _error(
            source,
            "sweep.scene",
            f"got {scene!r}",
            "a scene file (relative to the sweep file) or one of " + ", ".join(BUILTIN_SCENES),
        )
    if scene in BUILTIN_SCENES:
        text = resources.files("yore").joinpath(BUILTIN_SCENES[scene]).read_text("utf-8")
        return text, None
    base = path.parent if path is not None else Path(".")
    # absolute, not resolved: a symlink loop is then a file that cannot be read, not a crash
    scene_path = Path(os.path.abspath(base / scene))
    if not os.path.lexists(scene_path):
        raise _error(
            source,
            "sweep.scene",
            f"{scene_path} does not exist",
            "a scene file (relative to the sweep file) or one of " + ", ".join(BUILTIN_SCENES),
        )
    try:
        # the limits of a scene file (`yore run`, `yore check`): a regular file of at most
        # MAX_SCENE_FILE_BYTES, UTF-8
        return read_scene_text(scene_path), scene_path
    except SceneError as error:
        raise _error(source, "sweep.scene", " ".join(str(error).split())) from None
