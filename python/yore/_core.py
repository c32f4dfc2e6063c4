"""yore's C++ core as the package uses it: the compiled extension `yore._native`, loaded here
once the BLAS kernels CHOLMOD will run on are chosen (`yore.blas`: OpenBLAS reads that choice
the moment it loads, so it must come first). Every module of the package reaches the core
through this one, whichever of them is imported first; nothing else is done on loading it."""

from . import blas as _blas

_blas.prepare(in_command=_blas.in_command())
from . import _native  # noqa: E402  (the load the choice is for)

_blas.finish(in_command=_blas.in_command())

globals().update(
    {name: value for name, value in vars(_native).items() if not name.startswith("__")}
)
