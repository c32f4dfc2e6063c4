"""The one camera model of yore: `Camera` (a pinhole camera), how it is fitted to a cloth, and
how a scene's or run's ``[camera]`` settings become one.

Every consumer uses this module: screen strokes (`Simulation.stroke_screen` casts rays through
`Camera.pixel_rays`), pictures and animations (`yore.viz` maps a Camera to polyscope's view and
back), the viewer and scene files.

Pixel coordinates: pixel (0, 0) is the top-left pixel, x to the right, y down, and the
coordinate (x, y) names the *centre* of pixel (x, y); polyscope's screen coordinates name pixel
corners, so polyscope's (x + ½, y + ½) is yore's (x, y) (`yore.viz` converts).

Framing (`fit_camera`): the camera keeps its direction and field of view and moves along and
across its line of sight until the points' projection is centred in the image and its larger
extent fills ``1 / margin`` of it, so the cloth fills the picture however it is shaped.
`follow_cameras` frames each frame of an animation on its own cloth and smooths the result, so
the view follows the cloth without jumps.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from .limits import LIMITS
from .checks import check_factor, check_image_size, check_points, check_vector

from .options import FOV_DEGREES, FOV_RULE, IMAGE_HEIGHT, IMAGE_WIDTH

__all__ = [
    "Camera",
    "fit_camera",
    "follow_cameras",
    "camera_from_settings",
    "DEFAULT_DIRECTION",
    "DEFAULT_FOV_DEGREES",
    "DEFAULT_MARGIN",
]

#: From the target towards the eye, for y up: a view from the front, a little from the right
#: and above (rotated with ``up`` when another up direction is asked for).
DEFAULT_DIRECTION = (0.35, 0.45, 1.0)
DEFAULT_FOV_DEGREES = FOV_DEGREES
#: The points' projected extent fills 1 / margin of the image's width or height.
DEFAULT_MARGIN = 1.06


#: Largest coordinate of a camera's eye, target and up (m; the limit of what a picture can
#: frame, `yore.viz.pictures.MAX_FRAME_COORDINATE`): an eye at 1e300 overflowed the
#: projection into numpy warnings and an empty picture.
MAX_CAMERA_COORDINATE = LIMITS.max_camera_coordinate


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: eye and target (m), up direction, vertical field of view (degrees) and
    image size (pixels). Pixel (0, 0) is the top-left corner, x to the right, y down."""

    eye: tuple
    target: tuple
    up: tuple = (0.0, 1.0, 0.0)
    fov_degrees: float = FOV_DEGREES
    width: int = IMAGE_WIDTH
    height: int = IMAGE_HEIGHT

    def __post_init__(self):
        for name in ("eye", "target", "up"):
            try:
                value = np.asarray(getattr(self, name), dtype=float)
            except (TypeError, ValueError):
                value = np.full(0, np.nan)
            if (
                value.shape != (3,)
                or not np.all(np.isfinite(value))
                or np.abs(value).max() > MAX_CAMERA_COORDINATE
            ):
                raise ValueError(
                    f"camera {name} must be 3 finite numbers within "
                    f"±{MAX_CAMERA_COORDINATE:g}, got {getattr(self, name)!r}"
                )
            object.__setattr__(self, name, tuple(float(c) for c in value))
        object.__setattr__(self, "fov_degrees", check_fov(self.fov_degrees, "camera fov_degrees"))
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

    def rays(self, pixels) -> np.ndarray:
        """Unit ray directions (k×3) from the eye through pixel coordinates (k×2)."""
        pixels = np.atleast_2d(np.asarray(pixels, dtype=float))
        d0, dx, dy = self.pixel_rays()
        directions = d0 + pixels[:, :1] * dx + pixels[:, 1:2] * dy
        return directions / np.linalg.norm(directions, axis=1, keepdims=True)

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
        return np.column_stack(
            [(x + 1.0) * self.width / 2.0 - 0.5, (1.0 - y) * self.height / 2.0 - 0.5]
        )

    def resized(self, width=None, height=None) -> Camera:
        """The same view at another image size; a width or height alone keeps the aspect
        ratio (the other side rounded to whole pixels)."""
        if width is not None and height is None:
            height = (
                max(1, round(int(width) * self.height / self.width))
                if isinstance(width, numbers.Integral)
                else width
            )
        elif height is not None and width is None:
            width = (
                max(1, round(int(height) * self.width / self.height))
                if isinstance(height, numbers.Integral)
                else height
            )
        return Camera(
            eye=self.eye,
            target=self.target,
            up=self.up,
            fov_degrees=self.fov_degrees,
            width=self.width if width is None else width,
            height=self.height if height is None else height,
        )


def _point_arrays(points):
    """A list of (k, 3) finite arrays from one array or a list of them."""
    if isinstance(points, np.ndarray) and points.ndim == 2:
        arrays = [points]
    elif isinstance(points, (list, tuple)) and points and all(np.ndim(p) == 2 for p in points):
        arrays = list(points)
    else:
        arrays = [points]
    arrays = [check_points(p, "points") for p in arrays]
    if sum(len(a) for a in arrays) == 0:
        raise ValueError("points is empty: fit_camera needs at least one point")
    return arrays


