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

from typing import Any, NamedTuple

from ..limits import LIMITS
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
    MAX_SETTLE_SECONDS,
    MAX_THREADS,
    MAX_TIME,
    MIN_DT,
    MIN_EXPANSION,
)
from ..meshes import PATTERN_MIN_ANGLE
from .._core import PATTERN_MAX_ANGLE_DEGREES as PATTERN_MAX_ANGLE
from ..stroke import GROWTH_MODES, MAX_REFINE
from . import scene_rules as check
from .scene_rules import MAX_INTEGER, describe_value, did_you_mean

__all__ = [
    "SceneError",
    "SCHEMA",
    "Key",
    "TableSpec",
    "REQUIRED",
    "MAX_SCENE_FILE_BYTES",
    "MAX_INTEGER",
    "Invalid",
    "describe_value",
    "did_you_mean",
]

#: Largest scene file read, bytes.
MAX_SCENE_FILE_BYTES = LIMITS.max_scene_file_bytes


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

#: A key's default when the key must be given.
REQUIRED = object()


class Key(NamedTuple):
    """One key of a scene table: its ``rule`` (a `yore.rules.Rule`, or a checker of its own
    shape that raises `Invalid`, or "box"/"smooth", the name of a nested table checked by
    `BOX`/`SMOOTH`), its ``default`` (`REQUIRED`: it must be given; None: absent unless
    given) and the ``description`` docs/scene-files.md shows."""

    rule: Any
    default: Any
    description: str


class TableSpec(NamedTuple):
    """One table of a scene file: its keys (a dict of `Key`; None for [integrator], whose
    options are the chosen integrator's) and its ``kind``: "table" ([name]) or "array"
    ([[name]], an array of tables)."""

    keys: dict | None
    kind: str


GENERATOR_KEYS = {
    "grid": {
        "nx": Key(check.integer(2), 21, "vertices along the pattern's u (width) direction"),
        "ny": Key(check.integer(2), 21, "vertices along the pattern's v (height) direction"),
        "width": Key(check.number(0, strict_minimum=True, unit="m"), 1.0, "pattern size along u"),
        "height": Key(check.number(0, strict_minimum=True, unit="m"), 1.0, "pattern size along v"),
        "plane": Key(
            check.choice("xy", "xz"),
            "xy",
            "xy: upright, (u, v) -> (x, y, 0); xz: flat, (u, v) -> (u, 0, v)",
        ),
        "gather": Key(
            check.number(0, 1, strict_minimum=True),
            1.0,
            "start gathered along u to this fraction of the width (rest lengths stay "
            "those of the flat pattern)",
        ),
    },
    "cylinder": {
        "radius": Key(check.number(0, strict_minimum=True, unit="m"), 0.25, "tube radius"),
        "height": Key(check.number(0, strict_minimum=True, unit="m"), 0.5, "tube length along y"),
        "rings": Key(check.integer(2), 13, "vertex rings"),
        "segments": Key(check.integer(3), 32, "vertices per ring"),
    },
    "pattern": {
        "outline": Key(
            check.points(2, "[u, v]"),
            REQUIRED,
            "the pattern's boundary polygon, m (simple, at least 3 points)",
        ),
        "holes": Key(check.polygons, [], "holes: a list of polygons strictly inside the outline"),
        "edge_length": Key(
            check.number(0, strict_minimum=True, unit="m"),
            0.05,
            "longest edge of the mesh",
        ),
        "min_angle": Key(
            check.number(0, PATTERN_MAX_ANGLE, strict_minimum=True, unit="degrees"),
            PATTERN_MIN_ANGLE,
            "smallest angle of the mesh",
        ),
        "interior": Key(
            check.choice("lattice", "delaunay"),
            "lattice",
            "lattice: an equilateral lattice inside, CGAL along the edges; "
            "delaunay: CGAL's isotropic triangles throughout",
        ),
        "plane": Key(
            check.choice("xy", "xz"),
            "xy",
            "xy: upright, (u, v) -> (x, y, 0); xz: flat, (u, v) -> (u, 0, v)",
        ),
    },
    "file": {
        "path": Key(check.string, REQUIRED, "mesh file (any meshio format), relative to the scene"),
        "scale": Key(
            check.number(0, strict_minimum=True), 1.0, "factor applied to the coordinates"
        ),
    },
}

SELECTION = {
    "indices": Key(check.indices, None, "vertex indices"),
    "box": Key("box", None, "{min = [x, y, z], max = [x, y, z]}: vertices inside at t = 0, m"),
    "set": Key(check.string, None, "a named set of the mesh generator (see docs/scene-files.md)"),
}

STROKE_FORMS = ("points", "material", "screen")


SCHEMA_GENERATOR_EXPECTED = "one of " + ", ".join(repr(g) for g in GENERATOR_KEYS)

