"""Pictures and animations of cloth meshes from a small numpy software renderer.

numpy does the rasterization; Pillow (imported only where needed) draws titles and writes PNG
and GIF files, and ``ffmpeg`` (if installed) encodes MP4. No matplotlib, no GPU.

How an image is made (:func:`render_image`):

1. Vertices go to camera space (the :class:`~yore.stroke.Camera` basis). Triangles crossing the
   near plane, at depth ``NEAR_FRACTION`` × the farthest vertex's depth, are clipped against it
   (one triangle becomes one or two), so a camera among the cloth still sees what is in front
   of it; triangles wholly behind it are dropped.
2. Each face gets one colour (flat shading): ``color``, or its ``face_values`` through a colour
   map, times ``AMBIENT + DIFFUSE·|cos θ|`` where θ is the angle between the face normal and the
   direction to the eye (a two-sided Lambert term with a headlight). Faces seen from their back
   (clockwise on screen) are further scaled by ``BACK_FACE_SHADE`` so folds read.
3. All triangles are scan-converted at once: every (triangle, pixel row) pair gives the span of
   pixel centres inside the triangle, spans are expanded to fragments, and a z-buffer on inverse
   depth (which, unlike depth, is affine in screen space) keeps the nearest fragment per pixel.
4. Strokes are drawn as ``STROKE_COLOR`` polylines about 2.5 px wide, depth-tested against the
   surface with a relative tolerance ``STROKE_DEPTH_TOLERANCE`` (a stroke lies on the cloth, but
   its straight chords between vertices dip slightly into it): the part of a stroke that runs
   behind the cloth is hidden.

Pixel (x, y) is the unit square centred on (x, y) in the coordinates of :meth:`Camera.project`
(x right, y down). A triangle covers the pixels whose centres lie inside it or on its edges;
there is no anti-aliasing.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from .stroke import MAX_IMAGE_PIXELS, Camera, check_factor, check_image_size

__all__ = [
    "check_ffmpeg",
    "fit_camera",
    "render_image",
    "side_by_side",
    "save_png",
    "save_animation",
    "COLORMAPS",
    "STROKE_COLOR",
]

#: Shading: intensity = AMBIENT + DIFFUSE·|cos θ|, so a face seen head-on shows its full colour.
AMBIENT = 0.3
DIFFUSE = 0.7
#: Extra factor for faces seen from behind, so the two sides of a fold differ.
BACK_FACE_SHADE = 0.75
#: With ``edges=True``, pixels closer than this to a triangle edge (px) are scaled by EDGE_SHADE;
#: both triangles of an edge do this, so lines are about twice as wide.
EDGE_HALF_WIDTH = 0.5
EDGE_SHADE = 0.6
#: Strokes: RGB colour (0–255) and half-width in pixels.
STROKE_COLOR = (220, 30, 30)
STROKE_RADIUS = 1.25
#: A stroke pixel shows unless the surface there is nearer than its depth / (1 + this).
STROKE_DEPTH_TOLERANCE = 0.02
#: Near clipping plane as a fraction of the farthest depth: small enough to be invisible, large
#: enough that clipped vertices project to finite, float-safe pixel coordinates.
NEAR_FRACTION = 1e-3
#: Fragments rasterized per batch; bounds the temporary memory to some tens of MB.
_FRAGMENT_BATCH = 1 << 20
#: Slack (px) of the inside test, so pixel centres on an edge shared by two triangles are not
#: lost to rounding in both.
_INSIDE_TOLERANCE = 1e-7

# Colour maps as (position in [0, 1], RGB in [0, 1]) control points, linearly interpolated.
_COLORMAP_POINTS = {
    # diverging blue – light grey – red; a light grey centre stays visible on white backgrounds
    "coolwarm": np.array([
        [0.00, 0.23, 0.30, 0.75],
        [0.25, 0.55, 0.67, 0.96],
        [0.50, 0.92, 0.92, 0.92],
        [0.75, 0.95, 0.60, 0.48],
        [1.00, 0.71, 0.02, 0.15],
    ]),
    # sequential dark purple – blue – green – yellow, ordered in lightness like viridis
    "viridis": np.array([
        [0.00, 0.267, 0.005, 0.329],
        [0.25, 0.229, 0.322, 0.546],
        [0.50, 0.128, 0.567, 0.551],
        [0.75, 0.369, 0.789, 0.383],
        [1.00, 0.993, 0.906, 0.144],
    ]),
}
#: Names accepted by ``render_image(colormap=...)``.
COLORMAPS = tuple(_COLORMAP_POINTS)

_ANIMATION_SUFFIXES = (".gif", ".mp4")


# --------------------------------------------------------------------------------------------
# camera


def fit_camera(points, width=800, height=600, direction=(0.35, 0.45, 1.0), up=(0.0, 1.0, 0.0),
               fov_degrees=35.0, margin=1.08) -> Camera:
    """A camera that sees all ``points``, looking at their bounding-box centre.

    Parameters
    ----------
    points : (k, 3) array, or a list of (k_i, 3) arrays, metres
        For an animation pass every frame's vertices, so one camera fits the whole run.
    width, height : int
        Image size in pixels.
    direction : 3 floats
        From the target towards the eye (any length, not along ``up``).
    up : 3 floats
        The world direction shown upwards.
    fov_degrees : float
        Vertical field of view in degrees, in (0, 180).
    margin : float
        The sphere around the bounding-box centre through the farthest point, scaled by
        ``margin`` (> 0), is made to fit in the view; 1.08 leaves a thin border. Coincident
        points get a sphere of radius 1 m.

    Returns
    -------
    Camera
        Eye at ``centre + d·direction/|direction|`` with the smallest ``d`` for which the
        sphere lies inside both the vertical and the horizontal field of view.

    Raises
    ------
    ValueError
        If there are no points, a point array is not (k, 3) or not finite, ``direction`` is
        zero or along ``up``, or a number is out of range.
    """
    arrays = _point_arrays(points)
    stacked = np.concatenate(arrays)
    if len(stacked) == 0:
        raise ValueError("points is empty: fit_camera needs at least one point")
    direction = _check_vector(direction, "direction")
    up = _check_vector(up, "up")
    sine = np.linalg.norm(np.cross(direction, up)) / np.linalg.norm(direction) / np.linalg.norm(up)
    if sine <= 1e-12:
        raise ValueError(f"direction {tuple(direction)} must not be parallel to up {tuple(up)}")
    margin = check_factor(margin, "margin")
    fov_degrees = check_factor(fov_degrees, "fov_degrees")
    if fov_degrees >= 180.0:
        raise ValueError(f"fov_degrees must be in (0, 180), got {fov_degrees}")
    width, height = check_image_size(width, height, "fit_camera")

    centre = (stacked.min(axis=0) + stacked.max(axis=0)) / 2.0
    radius = float(np.max(np.linalg.norm(stacked - centre, axis=1)))
    if radius == 0.0:
        radius = 1.0
    half_vertical = math.radians(fov_degrees) / 2.0
    half_horizontal = math.atan(math.tan(half_vertical) * width / height)
    # A sphere of radius R at distance d fills a cone of half-angle asin(R/d); the image's
    # rectangle contains the cone of the smaller half-angle.
    distance = radius * margin / math.sin(min(half_vertical, half_horizontal))
    eye = centre + distance * direction / np.linalg.norm(direction)
    return Camera(eye=tuple(float(c) for c in eye), target=tuple(float(c) for c in centre),
                  up=tuple(float(c) for c in up), fov_degrees=fov_degrees, width=width,
                  height=height)


def _point_arrays(points):
    """``points`` as a list of (k, 3) float arrays (one array, or a list of them)."""
    if isinstance(points, np.ndarray):
        items = [points]
    else:
        items = list(points)
        # A list of 3-number rows is one point set, not many.
        if items and np.ndim(items[0]) == 1:
            items = [items]
    if not items:
        raise ValueError("points is empty: fit_camera needs at least one point")
    return [_check_points(item, "points" if len(items) == 1 else f"points[{i}]")
            for i, item in enumerate(items)]


def _camera_frame(camera):
    """(eye, right, up, forward, half_width, half_height) of ``camera``; tan of the half-angles."""
    if not isinstance(camera, Camera):
        raise ValueError(f"camera must be a yore.stroke.Camera, got {type(camera).__name__}")
    right, up, forward = camera.basis()
    half_height = math.tan(math.radians(float(camera.fov_degrees)) / 2.0)
    half_width = half_height * int(camera.width) / int(camera.height)
    return np.asarray(camera.eye, float), right, up, forward, half_width, half_height


def _to_camera_space(points, frame):
    """k×3 world points (m) → k×3 (right, up, depth) coordinates (m) relative to the eye."""
    eye, right, up, forward = frame[:4]
    relative = points - eye
    return np.column_stack([relative @ right, relative @ up, relative @ forward])


def _to_pixels(camera_points, frame, width, height):
    """k×3 camera-space points with depth > 0 → k×2 pixel coordinates, as Camera.project."""
    half_width, half_height = frame[4:]
    depth = camera_points[:, 2]
    x = camera_points[:, 0] / depth / half_width
    y = camera_points[:, 1] / depth / half_height
    return np.column_stack([(x + 1.0) * width / 2.0 - 0.5, (1.0 - y) * height / 2.0 - 0.5])


# --------------------------------------------------------------------------------------------
# rendering


def render_image(V, F, camera, *, face_values=None, value_range=None, colormap="coolwarm",
                 strokes=(), color=(0.44, 0.66, 0.86), background=(1.0, 1.0, 1.0),
                 edges=False) -> np.ndarray:
    """Renders a triangle mesh, flat shaded, with optional strokes drawn over it.

    Parameters
    ----------
    V : (n, 3) float array, metres
        Vertex positions (world space, y up), all finite.
    F : (f, 3) int array
        Triangles as vertex indices in [0, n).
    camera : Camera
        Viewpoint and image size.
    face_values : (f,) float array, optional
        One finite value per face (e.g. rest-length expansion, 1.0 = untouched) coloured through
        ``colormap`` instead of ``color``.
    value_range : (low, high), optional
        Values mapped to the two ends of the colour map (low < high); values outside are
        clamped. Used only with ``face_values``. By default: for ``"coolwarm"``, if the values'
        range [min, max] contains 1.0, the range symmetric about 1.0 that holds them all, so 1.0
        gets the neutral centre colour; otherwise [min, max]. If all values are equal they get
        the map's middle colour.
    colormap : str
        One of :data:`COLORMAPS`: ``"coolwarm"`` (diverging blue–white–red) or ``"viridis"``.
    strokes : iterable of (k, 3) float arrays, metres
        Polylines drawn in :data:`STROKE_COLOR`, about 2.5 px wide, over the mesh (not hidden by
        it). Parts behind the camera's near plane are clipped away; a single point is a dot.
    color : 3 floats in [0, 1]
        Face colour (RGB) when ``face_values`` is not given.
    background : 3 floats in [0, 1]
        Background colour (RGB).
    edges : bool
        Darken pixels within about half a pixel of triangle edges (a thin wireframe). Edges
        made by near-plane clipping are not drawn.

    Returns
    -------
    (camera.height, camera.width, 3) uint8 array
        RGB image, row 0 at the top.

    Raises
    ------
    ValueError
        If an array has the wrong shape, V or face_values is not finite, a face index is out of
        range, value_range, colormap or a colour is invalid, or camera is not a Camera.
    """
    V = _check_points(V, "V")
    F = _check_faces(F, len(V))
    frame = _camera_frame(camera)
    # A Camera checks its size too; checked again here because everything below is allocated
    # per pixel.
    width, height = check_image_size(camera.width, camera.height)
    base_color = _check_unit_rgb(color, "color")
    background = _check_unit_rgb(background, "background")
    polylines = _check_strokes(strokes)
    if colormap not in _COLORMAP_POINTS:
        raise ValueError(f"colormap must be one of {', '.join(COLORMAPS)}, got {colormap!r}")
    if face_values is None:
        face_colors = np.tile(base_color, (len(F), 1))
    else:
        face_colors = _map_values(_check_face_values(face_values, len(F)), value_range, colormap)
    face_colors = face_colors * _face_shading(V, F, frame[0])[:, None]

    image = np.empty((height * width, 3))
    image[:] = background
    depth_buffer = np.full(height * width, -np.inf)
    camera_vertices = _to_camera_space(V, frame)
    camera_strokes = [_to_camera_space(points, frame) for points in polylines]
    farthest = max([0.0] + [float(points[:, 2].max())
                            for points in [camera_vertices] + camera_strokes if len(points)])
    near = NEAR_FRACTION * farthest
    if len(F) and farthest > 0.0:
        triangles, parent, real_edges = _clip_near(camera_vertices[F], near)
        owner, edge_distance, depth_buffer = _rasterize(triangles, real_edges, frame, width,
                                                        height)
        covered = owner >= 0
        image[covered] = face_colors[parent[owner[covered]]]
        if edges:
            on_edge = edge_distance(covered) < EDGE_HALF_WIDTH
            covered_index = np.flatnonzero(covered)
            image[covered_index[on_edge]] *= EDGE_SHADE
    image = np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)
    if farthest > 0.0:
        for points in camera_strokes:
            _draw_polyline(image, points, near, frame, width, height, depth_buffer)
    return image.reshape(height, width, 3)


def _face_shading(V, F, eye):
    """(f,) brightness factors of the faces: two-sided headlight Lambert, back faces darker."""
    corners = V[F]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    to_eye = eye - corners.mean(axis=1)
    lengths = np.linalg.norm(normal, axis=1) * np.linalg.norm(to_eye, axis=1)
    # Degenerate faces (zero normal) or an eye on the face get cos θ = 0: ambient only.
    cosine = np.divide(np.einsum("ij,ij->i", normal, to_eye), lengths,
                       out=np.zeros(len(F)), where=lengths > 0)
    shade = AMBIENT + DIFFUSE * np.abs(cosine)
    return np.where(cosine < 0.0, BACK_FACE_SHADE * shade, shade)


def _clip_near(triangles, near):
    """Clips camera-space triangles (m×3×3, depth last) to depth >= near.

    Returns (triangles m'×3×3, parent (m',) index of the input triangle each came from,
    real_edges m'×3 bool: whether edge i, opposite vertex i, lies on an input edge).
    """
    behind = triangles[:, :, 2] < near
    count = behind.sum(axis=1)
    whole = count == 0
    pieces = [triangles[whole]]
    parents = [np.flatnonzero(whole)]
    reals = [np.ones((int(whole.sum()), 3), dtype=bool)]

    def crossing(behind_point, front_point):
        # Always parametrized from the behind end, so the two triangles sharing a clipped edge
        # compute bit-identical points and no crack opens between them.
        t = (near - behind_point[:, 2]) / (front_point[:, 2] - behind_point[:, 2])
        return behind_point + t[:, None] * (front_point - behind_point)

    # Rolling the corners so the odd one out comes first keeps the winding.
    roll = (np.arange(3)[None, :] + np.arange(3)[:, None]) % 3

    one = np.flatnonzero(count == 1)
    if len(one):
        a, b, c = np.moveaxis(triangles[one[:, None], roll[np.argmax(behind[one], axis=1)]], 1, 0)
        p, q = crossing(a, b), crossing(a, c)
        # the quad p, b, c, q split along p–c
        pieces += [np.stack([p, b, c], axis=1), np.stack([p, c, q], axis=1)]
        parents += [one, one]
        reals += [np.tile([True, False, True], (len(one), 1)),
                  np.tile([True, False, False], (len(one), 1))]

    two = np.flatnonzero(count == 2)
    if len(two):
        a, b, c = np.moveaxis(triangles[two[:, None], roll[np.argmin(behind[two], axis=1)]], 1, 0)
        pieces.append(np.stack([a, crossing(b, a), crossing(c, a)], axis=1))
        parents.append(two)
        reals.append(np.tile([False, True, True], (len(two), 1)))
    return np.concatenate(pieces), np.concatenate(parents), np.concatenate(reals)


def _runs(counts):
    """For consecutive runs of the given lengths: (run index, position in run) of each element."""
    counts = np.asarray(counts, dtype=np.int64)
    run = np.repeat(np.arange(len(counts)), counts)
    starts = np.cumsum(counts) - counts
    return run, np.arange(len(run)) - starts[run]


def _rasterize(triangles, real_edges, frame, width, height):
    """Z-buffered scan conversion of camera-space triangles (m×3×3, all depths > 0).

    Returns (owner, edge_distance, depth_buffer): owner is the (height·width,) index of the
    triangle seen at each pixel (−1 for none); edge_distance(mask) gives, for the pixels where
    mask holds, the distance in pixels to the nearest real edge of the owner triangle;
    depth_buffer holds the inverse depth (1/m) seen at each pixel (−inf for none).
    """
    screen = _to_pixels(triangles.reshape(-1, 3), frame, width, height).reshape(-1, 3, 2)
    inverse_depth = 1.0 / triangles[:, :, 2]
    x, y = screen[:, :, 0], screen[:, :, 1]
    # Edge i runs from corner i+1 to corner i+2; its edge function is zero on it and equals
    # twice the signed area at corner i.
    j, k = [1, 2, 0], [2, 0, 1]
    edge_x, edge_y = x[:, k] - x[:, j], y[:, k] - y[:, j]
    coefficient_x = -edge_y
    coefficient_y = edge_x
    constant = edge_y * x[:, j] - edge_x * y[:, j]
    twice_area = ((x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0])
                  - (y[:, 1] - y[:, 0]) * (x[:, 2] - x[:, 0]))
    edge_length = np.hypot(edge_x, edge_y)

    keep = np.abs(twice_area) > 1e-12
    low = np.ceil(screen.min(axis=1))
    high = np.floor(screen.max(axis=1))
    x_low, y_low = np.maximum(low[:, 0], 0), np.maximum(low[:, 1], 0)
    x_high, y_high = np.minimum(high[:, 0], width - 1), np.minimum(high[:, 1], height - 1)
    keep &= (x_low <= x_high) & (y_low <= y_high)

    # Signed distance to each edge in pixels, positive inside: d_i = a_i·x + b_i·y + c_i.
    scale = np.sign(twice_area)[:, None] / np.where(edge_length > 0, edge_length, 1.0)
    a, b, c = coefficient_x * scale, coefficient_y * scale, constant * scale
    # Inverse depth is affine in screen space: 1/z = Σ_i w_i/z_i with barycentric
    # w_i = edge function i / twice area.
    safe_area = np.where(keep, twice_area, 1.0)
    depth_x = (coefficient_x * inverse_depth).sum(axis=1) / safe_area
    depth_y = (coefficient_y * inverse_depth).sum(axis=1) / safe_area
    depth_c = (constant * inverse_depth).sum(axis=1) / safe_area

    owner = np.full(width * height, -1, dtype=np.int64)
    depth_buffer = np.full(width * height, -np.inf)
    visible = np.flatnonzero(keep)
    if len(visible):
        row_triangle, row_offset = _runs((y_high[visible] - y_low[visible] + 1).astype(np.int64))
        triangle = visible[row_triangle]
        row = y_low[triangle] + row_offset
        # Span of row `row` inside triangle: a_i·x >= -(b_i·row + c_i) for the three edges.
        rest = b[triangle] * row[:, None] + c[triangle] + _INSIDE_TOLERANCE
        coefficient = a[triangle]
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -rest / coefficient
        first = np.max(np.where(coefficient > 0, bound, -np.inf), axis=1)
        last = np.min(np.where(coefficient < 0, bound, np.inf), axis=1)
        first = np.maximum(np.ceil(first), x_low[triangle])
        last = np.minimum(np.floor(last), x_high[triangle])
        empty = np.any((coefficient == 0) & (rest < 0), axis=1) | (first > last)
        span_count = np.where(empty, 0, last - first + 1).astype(np.int64)
        span_pixel = (row * width + first).astype(np.int64)
        span_depth = depth_x[triangle] * first + depth_y[triangle] * row + depth_c[triangle]
        span_slope = depth_x[triangle]
        _resolve_depth(span_count, span_pixel, span_depth, span_slope, triangle, owner,
                       depth_buffer, max(_FRAGMENT_BATCH, width))

    def edge_distance(mask):
        pixel = np.flatnonzero(mask)
        seen = owner[pixel]
        px, py = (pixel % width)[:, None], (pixel // width)[:, None]
        distance = a[seen] * px + b[seen] * py + c[seen]
        return np.min(np.where(real_edges[seen], distance, np.inf), axis=1)

    return owner, edge_distance, depth_buffer


def _resolve_depth(span_count, span_pixel, span_depth, span_slope, span_triangle, owner,
                   depth_buffer, batch):
    """Writes the nearest span fragment per pixel into owner, in batches of about `batch`.

    A fragment wins in its batch if its inverse depth equals the buffer's maximum so far; a
    later batch can only overwrite it with a fragment at least as near, so the result after
    the last batch is the nearest fragment overall (ties: either one).
    """
    ends = np.cumsum(span_count)
    start = 0
    while start < len(span_count):
        done = ends[start - 1] if start else 0
        stop = max(int(np.searchsorted(ends, done + batch, side="right")), start + 1)
        span, offset = _runs(span_count[start:stop])
        span += start
        pixel = span_pixel[span] + offset
        inverse_depth = span_depth[span] + span_slope[span] * offset
        np.maximum.at(depth_buffer, pixel, inverse_depth)
        win = inverse_depth >= depth_buffer[pixel]
        owner[pixel[win]] = span_triangle[span[win]]
        start = stop


def _draw_polyline(image, points, near, frame, width, height, depth_buffer):
    """Paints a camera-space polyline (k×3) into the flat (height·width, 3) uint8 image where
    it is not behind the surface (``depth_buffer``: inverse depth per pixel) by more than
    STROKE_DEPTH_TOLERANCE."""
    if len(points) == 1:
        start, end = points, points
    else:
        start, end = points[:-1], points[1:]
    start_behind, end_behind = start[:, 2] < near, end[:, 2] < near
    keep = ~(start_behind & end_behind)
    start, end = start[keep].copy(), end[keep].copy()
    start_behind, end_behind = start_behind[keep], end_behind[keep]
    for moved, other, behind in ((start, end, start_behind), (end, start, end_behind)):
        t = (near - moved[behind, 2]) / (other[behind, 2] - moved[behind, 2])
        moved[behind] += t[:, None] * (other[behind] - moved[behind])
    if len(start) == 0:
        return
    p = _to_pixels(start, frame, width, height)
    q = _to_pixels(end, frame, width, height)
    # Inverse depth is affine along the projected segment (as across a projected triangle).
    inverse_p, inverse_q = 1.0 / start[:, 2], 1.0 / end[:, 2]
    # Clip to a rectangle a little larger than the image (Liang–Barsky), so a segment passing
    # near the eye, which projects enormously long, is not subdivided into millions of pieces.
    pad = STROKE_RADIUS + 1.0
    t0, t1 = np.zeros(len(p)), np.ones(len(p))
    d = q - p
    for axis, limit in ((0, width), (1, height)):
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = (-pad - p[:, axis]) / d[:, axis]
            tb = (limit - 1 + pad - p[:, axis]) / d[:, axis]
        inside = (p[:, axis] >= -pad) & (p[:, axis] <= limit - 1 + pad)
        parallel = d[:, axis] == 0
        t0 = np.maximum(t0, np.where(parallel, np.where(inside, -np.inf, np.inf),
                                     np.minimum(ta, tb)))
        t1 = np.minimum(t1, np.where(parallel, np.where(inside, np.inf, -np.inf),
                                     np.maximum(ta, tb)))
    keep = t0 <= t1
    p, q = p[keep] + t0[keep, None] * d[keep], p[keep] + t1[keep, None] * d[keep]
    if len(p) == 0:
        return
    inverse_change = (inverse_q - inverse_p)[keep]
    inverse_p, inverse_q = (inverse_p[keep] + t0[keep] * inverse_change,
                            inverse_p[keep] + t1[keep] * inverse_change)
    # Pieces of at most 8 px keep each bounding box, the pixels tested, small.
    piece_count = np.maximum(np.ceil(np.linalg.norm(q - p, axis=1) / 8.0), 1).astype(np.int64)
    segment, index = _runs(piece_count)
    fraction = np.column_stack([index, index + 1]) / piece_count[segment, None]
    a = p[segment] + fraction[:, :1] * (q - p)[segment]
    b = p[segment] + fraction[:, 1:] * (q - p)[segment]
    low = np.clip(np.ceil(np.minimum(a, b) - STROKE_RADIUS), 0, [width - 1, height - 1])
    high = np.clip(np.floor(np.maximum(a, b) + STROKE_RADIUS), 0, [width - 1, height - 1])
    size = (high - low + 1).astype(np.int64)
    piece, offset = _runs(size[:, 0] * size[:, 1])
    px = low[piece, 0] + offset % size[piece, 0]
    py = low[piece, 1] + offset // size[piece, 0]
    direction = b[piece] - a[piece]
    length_squared = np.einsum("ij,ij->i", direction, direction)
    relative = np.column_stack([px, py]) - a[piece]
    t = np.clip(np.divide(np.einsum("ij,ij->i", relative, direction), length_squared,
                          out=np.zeros(len(piece)), where=length_squared > 0), 0.0, 1.0)
    distance = np.linalg.norm(relative - t[:, None] * direction, axis=1)
    pixel = (py * width + px).astype(np.int64)
    inverse_a = inverse_p[segment] + fraction[:, 0] * (inverse_q - inverse_p)[segment]
    inverse_b = inverse_p[segment] + fraction[:, 1] * (inverse_q - inverse_p)[segment]
    inverse_depth = inverse_a[piece] + t * (inverse_b - inverse_a)[piece]
    # A stroke runs over the surface through its vertices; its chords may dip slightly below.
    in_front = inverse_depth * (1.0 + STROKE_DEPTH_TOLERANCE) >= depth_buffer[pixel]
    hit = (distance <= STROKE_RADIUS) & in_front
    image[pixel[hit]] = STROKE_COLOR


# --------------------------------------------------------------------------------------------
# colour maps


def _map_values(values, value_range, colormap):
    """(f,) values → (f, 3) RGB in [0, 1] through the named colour map (see render_image)."""
    if value_range is None:
        low, high = _default_value_range(values, colormap)
    else:
        low, high = _check_value_range(value_range)
    if len(values) == 0:
        return np.zeros((0, 3))
    if high > low:
        position = np.clip((values - low) / (high - low), 0.0, 1.0)
    else:
        position = np.full(len(values), 0.5)
    points = _COLORMAP_POINTS[colormap]
    return np.column_stack([np.interp(position, points[:, 0], points[:, channel])
                            for channel in (1, 2, 3)])


def _default_value_range(values, colormap):
    """The documented default value_range of render_image."""
    if len(values) == 0:
        return 0.0, 1.0
    low, high = float(values.min()), float(values.max())
    if colormap == "coolwarm" and low <= 1.0 <= high:
        half = max(1.0 - low, high - 1.0)
        return 1.0 - half, 1.0 + half
    return low, high


def _check_value_range(value_range):
    try:
        low, high = (float(v) for v in value_range)
    except (TypeError, ValueError):
        raise ValueError(f"value_range must be two numbers (low, high), "
                         f"got {value_range!r}") from None
    if not (math.isfinite(low) and math.isfinite(high)) or low >= high:
        raise ValueError(f"value_range must be finite with low < high, got ({low}, {high})")
    return low, high


# --------------------------------------------------------------------------------------------
# images and files


def side_by_side(images, titles=None, gap=8, title_height=28,
                 background=(255, 255, 255)) -> np.ndarray:
    """Places equal-height images left to right, with optional titles above them.

    Parameters
    ----------
    images : sequence of (h, w_i, 3) uint8 arrays
        At least one; all of the same height h.
    titles : sequence of str, optional
        One per image, drawn centred in a band of ``title_height`` pixels above it with Pillow's
        default font. Without titles there is no band.
    gap : int
        Pixels of background between neighbouring images (>= 0).
    title_height : int
        Height of the title band in pixels (>= 0).
    background : 3 ints in [0, 255]
        RGB colour of the gaps and the title band.

    Returns
    -------
    (h + title_height if titles else h, Σ w_i + gap·(len(images) − 1), 3) uint8 array

    Raises
    ------
    ValueError
        If there are no images, an image is not (h, w, 3) uint8, heights differ, the number of
        titles differs from the number of images, or gap, title_height or background is invalid.
    """
    images = [_check_image(image, f"images[{i}]") for i, image in enumerate(images)]
    if not images:
        raise ValueError("images is empty: side_by_side needs at least one image")
    heights = {image.shape[0] for image in images}
    if len(heights) != 1:
        raise ValueError(f"images must have equal heights, got {[im.shape[0] for im in images]}")
    gap = _check_count(gap, "gap")
    title_height = _check_count(title_height, "title_height")
    background = _check_byte_rgb(background, "background")
    if titles is not None:
        titles = [str(title) for title in titles]
        if len(titles) != len(images):
            raise ValueError(f"titles must have one entry per image ({len(images)}), "
                             f"got {len(titles)}")
    band = title_height if titles is not None else 0
    height = images[0].shape[0]
    total_width = sum(image.shape[1] for image in images) + gap * (len(images) - 1)
    if (band + height) * total_width > len(images) * MAX_IMAGE_PIXELS:
        raise ValueError(f"side_by_side: a {total_width}×{band + height} canvas is more than "
                         f"{MAX_IMAGE_PIXELS} pixels per image (gap {gap}, title_height "
                         f"{title_height})")
    canvas = np.empty((band + height, total_width, 3), dtype=np.uint8)
    canvas[:] = background
    lefts = np.cumsum([0] + [image.shape[1] + gap for image in images[:-1]])
    for left, image in zip(lefts, images):
        canvas[band:, left:left + image.shape[1]] = image
    if titles is not None and band > 0:
        canvas[:band] = _draw_titles(canvas[:band], titles, lefts,
                                     [image.shape[1] for image in images], background)
    return canvas


def _draw_titles(band, titles, lefts, widths, background):
    """The title band (uint8 array) with each title centred over its image."""
    from PIL import Image, ImageDraw, ImageFont

    height = band.shape[0]
    try:
        # Pillow >= 10.1 scales its built-in font when FreeType is available.
        font = ImageFont.load_default(size=max(8, int(0.55 * height)))
    except (TypeError, ImportError, OSError):
        font = ImageFont.load_default()
    # Dark text on light backgrounds, light text on dark ones (Rec. 601 luma).
    luma = 0.299 * background[0] + 0.587 * background[1] + 0.114 * background[2]
    ink = (25, 25, 25) if luma >= 128 else (235, 235, 235)
    picture = Image.fromarray(np.ascontiguousarray(band))
    draw = ImageDraw.Draw(picture)
    for title, left, width in zip(titles, lefts, widths):
        x0, y0, x1, y1 = draw.textbbox((0, 0), title, font=font)
        # Centred over the image; a title wider than its image starts at the image's left edge.
        x = int(left) + max((width - (x1 - x0)) // 2, 0) - x0
        y = (height - (y1 - y0)) // 2 - y0
        draw.text((x, y), title, fill=ink, font=font)
    return np.asarray(picture)


def save_png(path, image) -> Path:
    """Writes an (h, w, 3) uint8 RGB image as PNG, creating parent folders; returns the path.

    Raises ValueError if the image is not (h, w, 3) uint8 or the path does not end in ".png".
    """
    from PIL import Image

    image = _check_image(image, "image")
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"save_png writes PNG files; path must end in .png, got {str(path)!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(image).save(path, format="PNG")
    return path


def save_animation(path, images, fps=15.0) -> Path:
    """Writes equal-size (h, w, 3) uint8 frames as an animated GIF or an MP4; returns the path.

    ``.gif`` is written with Pillow and loops forever. GIF frame delays are whole hundredths
    of a second, so the frame rate is approximate, many viewers slow delays below 0.02 s down,
    and Pillow merges identical consecutive frames into one longer frame.

    ``.mp4`` pipes raw RGB frames to ``ffmpeg`` (looked up on PATH) for H.264 in yuv420p, which
    needs even sizes: an odd width or height is padded by repeating the last column or row.

    Parent folders are created.

    Raises
    ------
    ValueError
        If the suffix is not .gif or .mp4, there are no frames, a frame is not (h, w, 3) uint8
        or differs in size from the first, fps is not finite and > 0, or for .mp4 when ffmpeg
        is not installed.
    RuntimeError
        If ffmpeg fails (its error output is in the message).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _ANIMATION_SUFFIXES:
        raise ValueError(f"unsupported animation format {path.suffix!r} in {str(path)!r}; "
                         f"supported: {', '.join(_ANIMATION_SUFFIXES)}")
    frames = [_check_image(image, f"images[{i}]") for i, image in enumerate(images)]
    if not frames:
        raise ValueError("images is empty: an animation needs at least one frame")
    for i, frame in enumerate(frames):
        if frame.shape != frames[0].shape:
            raise ValueError(f"images[{i}] has shape {frame.shape}, but images[0] has "
                             f"{frames[0].shape}; all frames must have the same size")
    fps = check_factor(fps, "fps")
    if suffix == ".gif":
        _save_gif(path, frames, fps)
    else:
        _save_mp4(path, frames, fps)
    return path