def default_direction(up) -> np.ndarray:
    """DEFAULT_DIRECTION turned by the rotation taking +y to ``up`` (unit vector)."""
    up = np.asarray(up, float) / np.linalg.norm(up)
    direction = np.asarray(DEFAULT_DIRECTION, float)
    y = np.array([0.0, 1.0, 0.0])
    axis = np.cross(y, up)
    sine, cosine = np.linalg.norm(axis), float(y @ up)
    if sine < 1e-12:
        return direction if cosine > 0 else direction * np.array([1.0, -1.0, -1.0])
    axis /= sine
    # Rodrigues' rotation of direction about axis by the angle from y to up
    return (
        direction * cosine
        + np.cross(axis, direction) * sine
        + axis * (axis @ direction) * (1.0 - cosine)
    )


def check_fov(value, name) -> float:
    """A field of view in degrees checked by `yore.options.FOV_RULE`; ValueError naming
    `name` otherwise."""
    ok, checked = FOV_RULE.test(value)
    if not ok:
        raise ValueError(f"{name} must be {FOV_RULE.expected} (degrees), got {value!r}")
    return float(checked)


def _fit_arguments(up, direction, margin, fov_degrees, width, height):
    """`fit_camera`'s arguments checked, in its order; ValueError naming the wrong one."""
    up = check_vector(up, "up")
    direction = default_direction(up) if direction is None else check_vector(direction, "direction")
    sine = np.linalg.norm(np.cross(direction, up)) / np.linalg.norm(direction) / np.linalg.norm(up)
    if sine <= 1e-9:
        raise ValueError(f"direction {tuple(direction)} must not be parallel to up {tuple(up)}")
    margin = check_factor(margin, "margin")
    if margin < 1.0:
        raise ValueError(f"margin must be >= 1, got {margin}")
    fov_degrees = check_fov(fov_degrees, "fov_degrees")
    width, height = check_image_size(width, height, "fit_camera")
    return up, direction, margin, fov_degrees, width, height


def _fitting_distance(points, centre, frame):
    """The least distance from `centre` at which a camera with `frame` (right, up, forward,
    tan_x, tan_y, clearance) sees every point inside its picture and in front of it, and the
    points' (x, y, z) about the centre in that frame."""
    right, upward, forward, tan_x, tan_y, clearance = frame
    relative = points - centre
    x, y, z = relative @ right, relative @ upward, relative @ forward
    # a point at (x, y, z) about the centre seen from distance D lies inside when
    # |x| <= tan_x (D + z) and |y| <= tan_y (D + z); and in front when D + z > 0
    inside = max(np.max(np.abs(x) / tan_x - z), np.max(np.abs(y) / tan_y - z))
    return float(max(inside, np.max(-z) + clearance)), (x, y, z)


# over 60 lines: a docstring for its 7 parameters (the code is 39 lines)
def fit_camera(
    points,
    width=IMAGE_WIDTH,
    height=IMAGE_HEIGHT,
    direction=None,
    up=(0.0, 1.0, 0.0),
    fov_degrees=DEFAULT_FOV_DEGREES,
    margin=DEFAULT_MARGIN,
) -> Camera:
    """A camera looking along ``-direction`` that frames ``points`` tightly.

    Parameters
    ----------
    points : (k, 3) array, or a list of (k_i, 3) arrays, metres
        What must be seen (a list: e.g. two states shown side by side with one camera).
    width, height : int
        Image size in pixels.
    direction : 3 floats, optional
        From the target towards the eye (any length, not along ``up``). Default:
        `DEFAULT_DIRECTION` rotated from +y to ``up``.
    up : 3 floats
        The world direction shown upwards.
    fov_degrees : float
        Vertical field of view in degrees, in (0, 180).
    margin : float
        >= 1: the points' projection is centred and its larger relative extent is 1/margin of
        the image (1.06: a thin border). Coincident points get a 1 m box.

    Returns
    -------
    Camera
        Target and eye chosen so that every point is in front of the eye and inside the
        picture (found by a few fixed-point rounds: the distance that fits the points about
        a centre, then the centre moved to the middle of their projection).

    Raises
    ------
    ValueError
        If there are no points, a point array is not (k, 3) or not finite, ``direction`` is
        zero or along ``up``, or a number is out of range.
    """
    stacked = np.concatenate(_point_arrays(points))
    up, direction, margin, fov_degrees, width, height = _fit_arguments(
        up, direction, margin, fov_degrees, width, height
    )

    backward = direction / np.linalg.norm(direction)
    forward = -backward
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    upward = np.cross(right, forward)
    tan_y = math.tan(math.radians(fov_degrees) / 2.0) / margin
    tan_x = tan_y * width / height
    low, high = stacked.min(axis=0), stacked.max(axis=0)
    size = float(np.linalg.norm(high - low))
    if size == 0.0:
        stacked = np.concatenate([stacked, stacked[:1] + 0.5, stacked[:1] - 0.5])
        size = float(np.linalg.norm(stacked.max(axis=0) - stacked.min(axis=0)))
    centre = (stacked.min(axis=0) + stacked.max(axis=0)) / 2.0
    frame = (right, upward, forward, tan_x, tan_y, 1e-3 * size)
    for _ in range(6):
        distance, (x, y, z) = _fitting_distance(stacked, centre, frame)
        depth = distance + z
        u, v = x / depth / tan_x, y / depth / tan_y
        shift_u, shift_v = (u.max() + u.min()) / 2.0, (v.max() + v.min()) / 2.0
        if max(abs(shift_u), abs(shift_v)) < 1e-4:
            break
        # moving the centre across the line of sight by s at distance D shifts the image by
        # about s / (D tan); exact at the points' mean depth, so a few rounds converge
        centre = centre + (right * shift_u * tan_x + upward * shift_v * tan_y) * distance
    distance, _ = _fitting_distance(stacked, centre, frame)
    eye = centre - distance * forward
    return Camera(
        eye=tuple(eye),
        target=tuple(centre),
        up=tuple(float(c) for c in up),
        fov_degrees=fov_degrees,
        width=width,
        height=height,
    )


