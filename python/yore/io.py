"""Reading and writing triangle meshes, and writing simulation frames for ParaView.

File formats are handled by meshio and chosen from the file extension (``.obj``, ``.ply``,
``.off``, ``.stl``, ``.vtu``, ``.vtk``, ``.msh``, ``.mesh``, ...). Positions are n×3 float64
arrays in metres, faces f×3 int32 arrays of vertex indices.
"""

from __future__ import annotations

import math
import numbers
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .mesh_files import (  # noqa: F401  (the limits are io's API too)
    MAX_MESH_FILE_BYTES,
    VTU_MAX_INFLATION_RATIO,
    check_mesh_file,
    read_with_meshio,
    vtu_inflation_budget,
)

__all__ = [
    "load_mesh",
    "load_frame",
    "save_mesh",
    "FrameSeries",
    "MAX_MESH_FILE_BYTES",
    "write_atomically",
]


def write_atomically(path, write) -> Path:
    """Calls ``write(temporary_path)`` for a hidden file beside ``path`` with the same
    extension (so format-by-extension writers pick the same format), then renames it to
    ``path``: a reader, or a run interrupted mid-write, never sees half a file. Creates the
    parent folder; removes the temporary file if ``write`` fails."""
    path = Path(os.fspath(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.stem}.part{path.suffix}")
    try:
        write(partial)
        os.replace(partial, path)
    finally:
        if partial.exists():
            partial.unlink()
    return path


# Extensions whose meshio writer silently ignores point data; .obj keeps only the
# "obj:vn" (normals) and "obj:vt" (texture coordinates) entries.
_NO_POINT_DATA = {".off", ".stl"}
_OBJ_POINT_DATA = {"obj:vn", "obj:vt"}


def load_mesh(path):
    """Read a triangle mesh from a file.

    Parameters
    ----------
    path : str or os.PathLike
        Mesh file; the format is taken from the extension. Points stored in 2-D get z = 0.

    Returns
    -------
    V : (n, 3) float64 C-contiguous array, metres
        Vertex positions.
    F : (f, 3) int32 C-contiguous array
        Triangles as vertex indices, all triangle cell blocks of the file concatenated in
        order. "vertex" cells are ignored.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If meshio cannot read the file (unknown format, corrupt content), if it holds cells
        other than triangles (quads, polygons, lines, ...; the message names them) or no
        triangles at all, or if the mesh is invalid (NaN or infinite positions, an index out
        of range, a degenerate face, a non-manifold edge, ...), as checked by the core; also
        before reading, if ``path`` is not a regular file (a FIFO, a device, a directory) or
        is larger than `MAX_MESH_FILE_BYTES`. The message is one line naming the file.
    """
    path = Path(os.fspath(path))
    mesh = read_with_meshio(check_mesh_file(path))
    V, F = _triangles(path, mesh)

    from ._core import validate_mesh

    try:
        validate_mesh(V, F)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None
    return V, F


def load_frame(path):
    """Read a frame file as written by `FrameSeries` (or any triangle mesh file) with its point
    data: ``(V, F, point_data)``, V (n, 3) float64, F (f, 3) int32 with indices in [0, n),
    point_data a dict of float64 arrays with n rows.

    Unlike `load_mesh` the mesh is not validated as a cloth (a frame may hold any triangles);
    it is checked only so far that it can be drawn. Raises FileNotFoundError if ``path`` does
    not exist and ValueError naming the file for anything else: not a regular file, larger
    than `MAX_MESH_FILE_BYTES`, unreadable or corrupt, non-triangle cells, non-finite
    positions, indices out of range, point data of the wrong length.
    """
    path = Path(os.fspath(path))
    mesh = read_with_meshio(check_mesh_file(path))
    V, F = _triangles(path, mesh)
    if not np.isfinite(V).all():
        raise ValueError(f"{path}: vertex positions are not all finite")
    if F.size and (F.min() < 0 or F.max() >= len(V)):
        raise ValueError(
            f"{path}: triangle indices span [{F.min()}, {F.max()}], outside [0, {len(V)})"
        )
    point_data = {}
    for name, values in mesh.point_data.items():
        try:
            array = np.asarray(values, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{path}: point data {name!r} is not numeric") from None
        if array.ndim == 0 or array.shape[0] != len(V):
            raise ValueError(
                f"{path}: point data {name!r} has shape {array.shape}, expected {len(V)} rows"
            )
        point_data[name] = array
    return V, F, point_data


def _triangles(path, mesh):
    """(V, F) of a meshio mesh: V (n, 3) float64, F (f, 3) int32; ValueError naming ``path``."""
    triangles = []
    other = {}
    for block in mesh.cells:
        if block.type == "triangle":
            data = np.asarray(block.data)
            if data.ndim != 2 or data.shape[1] != 3:
                raise ValueError(f"{path}: a triangle block has shape {data.shape}")
            triangles.append(data)
        elif block.type != "vertex":
            other[block.type] = other.get(block.type, 0) + len(block.data)
    if other:
        found = ", ".join(f"{count} {kind}" for kind, count in sorted(other.items()))
        raise ValueError(
            f"{path} holds non-triangle cells ({found}); only triangle meshes are supported"
        )
    if not triangles:
        raise ValueError(f"{path} holds no triangle cells")

    points = np.asarray(mesh.points)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ValueError(
            f"{path}: expected 2-D or 3-D points, got an array of shape {points.shape}"
        )
    if points.dtype.kind not in "iuf":
        raise ValueError(f"{path}: point coordinates have non-numeric dtype {points.dtype}")
    V = np.zeros((points.shape[0], 3), dtype=np.float64)
    V[:, : points.shape[1]] = points

    faces = np.concatenate(triangles, axis=0)
    if faces.dtype.kind not in "iu":
        raise ValueError(f"{path}: triangle indices have non-integer dtype {faces.dtype}")
    limits = np.iinfo(np.int32)
    if faces.size and (faces.min() < limits.min or faces.max() > limits.max):
        # Checked before the cast so that a huge index cannot wrap into a valid one.
        raise ValueError(
            f"{path}: triangle indices span [{faces.min()}, {faces.max()}], beyond int32"
        )
    F = np.ascontiguousarray(faces, dtype=np.int32)
    return V, F


def save_mesh(path, V, F, point_data=None):
    """Write a triangle mesh to a file; the format is taken from the extension.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its folder must exist. An existing file is overwritten.
    V : (n, 3) array_like, metres
        Vertex positions, all finite.
    F : (f, 3) array_like of integers
        Triangles as vertex indices in [0, n).
    point_data : mapping of str to (n,) or (n, k) array_like, optional
        Per-vertex fields (velocities in m/s, forces in N, ...), written as float64. In a
        ``.ply`` file, whose meshio writer only stores scalar fields, an (n, k) field ``name``
        is written as k scalar fields ``name_x``, ``name_y``, ``name_z`` when k == 3 and
        ``name_0`` ... ``name_{k-1}`` otherwise.

    Raises
    ------
    ValueError
        If V is not an n×3 array of finite numbers, F is not an f×3 integer array with
        entries in [0, n), a point-data field has the wrong length or is not numeric, the
        format cannot store the given point data (``.off``, ``.stl``; ``.obj`` only stores
        "obj:vn" and "obj:vt"), or meshio does not know or cannot write the format.
    """
    path = Path(os.fspath(path))
    V = _as_positions(V)
    F = _as_faces(F, V.shape[0])
    fields = _as_point_data(point_data, V.shape[0])

    extension = path.suffix.lower()
    if fields and extension in _NO_POINT_DATA:
        raise ValueError(
            f"{extension} files cannot store point data, got fields {sorted(fields)}; "
            "use .vtu, .vtk or .ply"
        )
    if extension == ".obj":
        dropped = sorted(set(fields) - _OBJ_POINT_DATA)
        if dropped:
            raise ValueError(
                f".obj files only store point data 'obj:vn' and 'obj:vt', got {dropped}; "
                "use .vtu, .vtk or .ply"
            )
    if extension == ".ply":
        fields = _split_vector_fields(fields)

    mesh = meshio.Mesh(V, [("triangle", F)], point_data=fields)
    try:
        write_atomically(path, lambda partial: meshio.write(partial, mesh))
    except (meshio.ReadError, meshio.WriteError) as error:
        # meshio reports an unknown extension as a ReadError even when writing.
        raise ValueError(f"cannot write mesh file {path}: {error}") from error


class FrameSeries:
    """Numbered mesh files of a simulation run plus a ParaView collection that indexes them.

    Frame k is written to ``folder/{stem}_{k:05d}.{fmt}`` (k = 0, 1, ...). Frames may differ
    in vertex and face count, e.g. across a topology change. For the VTK formats ("vtu",
    "vtk") the collection ``folder/{stem}.pvd`` lists every frame written so far with its
    time (one ``<DataSet timestep=... file=...>`` per frame, paths relative to the .pvd). It
    is valid after every frame, so an interrupted run can still be opened in ParaView, and a
    frame adds its line in O(1) (the closing tags are written over, not the whole file:
    ``pvd_bytes_written``), so the thousandth frame costs what the first did.
    For "ply" and "obj" no .pvd is written (``pvd_path`` is None): a .pvd collection is
    meant for VTK XML/legacy files, and ParaView groups numbered files of other formats by
    itself. An existing .pvd or frame file of the same name is overwritten.

    Parameters
    ----------
    folder : str or os.PathLike
        Output folder, created (with its parents) if missing.
    stem : str
        File name prefix; must be non-empty and contain no path separator.
    fmt : {"vtu", "ply", "obj", "vtk"}
        Frame file format. "obj" cannot store point data.
    frames : list of (float, path), optional
        Frames already written (e.g. by the run a resumed run continues, possibly in another
        folder): they stay in the collection and numbering continues after them.

    Attributes
    ----------
    frames : list of (float, pathlib.Path)
        Time in seconds and path of every frame written, in order.
    pvd_path : pathlib.Path or None
        The collection file, or None for "ply" and "obj".

    Raises
    ------
    ValueError
        If fmt is not one of the formats above (the message lists them) or stem is invalid.

    Examples
    --------
    >>> with FrameSeries("out") as series:          # doctest: +SKIP
    ...     series.write(sim.time, cloth.positions, cloth.faces)
    """

    formats = ("vtu", "vtk", "ply", "obj")

    def __init__(self, folder, stem="frame", fmt="vtu", frames=None):
        if fmt not in self.formats:
            raise ValueError(f"fmt must be one of {list(self.formats)}, got {fmt!r}")
        if not isinstance(stem, str) or not stem or "/" in stem or os.sep in stem:
            raise ValueError(f"stem must be a non-empty file name prefix, got {stem!r}")
        self.folder = Path(os.fspath(folder))
        self.stem = stem
        self.fmt = fmt
        self.frames: list[tuple[float, Path]] = [
            (float(t), Path(os.fspath(p))) for t, p in (frames or [])
        ]
        self.pvd_path = self.folder / f"{stem}.pvd" if fmt in ("vtu", "vtk") else None
        self._closed = False
        #: bytes of the collection the last `write` wrote: a few hundred, however many frames
        #: the series holds (the collection is appended to, not rewritten)
        self.pvd_bytes_written = 0
        self._pvd_tail_at = None  # where the closing tags begin, once this series wrote the file
        self.folder.mkdir(parents=True, exist_ok=True)

    def write(self, time, V, F, point_data=None) -> Path:
        """Write the next frame and update the collection; return the frame's path.

        Parameters
        ----------
        time : float
            Simulation time of the frame in seconds, finite.
        V, F, point_data
            As for :func:`save_mesh`.

        Raises
        ------
        ValueError
            If time is not a finite number, the series is closed, or :func:`save_mesh`
            rejects the mesh (no frame is recorded then).
        """
        if self._closed:
            raise ValueError("cannot write to a closed FrameSeries")
        if not isinstance(time, numbers.Real) or isinstance(time, bool) or not math.isfinite(time):
            raise ValueError(f"time must be a finite number of seconds, got {time!r}")
        path = self.folder / f"{self.stem}_{len(self.frames):05d}.{self.fmt}"
        save_mesh(path, V, F, point_data)
        self.frames.append((float(time), path))
        if self.pvd_path is not None:
            self._write_pvd()
        return path

    def close(self) -> None:
        """Finish the series; later writes raise ValueError. The .pvd is already up to date."""
        self._closed = True

    def __enter__(self) -> FrameSeries:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def __len__(self) -> int:
        return len(self.frames)

    def _write_pvd(self) -> None:
        """Adds the newest frame to the collection in O(1): its line and the closing tags are
        written over the old closing tags, in one write of a few hundred bytes (the file is
        valid before and after it). The whole file is written (atomically, by a rename) only
        when the series first writes it or the file is not as this series left it."""
        tail = _PVD_TAIL.encode()
        entry = self._pvd_entry(*self.frames[-1]).encode()
        if self._pvd_tail_at is not None:
            try:
                with open(self.pvd_path, "r+b") as stream:
                    stream.seek(self._pvd_tail_at)
                    if stream.read() == tail:  # as this series left it
                        stream.seek(self._pvd_tail_at)
                        stream.write(entry + tail)
                        self._pvd_tail_at += len(entry)
                        self.pvd_bytes_written = len(entry) + len(tail)
                        return
            except OSError:
                pass  # (gone or unreadable: written whole below)
        head = _pvd_head().encode()
        body = b"".join(self._pvd_entry(t, p).encode() for t, p in self.frames)
        partial = self.pvd_path.with_name(self.pvd_path.name + ".part")
        partial.write_bytes(head + body + tail)
        os.replace(partial, self.pvd_path)
        self._pvd_tail_at = len(head) + len(body)
        self.pvd_bytes_written = len(head) + len(body) + len(tail)

    def _pvd_entry(self, time, path) -> str:
        # repr gives the shortest text that reads back as the same float
        name = Path(os.path.relpath(path, self.folder)).as_posix()
        return (
            f'    <DataSet timestep={quoteattr(repr(float(time)))} group="" part="0" '
            f"file={quoteattr(name)} />\n"
        )


_PVD_TAIL = "  </Collection>\n</VTKFile>\n"


def _pvd_head() -> str:
    order = "LittleEndian" if sys.byteorder == "little" else "BigEndian"
    return (
        "<?xml version='1.0' encoding='utf-8'?>\n"
        f'<VTKFile type="Collection" version="0.1" byte_order="{order}">\n'
        "  <Collection>\n"
    )


def _as_positions(V) -> np.ndarray:
    """V as an (n, 3) float64 C-contiguous array of finite numbers, else ValueError."""
    array = np.asarray(V)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"V must be an (n, 3) array of positions, got shape {array.shape}")
    if array.dtype.kind not in "iuf":
        raise ValueError(f"V must hold real numbers, got dtype {array.dtype}")
    array = np.ascontiguousarray(array, dtype=np.float64)
    if not np.isfinite(array).all():
        row = int(np.flatnonzero(~np.isfinite(array).all(axis=1))[0])
        raise ValueError(f"V must be finite, vertex {row} is {array[row].tolist()}")
    return array


def _as_faces(F, vertex_count: int) -> np.ndarray:
    """F as an (f, 3) int32 C-contiguous array of indices in [0, vertex_count), else ValueError."""
    array = np.asarray(F)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"F must be an (f, 3) array of vertex indices, got shape {array.shape}")
    if array.dtype.kind not in "iu":
        raise ValueError(f"F must hold integers, got dtype {array.dtype}")
    if array.size:
        low, high = array.min(), array.max()
        if low < 0 or high >= vertex_count:
            bad = low if low < 0 else high
            raise ValueError(f"F holds vertex index {bad}, outside [0, {vertex_count})")
    return np.ascontiguousarray(array, dtype=np.int32)


