"""The defaults of strokes, scenes and pictures, and rest-length smoothing's options, written
once (`yore.options` re-exports them beside the integrators' options)."""

from __future__ import annotations

from .limits import LIMITS
from . import _core, rules
from .documents import result_type

#: Largest ``iterations`` of `Simulation.smooth_rest_lengths`.
MAX_SMOOTHING_ITERATIONS = LIMITS.max_smoothing_iterations
#: Rest-length smoothing's options (`Simulation.smooth_rest_lengths`, a scene file's
#: ``strokes[].smooth``, the viewer's ``smooth``): the defaults and the rules, written once.
SmoothingSettings = result_type(
    "SmoothingSettings",
    ("iterations", "strength", "conserve"),
    "Rest-length smoothing's settings: iterations, strength (fraction moved per iteration), "
    "conserve (keep the region's added rest length).",
)
SMOOTHING_DEFAULTS = SmoothingSettings(iterations=10, strength=0.5, conserve=True)
SMOOTHING_RULES = SmoothingSettings(
    iterations=rules.count(0, MAX_SMOOTHING_ITERATIONS),
    strength=rules.real(0.0, 1.0, expected="a number in (0, 1]"),
    conserve=rules.flag(),
)


# -- strokes ------------------------------------------------------------------------------------
#: How a stroke grows its band (see `yore.stroke`), in the order of the core's table.
GROWTH_MODES = tuple(_core.growth_modes())
#: A stroke's options and their defaults, read from the C++ ``StrokeOptions`` and
#: ``SplitOptions`` structs (``_core.stroke_defaults``, ``_core.split_defaults``): expansion
#: and mass_scale (eq. (1) of the paper: 1.1; the new vertex's mass 0.95 × its corners' mean),
#: width None (the core's 0: the faces the stroke crosses), growth "paper", refine 0 passes.
StrokeDefaults = result_type(
    "StrokeDefaults",
    ("expansion", "mass_scale", "width", "growth", "refine"),
    "A stroke's options' defaults.",
)
STROKE_DEFAULTS = StrokeDefaults(
    expansion=float(_core.split_defaults["expansion"]),
    mass_scale=float(_core.split_defaults["mass_scale"]),
    width=_core.stroke_defaults["width"] or None,
    growth=_core.stroke_defaults["growth"],
    refine=int(_core.stroke_defaults["refine"]),
)

# -- the scene and pictures -----------------------------------------------------------------------
#: Gravitational acceleration of every scene unless given, m/s² (y is up).
GRAVITY = (0.0, -9.81, 0.0)
#: The cloth's total mass unless a scene gives mass, mass_per_vertex or density, kg (also
#: `yore.scenes`' default).
MASS = 0.1
#: Stiffness of the bending springs unless given (a scene file's material, with spring bending),
#: N/m; `yore.scenes` uses it for the structural springs too (the paper's single constant).
STIFFNESS = 200.0
#: A membrane's Poisson's ratio unless given (stretch = "membrane"); the core's own default.
POISSON_RATIO = float(_core.Cloth.defaults["poisson_ratio"])
#: The material of `yore.scenes` and of scene files unless given: the paper's single stiffness
#: for structural and bending springs, light damping along the springs (N·s/m) and still-air
#: drag (1/s). A bare `yore.Cloth` has its own defaults (``Cloth.defaults``: 100 N/m, no
#: damping, no drag), those of a physics object that dissipates nothing unless asked.
SCENE_MATERIAL = {
    "stretch_stiffness": STIFFNESS,
    "bend_stiffness": STIFFNESS,
    "damping": 0.02,
    "drag": 0.3,
    "poisson_ratio": POISSON_RATIO,
}
#: Frames per simulated second a run writes unless [output] gives fps or every_steps.
FRAMES_PER_SECOND = 30.0
#: Animation formats; a run makes none unless its [output] asks, `yore render` of a run folder
#: makes a GIF unless told otherwise (rendering is what it was asked for).
ANIMATION_FORMATS = ("none", "gif", "mp4")
RUN_ANIMATION, RENDER_ANIMATION = "none", "gif"
#: Size of pictures and of the viewer's window unless given, pixels.
IMAGE_WIDTH, IMAGE_HEIGHT = 800, 600
#: Vertical field of view of cameras unless given, degrees.
FOV_DEGREES = 35.0

#: The one check of a field of view, degrees, in (0, 180): the camera, `yore.camera.fit_camera`,
#: scene files' [camera] fov_degrees and the command's --fov all use it (a scene that passes
#: `yore check` cannot fail at the camera).
FOV_RULE = rules.real(0.0, 180.0, low_open=True, high_open=True)
