"""Strokes that add wrinkles: the paper's partial area expansion by mesh subdivision.

A stroke is located on the cloth's *current* surface (CGAL AABB trees in the C++ core) as the
faces it crosses and, per face, where it crosses (the mean of its samples there). Each face is
split 1→3 at that point; the new springs get rest length ``expansion`` × their current length
(eq. (1) of the paper), the new vertex ``mass_scale`` × its corners' mean mass.

Degenerate cases (documented rule): a split point whose smallest barycentric weight is below
0.1 is moved towards the face's centroid until that weight is 0.1, so each child keeps at least
a tenth of the face's area; if a child would still have an angle below 5°, the centroid is
tried, and if that too gives a sliver the face is left whole and reported in
``faces_skipped``. Strokes repeated over a region split its (new) faces again.

Options beyond the paper (all strokes, scene files alike):

- ``width`` (m, default None): the band of the stroke. None is the paper's: the faces the stroke
  crosses. A width takes every face with a corner closer than width/2 to the stroke's path, the
  distance measured in 3-D on the *current* surface (the path is the stroke's samples on the
  surface, so a 3-D, screen or material stroke all give the same kind of path). Each vertex gets
  the falloff weight w = 1 − smoothstep(d / (width/2)) (0 from width/2 on), each spring the
  falloff's mean along it (Simpson's rule: its two ends and its midpoint), so the rest metric
  carries the growth field to O(h²) and a band grows the same area on every mesh (issue 52; a
  band under ~2 edges wide is not resolved: ``refine`` it). In paper mode the split stays on
  the crossed faces (eq. (1)); width there only widens the band that ``refine`` refines.
- ``growth``: "paper" (default) splits the crossed faces 1→3 and lengthens only the new springs
  (eq. (1)); "isotropic", "along" and "across" split nothing and lengthen every spring in the
  band (structural and bending, original or not) from its rest length L: with g = 1 + (expansion
  − 1) w, isotropic gives L·g, along L·√(g²c² + s²) and across L·√(c² + g²s²), c and s the
  cosine and sine of the angle between the spring and the tangent of the path at the end nearer
  it. The angle is taken on the current surface at the time of the stroke (the rest frame for a
  cloth at rest; a strained cloth's springs turn a little).
- ``refine`` (int, 0–`MAX_REFINE`): passes of 1→4 midpoint refinement of the band's faces (a
  neighbour left with two split edges is refined too, one with a single split edge is bisected)
  before the growth; the stroke is traced again after each pass. New springs keep the rest
  metric, masses are redistributed with the total unchanged (`yore.Cloth` refine_faces).
- ``mass_scale``: a number is the paper's rule (a new point weighs mass_scale × its corners'
  mean, so the total mass grows); "conserve" takes the new point's mass from the split face's
  corners so the total is unchanged.
"""

from __future__ import annotations

import dataclasses
import numbers
from dataclasses import dataclass

import numpy as np

from .limits import LIMITS
from . import _core
from ._core import RefinementTooLarge, StrokeMissed
from .camera import Camera
from .checks import MAX_EXPANSION, MAX_MASS_SCALE, MIN_EXPANSION, check_factor
from .meshes import MAX_MESH_VERTICES
from .options import (
    GROWTH_MODES,  # in the order of the core's table (see the docstring)
    SMOOTHING_DEFAULTS,
    SMOOTHING_RULES,
    STROKE_DEFAULTS,
)
from .rules import Invalid

__all__ = [
    "StrokeMissed",
    "StrokeReport",
    "StrokeOptions",
    "StrokePath",
    "MIN_BARYCENTRIC",
    "MIN_ANGLE_DEGREES",
    "GROWTH_MODES",
    "MAX_REFINE",
    "MAX_REFINED_VERTICES",
    "RefinementTooLarge",
    "falloff_weight",
]

#: The degenerate-case rules (see the module docstring), the C++ ``SplitOptions``' defaults.
MIN_BARYCENTRIC = float(_core.split_defaults["min_barycentric"])
MIN_ANGLE_DEGREES = float(_core.split_defaults["min_angle_degrees"])

