"""polyscope, set up once per process: headless on EGL (Mesa's llvmpipe runs it on the CPU)
for pictures, or in a window for the viewer; the mapping between `yore.Camera` and
polyscope's view; screenshots and picking in yore's pixel coordinates.

polyscope is one global scene per process. `ensure` initializes it the first time (headless
unless a window is asked for); every picture registers its structures under the names in
`OWNED`, renders and removes them again, so pictures taken while the viewer is open do not
disturb it beyond the camera (which the viewer restores).

A missing piece raises `BackendUnavailable` (an OSError: the command line reports it as one
``yore: error:`` line) naming what to install; nothing falls back silently to another
renderer.
"""

from __future__ import annotations

import ctypes
import os
from pathlib import Path

import numpy as np

from ..camera import Camera
from ..checks import MAX_IMAGE_PIXELS

__all__ = [
    "BackendUnavailable",
    "EGL_PACKAGES",
    "ensure",
    "set_camera",
    "camera_from_view",
    "screenshot",
    "pick",
    "supersampling",
    "downsample",
    "SSAA_FACTOR",
]

#: Debian packages the headless backend needs (``make setup`` installs them).
EGL_PACKAGES = ("libegl1", "libegl-mesa0", "libgl1-mesa-dri", "libx11-6")
#: Supersampling for anti-aliasing: each picture is rendered at SSAA_FACTOR × its width and
#: height (where that stays within `SSAA_MAX_PIXELS` and `SSAA_MAX_SIDE`) and averaged down in
#: blocks of SSAA_FACTOR² pixels (polyscope's own SSAA setting does not reach headless
#: screenshots in 2.6).
SSAA_FACTOR = 3
SSAA_MAX_PIXELS = MAX_IMAGE_PIXELS  # the supersampled picture is a camera too
SSAA_MAX_SIDE = 8192
_MESA_VENDOR_FILES = ("/usr/share/glvnd/egl_vendor.d/50_mesa.json",)


#: Structures the viewer keeps in polyscope's scene (pictures hide them while they render).
VIEWER_SURFACES = ("cloth",)
VIEWER_CURVES = ("stroke being drawn",)


class BackendUnavailable(OSError):
    """polyscope or the OpenGL/EGL libraries it needs are missing, or it failed to start."""


_state = {"initialized": False, "window": False}


def _import_polyscope():
    try:
        import polyscope
    except ImportError as error:
        raise BackendUnavailable(
            f"pictures and the viewer need the polyscope package ({error}); install it with "
            "`pip install 'polyscope>=2.6,<2.7'` (make setup does)"
        ) from None
    return polyscope


def check_egl() -> None:
    """Raises BackendUnavailable naming the Debian packages when the EGL library or Mesa's EGL
    driver cannot be found (what `ps.init("openGL3_egl")` loads at run time)."""
    missing = []
    try:
        ctypes.CDLL("libEGL.so.1")
    except OSError:
        missing.append("libEGL.so.1 (libegl1)")
    if not any(Path(path).is_file() for path in _MESA_VENDOR_FILES):
        missing.append("Mesa's EGL driver (libegl-mesa0)")
    try:
        ctypes.CDLL("libX11.so.6")
    except OSError:
        missing.append("libX11.so.6 (libx11-6)")
    if missing:
        raise BackendUnavailable(
            "headless pictures need OpenGL through EGL, but "
            + ", ".join(missing)
            + (" is" if len(missing) == 1 else " are")
            + " missing; install the Debian packages "
            + " ".join(EGL_PACKAGES)
            + " (make setup does, as root or with sudo)"
        )


def ensure(window: bool = False):
    """polyscope, initialized: headless on EGL unless ``window`` (the viewer) asks for a
    window. Returns the polyscope module. Raises BackendUnavailable when it cannot start, or
    when a window is asked for after this process started polyscope headless."""
    ps = _import_polyscope()
    if _state["initialized"]:
        if window and not _state["window"]:
            raise BackendUnavailable(
                "polyscope already runs headless in this process (a picture was rendered "
                "before the viewer opened); open the viewer first, or in a new process"
            )
        return ps
    ps.set_use_prefs_file(False)
    ps.set_verbosity(0)
    ps.set_print_prefix("yore (polyscope): ")
    ps.set_errors_throw_exceptions(True)
    ps.set_display_message_popups(False)
    if window:
        if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            raise BackendUnavailable(
                "the viewer needs a display (DISPLAY is not set); over SSH use `yore view ... "
                "--headless --screenshot PICTURE.png` or `ssh -X`"
            )
        backend = "openGL3_glfw"
    else:
        check_egl()
        ps.set_allow_headless_backends(True)
        backend = "openGL3_egl"
    try:
        ps.init(backend)
    except Exception as error:  # polyscope raises RuntimeError with the backend's reason
        raise BackendUnavailable(
            f"polyscope could not start its {backend} backend: "
            f"{' '.join(str(error).split())}; it needs OpenGL 3.3 (a window) or EGL (headless: "
            f"Debian packages {' '.join(EGL_PACKAGES)})"
        ) from None
    _state.update(initialized=True, window=window)
    ps.set_program_name("yore")
    ps.set_ground_plane_mode("shadow_only")
    ps.set_shadow_darkness(0.25)
    ps.set_background_color((1.0, 1.0, 1.0))
    ps.set_automatically_compute_scene_extents(True)
    ps.set_autocenter_structures(False)
    ps.set_autoscale_structures(False)
    return ps


