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
"""

from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass, field

import numpy as np

from . import _core
from .metrics import face_areas

__all__ = ["Camera", "StrokeMissed", "StrokeReport", "MIN_BARYCENTRIC", "MIN_ANGLE_DEGREES",
           "MAX_IMAGE_SIDE", "MAX_IMAGE_PIXELS"]

#: The degenerate-case rules (see the module docstring).
MIN_BARYCENTRIC = 0.1
MIN_ANGLE_DEGREES = 5.0


#: Largest image a camera may have: each side at most MAX_IMAGE_SIDE pixels and at most
#: MAX_IMAGE_PIXELS pixels in all (2^23, e.g. 3840×2160), checked before anything is allocated
#: (the renderer needs some 60 bytes per pixel).
MAX_IMAGE_SIDE = 16384
MAX_IMAGE_PIXELS = 1 << 23


def check_image_size(width, height, what="camera"):
    """(width, height) as ints if both are integers in [1, MAX_IMAGE_SIDE] whose product is at
    most MAX_IMAGE_PIXELS; ValueError naming the side, its value and the limit otherwise."""
    for name, value in (("width", width), ("height", height)):
        if (isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral)
                or not 1 <= value <= MAX_IMAGE_SIDE):
            text = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
            raise ValueError(f"{what} {name}: got {type(value).__name__} {text}; expected an "
                             f"integer number of pixels in [1, {MAX_IMAGE_SIDE}]")
    if int(width) * int(height) > MAX_IMAGE_PIXELS:
        raise ValueError(f"{what} image size: {int(width)}×{int(height)} = "
                         f"{int(width) * int(height)} pixels is more than the limit of "
                         f"{MAX_IMAGE_PIXELS} pixels")
    return int(width), int(height)


class StrokeMissed(ValueError):
    """The stroke touches the cloth nowhere."""


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: eye and target (m), up direction, vertical field of view (degrees) and
    image size (pixels). Pixel (0, 0) is the top-left corner, x to the right, y down."""

    eye: tuple
    target: tuple
    up: tuple = (0.0, 1.0, 0.0)
    fov_degrees: float = 45.0
    width: int = 800
    height: int = 600

    def __post_init__(self):
        for name in ("eye", "target", "up"):
            try:
                value = np.asarray(getattr(self, name), dtype=float)
            except (TypeError, ValueError):
                value = np.full(0, np.nan)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise ValueError(f"camera {name} must be 3 finite numbers, got {getattr(self, name)!r}")
        if (isinstance(self.fov_degrees, (bool, np.bool_))
                or not isinstance(self.fov_degrees, numbers.Real)
                or not 0.0 < float(self.fov_degrees) < 180.0):
            raise ValueError(f"camera fov_degrees must be in (0, 180), got {self.fov_degrees}")
        width, height = check_image_size(self.width, self.height)
        object.__setattr__(self, "width", width)
        object.__setattr__(self, "height", height)
        forward = np.asarray(self.target, float) - np.asarray(self.eye, float)
        if np.linalg.norm(forward) == 0 or np.linalg.norm(np.cross(forward, self.up)) == 0:
            raise ValueError("camera target must differ from eye and not lie along up")

    def basis(self):
        """Unit vectors (right, up, forward) of the camera."""
        forward = np.asarray(self.target, float) - np.asarray(self.eye, float)
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, np.asarray(self.up, float))
        right /= np.linalg.norm(right)
        return right, np.cross(right, forward), forward

    def _scales(self):
        half_height = math.tan(math.radians(self.fov_degrees) / 2.0)
        return half_height * self.width / self.height, half_height

    def pixel_rays(self):
        """(d0, dx, dy): the ray direction through pixel (px, py) is d0 + px·dx + py·dy."""
        right, up, forward = self.basis()
        half_width, half_height = self._scales()
        dx = right * (2.0 * half_width / self.width)
        dy = -up * (2.0 * half_height / self.height)
        d0 = forward - right * half_width + up * half_height + 0.5 * (dx + dy)
        return d0, dx, dy

    def project(self, points) -> np.ndarray:
        """Pixel coordinates (k×2) of 3-D points in front of the camera."""
        points = np.atleast_2d(np.asarray(points, dtype=float)) - np.asarray(self.eye, float)
        right, up, forward = self.basis()
        depth = points @ forward
        if np.any(depth <= 0):
            raise ValueError("a point lies behind the camera")
        half_width, half_height = self._scales()
        x = (points @ right) / depth / half_width
        y = (points @ up) / depth / half_height
        return np.column_stack([(x + 1.0) * self.width / 2.0 - 0.5,
                                (1.0 - y) * self.height / 2.0 - 0.5])


