"""Argument checks shared across the package: one place for the rules every layer applies to
numbers, points, faces, colours and images, so the same bad value gets the same message
wherever it is passed (the core API, scene files, pictures, the viewer). The rules of numbers
are `yore.rules`' (the one rule type of options, scene files and state files).

Each check returns the value in its canonical form (float, int, float64 or int64 array) or
raises ValueError naming the argument, what it got and what it expects.
"""

from __future__ import annotations

import numpy as np

from .limits import LIMITS
from . import rules

__all__ = [
    "MAX_IMAGE_SIDE",
    "MAX_IMAGE_PIXELS",
    "check_image_size",
    "check_factor",
    "check_integer",
    "check_points",
    "check_faces",
    "check_vector",
    "check_unit_rgb",
    "check_image",
    "check_count",
    "check_vertex_values",
]

#: Most threads `yore.set_num_threads` accepts (each OpenMP thread is an operating-system thread).
MAX_THREADS = LIMITS.max_threads
#: Most steps one `Simulation.step`/`advance` call, or one run of a scene, may take (a run past
#: it needs ``yore run --allow-long``): 1e8 explicit steps of a small cloth are hours.
MAX_STEPS = LIMITS.max_steps
#: Smallest time step, s (a smaller one only overflows step counts: 1 s is then 1e12 steps).
MIN_DT = LIMITS.min_dt
#: Largest simulated time, s (about 32 years): a scene's duration, a stroke's time, a state's
#: clock. Past it step counts lose their meaning (1e308 s overflowed them).
MAX_TIME = LIMITS.max_time
#: Most pseudo-time `Simulation.settle` may spend, s (20 000 backward-Euler steps of 0.5 s).
MAX_SETTLE_SECONDS = LIMITS.max_settle_seconds
#: Largest rest-length factor of a stroke (the paper's is 1.1): a new spring at most ten times
#: its current length. Past it the springs' energy overflows (1e300 gave an infinite energy).
MAX_EXPANSION = LIMITS.max_expansion
#: Smallest rest-length factor of a stroke: a new spring at least a tenth of its current length
#: (the bound mirrors MAX_EXPANSION; 5e-324 gave rest lengths of 0, a state no file can hold).
MIN_EXPANSION = 1.0 / MAX_EXPANSION
#: Largest mass_scale of a stroke (the paper's is 0.95): a new vertex at most ten times its
#: corners' mean mass (1e308 gave masses beyond what a cloth may hold, a state no file can hold).
MAX_MASS_SCALE = LIMITS.max_mass_scale

#: Largest image a camera may have: each side at most MAX_IMAGE_SIDE pixels and at most
#: MAX_IMAGE_PIXELS pixels in all (2^23, e.g. 3840×2160), checked before anything is allocated.
MAX_IMAGE_SIDE = LIMITS.max_image_side
MAX_IMAGE_PIXELS = LIMITS.max_image_pixels

# The rules of `yore.rules` these checks apply (their messages are the arguments' own).
_IMAGE_SIDE = rules.count(1, MAX_IMAGE_SIDE)
_FACTOR = rules.real(0.0)
_COUNT = rules.count(0)


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def check_image_size(width, height, what="camera"):
    """(width, height) as ints if both are integers in [1, MAX_IMAGE_SIDE] whose product is at
    most MAX_IMAGE_PIXELS; ValueError naming the side, its value and the limit otherwise."""
    for name, value in (("width", width), ("height", height)):
        if not _IMAGE_SIDE.test(value)[0]:
            raise ValueError(
                f"{what} {name}: got {type(value).__name__} {_short(value)}; "
                f"expected an integer number of pixels in [1, {MAX_IMAGE_SIDE}]"
            )
    if int(width) * int(height) > MAX_IMAGE_PIXELS:
        raise ValueError(
            f"{what} image size: {int(width)}×{int(height)} = "
            f"{int(width) * int(height)} pixels is more than the limit of "
            f"{MAX_IMAGE_PIXELS} pixels"
        )
    return int(width), int(height)


