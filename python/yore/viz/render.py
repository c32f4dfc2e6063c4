"""Pictures of cloth meshes, rendered by polyscope (headless on EGL, see `yore.viz.backend`).

`render_image` shows a triangle mesh from a `yore.Camera`: smooth shading (polyscope's "clay"
material, back faces darker so folds read), anti-aliasing by supersampling, a ground plane
below the cloth with its shadow, optional per-vertex or per-face values through a colour map
with a colour bar, strokes as tubes on the surface and a title. It returns an RGB array of the
camera's size; `yore.viz.images` writes files.

Colour maps are sampled from matplotlib's tables (`COLORMAPS`) and loaded into polyscope, so the
surface and the colour bar use the same colours. Strokes take the colour of `STROKE_CANDIDATES`
farthest (in CIELAB) from every colour the surface can show (the map, shaded), so a stroke stays
visible over any colour map: red over viridis or the plain cloth, green over coolwarm.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from ..camera import Camera
from ..checks import check_faces, check_points, check_unit_rgb, check_vertex_values
from ..metrics import vertex_normals
from . import backend
from .images import draw_colorbar, draw_title

__all__ = [
    "render_image",
    "picture_layout",
    "framing_camera",
    "colorbar_width",
    "title_height",
    "COLORMAPS",
    "CLOTH_COLOR",
    "STROKE_CANDIDATES",
    "stroke_color",
    "colormap_table",
]

#: Colour maps `render_image` accepts (matplotlib's, sampled at 256 points).
COLORMAPS = ("viridis", "cividis", "magma", "coolwarm", "RdBu_r")
#: The cloth's colour without values (a light blue).
CLOTH_COLOR = (0.42, 0.62, 0.84)
#: Colours a stroke may take (RGB in [0, 1]): red, magenta, orange, green, cyan.
STROKE_CANDIDATES = (
    (0.90, 0.06, 0.10),
    (0.92, 0.10, 0.80),
    (1.00, 0.55, 0.00),
    (0.15, 0.85, 0.10),
    (0.00, 0.80, 0.95),
)
#: Stroke tube radius as a fraction of the cloth's bounding-box diagonal.
STROKE_RADIUS_FRACTION = 0.005
#: The structures pictures register (and remove again).
CLOTH_NAME = "yore picture: cloth"
STROKE_PREFIX = "yore picture: stroke "

_loaded_maps = {}
_map_folder = None


def colormap_table(name, samples=256) -> np.ndarray:
    """(samples, 3) RGB in [0, 1] of the colour map ``name`` (one of COLORMAPS), low first."""
    if name not in COLORMAPS:
        raise ValueError(f"colormap must be one of {', '.join(COLORMAPS)}, got {name!r}")
    from matplotlib import colormaps

    return np.asarray(colormaps[name](np.linspace(0.0, 1.0, samples)))[:, :3]


def polyscope_colormap(ps, name) -> str:
    """The name under which polyscope knows colour map ``name`` (loaded once per process)."""
    global _map_folder
    if name not in _loaded_maps:
        from PIL import Image

        if _map_folder is None:
            _map_folder = tempfile.TemporaryDirectory(prefix="yore-colormaps-")
        path = Path(_map_folder.name) / f"{name}.png"
        row = (colormap_table(name) * 255.0 + 0.5).astype(np.uint8)[None, :, :]
        Image.fromarray(np.repeat(row, 4, axis=0)).save(path)
        ps.load_color_map(f"yore-{name}", str(path))
        _loaded_maps[name] = f"yore-{name}"
    return _loaded_maps[name]


def _lab(rgb):
    """CIELAB (D65) of sRGB colours in [0, 1] (n×3)."""
    rgb = np.asarray(rgb, float)
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    xyz = linear @ np.array(
        [[0.4124, 0.2126, 0.0193], [0.3576, 0.7152, 0.1192], [0.1805, 0.0722, 0.9505]]
    )
    xyz /= np.array([0.9505, 1.0, 1.089])
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16.0 / 116.0)
    return np.column_stack(
        [116.0 * f[:, 1] - 16.0, 500.0 * (f[:, 0] - f[:, 1]), 200.0 * (f[:, 1] - f[:, 2])]
    )


def stroke_color(surface_colors) -> tuple:
    """The STROKE_CANDIDATES colour farthest in CIELAB from all ``surface_colors`` (n×3 RGB in
    [0, 1]) and their shaded versions (× 0.55 … 1), i.e. the one that stands out best."""
    surface = np.asarray(surface_colors, float).reshape(-1, 3)
    shaded = np.concatenate([surface * s for s in (0.55, 0.7, 0.85, 1.0)])
    lab = _lab(shaded)
    candidates = np.asarray(STROKE_CANDIDATES)
    distance = np.linalg.norm(_lab(candidates)[:, None, :] - lab[None, :, :], axis=2).min(axis=1)
    return tuple(float(c) for c in candidates[int(np.argmax(distance))])


def _value_range(values, value_range, colormap):
    if value_range is not None:
        try:
            low, high = (float(v) for v in value_range)
        except (TypeError, ValueError):
            raise ValueError(
                f"value_range must be two numbers (low, high), got {value_range!r}"
            ) from None
        if not (np.isfinite(low) and np.isfinite(high)) or low >= high:
            raise ValueError(f"value_range must be finite with low < high, got ({low}, {high})")
        return low, high
    low, high = (float(values.min()), float(values.max())) if values.size else (0.0, 1.0)
    if colormap in ("coolwarm", "RdBu_r") and low < 0.0 < high:
        # a diverging map centred on zero
        half = max(-low, high)
        low, high = -half, half
    if high <= low:
        pad = max(abs(low) * 1e-3, 1e-12)
        low, high = low - pad, high + pad
    return low, high


def _checked_picture(
    V, F, camera, vertex_values, face_values, color, background, strokes, colormap
):
    """`render_image`'s arguments checked, in its order: (V, F, colour, background, stroke
    polylines, values or None, "vertices" | "faces" | None)."""
    V = check_points(V, "V")
    F = check_faces(F, len(V))
    if not isinstance(camera, Camera):
        raise ValueError(f"camera must be a yore.Camera, got {type(camera).__name__}")
    if vertex_values is not None and face_values is not None:
        raise ValueError("give vertex_values or face_values, not both")
    base_color = check_unit_rgb(color, "color")
    background = check_unit_rgb(background, "background")
    polylines = _check_strokes(strokes)
    values, defined_on = None, None
    if vertex_values is not None:
        values, defined_on = check_vertex_values(vertex_values, len(V), "vertex_values"), "vertices"
    elif face_values is not None:
        values, defined_on = check_vertex_values(face_values, len(F), "face_values"), "faces"
    if colormap not in COLORMAPS:
        raise ValueError(f"colormap must be one of {', '.join(COLORMAPS)}, got {colormap!r}")
    return V, F, base_color, background, polylines, values, defined_on


def _framed(image, width, height, background, margins, bar, title):
    """The cloth's `image` placed in a width × height canvas with its colour bar at the right
    (``margins``: the strip's width and the title band's height; ``bar``: colour map, range,
    label) and its title on top."""
    strip, band = margins
    colormap, value_range, colorbar = bar
    canvas = np.empty((height, width, 3), dtype=np.uint8)
    canvas[:] = np.rint(background * 255.0).astype(np.uint8)
    canvas[band:, : width - strip] = image
    if strip:
        canvas = draw_colorbar(
            canvas, colormap_table(colormap), value_range, str(colorbar), left=width - strip
        )
    if band:
        canvas = draw_title(canvas, str(title), band)
    return canvas


# over 60 lines: a docstring for its 16 parameters (the code is 33 lines)
def render_image(
    V,
    F,
    camera,
    *,
    vertex_values=None,
    face_values=None,
    value_range=None,
    colormap="viridis",
    colorbar=None,
    strokes=(),
    color=CLOTH_COLOR,
    background=(1.0, 1.0, 1.0),
    edges=False,
    ground=True,
    title=None,
    antialias=True,
) -> np.ndarray:
    """Renders a triangle mesh with polyscope and returns the picture.

    Parameters
    ----------
    V : (n, 3) float array, metres
        Vertex positions (world space), all finite.
    F : (f, 3) int array
        Triangles as vertex indices in [0, n).
    camera : yore.Camera
        Viewpoint and image size.
    vertex_values, face_values : (n,) or (f,) float arrays, optional
        Values coloured through ``colormap`` (vertex values are interpolated across faces);
        give at most one.
    value_range : (low, high), optional
        Values mapped to the ends of the map (clamped outside). Default: [min, max], or for a
        diverging map over values of both signs the range symmetric about 0.
    colormap : str
        One of `COLORMAPS`.
    colorbar : str, optional
        With values: a colour bar with this label in a strip at the right (`colorbar_width`);
        the cloth is drawn in the rest, seeing at least what ``camera`` sees.
    strokes : iterable of (k, 3) float arrays, metres
        Polylines drawn as tubes (radius `STROKE_RADIUS_FRACTION` × the cloth's size) lifted
        half a radius off the surface towards the eye, in `stroke_color` of the surface's
        colours.
    color, background : 3 floats in [0, 1]
        Cloth colour without values; background colour.
    edges : bool
        Draw the mesh's edges (thin dark lines).
    ground : bool
        A ground plane below the cloth (across the world axis nearest ``camera.up``) showing
        the cloth's shadow.
    title : str, optional
        Written centred in a band at the top (`title_height`), the cloth drawn below it.
    antialias : bool or int
        True: supersample by `backend.SSAA_FACTOR` (3); an int k: by k (animations use 2, at
        half the cost); False: none. Lowered for very large pictures.

    Returns
    -------
    (camera.height, camera.width, 3) uint8 array, RGB, row 0 at the top.

    Raises
    ------
    ValueError
        Bad arrays, colours, value range or colour map, or camera not a `yore.Camera`.
    yore.viz.BackendUnavailable
        polyscope or EGL is missing.
    """
    V, F, base_color, background, polylines, values, defined_on = _checked_picture(
        V, F, camera, vertex_values, face_values, color, background, strokes, colormap
    )

    width, height = camera.width, camera.height
    if values is not None:
        value_range = _value_range(values, value_range, colormap)
    inner_width, inner_height = picture_layout(
        width, height, values is not None and colorbar, bool(title)
    )
    strip, band = width - inner_width, height - inner_height
    view = _inner_camera(camera, inner_width, inner_height)
    image = _render_view(
        V,
        F,
        view,
        values,
        defined_on,
        value_range,
        colormap,
        polylines,
        base_color,
        background,
        edges,
        ground,
        antialias,
    )
    if not (strip or band):
        return image
    return _framed(
        image, width, height, background, (strip, band), (colormap, value_range, colorbar), title
    )


def colorbar_width(width, height) -> int:
    """Pixels at the right of a picture that hold its colour bar."""
    return int(min(max(0.2 * height, 60), 0.4 * width))


def title_height(height) -> int:
    """Pixels at the top of a picture that hold its title."""
    return int(max(14, min(0.07 * height, 40)))


def picture_layout(width, height, colorbar=False, title=False):
    """(width, height) of the part of a width × height picture that shows the cloth, with a
    colour bar strip and/or a title band."""
    return (
        width - (colorbar_width(width, height) if colorbar else 0),
        height - (title_height(height) if title else 0),
    )


def framing_camera(inner, width, height) -> Camera:
    """The width × height camera to pass to `render_image` so that the cloth is drawn exactly as
    ``inner`` (a camera of the cloth's part, see `picture_layout`) frames it."""
    tan_inner = np.tan(np.radians(inner.fov_degrees) / 2.0)
    factor = min(1.0, height * inner.width / (width * inner.height))
    return Camera(
        eye=inner.eye,
        target=inner.target,
        up=inner.up,
        fov_degrees=float(np.degrees(2.0 * np.arctan(tan_inner * factor))),
        width=width,
        height=height,
    )


def _inner_camera(camera, width, height) -> Camera:
    """The camera for a width × height part of ``camera``'s picture: same eye and direction,
    the field of view widened where needed so that everything ``camera`` sees is still seen
    (the cloth is drawn a little smaller instead of being cropped)."""
    if (width, height) == (camera.width, camera.height):
        return camera
    tan_y = np.tan(np.radians(camera.fov_degrees) / 2.0)
    tan_x = tan_y * camera.width / camera.height
    tan_inner = max(tan_y, tan_x * height / width)
    return Camera(
        eye=camera.eye,
        target=camera.target,
        up=camera.up,
        fov_degrees=float(np.degrees(2.0 * np.arctan(tan_inner))),
        width=width,
        height=height,
    )


def _register_cloth(ps, V, F, base_color, factor, edges):
    """The cloth in polyscope: a surface, or a point cloud when it has no faces."""
    if len(F):
        return ps.register_surface_mesh(
            CLOTH_NAME,
            V,
            F,
            color=tuple(base_color),
            smooth_shade=True,
            material="clay",
            back_face_policy="different",
            edge_width=float(factor) if edges else 0.0,
            edge_color=(0.15, 0.15, 0.15),
        )
    else:
        return ps.register_point_cloud(CLOTH_NAME, V, color=tuple(base_color))


def _register_strokes(ps, polylines, V, F, camera, ink, registered):
    """The strokes in polyscope, as tubes lifted half a radius towards the eye, each name
    added to `registered` as soon as it is (the caller removes them, whatever happens)."""
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if len(V) else 1.0
    radius = STROKE_RADIUS_FRACTION * (size if size > 0 else 1.0)
    normals = vertex_normals(V, F) if len(F) else np.zeros_like(V)
    eye = np.asarray(camera.eye, float)
    for k, points in enumerate(polylines):
        lifted = _lift(points, V, normals, eye, 0.5 * radius)
        name = f"{STROKE_PREFIX}{k}"
        if len(lifted) == 1:
            cloud = ps.register_point_cloud(name, lifted, color=ink, material="flat")
            cloud.set_radius(1.6 * radius, relative=False)
        else:
            curve = ps.register_curve_network(name, lifted, "line", color=ink, material="flat")
            curve.set_radius(radius, relative=False)
        registered.append(name)


def _render_view(
    V,
    F,
    camera,
    values,
    defined_on,
    value_range,
    colormap,
    polylines,
    base_color,
    background,
    edges,
    ground,
    antialias,
):
    ps = backend.ensure()
    factor = (
        1
        if antialias is False
        else backend.supersampling(
            camera.width, camera.height, None if antialias is True else antialias
        )
    )
    backend.set_camera(
        camera.resized(camera.width * factor, camera.height * factor) if factor > 1 else camera
    )
    ps.set_background_color(tuple(background))
    ps.set_ground_plane_mode("shadow_only" if ground else "none")
    ps.set_transparency_mode("none")
    registered = []
    hidden = backend.hidden_viewer().__enter__()
    try:
        mesh = _register_cloth(ps, V, F, base_color, factor, edges)
        registered.append(CLOTH_NAME)
        surface_colors = base_color[None, :]
        if values is not None:
            low, high = _value_range(values, value_range, colormap)
            if len(F):
                mesh.add_scalar_quantity(
                    "values",
                    values,
                    defined_on=defined_on,
                    cmap=polyscope_colormap(ps, colormap),
                    vminmax=(low, high),
                    enabled=True,
                )
            surface_colors = colormap_table(colormap)
        ink = stroke_color(surface_colors)
        _register_strokes(ps, polylines, V, F, camera, ink, registered)
        # polyscope fits the ground plane and the clip planes to the scene's extent
        ps.update_scene_extents()
        image = backend.screenshot()
    finally:
        for name in registered:
            _remove(ps, name)
        hidden.__exit__(None, None, None)
    # box-filter the supersampled picture down to the camera's size
    image = backend.downsample(image, factor)
    return image


def _remove(ps, name):
    for has, remove in (
        (ps.has_surface_mesh, ps.remove_surface_mesh),
        (ps.has_curve_network, ps.remove_curve_network),
        (ps.has_point_cloud, ps.remove_point_cloud),
    ):
        if has(name):
            remove(name)


def _lift(points, V, normals, eye, offset):
    """Stroke points moved ``offset`` along the normal (turned towards the eye) of the nearest
    vertex, so a tube on the surface is not half buried in it."""
    if len(V) == 0 or not np.any(normals):
        return points
    nearest = (
        np.argmin(((points[:, None, :] - V[None, :, :]) ** 2).sum(axis=2), axis=1)
        if len(points) * len(V) <= 4_000_000
        else _nearest_chunked(points, V)
    )
    n = normals[nearest]
    towards = np.sign(np.einsum("ij,ij->i", n, eye - points))
    towards[towards == 0] = 1.0
    return points + offset * n * towards[:, None]


def _nearest_chunked(points, V):
    out = np.empty(len(points), dtype=np.int64)
    step = max(1, 4_000_000 // max(len(V), 1))
    for start in range(0, len(points), step):
        chunk = points[start : start + step]
        out[start : start + step] = np.argmin(
            ((chunk[:, None, :] - V[None, :, :]) ** 2).sum(axis=2), axis=1
        )
    return out


def _check_strokes(strokes):
    if strokes is None:
        return []
    polylines = []
    for i, stroke in enumerate(strokes):
        try:
            array = np.asarray(stroke, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"strokes[{i}] must be a (k, 3) array of numbers") from None
        if array.ndim != 2:
            raise ValueError(
                f"strokes[{i}] must have shape (k, 3), got {array.shape} "
                "(strokes is a list of polylines, not one polyline)"
            )
        polylines.append(check_points(array, f"strokes[{i}]", allow_empty=False))
    return polylines
