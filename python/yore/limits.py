"""yore's input limits, one table: the C++ header ``cpp/include/yore/platform/limits.hpp``
holds every limit of the library, the core's own and the Python package's, and ``yore._cpu`` (the
small module that loads before the core and its BLAS) exports it. `LIMITS` is that table, read by attribute (``LIMITS.max_mesh_vertices``);
the modules that check a limit name it from here (``yore.meshes.MAX_MESH_VERTICES`` is
``LIMITS.max_mesh_vertices``), so no number is written twice. docs/limitations.md lists them
with their reasons ("Input limits")."""

from __future__ import annotations

from . import _cpu
from .documents import result_type

__all__ = ["LIMITS", "Limits"]

Limits = result_type(
    "Limits",
    tuple(_cpu.limits),
    """Every input limit: counts as ints, quantities as floats (bytes, m, s).""",
)

#: The table, as the core has it.
LIMITS = Limits(_cpu.limits)
