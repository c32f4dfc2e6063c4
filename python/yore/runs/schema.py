"""Scene files' schema: every table and key of a scene file with its validator, default and
description (`SCHEMA`), the error a wrong scene raises (`SceneError`) and the limits.

A scene file names the mesh (a generator with its sizes, or a mesh file), the material, fixed
and driven vertices, gravity, the integrator with its options and dt, the duration, strokes at
given times with their options and rest-length smoothing, the camera and the outputs. The
tables and keys are documented in docs/scene-files.md and in `SCHEMA` below; the example
scenes in ``examples/*.toml`` use all of them. `yore.runs.loading` checks a file against it.

Limits, checked before anything is built or allocated: a scene file is a regular file of at
most `MAX_SCENE_FILE_BYTES`; TOML nested deeper than Python can parse is refused (in the file
and in ``--set`` values); every integer is at most `MAX_INTEGER` (2^31 - 1, so vertex indices
fit the core's int32); a generated mesh has at most `yore.meshes.MAX_MESH_VERTICES` vertices
(nx·ny or rings·segments); the camera image at most `yore.checks.MAX_IMAGE_SIDE` pixels a side
and `yore.checks.MAX_IMAGE_PIXELS` in all; integrator options follow
`yore.simulation.check_option` (iteration counts up to `MAX_STEP_ITERATIONS`); smoothing
iterations at most `yore.options.MAX_SMOOTHING_ITERATIONS`; floats are finite.
"""

from __future__ import annotations

import difflib
import math

import numpy as np

from ..limits import LIMITS
from .. import rules
from ..rules import Invalid
from ..options import (
    ANIMATION_FORMATS,
    DEFAULT_INTEGRATOR,
    FOV_DEGREES,
    FOV_RULE,
    FRAMES_PER_SECOND,
    IMAGE_HEIGHT,
    IMAGE_WIDTH,
    INTEGRATORS,
    MASS,
    RUN_ANIMATION,
    SMOOTHING_DEFAULTS,
    SMOOTHING_RULES,
    STIFFNESS,
    STROKE_DEFAULTS,
)
from ..checks import (
    MAX_EXPANSION,
    MAX_IMAGE_SIDE,
    MAX_MASS_SCALE,
    MAX_SETTLE_SECONDS,
    MAX_THREADS,
    MAX_TIME,
    MIN_DT,
    MIN_EXPANSION,
)
from ..camera import MAX_CAMERA_COORDINATE
from ..meshes import MAX_PATTERN_COORDINATE, PATTERN_MIN_ANGLE
from .._core import PATTERN_MAX_ANGLE_DEGREES as PATTERN_MAX_ANGLE
from ..stroke import GROWTH_MODES, MAX_REFINE

__all__ = ["SceneError", "SCHEMA", "MAX_SCENE_FILE_BYTES", "MAX_INTEGER"]

#: Largest scene file read, bytes.
MAX_SCENE_FILE_BYTES = LIMITS.max_scene_file_bytes
#: Largest integer any key takes (vertex indices, sizes, counts): the core's int32 range.
MAX_INTEGER = LIMITS.max_integer


class SceneError(ValueError):
    """A scene file is wrong. ``key`` is the dotted key (e.g. ``strokes[1].time``), ``line``
    its line in the file (None when unknown or given on the command line), ``expected`` what
    would have been accepted."""

    def __init__(self, source, key, problem, expected=None, line=None):
        self.source, self.key, self.problem = source, key, problem
        self.expected, self.line = expected, line
        place = f"{source}:{line}" if line else str(source)
        text = f"{place}: {key}: {problem}" if key else f"{place}: {problem}"
        if expected:
            text += f"; expected {expected}"
        super().__init__(text)


# -- the schema ----------------------------------------------------------------------------------
# Each key maps to (checker, default, description). A checker takes a value and returns
# the checked value or raises Invalid(problem, expected). A default of REQUIRED means the key
# must be given; None means "absent unless given".

REQUIRED = object()


def describe_value(value):
    """A value as scene errors quote it (`yore.rules.describe`)."""
    return rules.describe(value)


