"""The scene document's tables as classes, one per table of `yore.runs.schema.SCHEMA` (see
`yore.documents`): what `yore.runs.loading.load_scene` builds and ``Scene.data`` holds, read by
attribute (``data.simulation.duration``, ``data.strokes[0].expansion``)."""

from __future__ import annotations

from ..documents import table_type
from .schema import BOX, GENERATOR_KEYS, SCHEMA, SMOOTH

__all__ = ["SceneData", "TABLES", "MeshTable", "BoxTable", "SmoothTable"]

#: [mesh]: the generator and every generator's keys (those of the others stay None).
MeshTable = table_type(
    "MeshTable",
    dict.fromkeys(["generator", *(key for keys in GENERATOR_KEYS.values() for key in keys)]),
)
BoxTable = table_type("BoxTable", BOX)
SmoothTable = table_type("SmoothTable", SMOOTH)

#: The class of each table (of each entry, for the arrays of tables) by its name.
TABLES = {
    name: MeshTable if name == "mesh" else table_type(name.capitalize() + "Table", keys)
    for name, (keys, _) in SCHEMA.items()
    if keys is not None
}

#: The whole scene: one field per table; the arrays of tables are lists, [integrator] a dict of
#: the chosen integrator's options.
SceneData = table_type("SceneData", SCHEMA)
