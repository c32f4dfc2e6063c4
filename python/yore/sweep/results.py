"""A sweep's results: one record per finished cell on disk, and the `xarray.Dataset` built from
them (``OUT/results.nc``, NetCDF-4 through h5netcdf).

Layout of a sweep folder::

    sweep.toml            the sweep file as run (with the base scene's text in scene.toml)
    cells/000042.npz      a finished cell's final positions and faces (written first)
    cells/000042.json     its status, message and recorded values (written last: a cell is
                          finished when its .json exists, so an interrupted sweep resumes exactly)
    cells/000042.vtu      its final frame, with [record] frames = true
    results.nc            the Dataset: one dimension per axis (zip: one per zip, its keys as
                          coordinates along it), a "status" and a "message" variable, one float
                          variable per recorded quantity (NaN where a cell has none), and with a
                          [record] reference error_rms / error_max (m) against the reference cell

Every file is written under a temporary name and renamed. The client keeps one fixed-size array
per recorded quantity (allocated at the sweep's shape), never a cell's arrays, so its memory
does not grow with the number of finished cells.
"""

from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..documents import result_type
from ..limits import LIMITS
from ..io import write_atomically

__all__ = [
    "Results",
    "CellRecord",
    "open_results",
    "read_record",
    "RESULTS_NAME",
    "CELLS_DIR",
    "STATUSES",
]

RESULTS_NAME = "results.nc"
CELLS_DIR = "cells"


class Results:
    """The finished cells of one sweep in ``out``, as fixed-size arrays."""

    def __init__(self, sweep, out):
        self.sweep, self.out = sweep, Path(out)
        self.cells = self.out / CELLS_DIR
        self.cells.mkdir(parents=True, exist_ok=True)
        shape = sweep.shape
        self.status = np.full(shape, "", dtype=object)
        self.message = np.full(shape, "", dtype=object)
        self.values = {}
        self.finished = 0

    # -- cells ----------------------------------------------------------------------------------
    def load_finished(self) -> set:
        """Reads the cells finished earlier; returns their indices. Each record is checked
        against its cell (its overrides, statuses, values): a record that is not this sweep's
        is refused (ValueError naming it), never relabelled."""
        done = set()
        for cell in self.sweep.cells():
            path = self.cells / f"{cell.key}.json"
            if path.is_file() or path.is_symlink():
                self._store(cell, read_record(path, cell))
                done.add(cell.index)
        return done

    def add(self, cell, result) -> None:
        """Records a cell's result: arrays first, then its .json (the cell's 'done' mark)."""
        if result.get("positions") is not None:
            write_atomically(
                self.cells / f"{cell.key}.npz",
                lambda p: np.savez(p, positions=result["positions"], faces=result["faces"]),
            )
            if self.sweep.frames:
                from ..io import save_mesh

                save_mesh(self.cells / f"{cell.key}.vtu", result["positions"], result["faces"])
        record = CellRecord(
            status=result["status"],
            message=result["message"],
            overrides=dict(cell.overrides),
            values={
                k: v
                for k, v in result["values"].items()
                if isinstance(v, float) and math.isfinite(v)
            },
        )
        text = json.dumps(record, indent=1, default=str)
        write_atomically(
            self.cells / f"{cell.key}.json", lambda p: p.write_text(text + "\n", encoding="utf-8")
        )
        self._store(cell, record)

    def _store(self, cell, record):
        self.status[cell.position] = record.status
        self.message[cell.position] = record.message
        for name, value in record.values.items():
            if name not in self.values:
                self.values[name] = np.full(self.sweep.shape, np.nan)
            self.values[name][cell.position] = value
        self.finished += 1

    def counts(self) -> dict:
        flat = [s for s in self.status.reshape(-1) if s]
        return {status: flat.count(status) for status in dict.fromkeys(flat)}

    # -- errors against the reference ------------------------------------------------------------
    def reference_errors(self) -> None:
        """error_rms and error_max (m) of every finished cell's final positions against its
        reference cell's, where both finished with the same vertex count (NaN elsewhere)."""
        if not self.sweep.reference:
            return
        rms = np.full(self.sweep.shape, np.nan)
        largest = np.full(self.sweep.shape, np.nan)
        load = lru_cache(maxsize=4)(self._final_positions)
        for cell in self.sweep.cells():
            reference = self.sweep.reference_position(cell.position)
            if self.status[cell.position] != "done" or self.status[reference] != "done":
                continue
            mine = load(cell.index)
            theirs = load(int(np.ravel_multi_index(reference, self.sweep.shape)))
            if mine is None or theirs is None or mine.shape != theirs.shape:
                continue
            distance = np.linalg.norm(mine - theirs, axis=1)
            rms[cell.position] = float(np.sqrt(np.mean(distance**2)))
            largest[cell.position] = float(distance.max())
        self.values["error_rms"], self.values["error_max"] = rms, largest

    def _final_positions(self, index):
        path = self.cells / f"{index:06d}.npz"
        if not path.is_file():
            return None
        with np.load(path) as data:
            return np.array(data["positions"])

    # -- the Dataset ----------------------------------------------------------------------------
    def dataset(self):
        import xarray as xr

        dims = [d.name for d in self.sweep.dimensions]
        coords = {}
        for d in self.sweep.dimensions:
            if d.labels:
                coords[d.name] = (d.name, np.asarray(d.labels, dtype=str))
            elif len(d.keys) == 1:
                coords[d.name] = (d.name, _column([v[0] for v in d.values]))
            else:
                coords[d.name] = (d.name, np.arange(d.size))
                for k, key in enumerate(d.keys):
                    coords[key] = (d.name, _column([v[k] for v in d.values]))
        data = {
            "status": (dims, self.status.astype(str)),
            "message": (dims, self.message.astype(str)),
        }
        taken = set(data) | set(coords) | set(dims)
        for name, array in sorted(self.values.items()):
            # a recorded quantity never takes the name of a dimension, coordinate or the status
            while name in taken:
                name = "recorded_" + name
            taken.add(name)
            data[name] = (dims, array)
        dataset = xr.Dataset(data, coords=coords)
        dataset.attrs.update(
            {
                "sweep": self.sweep.text,
                "scene": str(self.sweep.scene_path or "built-in"),
                "cells": self.sweep.cell_count,
                "finished": int(np.count_nonzero(self.status != "")),
            }
        )
        dataset["status"].attrs["description"] = (
            "done, diverged, stroke missed, failed; empty: not run yet"
        )
        return dataset

    def write(self) -> Path:
        """Writes results.nc (atomically); returns its path."""
        dataset = self.dataset()
        path = self.out / RESULTS_NAME
        write_atomically(path, lambda p: dataset.to_netcdf(p, engine="h5netcdf"))
        return path


