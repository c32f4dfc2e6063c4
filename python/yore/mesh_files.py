"""Reading mesh files safely (`yore.io` loads meshes and frames with it): the size limit,
the file-kind check, meshio's readers called without their ``sys.exit``, and a budget for
what a .vtu file's compressed arrays may inflate to."""

from __future__ import annotations

from .limits import LIMITS

import contextlib
import errno
import os
import re
import stat
import threading
from pathlib import Path

import meshio
from meshio._helpers import reader_map as _meshio_readers  # see read_with_meshio

#: Largest mesh (or frame) file read, bytes (512 MiB, some ten million triangles as binary
#: PLY): meshio reads a file whole, and parsing takes a few times its size in memory, so a
#: larger file is refused before it is opened.
MAX_MESH_FILE_BYTES = LIMITS.max_mesh_file_bytes


def check_mesh_file(path: Path) -> Path:
    """``path`` if it names a regular file of at most MAX_MESH_FILE_BYTES; FileNotFoundError
    if it does not exist, ValueError naming it otherwise. Uses stat, never open, so a FIFO or
    a device (a link to /dev/zero) is refused without blocking or reading."""
    try:
        info = os.stat(path)  # follows symbolic links: a link to /dev/zero is a device
    except FileNotFoundError:
        raise FileNotFoundError(errno.ENOENT, "mesh file not found", str(path)) from None
    except OSError as error:
        raise ValueError(f"cannot read mesh file {path}: {error.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        kind = (
            "a directory"
            if stat.S_ISDIR(info.st_mode)
            else "a FIFO"
            if stat.S_ISFIFO(info.st_mode)
            else "a device"
            if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode)
            else "a socket"
            if stat.S_ISSOCK(info.st_mode)
            else "not a regular file"
        )
        raise ValueError(f"cannot read mesh file {path}: it is {kind}, not a regular file")
    if info.st_size > MAX_MESH_FILE_BYTES:
        raise ValueError(
            f"cannot read mesh file {path}: {info.st_size} bytes is more than the "
            f"limit of {MAX_MESH_FILE_BYTES} bytes ({MAX_MESH_FILE_BYTES >> 20} MiB)"
        )
    return path


def read_with_meshio(path: Path) -> meshio.Mesh:
    """meshio.read without its exit: raise ValueError with meshio's reason instead.

    meshio.read (5.3.5) prints the reader's ReadError and calls sys.exit(1) when no reader
    for the extension accepts the file, so the readers are called here directly.
    """
    formats = []
    suffix = ""
    # Candidate formats as meshio deduces them: the last suffix first, then longer
    # multi-dot extensions.
    for part in reversed(path.suffixes):
        suffix = (part + suffix).lower()
        formats += meshio.extension_to_filetypes.get(suffix, [])
    if not formats:
        raise ValueError(
            f"cannot read mesh file {path}: meshio knows no format for extension {path.suffix!r}"
        )
    reasons = []
    for name in formats:
        try:
            if name == "vtu":
                with _inflation_budget(path):
                    return _meshio_readers[name](str(path))
            return _meshio_readers[name](str(path))
        except _Inflated as error:
            raise ValueError(f"cannot read mesh file {path}: {error}") from None
        except meshio.ReadError as error:
            # Some readers raise a ReadError without a message; the parser's own exception,
            # if it has text, is then the best reason there is.
            inner = error.__cause__ or error.__context__
            if str(error):
                reasons.append(f"as {name}: {error}")
            elif inner is not None and str(inner):
                reasons.append(f"as {name}: {type(inner).__name__}: {inner}")
            else:
                reasons.append(f"as {name}: malformed file (meshio gave no detail)")
        except OSError as error:
            # Readers raise OSError for truncated content as well as for unreadable files.
            reasons.append(f"as {name}: {error.strerror or error}")
        except (MemoryError, RecursionError) as error:
            reasons.append(
                f"as {name}: {type(error).__name__} (the file's content is too "
                "large or too deeply nested)"
            )
        except SystemExit:
            # Some meshio readers exit on a malformed header instead of raising.
            reasons.append(f"as {name}: malformed file (meshio gave up)")
        except Exception as error:
            # meshio's parsers raise whatever their tokenizer hits on a malformed file.
            reasons.append(f"as {name}: {type(error).__name__}: {error}")
    text = " ".join("; ".join(reasons).split())  # one line, however meshio formats its reasons
    if len(text) > 400:
        text = text[:397] + "..."
    raise ValueError(f"cannot read mesh file {path}: {text}")


