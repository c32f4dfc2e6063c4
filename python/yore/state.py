"""Saving a simulation to a file and continuing it later, bit for bit.

A state file is a numpy ``.npz`` archive (no pickle inside, so loading one runs no code): every
array of the state under its own name, plus one JSON document that holds the scalars and says
where each array goes. JSON writes floats as the shortest text that reads back as the same
double, so scalars survive exactly too.

What is saved: the cloth (`yore.Cloth.state`: positions, velocities, springs in their order,
masses, constraints, drivers, material coordinates, the clock, the bending model with its
modulus and rest positions; files written before quadratic bending load as bending springs),
the integrator's name, options, dt and gravity, the integrator's history (BDF2's state one step
back, generalized-α's accelerations), Newton's projection memory, and any JSON-able
``metadata`` the caller adds (the ``yore run`` command keeps its step counter, frames and
records there).

What is not: caches that only speed things up (sparsity patterns, symbolic analyses, factors);
they are rebuilt at the first step and give the same numbers. Two options keep a factor across
steps on purpose and so do not resume exactly: ``lagged_factorization=True`` (implicit/BDF2)
and ``rebuild="stale-pcg"`` (local-global) continue with a fresh factor, which changes the
result at the level of their solver tolerance.
"""

from __future__ import annotations

import json
import math
import os
import stat
import struct
import tokenize
import zipfile
import zlib
from pathlib import Path

import numpy as np

from .limits import LIMITS
from ._core import Cloth
from .simulation import Simulation
from .state_schema import check_simulation, FieldChecker, show_value

__all__ = [
    "save_state",
    "load_state",
    "load_metadata",
    "STATE_FORMAT",
    "STATE_VERSION",
    "MAX_STATE_FILE_BYTES",
    "MAX_STATE_VERTICES",
]

STATE_FORMAT = "yore-state"
STATE_VERSION = 1
_DOCUMENT = "__document__"


def save_state(path, sim: Simulation, metadata=None) -> Path:
    """Writes ``sim`` (and optional JSON-able ``metadata``) to ``path`` (.npz); returns the path.

    The file is written under a temporary name and renamed, so an interrupted save never leaves
    a half-written state behind. What is written is first checked as `load_state` checks what
    it reads (the schema, then the core's consistency checks of the cloth), so a file
    `save_state` writes is one `load_state` reads. Raises ValueError, writing nothing, if
    ``metadata`` is not a JSON-able dict (or None) or the simulation is in a state no file may
    hold (the message names the field).
    """
    path = Path(os.fspath(path))
    if path.suffix != ".npz":
        raise ValueError(f"a state file ends in .npz, got {path.name!r}")
    if metadata is not None and not isinstance(metadata, dict):
        raise ValueError(f"state metadata must be a dict or None, got {type(metadata).__name__}")
    arrays = {}
    document = {
        "format": STATE_FORMAT,
        "version": STATE_VERSION,
        "simulation": _split(sim.state(), "simulation", arrays),
        "metadata": _split(metadata, "metadata", arrays),
    }
    try:
        text = json.dumps(document, allow_nan=False)
    except (TypeError, ValueError) as error:
        raise ValueError(f"state metadata must be JSON-able: {error}") from None
    # what load_state would refuse is not written (a 70 MB metadata string used to be)
    if len(text) > _MAX_DOCUMENT_CHARS:
        raise ValueError(
            f"{path} (not written): the state's document is {len(text)} characters "
            f"long, more than the {_MAX_DOCUMENT_CHARS} a state file may hold; "
            "keep large metadata in arrays or beside the state"
        )
    metadata_bytes = sum(a.nbytes for name, a in arrays.items() if name.startswith("metadata/"))
    if metadata_bytes > _METADATA_ARRAY_BYTES:
        raise ValueError(
            f"{path} (not written): the metadata's arrays hold {metadata_bytes} "
            f"bytes, more than the {_METADATA_ARRAY_BYTES} a state file may hold"
        )
    _check_written(path, json.loads(text), arrays)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".part.npz")
    np.savez(partial, **arrays, **{_DOCUMENT: np.array(text)})
    os.replace(partial, path)
    return path


