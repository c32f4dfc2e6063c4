"""The progress bar of long steps (`yore.Simulation.step`/`advance`, `settle`): tqdm's, shown
unasked on a terminal only (never in a log file), or always when asked (progress=True)."""

from __future__ import annotations

__all__ = ["open_bar", "AFTER_SECONDS"]

#: A run expected to take longer than this shows a bar unasked (progress=None), s.
AFTER_SECONDS = 2.0


def open_bar(total, initial, description, progress):
    """A tqdm bar of ``total`` steps from ``initial``; ``progress`` None shows it on a terminal
    only, True always."""
    from tqdm.auto import tqdm

    return tqdm(
        total=total,
        initial=initial,
        unit="step",
        desc=description,
        leave=False,
        dynamic_ncols=True,
        disable=None if progress is None else False,
    )