#: Vertices a refinement pass adds per band face, and the band's growth per pass, at most
#: (an estimate from above for `predicted_refined_vertices`; measured 1.2–1.9 and 2–4.6).
REFINE_VERTICES_PER_FACE = _core.refine_vertices_per_face
REFINE_BAND_GROWTH = _core.refine_band_growth
#: Most refinement passes one stroke may ask for: each pass quadruples the band's faces.
MAX_REFINE = LIMITS.max_refine
#: Most vertices a refining stroke (refine > 0) may leave the cloth with, predicted from above
#: before it refines. Refinement grows geometrically: eight strokes of one pass over a 7×7
#: cloth reached ~500 000 vertices, whose implicit factor then ran out of memory (2.9 GB). A
#: mesh read or generated may still have up to `MAX_MESH_VERTICES`.
MAX_REFINED_VERTICES = LIMITS.max_refined_vertices


#: The fields of a report the core fills in: `_core.StrokeResult`'s, by their C++ names.
CORE_FIELDS = tuple(name for name in dir(_core.StrokeResult) if not name.startswith("_"))


class StrokeReport:
    """What a stroke did. Areas in m², lengths in m, masses in kg, times in s.

    The core's fields (`_core.StrokeResult`, named as in C++ and read-only; `CORE_FIELDS`):
    faces_split, faces_skipped (faces left whole: their children would be slivers),
    vertices_added, new_vertices, springs_added, springs_removed, region_faces (the split's
    children, else the band), area_before, rest_area_before, rest_area_after, samples,
    missed_samples, moved_inward, locate_seconds, subdivide_seconds, faces_refined and
    faces_bisected (by the refinement passes), springs_grown, rest_length_added (Σ new − old
    rest length), mass_added, line_vertices (the stroke's vertices in stroke order, for
    pictures), spring_weights and vertex_weights (the band's, growth modes).

    The Python side's own: growth, width and refine (the options the stroke ran with),
    topology_version (the cloth's after it), reanalyze_seconds (filled in by the next step; 0
    for the explicit integrator, which has nothing to rebuild) and extra (a dict: the band's
    weights in the growth modes, the step's change when the stroke lowered it, the smoothing
    stage's result).
    """

    def __init__(self, result, options, topology_version):
        self._result = result
        self.growth, self.width, self.refine = options.growth, options.width, options.refine
        self.topology_version = topology_version
        self.reanalyze_seconds = None
        self.extra = (
            {}
            if options.growth == "paper"
            else {"spring_weights": result.spring_weights, "vertex_weights": result.vertex_weights}
        )

    def __setattr__(self, name, value):
        if name in CORE_FIELDS:
            raise AttributeError(f"StrokeReport.{name} is the core's, read-only")
        super().__setattr__(name, value)

    def __getattr__(self, name):
        if name in CORE_FIELDS:
            return getattr(self.__dict__["_result"], name)
        raise AttributeError(f"'StrokeReport' object has no attribute {name!r}")

    @property
    def missed_fraction(self) -> float:
        """Fraction of the stroke's samples that touched no surface (a partly missing stroke)."""
        return self.missed_samples / self.samples if self.samples else 0.0

    def __repr__(self):
        return (
            f"StrokeReport(growth={self.growth!r}, faces_split={self.faces_split}, "
            f"vertices_added={self.vertices_added}, springs_grown={self.springs_grown})"
        )


#: Largest stroke coordinate accepted (m or px): far beyond any cloth, small enough that the
#: polyline's length and its clipping to the cloth's reach stay exact to well under a sample.
#: Beyond the clipping, a stroke takes at most `_core` kMaxStrokeSamples (10^6) samples.
MAX_STROKE_COORDINATE = LIMITS.max_stroke_coordinate


def check_stroke_points(points, dimension: int, name: str) -> np.ndarray:
    """A k×dimension float array of finite points (k >= 1, |coordinate| <= 1e12), as k×3 (2-D
    padded with z = 0)."""
    try:
        array = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numbers, got {points!r}") from None
    if array.ndim != 2 or array.shape[1] != dimension:
        raise ValueError(f"{name} must have shape (k, {dimension}), got {array.shape}")
    if array.shape[0] == 0:
        raise ValueError(f"{name} is empty: a stroke needs at least one point")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} holds non-finite values")
    if np.abs(array).max() > MAX_STROKE_COORDINATE:
        raise ValueError(
            f"{name} holds a coordinate of magnitude {np.abs(array).max():.3g}, "
            f"beyond ±{MAX_STROKE_COORDINATE:g} (metres or pixels)"
        )
    if dimension == 2:
        array = np.column_stack([array, np.zeros(len(array))])
    return np.ascontiguousarray(array)