def load_state(path):
    """Reads a state file written by `save_state`; returns ``(simulation, metadata)``.

    The file is checked field by field against the schema of `STATE_VERSION` before anything
    is built (see `check_simulation`): names, types, dtypes, shapes, ranges, finiteness and
    consistent sizes (springs, faces, constraints and drivers against the vertex count). Raises
    ValueError, in one line naming the file and the field, if the file is missing, not a
    regular file, larger than `MAX_STATE_FILE_BYTES`, truncated or corrupt (bad zip, bad CRC,
    bad .npy header, object arrays, bad JSON), not a yore state, of another version, or holds a
    field of the wrong kind.
    """
    path = Path(os.fspath(path))
    arrays, document, unknown = _read_archive(path)
    field = FieldChecker(path)
    if not isinstance(document, dict) or set(document) != {
        "format",
        "version",
        "simulation",
        "metadata",
    }:
        raise field.error(
            "document", "is not a yore state document", "keys format, version, simulation, metadata"
        )
    if document["format"] != STATE_FORMAT:
        raise field.error("format", f"got {show_value(document['format'])}", repr(STATE_FORMAT))
    if document["version"] != STATE_VERSION or isinstance(document["version"], bool):
        raise field.error(
            "version",
            f"got {show_value(document['version'])}; this yore reads version {STATE_VERSION}",
            str(STATE_VERSION),
        )
    simulation = field.join(document["simulation"], arrays, "simulation")
    metadata = field.join(document["metadata"], arrays, "metadata")
    _refuse_unknown(path, unknown)
    if metadata is not None and not isinstance(metadata, dict):
        raise field.error("metadata", f"got {show_value(metadata)}", "a table or null")
    check_simulation(field, simulation)
    try:
        sim = Simulation.from_state(simulation)
    except (ValueError, TypeError, RuntimeError) as error:
        # The schema above should leave nothing for the core to refuse; if it does, the
        # message still names the file.
        raise ValueError(
            f"{path}: not a consistent yore state: {' '.join(str(error).split())}"
        ) from None
    return sim, metadata


def _check_written(path, document, arrays):
    """The checks `load_state` applies to a file, applied to what `save_state` is about to
    write (``document`` after its JSON round trip, ``arrays`` as stored): ValueError naming
    the field otherwise, before anything is written."""
    field = FieldChecker(f"{path} (not written)")
    simulation = field.join(document["simulation"], arrays, "simulation")
    check_simulation(field, simulation)
    vertices = len(simulation["cloth"]["positions"])
    if vertices > MAX_STATE_VERTICES:
        raise ValueError(
            f"{path} (not written): the cloth has {vertices} vertices, more than "
            f"the {MAX_STATE_VERTICES} a state file may hold"
        )
    try:
        Cloth.from_state(simulation["cloth"])
    except (ValueError, TypeError, RuntimeError) as error:
        raise ValueError(
            f"{path} (not written): the simulation is in a state no file may hold: "
            f"{' '.join(str(error).split())}"
        ) from None


#: Largest state file read, bytes (a state of a million vertices is some hundreds of MB).
MAX_STATE_FILE_BYTES = LIMITS.max_state_file_bytes
#: Largest JSON document in a state file, characters.
_MAX_DOCUMENT_CHARS = 64 * 2**20


#: What reading a tampered or truncated state file can raise, turned into one ValueError.
_READ_ERRORS = (
    ValueError,
    EOFError,
    OSError,
    zlib.error,
    KeyError,
    NotImplementedError,
    RuntimeError,
    MemoryError,
    struct.error,
    SyntaxError,
    tokenize.TokenError,  # numpy's header parser retries an unparsable header with tokenize
)


def _check_state_file(path):
    """ValueError unless `path` is a regular file within `MAX_STATE_FILE_BYTES`."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ValueError(f"state file {path} does not exist") from None
    except OSError as error:
        raise ValueError(f"cannot read state file {path}: {error.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        raise ValueError(f"cannot read state file {path}: not a regular file")
    if info.st_size > MAX_STATE_FILE_BYTES:
        raise ValueError(
            f"cannot read state file {path}: {info.st_size} bytes is more than the "
            f"limit of {MAX_STATE_FILE_BYTES} bytes"
        )


def _read_archive(path):
    """(arrays, document, unknown) of a state file, read with zipfile and the .npy header
    parser (so a tampered header cannot make numpy allocate what the file does not hold, and no
    pickle is ever loaded); ``unknown``: the members the document does not refer to, not read.
    ValueError naming the file and the member otherwise."""
    _check_state_file(path)
    arrays, unknown = {}, []
    member = None
    try:
        with zipfile.ZipFile(path) as archive:
            entries = archive.infolist()
            # Sizes and names are checked from the directory before anything is inflated: the
            # total the members declare is bounded (each member is read only up to its
            # declared size), and a member the document does not refer to is refused unread.
            _check_declared(entries)
            by_name = {}
            for entry in entries:
                member = entry.filename
                _check_member(entry, by_name)
                by_name[member] = entry
            member = _DOCUMENT + ".npy"
            if member not in by_name:
                raise _DocumentError(f"{path} is not a yore state file (no {_DOCUMENT} entry)")
            with archive.open(by_name[member]) as stream:
                text = _read_npy(stream, by_name[member].file_size, limit=4 * _MAX_DOCUMENT_CHARS)
            document = _parse_document(path, text)
            referenced = _referenced_arrays(document)
            wanted = {}
            for name, entry in by_name.items():
                member = name
                if name[:-4] == _DOCUMENT:
                    continue
                if name[:-4] not in referenced:
                    unknown.append(name[:-4])  # refused by the caller, never read
                    continue
                with archive.open(entry) as stream:
                    wanted[name] = _npy_header(stream, entry.file_size)
            member = None
            _check_budget(path, wanted)
            for name, entry in by_name.items():
                if name in wanted:
                    member = name
                    with archive.open(entry) as stream:
                        arrays[name[:-4]] = _read_npy(stream, entry.file_size)
    except zipfile.BadZipFile as error:
        where = f" (member {member})" if member else ""
        raise ValueError(
            f"{path} is not a readable yore state file (.npz){where}: {error}"
        ) from None
    except _DocumentError as error:
        raise ValueError(str(error)) from None
    except _READ_ERRORS as error:
        where = (
            f"field {member[:-4] if member.endswith('.npy') else member}" if member else "archive"
        )
        raise ValueError(
            f"{path} is not a readable yore state file: {where}: "
            f"{type(error).__name__}: {' '.join(str(error).split())}"[:400]
        ) from None
    return arrays, document, sorted(unknown)


def _check_declared(entries):
    """The uncompressed sizes a state file's members declare, in all, within the limit."""
    declared = sum(entry.file_size for entry in entries)
    if declared > MAX_STATE_FILE_BYTES:
        raise ValueError(
            f"its members declare {declared} bytes uncompressed in all, "
            f"more than the limit of {MAX_STATE_FILE_BYTES}"
        )