@dataclass
class StrokeReport:
    """What a stroke did. Areas in m², times in s. ``reanalyze_seconds`` is filled in by the
    next step (0 for the explicit integrator, which has nothing to rebuild)."""

    faces_split: int
    faces_skipped: np.ndarray
    vertices_added: int
    springs_added: int
    springs_removed: int
    region_faces: np.ndarray
    new_vertices: np.ndarray
    area_before: float
    rest_area_before: float
    rest_area_after: float
    samples: int
    missed_samples: int
    moved_inward: int
    locate_seconds: float
    subdivide_seconds: float
    reanalyze_seconds: float | None = None
    topology_version: int = 0
    extra: dict = field(default_factory=dict)

    @property
    def missed_fraction(self) -> float:
        """Fraction of the stroke's samples that touched no surface (a partly missing stroke)."""
        return self.missed_samples / self.samples if self.samples else 0.0


#: Largest stroke coordinate accepted (m or px): far beyond any cloth, small enough that the
#: polyline's length and its clipping to the cloth's reach stay exact to well under a sample.
#: Beyond the clipping, a stroke takes at most `_core` kMaxStrokeSamples (10^6) samples.
MAX_STROKE_COORDINATE = 1e12


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
        raise ValueError(f"{name} holds a coordinate of magnitude {np.abs(array).max():.3g}, "
                         f"beyond ±{MAX_STROKE_COORDINATE:g} (metres or pixels)")
    if dimension == 2:
        array = np.column_stack([array, np.zeros(len(array))])
    return np.ascontiguousarray(array)


def check_factor(value, name: str, unit: str = "") -> float:
    """`value` as a finite float > 0; ValueError naming `name` otherwise."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number{unit and f' ({unit})'}, got {value!r}") from None
    if not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"{name} must be finite and > 0{unit and f' ({unit})'}, got {number}")
    return number


def mean_edge_length(V, F) -> float:
    V = np.asarray(V, dtype=float)
    return float(np.mean([np.linalg.norm(V[F[:, a]] - V[F[:, b]], axis=1).mean()
                          for a, b in ((0, 1), (1, 2), (2, 0))]))


def apply_stroke(cloth, trace, expansion, mass_scale, locate_seconds) -> StrokeReport:
    """Splits the faces a trace found; raises StrokeMissed when it found none."""
    if len(trace["faces"]) == 0:
        raise StrokeMissed(f"the stroke touches the cloth nowhere ({trace['samples']} samples, "
                           "all missed)")
    area_before = float(face_areas(cloth.positions, cloth.faces)[trace["faces"]].sum())
    start = time.perf_counter()
    split = _core.split_faces(cloth, trace["faces"], trace["barycentric"], expansion=expansion,
                              mass_scale=mass_scale, min_barycentric=MIN_BARYCENTRIC,
                              min_angle_degrees=MIN_ANGLE_DEGREES)
    subdivide = time.perf_counter() - start
    return StrokeReport(
        faces_split=len(split["split_faces"]), faces_skipped=np.array(split["skipped_faces"]),
        vertices_added=len(split["new_vertices"]), springs_added=split["springs_added"],
        springs_removed=split["springs_removed"], region_faces=np.array(split["region_faces"]),
        new_vertices=np.array(split["new_vertices"]), area_before=area_before,
        rest_area_before=split["rest_area_before"], rest_area_after=split["rest_area_after"],
        samples=trace["samples"], missed_samples=trace["missed_samples"],
        moved_inward=split["moved_inward"], locate_seconds=locate_seconds,
        subdivide_seconds=subdivide, topology_version=cloth.topology_version)