#: A cell's record, the cells/<key>.json a sweep writes once the cell is done: its status, a
#: message, the overrides that made the cell (checked against the sweep's on reading) and its
#: values (finite numbers by name).
CellRecord = result_type(
    "CellRecord",
    ("status", "message", "overrides", "values"),
    """A sweep cell's record: status (e.g. "done", "diverged"), message, the cell's overrides
    and its values (finite numbers by name).""",
)

#: The statuses `run_cell` records (a cell function may add its own, short texts), and the
#: largest record file read, bytes.
STATUSES = ("done", "diverged", "stroke missed", "failed")
MAX_RECORD_BYTES = LIMITS.max_record_bytes


def read_record(path, cell) -> CellRecord:
    """The record of ``cell`` in ``path``, checked; ValueError naming the file otherwise."""

    def refuse(problem):
        raise ValueError(
            f"{path}: {problem}; not a record of this sweep's cell {cell.index} "
            "(remove the file to run the cell again)"
        )

    record, problem = _read_record_file(path)
    if problem is None:
        problem = _record_problem(record, cell)
    if problem is not None:
        refuse(problem)
    return CellRecord(record)


def _read_record_file(path):
    """(the record file's JSON, None), or (None, what is wrong with the file)."""
    try:
        info = path.stat()
    except OSError as error:
        return None, f"cannot be read ({error.strerror})"
    if not path.is_file():
        return None, "not a regular file"
    if info.st_size > MAX_RECORD_BYTES:
        return None, f"{info.st_size} bytes, more than a record's {MAX_RECORD_BYTES}"
    try:
        return json.loads(path.read_text(encoding="utf-8")), None
    except (OSError, UnicodeDecodeError, ValueError) as error:
        return None, f"not valid JSON ({' '.join(str(error).split())[:120]})"
    except RecursionError:
        return None, "nested too deeply"


def _record_problem(record, cell):
    """What is wrong with a record's contents for this cell, or None."""
    if not isinstance(record, dict) or set(record) != {"status", "message", "overrides", "values"}:
        return "not a table with status, message, overrides and values"
    status = record["status"]
    if not isinstance(status, str) or not 0 < len(status) <= 64 or any(ord(c) < 32 for c in status):
        return f"status {status!r} is not a short text (e.g. {', '.join(STATUSES)})"
    if not isinstance(record["message"], str):
        return "message is not a string"
    expected = json.loads(json.dumps(cell.overrides, default=str))
    if record["overrides"] != expected:
        return (
            f"it was written for other settings ({record['overrides']!r}; this cell's are "
            f"{expected!r}): the sweep file was changed since"
        )
    values = record["values"]
    if not isinstance(values, dict) or not all(
        isinstance(name, str)
        and isinstance(value, (int, float))
        and not isinstance(value, bool)
        and math.isfinite(value)
        for name, value in values.items()
    ):
        return "values is not a table of finite numbers"
    return None


def _column(values):
    """A coordinate array: floats, ints, bools or strings, as numpy makes them."""
    if all(isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=bool)
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.asarray(
            values, dtype=float if any(isinstance(v, float) for v in values) else np.int64
        )
    return np.asarray([str(v) for v in values], dtype=str)


def open_results(out):
    """The Dataset of sweep folder ``out`` (loaded into memory; the file is closed)."""
    import xarray as xr

    path = Path(out) / RESULTS_NAME
    if not path.is_file():
        raise ValueError(f"{out} holds no sweep results ({RESULTS_NAME}); run `yore sweep` first")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as dataset:
            return dataset.load()
    except (OSError, ValueError, KeyError, RuntimeError, TypeError) as error:
        raise ValueError(
            f"{path} cannot be read as a sweep's results "
            f"({type(error).__name__}: {' '.join(str(error).split())[:160]})"
        ) from None