def _check_member(entry, seen):
    """A state file's member: a .npy array, stored once (ValueError otherwise)."""
    if not entry.filename.endswith(".npy") or entry.is_dir():
        raise ValueError("not a .npy array")
    if entry.filename in seen:
        raise ValueError("stored twice")


class _DocumentError(Exception):
    """The document member is readable but not a JSON text (its message is final)."""


def _parse_document(path, text):
    if text.dtype.kind != "U" or text.shape != () or text.dtype.itemsize > 4 * _MAX_DOCUMENT_CHARS:
        raise _DocumentError(
            f"{path}: field {_DOCUMENT}: got {show_value(text)}; expected a JSON text"
        )
    try:
        return json.loads(str(text[()]))
    except (ValueError, RecursionError) as error:
        problem = (
            "nested too deeply"
            if isinstance(error, RecursionError)
            else f"not valid JSON ({' '.join(str(error).split())})"
        )
        raise _DocumentError(f"{path}: field {_DOCUMENT}: {problem}") from None


def _referenced_arrays(document):
    """The array names the document refers to (``{"$array": name}`` anywhere in it)."""
    names, stack = set(), [document]
    while stack:
        value = stack.pop()
        if isinstance(value, dict):
            if set(value) == {"$array"} and isinstance(value["$array"], str):
                names.add(value["$array"])
            else:
                stack.extend(value.values())
        elif isinstance(value, list):
            stack.extend(value)
    return names


#: Bytes a state's simulation arrays may declare in all, per vertex of its cloth (positions,
#: velocities, masses, faces, springs of both kinds, material coordinates, bending rest
#: positions, a history, drivers: about 500 on a grid), plus a fixed allowance; the metadata's
#: arrays at most _METADATA_ARRAY_BYTES. Checked from the members' headers before any array is
#: read, so a small file cannot inflate into gigabytes.
_BYTES_PER_VERTEX = 2048
_FIXED_BYTES = 1 << 20
_METADATA_ARRAY_BYTES = 256 << 20
_POSITIONS = "simulation/cloth/positions.npy"
#: Most vertices a state's cloth may have: four times the largest mesh yore generates or reads
#: (`yore.meshes.MAX_MESH_VERTICES`; strokes stay within it). The positions' header alone must
#: not set the budget: a 1 MB file whose positions inflate to 1 GiB declared 45 million.
MAX_STATE_VERTICES = LIMITS.max_state_vertices
#: Members with one row per vertex: their headers must agree with the positions' before any of
#: them is inflated, so a forged vertex count must be forged (and inflated) in all of them.
_PER_VERTEX = (
    "simulation/cloth/velocities.npy",
    "simulation/cloth/masses.npy",
    "simulation/cloth/material_coordinates.npy",
    "simulation/cloth/vertex_states.npy",
)