def did_you_mean(key, candidates):
    close = difflib.get_close_matches(str(key), [str(c) for c in candidates], n=2, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


# The scene file's rules: `yore.rules.Rule`s of TOML's own types (numpy's are no TOML value),
# whose errors say "got float 3.5" and, for a number out of its bounds, just the number.
def _got(value):
    return f"got {describe_value(value)}"


def _got_number(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return _got(value)
    return f"got {float(value):g}" if math.isfinite(value) else f"got {float(value)}"


def _number(minimum=None, maximum=None, strict_minimum=False, unit="", strict_maximum=False):
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
        problem=_got_number,
        python_types=True,
    )


def _number_or_auto(minimum=None, unit=""):
    number = _number(minimum, unit=unit)

    def test(value):
        return (True, value) if value == "auto" else number.test(value)

    return rules.custom(test, f'{number.expected} or "auto"', problem=_got_number)


def _integer(minimum, maximum=MAX_INTEGER):
    expected = (
        f"an integer >= {minimum}"
        if maximum == MAX_INTEGER
        else f"an integer in [{minimum}, {maximum}]"
    )

    def problem(value):
        if not isinstance(value, bool) and isinstance(value, int) and value > maximum:
            return f"{_got(value)}, more than the limit {maximum}"
        return _got(value)

    return rules.count(minimum, maximum, expected=expected, problem=problem, python_types=True)


_boolean = rules.flag("true or false", problem=_got, python_types=True)
_string = rules.text(problem=_got)


def _choice(*choices):
    # TOML values compare by equality here (a choice of names only ever gets strings through)
    return rules.custom(
        lambda value: (value in choices, value),
        "one of " + ", ".join(repr(c) for c in choices),
        problem=_got,
    )


def _shaped(check):
    """A checker that returns the value or raises `Invalid` with its own problem (which point
    of a list), as a `yore.rules.Rule`."""
    return rules.custom(lambda value: (True, check(value)), check.expected, problem=_got)


def _points(dimension, what):
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
    return _shaped(check)


def _polygons(value):
    if not isinstance(value, list):
        raise Invalid(f"got {describe_value(value)}", _polygons.expected)
    points = _points(2, "[u, v]")
    polygons = []
    for k, polygon in enumerate(value):
        try:
            polygons.append(points(polygon))
        except Invalid as error:
            raise Invalid(f"hole {k}: {error.problem}", _polygons.expected) from None
    return polygons


_polygons.expected = "a list of polygons, each a list of [u, v] points"


def _vector3(value):
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


_vector3.expected = "3 numbers [x, y, z]"


def _camera_vector(value):
    vector = _vector3(value)
    if np.abs(vector).max() > MAX_CAMERA_COORDINATE:
        raise Invalid("got [" + ", ".join(f"{c:g}" for c in vector) + "]", _camera_vector.expected)
    return vector


_camera_vector.expected = f"3 numbers [x, y, z] within ±{MAX_CAMERA_COORDINATE:g}"


def _point(value):
    """A point of the scene, m (a driver's centre, a box's corner): within the coordinates a
    pattern may have, `MAX_PATTERN_COORDINATE` (a centre at 1e300 m passed `yore check` and
    made the run's first positions infinite)."""
    vector = _vector3(value)
    if np.abs(vector).max() > MAX_PATTERN_COORDINATE:
        raise Invalid("got [" + ", ".join(f"{c:g}" for c in vector) + "]", _point.expected)
    return vector


_point.expected = f"3 numbers [x, y, z] within ±{MAX_PATTERN_COORDINATE:g} m"


def _indices(value):
    expected = _indices.expected
    if not isinstance(value, list) or not value:
        raise Invalid(f"got {describe_value(value)}", expected)
    for i in value:
        if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i <= MAX_INTEGER:
            raise Invalid(f"got the index {describe_value(i)}", expected)
    return np.asarray(value, dtype=np.int32)


_indices.expected = "a list of vertex indices (integers in [0, 2147483647])"
_polygons, _vector3, _camera_vector, _point, _indices = map(
    _shaped, (_polygons, _vector3, _camera_vector, _point, _indices)
)

GENERATOR_KEYS = {
    "grid": {
        "nx": (_integer(2), 21, "vertices along the pattern's u (width) direction"),
        "ny": (_integer(2), 21, "vertices along the pattern's v (height) direction"),
        "width": (_number(0, strict_minimum=True, unit="m"), 1.0, "pattern size along u"),
        "height": (_number(0, strict_minimum=True, unit="m"), 1.0, "pattern size along v"),
        "plane": (
            _choice("xy", "xz"),
            "xy",
            "xy: upright, (u, v) -> (x, y, 0); xz: flat, (u, v) -> (u, 0, v)",
        ),
        "gather": (
            _number(0, 1, strict_minimum=True),
            1.0,
            "start gathered along u to this fraction of the width (rest lengths stay "
            "those of the flat pattern)",
        ),
    },
    "cylinder": {
        "radius": (_number(0, strict_minimum=True, unit="m"), 0.25, "tube radius"),
        "height": (_number(0, strict_minimum=True, unit="m"), 0.5, "tube length along y"),
        "rings": (_integer(2), 13, "vertex rings"),
        "segments": (_integer(3), 32, "vertices per ring"),
    },
    "pattern": {
        "outline": (
            _points(2, "[u, v]"),
            REQUIRED,
            "the pattern's boundary polygon, m (simple, at least 3 points)",
        ),
        "holes": (_polygons, [], "holes: a list of polygons strictly inside the outline"),
        "edge_length": (
            _number(0, strict_minimum=True, unit="m"),
            0.05,
            "longest edge of the mesh",
        ),
        "min_angle": (
            _number(0, PATTERN_MAX_ANGLE, strict_minimum=True, unit="degrees"),
            PATTERN_MIN_ANGLE,
            "smallest angle of the mesh",
        ),
        "interior": (
            _choice("lattice", "delaunay"),
            "lattice",
            "lattice: an equilateral lattice inside, CGAL along the edges; "
            "delaunay: CGAL's isotropic triangles throughout",
        ),
        "plane": (
            _choice("xy", "xz"),
            "xy",
            "xy: upright, (u, v) -> (x, y, 0); xz: flat, (u, v) -> (u, 0, v)",
        ),
    },
    "file": {
        "path": (_string, REQUIRED, "mesh file (any meshio format), relative to the scene"),
        "scale": (_number(0, strict_minimum=True), 1.0, "factor applied to the coordinates"),
    },
}

SELECTION = {
    "indices": (_indices, None, "vertex indices"),
    "box": ("box", None, "{min = [x, y, z], max = [x, y, z]}: vertices inside at t = 0, m"),
    "set": (_string, None, "a named set of the mesh generator (see docs/scene-files.md)"),
}

STROKE_FORMS = ("points", "material", "screen")


def _mass_scale(value):
    if value == "conserve" and isinstance(value, str):
        return value
    try:
        return _positive_factor(value)
    except Invalid as error:
        raise Invalid(error.problem, _mass_scale.expected) from None


_positive_factor = _number(0, MAX_MASS_SCALE, strict_minimum=True)
_mass_scale.expected = f"a number in (0, {MAX_MASS_SCALE:g}] or 'conserve'"
_mass_scale = _shaped(_mass_scale)
SCHEMA_GENERATOR_EXPECTED = "one of " + ", ".join(repr(g) for g in GENERATOR_KEYS)

SCHEMA = {
    "scene": (
        {
            "name": (_string, None, "a title"),
            "description": (_string, None, "free text"),
        },
        "table",
    ),
    "mesh": (
        {
            "generator": (_choice(*GENERATOR_KEYS), REQUIRED, "grid, cylinder, pattern or file"),
        },
        "table",
    ),
    "material": (
        {
            "mass": (
                _number(0, strict_minimum=True, unit="kg"),
                None,
                f"total mass, spread uniformly over the vertices (the paper's choice; default "
                f"{MASS:g} unless mass_per_vertex or density is given)",
            ),
            "mass_per_vertex": (_number(0, strict_minimum=True, unit="kg"), None, "per vertex"),
            "density": (
                _number(0, strict_minimum=True, unit="kg/m²"),
                None,
                "areal density, lumped to the vertices by area",
            ),
            "stretch": (
                _choice("springs", "membrane"),
                "springs",
                "what resists stretching: the paper's structural springs, or a continuum "
                "membrane (St. Venant–Kirchhoff triangles) of young_modulus and "
                "poisson_ratio",
            ),
            "stretch_stiffness": (
                _number(0, strict_minimum=True, unit="N/m"),
                200.0,
                "structural springs (not with stretch = membrane)",
            ),
            "young_modulus": (
                _number(0, strict_minimum=True, unit="N/m"),
                None,
                "the membrane's 2-D Young's modulus, Pa × thickness (required with "
                "stretch = membrane)",
            ),
            "poisson_ratio": (
                _number(-1, 1, strict_minimum=True, strict_maximum=True),
                None,
                "the membrane's Poisson's ratio (default 0.3)",
            ),
            "membrane_strain": (
                _choice("faces", "smoothed"),
                None,
                "the membrane's strain: the faces' (default) or smoothed at the "
                "vertices (with quadratic or hinge bending; for tension across "
                "the mesh's rows)",
            ),
            "bend_stiffness": (
                _number(0, unit="N/m"),
                None,
                f"bending springs (default {STIFFNESS:g}; 0: none; not with quadratic bending)",
            ),
            "bending": (
                _choice("springs", "quadratic", "hinge"),
                "springs",
                "bending model: the paper's springs, the quadratic energy ½ B ∫ |∇∇x|² "
                "(fitted per vertex, the same on any mesh) or Bergou et al. 2006's hinge "
                "energy (depends on the mesh's directions)",
            ),
            "bending_modulus": (
                _number(0, unit="N·m"),
                None,
                "quadratic bending's modulus (required with bending = quadratic)",
            ),
            "damping": (_number(0, unit="N·s/m"), 0.02, "along each spring"),
            "drag": (_number(0, unit="1/s"), 0.3, "still air"),
        },
        "table",
    ),
    "fixed": (dict(SELECTION), "array"),
    "driven": (
        {
            **SELECTION,
            "motion": (_choice("rotation"), "rotation", "the kind of prescribed motion"),
            "center": (_point, REQUIRED, "a point on the rotation axis, m"),
            "axis": (_vector3, REQUIRED, "axis direction"),
            "omega": (_number(unit="rad/s"), REQUIRED, "angular speed, right-handed about axis"),
        },
        "array",
    ),
    "simulation": (
        {
            "integrator": (_choice(*INTEGRATORS), DEFAULT_INTEGRATOR, "the time integrator"),
            "dt": (
                _number_or_auto(MIN_DT, unit="s"),
                None,
                'time step; default: below the stable step (explicit) or 1/60 s; "auto": '
                "steps chosen by error control (tr-bdf2, cvode, arkode), dt the output "
                "interval",
            ),
            "duration": (
                _number(0, MAX_TIME, strict_minimum=True, unit="s"),
                REQUIRED,
                "simulated time",
            ),
            "gravity": (_vector3, None, "m/s², default [0, -9.81, 0]"),
            "settle": (
                _number(0, MAX_SETTLE_SECONDS, unit="s"),
                0.0,
                "at most this much pseudo-time of relaxation "
                "to a static equilibrium before t = 0 (Simulation.settle; no driven "
                "vertices); 0: start as built",
            ),
            "threads": (
                _integer(1, MAX_THREADS),
                None,
                "threads of the core's loops and of BLAS "
                "(yore.set_num_threads); default: the machine's cores",
            ),
        },
        "table",
    ),
    "integrator": (None, "table"),  # options of the chosen integrator, checked separately
    "strokes": (
        {
            "time": (_number(0, MAX_TIME, unit="s"), REQUIRED, "when the stroke is drawn"),
            "points": (_points(3, "[x, y, z] (m)"), None, "3-D polyline near the surface"),
            "material": (_points(2, "[u, v] (m)"), None, "polyline in rest-pattern coordinates"),
            "screen": (_points(2, "[x, y] pixel"), None, "polyline in pixels of [camera]"),
            "expansion": (
                _number(MIN_EXPANSION, MAX_EXPANSION),
                STROKE_DEFAULTS.expansion,
                "rest length / current length of new springs (eq. (1))",
            ),
            "mass_scale": (
                _mass_scale,
                STROKE_DEFAULTS.mass_scale,
                "new vertex mass / corners' mean, or 'conserve' "
                "(taken from the corners; total mass unchanged)",
            ),
            "width": (
                _number(0, strict_minimum=True, unit="m"),
                None,
                "band around the stroke with a smooth falloff (default: the crossed faces)",
            ),
            "growth": (
                _choice(*GROWTH_MODES),
                STROKE_DEFAULTS.growth,
                "paper (eq. (1) on new springs), isotropic, along or across the stroke",
            ),
            "refine": (
                _integer(0, MAX_REFINE),
                STROKE_DEFAULTS.refine,
                "1→4 refinement passes of the band first",
            ),
            "max_distance": (
                _number(0, strict_minimum=True, unit="m"),
                None,
                "points only: farthest a point may be from the surface",
            ),
            "smooth": (
                "smooth",
                None,
                "{iterations, strength, region}: rest-length smoothing right after the stroke",
            ),
        },
        "array",
    ),
    "camera": (
        {
            "eye": (_camera_vector, None, "m; default: fitted to the cloth at t = 0"),
            "target": (_camera_vector, None, "m; default: the cloth's centre at t = 0"),
            "up": (_camera_vector, [0.0, 1.0, 0.0], "up direction"),
            "fov_degrees": (
                FOV_RULE,
                FOV_DEGREES,
                "vertical field of view",
            ),
            "width": (
                _integer(LIMITS.min_picture_side, MAX_IMAGE_SIDE),
                IMAGE_WIDTH,
                "image width, pixels",
            ),
            "height": (
                _integer(LIMITS.min_picture_side, MAX_IMAGE_SIDE),
                IMAGE_HEIGHT,
                "image height, pixels",
            ),
        },
        "table",
    ),
    "output": (
        {
            "format": (_choice("vtu", "vtk", "ply", "obj", "none"), "vtu", "frame file format"),
            "fps": (
                _number(0, strict_minimum=True),
                None,
                f"frames per simulated second (default {FRAMES_PER_SECOND:g} unless every_steps is "
                "given)",
            ),
            "every_steps": (_integer(1), None, "a frame every this many steps"),
            "pictures": (
                _boolean,
                True,
                "before/after PNG (before = just before the first stroke)",
            ),
            "animation": (_choice(*ANIMATION_FORMATS), RUN_ANIMATION, "an animation of the frames"),
            "color_by": (
                _choice("none", "expansion", "wrinkles"),
                "none",
                "colour pictures by rest-length expansion or wrinkle height",
            ),
            "framing": (
                _choice("cloth", "run"),
                "cloth",
                "cloth: each picture framed on the cloth it shows, the animation "
                "follows it; run: one camera for the whole run",
            ),
        },
        "table",
    ),
}

SMOOTH = {
    "iterations": (
        _integer(0, SMOOTHING_RULES.iterations.high),
        SMOOTHING_DEFAULTS.iterations,
        "smoothing iterations",
    ),
    "strength": (
        _number(SMOOTHING_RULES.strength.low, SMOOTHING_RULES.strength.high, strict_minimum=True),
        SMOOTHING_DEFAULTS.strength,
        "fraction moved per iteration",
    ),
    "region": (_choice("stroke", "all"), "stroke", "the stroke's region and one ring, or all"),
    "conserve": (
        _boolean,
        SMOOTHING_DEFAULTS.conserve,
        "keep the region's added rest length (redistribute only)",
    ),
}
BOX = {
    "min": (_point, REQUIRED, "lower corner, m"),
    "max": (_point, REQUIRED, "upper corner, m"),
}
