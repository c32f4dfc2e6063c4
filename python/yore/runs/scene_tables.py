"""The scene document's tables as classes, one per table of `yore.runs.schema.SCHEMA` (see
`yore.documents`): what `yore.runs.loading.load_scene` builds and ``Scene.data`` holds, read by
attribute (``data.simulation.duration``, ``data.strokes[0].expansion``)."""

from __future__ import annotations

from ..documents import table_type
from .schema import BOX, GENERATOR_KEYS, SCHEMA, SELECTION, SMOOTH

__all__ = [
    "SceneData",
    "TABLES",
    "SceneTable",
    "MeshTable",
    "MaterialTable",
    "FixedTable",
    "DrivenTable",
    "SimulationTable",
    "StrokeTable",
    "CameraTable",
    "OutputTable",
    "BoxTable",
    "SmoothTable",
]


def _keys(name):
    return SCHEMA[name].keys


SceneTable = table_type("SceneTable", _keys("scene"))
#: [mesh]: the generator and every generator's keys (those of the others stay None).
MeshTable = table_type(
    "MeshTable",
    dict.fromkeys(["generator", *(key for keys in GENERATOR_KEYS.values() for key in keys)]),
)
MaterialTable = table_type("MaterialTable", _keys("material"))
FixedTable = table_type("FixedTable", SELECTION)
DrivenTable = table_type("DrivenTable", _keys("driven"))
SimulationTable = table_type("SimulationTable", _keys("simulation"))
StrokeTable = table_type("StrokeTable", _keys("strokes"))
CameraTable = table_type("CameraTable", _keys("camera"))
OutputTable = table_type("OutputTable", _keys("output"))
BoxTable = table_type("BoxTable", BOX)
SmoothTable = table_type("SmoothTable", SMOOTH)

#: The class of each table (of each entry, for the arrays of tables) by its name in the file.
TABLES = {
    "scene": SceneTable,
    "mesh": MeshTable,
    "material": MaterialTable,
    "fixed": FixedTable,
    "driven": DrivenTable,
    "simulation": SimulationTable,
    "strokes": StrokeTable,
    "camera": CameraTable,
    "output": OutputTable,
}

#: The whole scene: one field per table; the arrays of tables are lists, [integrator] a dict of
#: the chosen integrator's options.
SceneData = table_type("SceneData", SCHEMA)
