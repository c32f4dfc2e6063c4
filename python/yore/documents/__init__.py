"""yore.documents: checked documents as typed trees.

A document (a scene file, for now) is checked once, on load, by its schema; what comes out is a
tree of `Table`s, one class per table of the schema, whose keys are attributes (``scene.data.
simulation.duration``), None where the file left an optional key out. Code reads the tree by
attribute; a `Table` also reads as a mapping of the keys that are set, so that functions taking
a table (`yore.camera.camera_from_settings`, a summary's copy) take it as they took the dict.
"""

from __future__ import annotations

from .tree import Result, Table, result_type, table_type

__all__ = ["Table", "table_type", "Result", "result_type"]
