"""Heat maps of a sweep's results: any recorded value over any two dimensions."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .results import open_results

__all__ = ["heat_map"]


def _selection(dataset, dims, x, y, select):
    """{dimension: index} fixing every dimension but ``x`` and ``y``: those ``select`` names
    by value, and the others' only value; ValueError naming a bad one."""
    selection = {}
    for name, wanted in (select or {}).items():
        if name not in dims or name in (x, y):
            raise ValueError(
                f"--select {name}: not one of the other dimensions "
                f"({', '.join(d for d in dims if d not in (x, y)) or 'none'})"
            )
        selection[name] = _index_of(dataset[name].values, name, wanted)
    rest = [d for d in dims if d not in (x, y) and d not in selection]
    for name in rest:
        if dataset.sizes[name] != 1:
            raise ValueError(
                f"dimension {name!r} has {dataset.sizes[name]} values; fix one "
                f"with --select {name}=VALUE"
            )
        selection[name] = 0
    return selection


def _index_of(coordinate, name, wanted):
    """The first index of ``wanted`` along a coordinate (as text, or as a number)."""
    matches = [
        k
        for k, c in enumerate(coordinate)
        if str(c) == str(wanted)
        or (_is_number(wanted) and _is_number(c) and float(c) == float(wanted))
    ]
    if not matches:
        raise ValueError(
            f"--select {name}={wanted}: not one of its values ({', '.join(map(str, coordinate))})"
        )
    return matches[0]


def _label_cells(ax, grid, status):
    """Each cell's value, or its status where it is not done."""
    for (i, j), number in np.ndenumerate(grid):
        text = (
            status[i, j]
            if status[i, j] not in ("done", "")
            else (f"{number:.3g}" if np.isfinite(number) else "–")
        )
        ax.text(
            j,
            i,
            text or "not run",
            ha="center",
            va="center",
            fontsize=7,
            color="white" if status[i, j] == "done" else "black",
        )


def heat_map(out, x, y, value, select=None, path=None, log=None) -> Path:
    """Writes a PNG heat map of ``value`` over dimensions ``x`` and ``y`` of the sweep in
    ``out`` (default OUT/<value>_<y>_<x>.png); the other dimensions must have one value or be
    fixed by ``select`` ({dimension: value}). Cells not done are shown by their status. ``log``:
    a logarithmic colour scale (default: when the values are positive and span 100×).
    Raises ValueError naming a bad dimension, value or selection."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    if path is not None:
        path = Path(path)
        if path.is_dir() or path.suffix.lower() != ".png":
            raise ValueError(
                f"the picture must be a .png file, got {str(path)!r}"
                + (" (a folder)" if path.is_dir() else "")
            )
    dataset = open_results(out)
    dims = _check_plot(out, dataset, x, y, value)
    selection = _selection(dataset, dims, x, y, select)
    cut = dataset.isel(selection) if selection else dataset
    grid = cut[value].transpose(y, x).values.astype(float)
    status = cut["status"].transpose(y, x).values
    fig, ax = plt.subplots(figsize=(1.2 + 0.9 * grid.shape[1], 1.2 + 0.6 * grid.shape[0]))
    finite = grid[np.isfinite(grid)]
    use_log = (
        log
        if log is not None
        else bool(finite.size and finite.min() > 0 and finite.max() / finite.min() >= 100)
    )
    norm = LogNorm(finite.min(), finite.max()) if use_log and finite.size else None
    image = ax.imshow(
        np.ma.masked_invalid(grid), origin="lower", cmap="viridis", norm=norm, aspect="auto"
    )
    fig.colorbar(image, ax=ax, label=value)
    _label_cells(ax, grid, status)
    ax.set_xticks(range(grid.shape[1]), [_label(c) for c in cut[x].values], rotation=30)
    ax.set_yticks(range(grid.shape[0]), [_label(c) for c in cut[y].values])
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    fixed = ", ".join(f"{n} = {_label(dataset[n].values[k])}" for n, k in selection.items())
    ax.set_title(value + (f" ({fixed})" if fixed else ""), fontsize=9)
    fig.tight_layout()
    path = Path(path) if path is not None else Path(out) / f"{value}_{y}_{x}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _check_plot(out, dataset, x, y, value):
    """The sweep's dimensions, after checking that ``x`` and ``y`` are two of them and
    ``value`` a recorded value."""
    if "status" not in dataset.data_vars or not dataset["status"].dims:
        raise ValueError(
            f"{Path(out) / 'results.nc'} is not a yore sweep's results (it has no status per cell)"
        )
    dims = list(dataset["status"].dims)
    for name, what in ((x, "--x"), (y, "--y")):
        if name not in dims:
            raise ValueError(
                f"{what} {name!r} is not a dimension of the sweep; its "
                f"dimensions: {', '.join(dims)}"
            )
    if x == y:
        raise ValueError("--x and --y must be two different dimensions")
    if value not in dataset.data_vars or value in ("status", "message"):
        names = sorted(v for v in dataset.data_vars if v not in ("status", "message"))
        raise ValueError(
            f"--value {value!r} is not recorded by this sweep; recorded: {', '.join(names)}"
        )
    return dims


def _is_number(value) -> bool:
    try:
        float(value)
        return True
    except (TypeError, ValueError):
        return False


def _label(value) -> str:
    if isinstance(value, (float, np.floating)):
        return f"{float(value):g}"
    return str(value)