class hidden_viewer:
    """Context: the viewer's structures disabled (so a picture shows only its own)."""

    def __enter__(self):
        ps = ensure(_state["window"])
        self.restore = []
        for names, has, get in (
            (VIEWER_SURFACES, ps.has_surface_mesh, ps.get_surface_mesh),
            (VIEWER_CURVES, ps.has_curve_network, ps.get_curve_network),
        ):
            for name in names:
                if has(name) and get(name).is_enabled():
                    get(name).set_enabled(False)
                    self.restore.append(get(name))
        return self

    def __exit__(self, *exc):
        for structure in self.restore:
            structure.set_enabled(True)
        return False


_UP_NAMES = {
    (0, 1): "x_up",
    (0, -1): "neg_x_up",
    (1, 1): "y_up",
    (1, -1): "neg_y_up",
    (2, 1): "z_up",
    (2, -1): "neg_z_up",
}
_FRONT_NAMES = {
    (0, 1): "x_front",
    (0, -1): "neg_x_front",
    (1, 1): "y_front",
    (1, -1): "neg_y_front",
    (2, 1): "z_front",
    (2, -1): "neg_z_front",
}


def _axis(vector, exclude=None):
    vector = np.asarray(vector, float).copy()
    if exclude is not None:
        vector[exclude] = 0.0
    axis = int(np.argmax(np.abs(vector)))
    return axis, 1 if vector[axis] >= 0 else -1


def supersampling(width, height, factor=None) -> int:
    """The supersampling factor for a width × height picture: ``factor`` (default
    SSAA_FACTOR), lowered until the supersampled picture fits the limits."""
    factor = SSAA_FACTOR if factor is None else max(1, int(factor))
    while factor > 1 and (
        width * height * factor**2 > SSAA_MAX_PIXELS or max(width, height) * factor > SSAA_MAX_SIDE
    ):
        factor -= 1
    return factor


def downsample(image, factor) -> np.ndarray:
    """An (h·f, w·f, 3) uint8 picture averaged in f × f blocks (rounded) to (h, w, 3)."""
    if factor == 1:
        return image
    height, width = image.shape[0] // factor, image.shape[1] // factor
    blocks = image.reshape(height, factor, width, factor, 3).astype(np.uint16)
    total = blocks.sum(axis=3).sum(axis=1)
    return ((total + factor * factor // 2) // (factor * factor)).astype(np.uint8)


def set_camera(camera: Camera) -> None:
    """Sets polyscope's view to ``camera``: window (framebuffer) size, eye, direction, up and
    vertical field of view; the ground plane lies across the world axis nearest to the
    camera's up."""
    ps = ensure(_state["window"])
    if not _state["window"] and tuple(ps.get_window_size()) != (camera.width, camera.height):
        ps.set_window_size(camera.width, camera.height)
    up_axis = _axis(camera.up)
    ps.set_up_dir(_UP_NAMES[up_axis])
    right, up, forward = camera.basis()
    front = _axis(-forward, exclude=up_axis[0])
    ps.set_front_dir(_FRONT_NAMES[front])
    intrinsics = ps.CameraIntrinsics(
        fov_vertical_deg=camera.fov_degrees, aspect=camera.width / camera.height
    )
    extrinsics = ps.CameraExtrinsics(
        root=np.asarray(camera.eye, float), look_dir=forward, up_dir=up
    )
    ps.set_view_camera_parameters(ps.CameraParameters(intrinsics, extrinsics))


def camera_from_view() -> Camera:
    """polyscope's current view as a `yore.Camera` (image size: the window's)."""
    ps = ensure(_state["window"])
    parameters = ps.get_view_camera_parameters()
    width, height = ps.get_window_size()
    eye = np.asarray(parameters.get_position(), float)
    look = np.asarray(parameters.get_look_dir(), float)
    up = np.asarray(parameters.get_up_dir(), float)
    return Camera(
        eye=tuple(eye),
        target=tuple(eye + look),
        up=tuple(up),
        fov_degrees=float(parameters.get_fov_vertical_deg()),
        width=int(width),
        height=int(height),
    )


def screenshot() -> np.ndarray:
    """The current view as an (h, w, 3) uint8 RGB image, without polyscope's panels."""
    ps = ensure(_state["window"])
    image = ps.screenshot_to_buffer(transparent_bg=False, include_UI=False)
    return np.ascontiguousarray(image[:, :, :3])


def pick(pixel):
    """What lies under pixel ``(x, y)`` (yore's pixel coordinates: (0, 0) is the centre of the
    top-left pixel): polyscope's PickResult."""
    ps = ensure(_state["window"])
    return ps.pick(screen_coords=(float(pixel[0]) + 0.5, float(pixel[1]) + 0.5))
