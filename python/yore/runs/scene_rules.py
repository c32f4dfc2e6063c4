"""The scene file's rules: `yore.rules.Rule`s of TOML's own types (numpy's are no TOML value),
whose errors say "got float 3.5" and, for a number out of its bounds, just the number; and the
checks of its shaped values (points, polygons, vectors, vertex indices), which name the part at
fault. `yore.runs.schema` declares each key of a scene file with one of them."""

from __future__ import annotations

import difflib
import math

import numpy as np

from .. import rules
from ..rules import Invalid
from ..checks import MAX_MASS_SCALE
from ..camera import MAX_CAMERA_COORDINATE
from ..limits import LIMITS
from ..meshes import MAX_PATTERN_COORDINATE

__all__ = [
    "describe_value",
    "did_you_mean",
    "number",
    "number_or_auto",
    "integer",
    "boolean",
    "string",
    "choice",
    "points",
    "polygons",
    "vector3",
    "camera_vector",
    "point",
    "indices",
    "mass_scale",
]

#: Largest integer any key takes (vertex indices, sizes, counts): the core's int32 range.
MAX_INTEGER = LIMITS.max_integer


def describe_value(value):
    """A value as scene errors quote it (`yore.rules.describe`)."""
    return rules.describe(value)


def did_you_mean(key, candidates):
    close = difflib.get_close_matches(str(key), [str(c) for c in candidates], n=2, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


# The scene file's rules: `yore.rules.Rule`s of TOML's own types (numpy's are no TOML value),
# whose errors say "got float 3.5" and, for a number out of its bounds, just the number.
def got(value):
    return f"got {describe_value(value)}"


def got_number(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return got(value)
    return f"got {float(value):g}" if math.isfinite(value) else f"got {float(value)}"


def number(minimum=None, maximum=None, strict_minimum=False, unit="", strict_maximum=False):
    bounds = []
    if minimum is not None:
        bounds.append(f"{'>' if strict_minimum else '>='} {minimum:g}")
    if maximum is not None:
        bounds.append(f"{'<' if strict_maximum else '<='} {maximum:g}")
    expected = (
        "a number" + (f" {' and '.join(bounds)}" if bounds else "") + (f" ({unit})" if unit else "")
    )
    return rules.real(
        minimum,
        maximum,
        low_open=strict_minimum,
        high_open=strict_maximum,
        expected=expected,
        problem=got_number,
        python_types=True,
    )


def number_or_auto(minimum=None, unit=""):
    rule = number(minimum, unit=unit)

    def test(value):
        return (True, value) if value == "auto" else rule.test(value)

    return rules.custom(test, f'{rule.expected} or "auto"', problem=got_number)


def integer(minimum, maximum=MAX_INTEGER):
    expected = (
        f"an integer >= {minimum}"
        if maximum == MAX_INTEGER
        else f"an integer in [{minimum}, {maximum}]"
    )

    def problem(value):
        if not isinstance(value, bool) and isinstance(value, int) and value > maximum:
            return f"{got(value)}, more than the limit {maximum}"
        return got(value)

    return rules.count(minimum, maximum, expected=expected, problem=problem, python_types=True)


boolean = rules.flag("true or false", problem=got, python_types=True)
string = rules.text(problem=got)


def choice(*choices):
    # TOML values compare by equality here (a choice of names only ever gets strings through)
    return rules.custom(
        lambda value: (value in choices, value),
        "one of " + ", ".join(repr(c) for c in choices),
        problem=got,
    )


def shaped(check):
    """A checker that returns the value or raises `Invalid` with its own problem (which point
    of a list), as a `yore.rules.Rule`."""
    return rules.custom(lambda value: (True, check(value)), check.expected, problem=got)


def points(dimension, what):
    expected = f"a list of {what} points"

    def check(value):
        if not isinstance(value, list) or not value:
            raise Invalid(f"got {describe_value(value)}", expected)
        for point in value:
            if (
                not isinstance(point, list)
                or len(point) != dimension
                or any(
                    isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
                    for c in point
                )
            ):
                raise Invalid(f"got the point {point!r}", expected)
        return np.asarray(value, dtype=np.float64)

    check.expected = expected
    return shaped(check)


def polygons(value):
    if not isinstance(value, list):
        raise Invalid(f"got {describe_value(value)}", polygons.expected)
    outline = points(2, "[u, v]")
    checked = []
    for k, polygon in enumerate(value):
        try:
            checked.append(outline(polygon))
        except Invalid as error:
            raise Invalid(f"hole {k}: {error.problem}", polygons.expected) from None
    return checked


polygons.expected = "a list of polygons, each a list of [u, v] points"


def vector3(value):
    if (
        not isinstance(value, list)
        or len(value) != 3
        or any(
            isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c)
            for c in value
        )
    ):
        raise Invalid(f"got {describe_value(value)}", "3 numbers [x, y, z]")
    return np.asarray(value, dtype=np.float64)


vector3.expected = "3 numbers [x, y, z]"


def camera_vector(value):
    vector = vector3(value)
    if np.abs(vector).max() > MAX_CAMERA_COORDINATE:
        raise Invalid("got [" + ", ".join(f"{c:g}" for c in vector) + "]", camera_vector.expected)
    return vector


camera_vector.expected = f"3 numbers [x, y, z] within ±{MAX_CAMERA_COORDINATE:g}"


def point(value):
    """A point of the scene, m (a driver's centre, a box's corner): within the coordinates a
    pattern may have, `MAX_PATTERN_COORDINATE` (a centre at 1e300 m passed `yore check` and
    made the run's first positions infinite)."""
    vector = vector3(value)
    if np.abs(vector).max() > MAX_PATTERN_COORDINATE:
        raise Invalid("got [" + ", ".join(f"{c:g}" for c in vector) + "]", point.expected)
    return vector


point.expected = f"3 numbers [x, y, z] within ±{MAX_PATTERN_COORDINATE:g} m"


def indices(value):
    expected = indices.expected
    if not isinstance(value, list) or not value:
        raise Invalid(f"got {describe_value(value)}", expected)
    for i in value:
        if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i <= MAX_INTEGER:
            raise Invalid(f"got the index {describe_value(i)}", expected)
    return np.asarray(value, dtype=np.int32)


indices.expected = "a list of vertex indices (integers in [0, 2147483647])"
polygons, vector3, camera_vector, point, indices = map(
    shaped, (polygons, vector3, camera_vector, point, indices)
)


def mass_scale(value):
    if value == "conserve" and isinstance(value, str):
        return value
    try:
        return positive_factor(value)
    except Invalid as error:
        raise Invalid(error.problem, mass_scale.expected) from None


positive_factor = number(0, MAX_MASS_SCALE, strict_minimum=True)
mass_scale.expected = f"a number in (0, {MAX_MASS_SCALE:g}] or 'conserve'"
mass_scale = shaped(mass_scale)