def _save_gif(path, frames, fps):
    from PIL import Image

    pictures = [Image.fromarray(frame) for frame in frames]
    path.parent.mkdir(parents=True, exist_ok=True)
    pictures[0].save(path, format="GIF", save_all=True, append_images=pictures[1:],
                     duration=max(int(round(1000.0 / fps)), 1), loop=0)


def check_ffmpeg() -> str:
    """The path of ``ffmpeg`` (what MP4 animations need); ValueError when it is not on PATH."""
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise ValueError("an MP4 animation needs ffmpeg, which is not on PATH; install ffmpeg "
                         "or save the animation as .gif instead")
    return ffmpeg


def _save_mp4(path, frames, fps):
    ffmpeg = check_ffmpeg()
    height, width = frames[0].shape[:2]
    pad = ((0, height % 2), (0, width % 2), (0, 0))
    command = [ffmpeg, "-y", "-loglevel", "error",
               "-f", "rawvideo", "-pixel_format", "rgb24",
               "-video_size", f"{width + width % 2}x{height + height % 2}",
               "-framerate", repr(float(fps)), "-i", "-",
               "-an", "-c:v", "libx264", "-pix_fmt", "yuv420p", "-movflags", "+faststart",
               str(path)]
    path.parent.mkdir(parents=True, exist_ok=True)
    # ffmpeg's messages go to a file rather than a pipe: an unread pipe that fills up would
    # block ffmpeg while we block writing frames to it.
    with tempfile.TemporaryFile() as errors:
        process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                   stderr=errors)
        try:
            for frame in frames:
                process.stdin.write(np.pad(frame, pad, mode="edge").tobytes())
        except BrokenPipeError:
            pass  # ffmpeg stopped early; its exit status and message say why
        finally:
            try:
                process.stdin.close()
            except BrokenPipeError:
                pass
            status = process.wait()
        if status != 0:
            errors.seek(0)
            message = errors.read().decode(errors="replace").strip()
            raise RuntimeError(f"ffmpeg failed with exit status {status} writing "
                               f"{str(path)!r}: {message}")


