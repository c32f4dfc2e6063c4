"""Saving a simulation to a file and continuing it later, bit for bit.

A state file is a numpy ``.npz`` archive (no pickle inside, so loading one runs no code): every
array of the state under its own name, plus one JSON document that holds the scalars and says
where each array goes. JSON writes floats as the shortest text that reads back as the same
double, so scalars survive exactly too.

What is saved: the cloth (`yore.Cloth.state`: positions, velocities, springs in their order,
masses, constraints, drivers, material coordinates, the clock), the integrator's name, options,
dt and gravity, BDF2's one-step history, and any JSON-able ``metadata`` the caller adds (the
``yore run`` command keeps its step counter, frames and records there).

What is not: caches that only speed things up (sparsity patterns, symbolic analyses, factors);
they are rebuilt at the first step and give the same numbers. Two options keep a factor across
steps on purpose and so do not resume exactly: ``lagged_factorization=True`` (implicit/BDF2)
and ``rebuild="stale-pcg"`` (local-global) continue with a fresh factor, which changes the
result at the level of their solver tolerance.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import numpy as np

from .simulation import Simulation

__all__ = ["save_state", "load_state", "load_metadata", "STATE_FORMAT"]

STATE_FORMAT = "yore-state"
STATE_VERSION = 1
_DOCUMENT = "__document__"


def save_state(path, sim: Simulation, metadata=None) -> Path:
    """Writes ``sim`` (and optional JSON-able ``metadata``) to ``path`` (.npz); returns the path.

    The file is written under a temporary name and renamed, so an interrupted save never leaves
    a half-written state behind. Raises ValueError if ``metadata`` is not JSON-able.
    """
    path = Path(os.fspath(path))
    if path.suffix != ".npz":
        raise ValueError(f"a state file ends in .npz, got {path.name!r}")
    arrays = {}
    document = {"format": STATE_FORMAT, "version": STATE_VERSION,
                "simulation": _split(sim.state(), "simulation", arrays),
                "metadata": _split(metadata, "metadata", arrays)}
    try:
        text = json.dumps(document, allow_nan=False)
    except (TypeError, ValueError) as error:
        raise ValueError(f"state metadata must be JSON-able: {error}") from None
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".part.npz")
    np.savez(partial, **arrays, **{_DOCUMENT: np.array(text)})
    os.replace(partial, path)
    return path


def load_state(path):
    """Reads a state file written by `save_state`; returns ``(simulation, metadata)``.

    Raises ValueError if the file is missing, is not a yore state, or holds an inconsistent
    cloth (the message names what is wrong).
    """
    path = Path(os.fspath(path))
    if not path.is_file():
        raise ValueError(f"state file {path} does not exist")
    try:
        archive = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a yore state file (.npz): {error}") from None
    with archive:
        if _DOCUMENT not in archive.files:
            raise ValueError(f"{path} is not a yore state file (no {_DOCUMENT} entry)")
        document = json.loads(str(archive[_DOCUMENT]))
        if document.get("format") != STATE_FORMAT:
            raise ValueError(f"{path} is not a yore state file")
        if document.get("version") != STATE_VERSION:
            raise ValueError(f"{path} has state version {document.get('version')}; this yore "
                             f"reads version {STATE_VERSION}")
        arrays = {name: archive[name] for name in archive.files if name != _DOCUMENT}
    simulation = Simulation.from_state(_join(document["simulation"], arrays))
    return simulation, _join(document["metadata"], arrays)


def load_metadata(path):
    """The ``metadata`` a state file was saved with, without building its simulation.
    Raises ValueError as `load_state`."""
    path = Path(os.fspath(path))
    if not path.is_file():
        raise ValueError(f"state file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as archive:
            document = json.loads(str(archive[_DOCUMENT]))
            return _join(document["metadata"], archive)  # arrays read only when referenced
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path} is not a readable yore state file: {error}") from None


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


def _join(value, arrays):
    """Inverse of `_split`."""
    if isinstance(value, dict):
        if set(value) == {"$array"}:
            return arrays[value["$array"]]
        return {key: _join(item, arrays) for key, item in value.items()}
    if isinstance(value, list):
        return [_join(item, arrays) for item in value]
    return value