def _as_point_data(point_data, vertex_count: int) -> dict[str, np.ndarray]:
    """Point data as a dict of float64 (n,) or (n, k) arrays, else ValueError."""
    if point_data is None:
        return {}
    if not isinstance(point_data, Mapping):
        raise ValueError(
            f"point_data must be a mapping of names to arrays, got {type(point_data).__name__}"
        )
    fields = {}
    for name, value in point_data.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"point_data names must be non-empty strings, got {name!r}")
        array = np.asarray(value)
        if array.dtype.kind not in "biuf":
            raise ValueError(f"point_data[{name!r}] must be numeric, got dtype {array.dtype}")
        if array.ndim not in (1, 2) or array.shape[0] != vertex_count:
            raise ValueError(
                f"point_data[{name!r}] must have shape ({vertex_count},) or ({vertex_count}, k), "
                f"got {array.shape}"
            )
        fields[name] = np.ascontiguousarray(array, dtype=np.float64)
    return fields


def _split_vector_fields(fields: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Replace every (n, k) field by k scalar fields, as PLY needs; reject clashing names."""
    scalars = {}
    for name, array in fields.items():
        if array.ndim == 1:
            parts = {name: array}
        else:
            suffixes = ("x", "y", "z") if array.shape[1] == 3 else range(array.shape[1])
            parts = {f"{name}_{suffix}": array[:, k].copy() for k, suffix in enumerate(suffixes)}
        for part in parts:
            if part in scalars or part in ("x", "y", "z") or any(c.isspace() for c in part):
                raise ValueError(
                    f"point_data field {part!r} cannot be written to PLY: it clashes with another "
                    "field or a coordinate, or contains whitespace"
                )
        scalars.update(parts)
    return scalars