# --------------------------------------------------------------------------------------------
# argument checks


def _check_points(points, name):
    """A (k, 3) finite float64 array, or ValueError naming `name`."""
    try:
        array = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a (k, 3) array of numbers, got {points!r}") from None
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (k, 3), got {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise ValueError(f"{name} must be finite, got {array[tuple(bad)]} "
                         f"at {name}[{bad[0]}, {bad[1]}]")
    return array


def _check_faces(F, vertex_count):
    """F as a (f, 3) int64 array of indices in [0, vertex_count), or ValueError."""
    faces = np.asarray(F)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"F must have shape (f, 3), got {faces.shape}")
    if faces.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if faces.dtype.kind not in "iu":
        raise ValueError(f"F must hold integer vertex indices, got dtype {faces.dtype}")
    low, high = int(faces.min()), int(faces.max())
    if low < 0 or high >= vertex_count:
        bad = low if low < 0 else high
        raise ValueError(f"F holds vertex index {bad}, outside [0, {vertex_count}) for "
                         f"{vertex_count} vertices in V")
    return faces.astype(np.int64)


def _check_face_values(face_values, face_count):
    try:
        values = np.asarray(face_values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"face_values must be numbers, got {face_values!r}") from None
    if values.shape != (face_count,):
        raise ValueError(f"face_values must have shape ({face_count},), one per face, "
                         f"got {values.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"face_values must be finite, got {values[~np.isfinite(values)][0]} "
                         f"at index {int(np.flatnonzero(~np.isfinite(values))[0])}")
    return values