def check_factor(value, name: str, unit: str = "") -> float:
    """`value` as a finite float > 0; ValueError naming `name` otherwise."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise ValueError(f"{name} must be a number{unit and f' ({unit})'}, got {value!r}")
    try:
        number = float(value)  # numbers of any type float() takes (numpy scalars, 0-d arrays)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a number{unit and f' ({unit})'}, got {_short(value)}"
        ) from None
    if not _FACTOR.test(number)[0]:
        raise ValueError(f"{name} must be finite and > 0{unit and f' ({unit})'}, got {number}")
    return number


def check_integer(value, name, minimum, maximum=None) -> int:
    """`value` as an int if it is an integer (bool refused) in [minimum, maximum];
    ValueError naming `name` otherwise."""
    rule = rules.count(minimum, maximum)
    if not rule.test(value)[0]:
        raise ValueError(f"{name} must be {rule.expected}, got {_short(value)}")
    return int(value)


def check_points(points, name, allow_empty=True) -> np.ndarray:
    """A (k, 3) finite float64 array, or ValueError naming `name`."""
    try:
        array = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a (k, 3) array of numbers, got {_short(points)}"
        ) from None
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (k, 3), got {array.shape}")
    if not allow_empty and len(array) == 0:
        raise ValueError(f"{name} is empty: it needs at least one point")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise ValueError(
            f"{name} must be finite, got {array[tuple(bad)]} at {name}[{bad[0]}, {bad[1]}]"
        )
    return array


def check_faces(F, vertex_count, name="F") -> np.ndarray:
    """F as a (f, 3) int64 array of indices in [0, vertex_count), or ValueError."""
    faces = np.asarray(F)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"{name} must have shape (f, 3), got {faces.shape}")
    if faces.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if faces.dtype.kind not in "iu":
        raise ValueError(f"{name} must hold integer vertex indices, got dtype {faces.dtype}")
    low, high = int(faces.min()), int(faces.max())
    if low < 0 or high >= vertex_count:
        bad = low if low < 0 else high
        raise ValueError(
            f"{name} holds vertex index {bad}, outside [0, {vertex_count}) for "
            f"{vertex_count} vertices"
        )
    return faces.astype(np.int64)


def check_vertex_values(values, count, name="values") -> np.ndarray:
    """(count,) finite float64 values, or ValueError."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numbers, got {_short(values)}") from None
    if array.shape != (count,):
        raise ValueError(f"{name} must have shape ({count},), got {array.shape}")
    if not np.all(np.isfinite(array)):
        index = int(np.flatnonzero(~np.isfinite(array))[0])
        raise ValueError(f"{name} must be finite, got {array[index]} at index {index}")
    return array


def check_vector(vector, name) -> np.ndarray:
    """3 finite numbers, not all zero, as a float64 array; ValueError otherwise."""
    try:
        value = np.asarray(vector, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 finite numbers, got {_short(vector)}") from None
    if value.shape != (3,) or not np.all(np.isfinite(value)) or not np.any(value):
        raise ValueError(f"{name} must be 3 finite numbers, not all zero, got {_short(vector)}")
    return value


def check_unit_rgb(rgb, name) -> np.ndarray:
    """An RGB colour as 3 numbers in [0, 1]; ValueError otherwise."""
    try:
        value = np.asarray(rgb, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 numbers in [0, 1], got {_short(rgb)}") from None
    if value.shape != (3,) or not np.all((value >= 0.0) & (value <= 1.0)):
        raise ValueError(f"{name} must be 3 numbers in [0, 1] (RGB), got {_short(rgb)}")
    return value


def check_image(image, name) -> np.ndarray:
    """An (h, w, 3) uint8 RGB image (h, w >= 1), C-contiguous; ValueError otherwise."""
    array = np.asarray(image)
    if array.dtype != np.uint8:
        raise ValueError(f"{name} must have dtype uint8, got {array.dtype}")
    if array.ndim != 3 or array.shape[2] != 3 or array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"{name} must have shape (h, w, 3) with h, w >= 1, got {array.shape}")
    return np.ascontiguousarray(array)


def check_count(value, name, unit="pixels") -> int:
    """An integer >= 0 (bool refused); ValueError otherwise."""
    if not _COUNT.test(value)[0]:
        raise ValueError(f"{name} must be {_COUNT.expected} ({unit}), got {_short(value)}")
    return int(value)