class _Inflated(Exception):
    """A compressed mesh file inflated past its budget (the message says how far)."""


_VTU_ITEM_BYTES = {
    b"Int8": 1,
    b"UInt8": 1,
    b"Int16": 2,
    b"UInt16": 2,
    b"Int32": 4,
    b"UInt32": 4,
    b"Float32": 4,
    b"Int64": 8,
    b"UInt64": 8,
    b"Float64": 8,
}
_INFLATION_LOCK = threading.Lock()


#: A .vtu file's compressed arrays may inflate to at most this many times the file's own size
#: (plus 1 MiB). The shapes its XML declares are the file's word only: a forged point count
#: let a 1.4 MB file inflate to 1.1 GB before it was refused (issue 53, N08). Measured on
#: yore's own files: 6× for meshes, ~20× for frames whose point data are zeros; zlib cannot
#: pass ~1030× on anything.
VTU_MAX_INFLATION_RATIO = 64


def vtu_inflation_budget(data: bytes) -> int:
    """Bytes a .vtu file's compressed arrays may inflate to, from the shapes its XML declares:
    8 × (points + cells) entries of every DataArray (components × item size each; a triangle's
    connectivity is 3 entries per cell), at most `VTU_MAX_INFLATION_RATIO` × the file's size
    + 1 MiB (a forged count does not raise it past that) and at most `MAX_MESH_FILE_BYTES`
    (content past it is refused as a file past it would be)."""
    entities = sum(
        int(n) for n in re.findall(rb'NumberOf(?:Points|Cells)\s*=\s*"(\d{1,18})"', data)
    )
    per_entity = 0
    for tag in re.findall(rb"<DataArray\b[^>]*>", data):
        kind = re.search(rb'\stype\s*=\s*"(\w+)"', tag)
        components = re.search(rb'NumberOfComponents\s*=\s*"(\d{1,9})"', tag)
        per_entity += _VTU_ITEM_BYTES.get(kind.group(1) if kind else b"", 8) * (
            int(components.group(1)) if components else 1
        )
    return min(
        8 * entities * per_entity + (64 << 10),
        VTU_MAX_INFLATION_RATIO * len(data) + (1 << 20),
        MAX_MESH_FILE_BYTES,
    )


class _BudgetedDecompressor:
    """Stands in for meshio's ``zlib``/``lzma`` module while a .vtu file is read: its
    ``decompress`` inflates at most the bytes left in the shared budget (never more), and
    raises _Inflated past it."""

    def __init__(self, make, budget):
        self.make, self.budget = make, budget

    def decompress(self, data):
        left = self.budget["left"]
        decompressor = self.make()
        inflated = decompressor.decompress(data, left + 1)
        if len(inflated) > left:
            raise _Inflated(
                f"its compressed arrays inflate to more than the "
                f"{self.budget['total']} bytes its declared shapes allow "
                "(refused while inflating)"
            )
        if not decompressor.eof:  # (what zlib.decompress would refuse)
            raise ValueError("a compressed block is truncated")
        self.budget["left"] = left - len(inflated)
        return inflated


@contextlib.contextmanager
def _inflation_budget(path):
    """meshio's VTU reader with `vtu_inflation_budget` bytes to inflate, shared by every
    compressed block of the file."""
    import lzma
    import zlib

    from meshio.vtu import _vtu

    budget = vtu_inflation_budget(Path(path).read_bytes())
    shared = {"left": budget, "total": budget}
    with _INFLATION_LOCK:
        saved = _vtu.zlib, _vtu.lzma
        _vtu.zlib = _BudgetedDecompressor(zlib.decompressobj, shared)
        _vtu.lzma = _BudgetedDecompressor(lzma.LZMADecompressor, shared)
        try:
            yield
        finally:
            _vtu.zlib, _vtu.lzma = saved
