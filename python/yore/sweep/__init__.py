"""Parameter sweeps on Dask: a grid of scene variations, one task per cell, results as an
xarray Dataset in NetCDF.

- `load_sweep` (`yore.sweep.sweep_file`): read and check a sweep file, every cell's scene
  included; the file's format and the `Sweep` it gives are `yore.sweep.spec`'s.
- `run`, `resume` (`yore.sweep.run`): run it on a local Dask cluster or a scheduler's.
- `open_results` (`yore.sweep.results`): the Dataset of a sweep folder.
- `heat_map` (`yore.sweep.plot`): any recorded value over any two dimensions.

Dask and xarray are imported only when a sweep runs or its results are read, so ``import
yore`` does not pay for them.
"""

from __future__ import annotations

from .plot import heat_map
from .results import open_results
from .run import resume, run
from .spec import Sweep, SweepError
from .sweep_file import load_sweep

__all__ = ["load_sweep", "run", "resume", "open_results", "heat_map", "Sweep", "SweepError"]