def falloff_weight(distance, width):
    """Falloff weights (in [0, 1]) at distances (m) from a stroke of this width (m):
    1 − smoothstep(distance / (width/2)), 1 on the stroke and 0 from width/2 on."""
    width = check_factor(width, "width", "m")
    return _core.falloff_weight(np.atleast_1d(np.asarray(distance, dtype=float)), width / 2.0)


def check_stroke_options(width, growth, refine, mass_scale):
    """(width or None, growth, refine, mass_scale) checked; ValueError naming the problem."""
    if width is not None:
        width = check_factor(width, "width", "m")
    if not isinstance(growth, str) or growth not in GROWTH_MODES:
        raise ValueError(
            f"growth: got {growth!r}; expected one of " + ", ".join(repr(g) for g in GROWTH_MODES)
        )
    if (
        isinstance(refine, (bool, np.bool_))
        or not isinstance(refine, numbers.Integral)
        or not 0 <= refine <= MAX_REFINE
    ):
        raise ValueError(
            f"refine: got {refine!r}; expected an integer in [0, {MAX_REFINE}] "
            "(refinement passes; each quadruples the band's faces)"
        )
    if isinstance(mass_scale, str):
        if mass_scale != "conserve":
            raise ValueError(
                f"mass_scale: got {mass_scale!r}; expected a number > 0 (the "
                "paper's rule) or 'conserve'"
            )
    else:
        mass_scale = check_factor(mass_scale, "mass_scale")
        if mass_scale > MAX_MASS_SCALE:
            raise ValueError(
                f"mass_scale must be at most {MAX_MASS_SCALE:g} (a new vertex's "
                "mass over its corners' mean; the paper's is 0.95), got "
                f"{mass_scale:g}"
            )
    return width, growth, int(refine), mass_scale


def check_expansion(expansion) -> float:
    """A stroke's expansion as a float in [`MIN_EXPANSION`, `MAX_EXPANSION`]; ValueError."""
    expansion = check_factor(expansion, "expansion")
    if not MIN_EXPANSION <= expansion <= MAX_EXPANSION:
        raise ValueError(
            f"expansion must be in [{MIN_EXPANSION:g}, {MAX_EXPANSION:g}] (a "
            "new spring's rest length over its current length; the paper's "
            f"is 1.1), got {expansion:g}"
        )
    return expansion


#: Where a stroke's smoothing stage smooths: the stroke's region and one ring, or everything.
SMOOTHING_REGIONS = ("stroke", "all")


def check_smoothing(smooth):
    """A stroke's smoothing stage as None or {"iterations", "strength", "conserve", "region"}
    (missing keys at their defaults, `yore.options.SMOOTHING_DEFAULTS`; an int is the
    iterations); ValueError naming the key."""
    if smooth is None:
        return None
    if isinstance(smooth, numbers.Integral) and not isinstance(smooth, (bool, np.bool_)):
        smooth = {"iterations": smooth}
    if not isinstance(smooth, dict):
        raise ValueError(
            f"smooth: got {type(smooth).__name__} {smooth!r}; expected None, "
            "iterations or a dict of iterations, strength, conserve, region"
        )
    unknown = sorted(set(smooth) - set(SMOOTHING_DEFAULTS) - {"region"})
    if unknown:
        raise ValueError(
            f"smooth: unknown key {unknown[0]!r}; valid: "
            f"{', '.join(list(SMOOTHING_DEFAULTS) + ['region'])}"
        )
    checked = {**SMOOTHING_DEFAULTS, "region": SMOOTHING_REGIONS[0]}
    for name, value in smooth.items():
        if name == "region":
            if value not in SMOOTHING_REGIONS:
                raise ValueError(
                    f"smooth region: got {value!r}; expected one of "
                    f"{', '.join(map(repr, SMOOTHING_REGIONS))}"
                )
            checked[name] = value
            continue
        try:
            checked[name] = SMOOTHING_RULES[name](value)
        except Invalid as invalid:
            raise ValueError(
                f"smooth {name}: {invalid.problem}; expected {invalid.expected}"
            ) from None
    return checked