def _check_strokes(strokes):
    if strokes is None:
        return []
    polylines = []
    for i, stroke in enumerate(strokes):
        try:
            array = np.asarray(stroke, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"strokes[{i}] must be a (k, 3) array of numbers, "
                             f"got {stroke!r}") from None
        if array.ndim != 2:
            raise ValueError(f"strokes[{i}] must have shape (k, 3), got {array.shape} "
                             "(strokes is a list of polylines, not one polyline)")
        polylines.append(_check_points(array, f"strokes[{i}]"))
        if len(polylines[-1]) == 0:
            raise ValueError(f"strokes[{i}] is empty: a stroke needs at least one point")
    return polylines


def _check_unit_rgb(rgb, name):
    try:
        value = np.asarray(rgb, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 numbers in [0, 1], got {rgb!r}") from None
    if value.shape != (3,) or not np.all((value >= 0.0) & (value <= 1.0)):
        raise ValueError(f"{name} must be 3 numbers in [0, 1] (RGB), got {rgb!r}")
    return value


def _check_byte_rgb(rgb, name):
    try:
        value = np.asarray(rgb)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 integers in [0, 255], got {rgb!r}") from None
    if (value.shape != (3,) or value.dtype.kind not in "iu"
            or not np.all((value >= 0) & (value <= 255))):
        raise ValueError(f"{name} must be 3 integers in [0, 255] (RGB), got {rgb!r}")
    return value.astype(np.uint8)


def _check_image(image, name):
    array = np.asarray(image)
    if array.dtype != np.uint8:
        raise ValueError(f"{name} must have dtype uint8, got {array.dtype}")
    if array.ndim != 3 or array.shape[2] != 3 or array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"{name} must have shape (h, w, 3) with h, w >= 1, got {array.shape}")
    return np.ascontiguousarray(array)


def _check_vector(vector, name):
    try:
        value = np.asarray(vector, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 finite numbers, got {vector!r}") from None
    if value.shape != (3,) or not np.all(np.isfinite(value)) or not np.any(value):
        raise ValueError(f"{name} must be 3 finite numbers, not all zero, got {vector!r}")
    return value


def _check_count(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{name} must be an integer >= 0 (pixels), got {value!r}")
    return int(value)
