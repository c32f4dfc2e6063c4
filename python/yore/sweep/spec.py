"""Sweep files: a base scene, axes over its keys, what to record; checked before anything runs.

::

    [sweep]
    scene = "base.toml"        # a scene file, relative to this file, or "hanging" (yore's demo
                               # scene, yore/data/hanging.toml)
    repeats = 1                # each cell this many times (a "repeat" dimension when > 1)
    [sweep.set]                # overrides for every cell, as `yore run --set`
    "mesh.nx" = 13
    [axes]                     # one dimension per key; every combination is a cell
    "material.stretch_stiffness" = [2e3, 2e4, 2e5]
    "simulation.integrator" = ["explicit", "quasi-newton"]
    [zip.method]               # keys that vary together: one dimension ("method"), its members
    "simulation.integrator" = ["explicit", "implicit"]    # as coordinates along it
    "simulation.dt" = [1e-4, 1e-2]
    [zip]                      # or variants: a list of override tables, each setting only its
    integrator = [             # own keys; "label" names it (the dimension's coordinate)
      { label = "explicit", "simulation.integrator" = "explicit" },
      { label = "BE linearized", "simulation.integrator" = "implicit",
        "integrator.linearized" = true },
    ]
    [record]
    frames = false             # keep each cell's final frame (cells/<id>/final.vtu)
    reference = { "simulation.dt" = 1e-4 }   # error of every cell against the cell with these
                                             # values (and its own on the other axes); a
                                             # variant by its label: { method = "explicit" }

Every cell's scene (base + [sweep.set] + the cell's values) is loaded and checked like a scene
file before any cell runs; an unknown key, a bad value or a bad axis fails then, naming it.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..limits import LIMITS
from ..runs import load_scene

__all__ = [
    "Sweep",
    "Cell",
    "Dimension",
    "SweepError",
    "MAX_CELLS",
    "BUILTIN_SCENES",
    "same_value",
]

#: Most cells a sweep may have (checked before anything runs).
MAX_CELLS = LIMITS.max_cells
MAX_REPEATS = LIMITS.max_repeats
MAX_SWEEP_FILE_BYTES = LIMITS.max_sweep_file_bytes
#: Scene names a sweep may use instead of a file: the scenes yore ships.
BUILTIN_SCENES = {"hanging": "data/hanging.toml"}


class SweepError(ValueError):
    """A sweep file is wrong; the message names the file, the key and what was expected."""


@dataclass(frozen=True)
class Dimension:
    """One dimension of the results: ``name``, the scene keys it sets and its values (one tuple
    per position, a value per key)."""

    name: str
    keys: tuple
    values: tuple
    #: variants only: one label per position, and per position the keys it sets
    labels: tuple = ()
    variant_keys: tuple = ()

    def overrides(self, k) -> dict:
        """The scene overrides of position ``k``."""
        if self.labels:
            return dict(zip(self.variant_keys[k], self.values[k]))
        return dict(zip(self.keys, self.values[k]))

    @property
    def size(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class Cell:
    """One run of the sweep: its index (row-major over the dimensions), position along each
    dimension, the scene overrides and the repeat number."""

    index: int
    position: tuple
    overrides: dict
    repeat: int

    @property
    def key(self) -> str:
        return f"{self.index:06d}"


@dataclass
class Sweep:
    """A checked sweep file (see the module docstring)."""

    text: str
    path: Path | None
    scene_text: str
    scene_path: Path | None
    sets: dict
    dimensions: list
    repeats: int
    frames: bool = False
    reference: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple:
        return tuple(d.size for d in self.dimensions)

    @property
    def cell_count(self) -> int:
        return math.prod(self.shape)

    def cells(self):
        """The cells, in index order (a generator: a large sweep is not held in memory)."""
        ranges = [range(d.size) for d in self.dimensions]
        for index, position in enumerate(itertools.product(*ranges)):
            overrides = dict(self.sets)
            repeat = 0
            for dimension, k in zip(self.dimensions, position):
                if dimension.name == "repeat":
                    repeat = k
                    continue
                overrides.update(dimension.overrides(k))
            yield Cell(index, position, overrides, repeat)

    def reference_position(self, position) -> tuple | None:
        """The position of the reference cell of the cell at ``position`` (None without a
        reference): the reference's values on its keys, the cell's own elsewhere."""
        if not self.reference:
            return None
        out = list(position)
        for d, dimension in enumerate(self.dimensions):
            if dimension.labels:
                if dimension.name in self.reference:  # a variant, by its label
                    out[d] = dimension.labels.index(self.reference[dimension.name])
                continue
            wanted = [self.reference.get(key) for key in dimension.keys]
            if any(w is not None for w in wanted):
                out[d] = next(
                    k
                    for k, values in enumerate(dimension.values)
                    if all(w is None or same_value(w, v) for w, v in zip(wanted, values))
                )
        return tuple(out)

    def scene(self, cell):
        """The cell's scene (`yore.runs.Scene`)."""
        return load_scene(self.scene_path, text=self.scene_text, overrides=cell.overrides)


def same_value(a, b) -> bool:
    if (
        isinstance(a, (int, float))
        and isinstance(b, (int, float))
        and not isinstance(a, bool)
        and not isinstance(b, bool)
    ):
        return float(a) == float(b)
    return a == b