def _check_budget(path, headers):
    """_DocumentError (naming the file, the member and the budget) if the arrays' declared
    sizes pass the budget their cloth's vertex count gives (`_BYTES_PER_VERTEX`)."""

    def nbytes(name):
        shape, dtype, _ = headers[name]
        return math.prod(shape) * dtype.itemsize

    shape = headers.get(_POSITIONS, ((0,), None))[0]
    vertices = shape[0] if len(shape) == 2 else 0
    if vertices > MAX_STATE_VERTICES:
        raise _DocumentError(
            f"{path}: field simulation.cloth.positions: its header declares "
            f"{vertices} vertices, more than the {MAX_STATE_VERTICES} a state "
            "may hold; refused before reading"
        )
    per_vertex = _PER_VERTEX + tuple(n for n in headers if n.startswith("simulation/history/"))
    for name in per_vertex if _POSITIONS in headers else ():  # (no positions: named later)
        rows = headers[name][0][:1] if name in headers else None
        if rows is not None and rows != (vertices,):
            raise _DocumentError(
                f"{path}: field {name[:-4].replace('/', '.')}: its header "
                f"declares {rows[0] if rows else 0} rows where the positions "
                f"declare {vertices} vertices; refused before reading"
            )
    for prefix, budget, what in (
        (
            "simulation/",
            _FIXED_BYTES + _BYTES_PER_VERTEX * vertices,
            f"{_FIXED_BYTES + _BYTES_PER_VERTEX * vertices} for a cloth of {vertices} "
            f"vertices ({_BYTES_PER_VERTEX} per vertex)",
        ),
        ("metadata/", _METADATA_ARRAY_BYTES, str(_METADATA_ARRAY_BYTES)),
    ):
        names = [name for name in headers if name.startswith(prefix)]
        if sum(nbytes(name) for name in names) > budget:
            largest = max(names, key=nbytes)
            raise _DocumentError(
                f"{path}: field {largest[:-4].replace('/', '.')}: the {prefix[:-1]} arrays "
                f"declare {sum(nbytes(name) for name in names)} bytes in all (this one "
                f"{nbytes(largest)}), more than the {what} bytes a state may hold; refused "
                "before reading"
            )


def _npy_header(stream, size):
    """(shape, dtype) of a .npy member, checked against the member's size (nothing inflated
    past the header)."""
    version = np.lib.format.read_magic(stream)
    if version == (1, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(stream)
    elif version == (2, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_2_0(stream)
    else:
        raise ValueError(f".npy format version {version} is not one yore writes")
    if dtype.hasobject:
        raise ValueError("holds Python objects (a pickle), which a state file never does")
    if math.prod(shape) * dtype.itemsize > size:
        raise ValueError(
            f"the header announces shape {shape} of {dtype}, more than the {size} bytes stored"
        )
    return shape, dtype, fortran


def _read_npy(stream, size, limit=None):
    """One .npy member: header checked against the member's size (and ``limit`` bytes) before
    the data is read."""
    shape, dtype, fortran = _npy_header(stream, size)
    count = math.prod(shape)
    if limit is not None and count * dtype.itemsize > limit:
        raise ValueError(
            f"the header announces {count * dtype.itemsize} bytes, more than the "
            f"limit of {limit}; refused before reading"
        )
    # inflated straight into the array (one copy in memory, not two)
    array = np.empty(count, dtype=dtype)
    view, got = memoryview(array.view(np.uint8)), 0
    while got < len(view):
        read = stream.readinto(view[got:])
        if not read:
            break
        got += read
    if got != count * dtype.itemsize:
        raise ValueError(f"truncated: {got} of {count * dtype.itemsize} bytes")
    if stream.read(1):
        raise ValueError("more bytes than its header announces")
    return array.reshape(shape, order="F" if fortran else "C")


def load_metadata(path):
    """The ``metadata`` a state file was saved with (a dict or None), without building its
    simulation. Raises ValueError as `load_state` for a file that cannot be read."""
    path = Path(os.fspath(path))
    arrays, document, unknown = _read_archive(path)
    if not isinstance(document, dict) or "metadata" not in document:
        raise FieldChecker(path).error(
            "document", "is not a yore state document", "keys format, version, simulation, metadata"
        )
    metadata = FieldChecker(path).join(document["metadata"], arrays, "metadata")
    _refuse_unknown(path, unknown)
    return metadata


def _refuse_unknown(path, unknown):
    """ValueError for members of a state file its document does not refer to (never read)."""
    if unknown:
        raise ValueError(
            f"{path}: member {unknown[0]}.npy is not a field the state refers to "
            f"({len(unknown)} such member(s), refused unread)"
        )


def _split(value, name, arrays):
    """JSON-able copy of ``value`` with every numpy array moved into ``arrays``."""
    if isinstance(value, np.ndarray):
        arrays[name] = value
        return {"$array": name}
    if isinstance(value, dict):
        return {str(key): _split(item, f"{name}/{key}", arrays) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_split(item, f"{name}/{index}", arrays) for index, item in enumerate(value)]
    if isinstance(value, np.generic):
        return value.item()
    return value