SCHEMA = {
    "scene": TableSpec(
        {
            "name": Key(check.string, None, "a title"),
            "description": Key(check.string, None, "free text"),
        },
        "table",
    ),
    "mesh": TableSpec(
        {
            "generator": Key(
                check.choice(*GENERATOR_KEYS),
                REQUIRED,
                "grid, cylinder, pattern or file",
            ),
        },
        "table",
    ),
    "material": TableSpec(
        {
            "mass": Key(
                check.number(0, strict_minimum=True, unit="kg"),
                None,
                f"total mass, spread uniformly over the vertices (the paper's choice; default "
                f"{MASS:g} unless mass_per_vertex or density is given)",
            ),
            "mass_per_vertex": Key(
                check.number(0, strict_minimum=True, unit="kg"),
                None,
                "per vertex",
            ),
            "density": Key(
                check.number(0, strict_minimum=True, unit="kg/m²"),
                None,
                "areal density, lumped to the vertices by area",
            ),
            "stretch": Key(
                check.choice("springs", "membrane"),
                "springs",
                "what resists stretching: the paper's structural springs, or a continuum "
                "membrane (St. Venant–Kirchhoff triangles) of young_modulus and "
                "poisson_ratio",
            ),
            "stretch_stiffness": Key(
                check.number(0, strict_minimum=True, unit="N/m"),
                200.0,
                "structural springs (not with stretch = membrane)",
            ),
            "young_modulus": Key(
                check.number(0, strict_minimum=True, unit="N/m"),
                None,
                "the membrane's 2-D Young's modulus, Pa × thickness (required with "
                "stretch = membrane)",
            ),
            "poisson_ratio": Key(
                check.number(-1, 1, strict_minimum=True, strict_maximum=True),
                None,
                "the membrane's Poisson's ratio (default 0.3)",
            ),
            "membrane_strain": Key(
                check.choice("faces", "smoothed"),
                None,
                "the membrane's strain: the faces' (default) or smoothed at the "
                "vertices (with quadratic or hinge bending; for tension across "
                "the mesh's rows)",
            ),
            "bend_stiffness": Key(
                check.number(0, unit="N/m"),
                None,
                f"bending springs (default {STIFFNESS:g}; 0: none; not with quadratic bending)",
            ),
            "bending": Key(
                check.choice("springs", "quadratic", "hinge"),
                "springs",
                "bending model: the paper's springs, the quadratic energy ½ B ∫ |∇∇x|² "
                "(fitted per vertex, the same on any mesh) or Bergou et al. 2006's hinge "
                "energy (depends on the mesh's directions)",
            ),
            "bending_modulus": Key(
                check.number(0, unit="N·m"),
                None,
                "quadratic bending's modulus (required with bending = quadratic)",
            ),
            "damping": Key(check.number(0, unit="N·s/m"), 0.02, "along each spring"),
            "drag": Key(check.number(0, unit="1/s"), 0.3, "still air"),
        },
        "table",
    ),
    "fixed": TableSpec(dict(SELECTION), "array"),
    "driven": TableSpec(
        {
            **SELECTION,
            "motion": Key(check.choice("rotation"), "rotation", "the kind of prescribed motion"),
            "center": Key(check.point, REQUIRED, "a point on the rotation axis, m"),
            "axis": Key(check.vector3, REQUIRED, "axis direction"),
            "omega": Key(
                check.number(unit="rad/s"),
                REQUIRED,
                "angular speed, right-handed about axis",
            ),
        },
        "array",
    ),
    "simulation": TableSpec(
        {
            "integrator": Key(
                check.choice(*INTEGRATORS), DEFAULT_INTEGRATOR, "the time integrator"
            ),
            "dt": Key(
                check.number_or_auto(MIN_DT, unit="s"),
                None,
                'time step; default: below the stable step (explicit) or 1/60 s; "auto": '
                "steps chosen by error control (tr-bdf2, cvode, arkode), dt the output "
                "interval",
            ),
            "duration": Key(
                check.number(0, MAX_TIME, strict_minimum=True, unit="s"),
                REQUIRED,
                "simulated time",
            ),
            "gravity": Key(check.vector3, None, "m/s², default [0, -9.81, 0]"),
            "settle": Key(
                check.number(0, MAX_SETTLE_SECONDS, unit="s"),
                0.0,
                "at most this much pseudo-time of relaxation "
                "to a static equilibrium before t = 0 (Simulation.settle; no driven "
                "vertices); 0: start as built",
            ),
            "threads": Key(
                check.integer(1, MAX_THREADS),
                None,
                "threads of the core's loops and of BLAS "
                "(yore.set_num_threads); default: the machine's cores",
            ),
        },
        "table",
    ),
    "integrator": TableSpec(None, "table"),  # options of the chosen integrator, checked separately
    "strokes": TableSpec(
        {
            "time": Key(check.number(0, MAX_TIME, unit="s"), REQUIRED, "when the stroke is drawn"),
            "points": Key(check.points(3, "[x, y, z] (m)"), None, "3-D polyline near the surface"),
            "material": Key(
                check.points(2, "[u, v] (m)"),
                None,
                "polyline in rest-pattern coordinates",
            ),
            "screen": Key(check.points(2, "[x, y] pixel"), None, "polyline in pixels of [camera]"),
            "expansion": Key(
                check.number(MIN_EXPANSION, MAX_EXPANSION),
                STROKE_DEFAULTS.expansion,
                "rest length / current length of new springs (eq. (1))",
            ),
            "mass_scale": Key(
                check.mass_scale,
                STROKE_DEFAULTS.mass_scale,
                "new vertex mass / corners' mean, or 'conserve' "
                "(taken from the corners; total mass unchanged)",
            ),
            "width": Key(
                check.number(0, strict_minimum=True, unit="m"),
                None,
                "band around the stroke with a smooth falloff (default: the crossed faces)",
            ),
            "growth": Key(
                check.choice(*GROWTH_MODES),
                STROKE_DEFAULTS.growth,
                "paper (eq. (1) on new springs), isotropic, along or across the stroke",
            ),
            "refine": Key(
                check.integer(0, MAX_REFINE),
                STROKE_DEFAULTS.refine,
                "1→4 refinement passes of the band first",
            ),
            "max_distance": Key(
                check.number(0, strict_minimum=True, unit="m"),
                None,
                "points only: farthest a point may be from the surface",
            ),
            "smooth": Key(
                "smooth",
                None,
                "{iterations, strength, region}: rest-length smoothing right after the stroke",
            ),
        },
        "array",
    ),
    "camera": TableSpec(
        {
            "eye": Key(check.camera_vector, None, "m; default: fitted to the cloth at t = 0"),
            "target": Key(check.camera_vector, None, "m; default: the cloth's centre at t = 0"),
            "up": Key(check.camera_vector, [0.0, 1.0, 0.0], "up direction"),
            "fov_degrees": Key(
                FOV_RULE,
                FOV_DEGREES,
                "vertical field of view",
            ),
            "width": Key(
                check.integer(LIMITS.min_picture_side, MAX_IMAGE_SIDE),
                IMAGE_WIDTH,
                "image width, pixels",
            ),
            "height": Key(
                check.integer(LIMITS.min_picture_side, MAX_IMAGE_SIDE),
                IMAGE_HEIGHT,
                "image height, pixels",
            ),
        },
        "table",
    ),
    "output": TableSpec(
        {
            "format": Key(
                check.choice("vtu", "vtk", "ply", "obj", "none"),
                "vtu",
                "frame file format",
            ),
            "fps": Key(
                check.number(0, strict_minimum=True),
                None,
                f"frames per simulated second (default {FRAMES_PER_SECOND:g} unless every_steps is "
                "given)",
            ),
            "every_steps": Key(check.integer(1), None, "a frame every this many steps"),
            "pictures": Key(
                check.boolean,
                True,
                "before/after PNG (before = just before the first stroke)",
            ),
            "animation": Key(
                check.choice(*ANIMATION_FORMATS),
                RUN_ANIMATION,
                "an animation of the frames",
            ),
            "color_by": Key(
                check.choice("none", "expansion", "wrinkles"),
                "none",
                "colour pictures by rest-length expansion or wrinkle height",
            ),
            "framing": Key(
                check.choice("cloth", "run"),
                "cloth",
                "cloth: each picture framed on the cloth it shows, the animation "
                "follows it; run: one camera for the whole run",
            ),
        },
        "table",
    ),
}

SMOOTH = {
    "iterations": Key(
        check.integer(0, SMOOTHING_RULES.iterations.high),
        SMOOTHING_DEFAULTS.iterations,
        "smoothing iterations",
    ),
    "strength": Key(
        check.number(
            SMOOTHING_RULES.strength.low, SMOOTHING_RULES.strength.high, strict_minimum=True
        ),
        SMOOTHING_DEFAULTS.strength,
        "fraction moved per iteration",
    ),
    "region": Key(
        check.choice("stroke", "all"), "stroke", "the stroke's region and one ring, or all"
    ),
    "conserve": Key(
        check.boolean,
        SMOOTHING_DEFAULTS.conserve,
        "keep the region's added rest length (redistribute only)",
    ),
}
BOX = {
    "min": Key(check.point, REQUIRED, "lower corner, m"),
    "max": Key(check.point, REQUIRED, "upper corner, m"),
}