@dataclass(frozen=True)
class StrokeOptions:
    """How a stroke changes the cloth: one value for `yore.Simulation.stroke`, the viewer and
    scene files. The defaults are the C++ tables' (`yore.options.STROKE_DEFAULTS`).

    expansion: rest length of new springs over their current length (eq. (1): 1.1), or the
    factor a spring at full weight grows by in the other growth modes. mass_scale: a new
    vertex's mass over its face corners' mean (0.95), or "conserve". width: m, the band (None:
    the faces the stroke crosses). growth: "paper" | "isotropic" | "along" | "across". refine:
    1→4 refinement passes of the band first. max_distance: m, 3-D paths only: the farthest a
    point may be from the surface (None: 5 % of the cloth's bounding-box diagonal). smooth:
    rest-length smoothing right after the stroke, the pipeline's optional last stage (None:
    none; iterations, or a dict of iterations, strength, conserve and region "stroke" | "all";
    see `yore.Simulation.smooth_rest_lengths`).
    """

    expansion: float = STROKE_DEFAULTS["expansion"]
    mass_scale: object = STROKE_DEFAULTS["mass_scale"]
    width: object = STROKE_DEFAULTS["width"]
    growth: str = STROKE_DEFAULTS["growth"]
    refine: int = STROKE_DEFAULTS["refine"]
    max_distance: object = None
    smooth: object = None

    def checked(self) -> "StrokeOptions":
        """These options with every value in canonical form; ValueError naming the first
        wrong one."""
        width, growth, refine, mass_scale = check_stroke_options(
            self.width, self.growth, self.refine, self.mass_scale
        )
        max_distance = (
            None if self.max_distance is None else check_factor(self.max_distance, "max_distance")
        )
        return StrokeOptions(
            expansion=check_expansion(self.expansion),
            mass_scale=mass_scale,
            width=width,
            growth=growth,
            refine=refine,
            max_distance=max_distance,
            smooth=check_smoothing(self.smooth),
        )

    def replace(self, **changes) -> "StrokeOptions":
        """A copy with ``changes``; ValueError naming an unknown option."""
        unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(self)})
        if unknown:
            raise ValueError(
                f"unknown stroke option {unknown[0]!r}; valid: "
                f"{', '.join(f.name for f in dataclasses.fields(self))}"
            )
        return dataclasses.replace(self, **changes)

    @classmethod
    def of(cls, options=None, **changes) -> "StrokeOptions":
        """``options`` (a StrokeOptions, a dict of options or None for the defaults) with
        ``changes``, checked."""
        if options is None:
            options = cls()
        elif isinstance(options, dict):
            options = cls().replace(**options)
        elif not isinstance(options, cls):
            raise ValueError(
                f"options must be a yore.StrokeOptions, a dict or None, got "
                f"{type(options).__name__}"
            )
        return options.replace(**changes).checked()


class StrokePath:
    """Where a stroke is drawn, in one of three spaces (`yore.Simulation.stroke` takes any):

    - ``StrokePath.world(points)``: a 3-D polyline (k, 3) in metres near the cloth; each point
      goes to the closest point of the current surface (the paper's stroke). A bare (k, 3)
      array passed to `Simulation.stroke` is this.
    - ``StrokePath.screen(pixels, camera)``: a 2-D polyline (k, 2) in pixels of a
      `yore.Camera`, as the paper's user draws over a view: rays through the current surface,
      nearest hit.
    - ``StrokePath.material(uv)``: a 2-D polyline (k, 2) in the cloth's rest-pattern
      coordinates (``cloth.material_coordinates``, set by the scenes and pattern meshes).
    """

    SPACES = ("world", "screen", "material")

    def __init__(self, space, points, camera=None):
        if space not in self.SPACES:
            raise ValueError(
                f"stroke path space: got {space!r}; expected one of "
                f"{', '.join(map(repr, self.SPACES))}"
            )
        if space == "screen" and not isinstance(camera, Camera):
            raise ValueError(f"camera must be a yore.Camera, got {type(camera).__name__}")
        names = {
            "world": ("points_3d", 3),
            "screen": ("points_px", 2),
            "material": ("points_uv", 2),
        }
        name, dimension = names[space]
        self.space, self.camera = space, camera
        self.points = check_stroke_points(points, dimension, name)  # k×3 (2-D: z = 0)

    @classmethod
    def world(cls, points) -> "StrokePath":
        return cls("world", points)

    @classmethod
    def screen(cls, pixels, camera) -> "StrokePath":
        return cls("screen", pixels, camera)

    @classmethod
    def material(cls, uv) -> "StrokePath":
        return cls("material", uv)

    @classmethod
    def of(cls, path) -> "StrokePath":
        """``path`` itself, or a (k, 3) array of points as a world path."""
        return path if isinstance(path, cls) else cls.world(path)

    def __repr__(self):
        return f"StrokePath.{self.space}({len(self.points)} points)"