def follow_cameras(
    frames,
    width=IMAGE_WIDTH,
    height=IMAGE_HEIGHT,
    direction=None,
    up=(0.0, 1.0, 0.0),
    fov_degrees=DEFAULT_FOV_DEGREES,
    margin=DEFAULT_MARGIN,
    window=9,
) -> list:
    """One camera per frame (a list of (k_i, 3) position arrays) that follows the cloth: each
    frame is framed on its own (`fit_camera`), then the targets are averaged and the
    distances taken as the largest over a centred window of ``window`` frames, so the view
    glides instead of jumping and no frame is cropped by the smoothing of its neighbours'
    targets more than the window's motion."""
    fitted = [
        fit_camera(points, width, height, direction, up, fov_degrees, margin) for points in frames
    ]
    if not fitted:
        raise ValueError("frames is empty: follow_cameras needs at least one frame")
    eyes = np.array([c.eye for c in fitted])
    targets = np.array([c.target for c in fitted])
    offsets = eyes - targets
    distances = np.linalg.norm(offsets, axis=1)
    unit = offsets[0] / distances[0]
    half = max(int(window), 1) // 2
    cameras = []
    for k in range(len(fitted)):
        lo, hi = max(0, k - half), min(len(fitted), k + half + 1)
        target = targets[lo:hi].mean(axis=0)
        # the distance that still frames this frame about the smoothed target, or the
        # window's largest, whichever is larger
        spread = np.linalg.norm(targets[lo:hi] - target, axis=1).max()
        distance = distances[lo:hi].max() + spread / math.tan(math.radians(fov_degrees) / 2)
        cameras.append(
            Camera(
                eye=tuple(target + distance * unit),
                target=tuple(target),
                up=fitted[k].up,
                fov_degrees=fov_degrees,
                width=width,
                height=height,
            )
        )
    return cameras


def camera_from_settings(
    settings, points, width=None, height=None, eye=None, target=None, up=None, fov_degrees=None
) -> Camera:
    """A camera from [camera] settings (a scene's table, or a run summary's copy of it): eye
    and target as given, else fitted to ``points`` (one (k, 3) array or a list of them); the
    arguments, when given, override the settings. A width or a height given alone keeps the
    settings' aspect ratio."""
    settings = settings or {}
    base_width = int(settings.get("width", IMAGE_WIDTH))
    base_height = int(settings.get("height", IMAGE_HEIGHT))
    if width is not None and height is None:
        height = max(1, round(base_height * int(width) / base_width))
    elif height is not None and width is None:
        width = max(1, round(base_width * int(height) / base_height))
    width = int(width or base_width)
    height = int(height or base_height)
    up = tuple(up if up is not None else settings.get("up", (0.0, 1.0, 0.0)))
    fov = float(
        fov_degrees if fov_degrees is not None else settings.get("fov_degrees", DEFAULT_FOV_DEGREES)
    )
    eye = eye if eye is not None else settings.get("eye")
    target = target if target is not None else settings.get("target")
    if eye is not None and target is not None:
        return Camera(
            eye=tuple(eye), target=tuple(target), up=up, fov_degrees=fov, width=width, height=height
        )
    if eye is not None:
        # an eye alone looks at the cloth's centre
        stacked = np.concatenate(_point_arrays(points))
        centre = (stacked.min(axis=0) + stacked.max(axis=0)) / 2.0
        return Camera(
            eye=tuple(eye), target=tuple(centre), up=up, fov_degrees=fov, width=width, height=height
        )
    if target is not None:
        fitted = fit_camera(points, width, height, None, up, fov)
        offset = np.asarray(fitted.eye) - np.asarray(fitted.target)
        return Camera(
            eye=tuple(np.asarray(target, float) + offset),
            target=tuple(target),
            up=up,
            fov_degrees=fov,
            width=width,
            height=height,
        )
    return fit_camera(points, width, height, None, up, fov)
