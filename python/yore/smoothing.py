"""Rest-length smoothing: Laplacian smoothing of the ratio rest / reference length of springs
(the paper's remedy for uneven surfaces), optionally conserving the rest length a stroke added.
`yore.Simulation.smooth_rest_lengths` and a stroke's smoothing stage call it."""

from __future__ import annotations

import numpy as np

from .metrics import rest_ratio_roughness, spring_mean_around_ends
from .options import SMOOTHING_RULES, show_value
from .rules import Invalid

__all__ = ["smooth_rest_lengths", "around_faces", "checked_arguments"]


def around_faces(cloth, faces) -> np.ndarray:
    """The vertices of ``faces`` and one ring of springs around them (a stroke's region)."""
    ends = cloth.springs.ends
    region_vertices = np.unique(cloth.faces[faces])
    ring = np.isin(ends, region_vertices).any(axis=1)
    return np.unique(ends[ring])


def smooth_rest_lengths(cloth, iterations, strength, region, conserve) -> dict:
    """Smooths the rest lengths of the springs touching ``region`` (vertex indices, or "all")
    as `yore.Simulation.smooth_rest_lengths` documents; returns its figures. ValueError for
    bad arguments (named as that method's)."""
    iterations, strength, conserve = checked_arguments(iterations, strength, conserve)
    selected = _selected_springs(cloth, region)
    reference = cloth.springs.reference
    ratio = cloth.springs.rest / reference
    before = rest_ratio_roughness(cloth, np.flatnonzero(selected))
    added_before = _added(ratio, reference, selected)
    for _ in range(iterations):
        neighbour = spring_mean_around_ends(cloth, ratio)
        ratio = np.where(selected, (1.0 - strength) * ratio + strength * neighbour, ratio)
    added_after = _added(ratio, reference, selected)
    if conserve and added_before != 0.0 and added_after * added_before > 0.0:
        scaled = np.where(selected, 1.0 + (ratio - 1.0) * (added_before / added_after), ratio)
        if np.all(scaled > 0.0):  # a mixed-sign excess could scale a ratio through zero
            ratio = scaled
            added_after = _added(ratio, reference, selected)
    cloth.springs.rest = ratio * reference
    return {
        "springs": int(selected.sum()),
        "roughness_before": before,
        "roughness_after": rest_ratio_roughness(cloth, np.flatnonzero(selected)),
        "rest_added_before": added_before,
        "rest_added_after": added_after,
    }


def checked_arguments(iterations, strength, conserve):
    """(iterations, strength, conserve) by `yore.options.SMOOTHING_RULES`; ValueError."""
    return tuple(
        _checked(SMOOTHING_RULES[name], value, f"smooth_rest_lengths {name}")
        for name, value in (
            ("iterations", iterations),
            ("strength", strength),
            ("conserve", conserve),
        )
    )


def _added(ratio, reference, selected) -> float:
    """Rest length the selected springs hold beyond their reference lengths, m."""
    return float(np.sum((ratio[selected] - 1.0) * reference[selected]))


def _selected_springs(cloth, region) -> np.ndarray:
    """Which springs ``region`` ("all" or vertex indices) smooths: those with an end in it."""
    ends = cloth.springs.ends
    if isinstance(region, str):
        if region != "all":
            raise ValueError(f"region must be vertex indices, 'all' or None, got {region!r}")
        return np.ones(len(ends), dtype=bool)
    return np.isin(ends, _region_indices(region, cloth.vertex_count)).any(axis=1)


def _checked(rule, value, what):
    """``value`` checked by a `yore.rules.Rule`: ValueError "WHAT: got ...; expected ..."."""
    try:
        return rule(value)
    except Invalid as invalid:
        raise ValueError(f"{what}: {invalid.problem}; expected {invalid.expected}") from None


def _region_indices(region, vertex_count):
    """``region`` of `Simulation.smooth_rest_lengths` as a 1-D int64 array of vertex indices in
    [0, vertex_count); ValueError otherwise (floats, booleans, nested lists, out of range)."""
    expected = f"None, 'all' or vertex indices (integers in [0, {vertex_count}))"
    if isinstance(region, (bool, np.bool_, float, dict, set)):
        raise ValueError(
            f"smooth_rest_lengths region: got {show_value(region)}; expected {expected}"
        )
    try:
        array = np.asarray(region)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(
            f"smooth_rest_lengths region: got {show_value(region)}; expected {expected}"
        ) from None
    if array.dtype.kind not in "iu" and not (array.size == 0 and array.dtype.kind == "f"):
        raise ValueError(
            f"smooth_rest_lengths region: got {show_value(region)} (dtype "
            f"{array.dtype}); expected {expected}"
        )
    if array.ndim > 1:
        raise ValueError(
            f"smooth_rest_lengths region: got an array of shape {array.shape}; expected {expected}"
        )
    array = array.reshape(-1)
    if array.size and (array.min() < 0 or array.max() >= vertex_count):
        bad = array.min() if array.min() < 0 else array.max()
        raise ValueError(
            f"smooth_rest_lengths region: vertex {int(bad)} is out of range; expected {expected}"
        )
    return array.astype(np.int64)