def predicted_refined_vertices(vertices, band_faces, passes):
    """An estimate from above of the vertex count after ``passes`` refinement passes of a band
    of ``band_faces`` faces on a mesh of ``vertices``: each pass adds at most
    `REFINE_VERTICES_PER_FACE` vertices per band face, and the band (the same width in metres
    over smaller faces) grows at most `REFINE_BAND_GROWTH` times per pass (measured on grids:
    1.2–1.9 and 2–4.6)."""
    return _core.predicted_refined_vertices(vertices, band_faces, passes)


def apply_stroke(cloth, trace, points, options, **trace_options) -> StrokeReport:
    """Applies one stroke in one call of the core (`_core.apply_stroke`): traces it, refines
    its band ``refine`` times (tracing again after each pass), then splits or grows.

    trace : "closest" (``points`` k×3 m, ``max_distance`` m), "material" (``points`` k×3 in
    rest-pattern m with z = 0, ``max_distance`` the tolerance) or "rays" (``points`` k×3 pixels
    with z = 0, ``eye``, ``base_direction``, ``direction_per_pixel_x``,
    ``direction_per_pixel_y``, ``spacing_pixels``), all in ``trace_options``. Raises
    StrokeMissed when a trace finds nothing, RefinementTooLarge (the cloth unchanged) when the
    refinement could make the mesh larger than `MAX_REFINED_VERTICES`. ``options``: checked
    `StrokeOptions`.
    """
    expansion, mass_scale, width = options.expansion, options.mass_scale, options.width
    growth, refine = options.growth, options.refine
    conserve = isinstance(mass_scale, str) and mass_scale == "conserve"
    result = _core.apply_stroke(
        cloth,
        trace,
        points,
        growth=growth,
        width=0.0 if width is None else float(width),
        refine=refine,
        expansion=expansion,
        mass_scale=1.0 if conserve else mass_scale,
        conserve_mass=conserve,
        max_vertices=MAX_REFINED_VERTICES if refine > 0 else MAX_MESH_VERTICES,
        **trace_options,
    )
    return StrokeReport(result, options, cloth.topology_version)


def trace_and_apply(cloth, path, options) -> StrokeReport:
    """One stroke on ``cloth`` along a `StrokePath`, traced in its space and applied
    (`apply_stroke`): a world path by closest points within ``options.max_distance`` (default
    5 % of the cloth's bounding-box diagonal), a screen path by the camera's rays through the
    current surface, a material path in the rest pattern (the cloth's material coordinates,
    to a tolerance of 1e-9 of their extent). ValueError for a max_distance on a path that is
    not a world one, and a material path on a cloth without material coordinates (the caller
    refuses a cloth without faces first)."""
    if options.max_distance is not None and path.space != "world":
        raise ValueError(
            f"max_distance is for 3-D (world) paths, not a {path.space} path "
            "(its samples are found by rays or in the rest pattern)"
        )
    if path.space == "world":
        max_distance = options.max_distance
        if max_distance is None:
            X = cloth.positions
            max_distance = 0.05 * float(np.linalg.norm(X.max(axis=0) - X.min(axis=0)))
        return apply_stroke(cloth, "closest", path.points, options, max_distance=max_distance)
    if path.space == "screen":
        d0, dx, dy = path.camera.pixel_rays()
        return apply_stroke(
            cloth,
            "rays",
            path.points,
            options,
            eye=np.asarray(path.camera.eye, float),
            base_direction=d0,
            direction_per_pixel_x=dx,
            direction_per_pixel_y=dy,
        )
    uv = cloth.material_coordinates
    if uv is None:
        raise ValueError(
            "the cloth has no material coordinates; set cloth.material_coordinates (n×2) first"
        )
    tolerance = 1e-9 * float(np.linalg.norm(uv.max(axis=0) - uv.min(axis=0)))
    return apply_stroke(cloth, "material", path.points, options, max_distance=tolerance)
