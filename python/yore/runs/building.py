"""Building what a `yore.runs.loading.Scene` describes: the Simulation at t = 0 with the named
vertex sets of its mesh (`Scene.build`), the scene's camera (`scene_camera`) and its strokes
drawn on a simulation (`apply_scene_stroke`, which the run and `Scene.check_strokes` call).

What the static checks could not see raises `SceneError` here, named by the scene: vertex
indices out of range, a selection that selects nothing, a vertex both fixed and driven,
integrator options the integrator rejects, a mesh file that cannot be read, a stroke that misses.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._core import ArgumentError, Cloth
from ..io import load_mesh
from ..meshes import cylinder_mesh, cylinder_ring, grid_mesh, pattern_mesh
from ..options import GRAVITY, InactiveOptionError
from ..simulation import Simulation
from ..camera import Camera, camera_from_settings
from ..stroke import RefinementTooLarge, StrokeMissed, StrokeOptions, StrokePath
from .schema import STROKE_FORMS, did_you_mean

__all__ = ["scene_camera", "apply_scene_stroke"]


# -- building -------------------------------------------------------------------------------------
def _boundary_vertices(F):
    """The vertices on a mesh's boundary: the ends of the edges that only one face has."""
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return np.unique(unique[counts == 1]).astype(np.int32)


#: The Cloth arguments that are scene keys of [material] by the same name.
MATERIAL_ARGUMENTS = (
    "stretch_stiffness",
    "bend_stiffness",
    "bending_modulus",
    "damping",
    "drag",
    "young_modulus",
    "poisson_ratio",
    "membrane_strain",
)


def build_simulation(scene, dt=None):
    """The scene's simulation at t = 0 and its named vertex sets; ``dt`` (s), when given,
    replaces the explicit default step of a scene that leaves [simulation] dt out (see
    `yore.runs.runner.check_scene`)."""
    data = scene.data
    pattern, F, uv, sets = _build_mesh(scene)
    cloth = _build_cloth(scene, pattern, F, uv)
    _constrain(scene, cloth, sets)
    simulation = data.simulation
    gravity = simulation.gravity
    try:
        sim = Simulation(
            cloth,
            integrator=simulation.integrator,
            dt=simulation.dt if dt is None else dt,
            gravity=GRAVITY if gravity is None else gravity,
            **data.integrator,
        )
    except InactiveOptionError as error:
        # an [integrator] option of a mode the scene does not select: named by its key, here
        # where `yore check` and the run both build (a resumed run does not: it continues)
        raise scene.error(f"integrator.{error.option}", str(error)) from None
    except ValueError as error:
        raise scene.error("integrator", str(error)) from None
    # A run schedules strokes and frames in steps of one dt: it keeps its dt after strokes (an
    # explicit scene that refines gives its [simulation] dt, else the run stops with advice).
    sim.keep_dt()
    name = data.scene.name
    sim.scene = {"name": scene.source if name is None else name, "sets": sets, "uv": uv}
    return sim, sets


def _build_mesh(scene):
    """(rest pattern n×3, faces, material coordinates or None, named vertex sets) of the
    scene's [mesh]."""
    mesh = scene.data.mesh
    generator = mesh.generator
    uv = None
    if generator == "grid":
        try:
            V, F = grid_mesh(mesh.nx, mesh.ny, width=mesh.width, height=mesh.height)
        except ArgumentError as error:  # a size out of range, by the argument's name
            raise scene.error(
                f"mesh.{error.argument}", str(error), "a grid yore can mesh"
            ) from None
        uv = V[:, :2].copy()
        pattern = (
            V if mesh.plane == "xy" else np.column_stack([uv[:, 0], np.zeros(len(uv)), uv[:, 1]])
        )
        sets = _grid_sets(mesh.nx, mesh.ny)
    elif generator == "pattern":
        try:
            V, F = pattern_mesh(
                mesh.outline,
                mesh.holes,
                mesh.edge_length,
                mesh.min_angle,
                mesh.interior,
            )
        except ArgumentError as error:  # the key at fault, by the argument's name
            raise scene.error(
                f"mesh.{error.argument}", str(error), "a pattern CGAL can mesh"
            ) from None
        uv = V[:, :2].copy()
        pattern = (
            V if mesh.plane == "xy" else np.column_stack([uv[:, 0], np.zeros(len(uv)), uv[:, 1]])
        )
        sets = {"boundary": _boundary_vertices(F)}
    elif generator == "cylinder":
        try:
            pattern, F = cylinder_mesh(mesh.radius, mesh.height, mesh.rings, mesh.segments)
        except ArgumentError as error:
            raise scene.error(
                f"mesh.{error.argument}", str(error), "a tube yore can mesh"
            ) from None
        sets = {
            "bottom rim": cylinder_ring(mesh.rings, mesh.segments, 0),
            "top rim": cylinder_ring(mesh.rings, mesh.segments, -1),
        }
    else:
        path = Path(mesh.path)
        if not path.is_absolute():
            path = scene.base_dir / path
        try:
            pattern, F = load_mesh(path)
        except (ValueError, OSError) as error:
            raise scene.error("mesh.path", str(error), "a readable triangle mesh file") from None
        pattern = pattern * mesh.scale
        sets = {}
    sets["all"] = np.arange(len(pattern), dtype=np.int32)

    return pattern, F, uv, sets


def _build_cloth(scene, pattern, F, uv):
    """The cloth of the scene's [material] on the mesh (gathered as [mesh] says)."""
    mesh, material = scene.data.mesh, scene.data.material
    n = len(pattern)
    if material.density is not None:
        mass_arguments = {"density": material.density}
    elif material.mass_per_vertex is not None:
        mass_arguments = {"masses": material.mass_per_vertex}
    else:
        mass_arguments = {"masses": material.mass / n}
    try:
        bending_arguments = (
            {"bending": material.bending, "bending_modulus": material.bending_modulus}
            if material.bending in ("quadratic", "hinge")
            else {"bend_stiffness": material.bend_stiffness}
        )
        stretch_arguments = (
            {
                "stretch": "membrane",
                "young_modulus": material.young_modulus,
                "poisson_ratio": material.poisson_ratio,
                "membrane_strain": material.membrane_strain,
            }
            if material.stretch == "membrane"
            else {"stretch_stiffness": material.stretch_stiffness}
        )
        cloth = Cloth(
            pattern,
            F,
            damping=material.damping,
            drag=material.drag,
            **mass_arguments,
            **bending_arguments,
            **stretch_arguments,
        )
    except ArgumentError as error:
        # The core checks the material's values and the per-vertex masses, and names the
        # argument at fault: the key (or table) the value came from.
        if error.argument in MATERIAL_ARGUMENTS:
            raise scene.error(f"material.{error.argument}", str(error)) from None
        if error.argument == "masses":
            raise scene.error(
                "material",
                str(error),
                "masses that are normal numbers > 0 per vertex, at most 1e12 kg",
            ) from None
        raise scene.error("mesh", str(error), "a valid triangle mesh") from None
    except ValueError as error:  # the mesh
        raise scene.error("mesh", str(error), "a valid triangle mesh") from None
    if mesh.generator == "grid" and mesh.gather != 1.0:
        gathered = pattern.copy()
        middle = 0.5 * mesh.width
        gathered[:, 0] = middle + mesh.gather * (pattern[:, 0] - middle)
        cloth.positions = gathered
    if uv is not None:
        cloth.material_coordinates = uv

    return cloth


def _constrain(scene, cloth, sets):
    """The scene's [[fixed]] and [[driven]] vertices."""
    positions = cloth.positions
    for k, entry in enumerate(scene.data.fixed):
        vertices = _select(scene, f"fixed[{k}]", entry, sets, positions)
        try:
            cloth.fix(vertices)
        except ValueError as error:
            raise scene.error(f"fixed[{k}]", str(error)) from None
    for k, entry in enumerate(scene.data.driven):
        vertices = _select(scene, f"driven[{k}]", entry, sets, positions)
        try:
            cloth.drive_rotation(vertices, center=entry.center, axis=entry.axis, omega=entry.omega)
        except ValueError as error:
            raise scene.error(f"driven[{k}]", str(error)) from None


def _grid_sets(nx, ny):
    index = np.arange(nx * ny, dtype=np.int32).reshape(ny, nx)  # [j, i] = j*nx + i
    sets = {
        "bottom edge": index[0, :],
        "top edge": index[-1, :],
        "left edge": index[:, 0],
        "right edge": index[:, -1],
    }
    for name in ("bottom", "top", "left", "right"):
        edge = sets[f"{name} edge"]
        sets[f"{name} corners"] = np.array([edge[0], edge[-1]], dtype=np.int32)
    sets["corners"] = np.array(
        sorted({index[0, 0], index[0, -1], index[-1, 0], index[-1, -1]}), dtype=np.int32
    )
    return sets


def _select(scene, where, entry, sets, positions):
    if entry.indices is not None:
        vertices = entry.indices
        bad = vertices[vertices >= len(positions)]
        if bad.size:
            raise scene.error(
                f"{where}.indices",
                f"vertex {int(bad[0])} is out of range",
                f"indices in [0, {len(positions)})",
            )
        return vertices
    if entry.set is not None:
        name = entry.set
        if name not in sets:
            raise scene.error(
                f"{where}.set",
                f"unknown set {name!r}{did_you_mean(name, sets)}",
                "one of " + ", ".join(repr(s) for s in sets),
            )
        return sets[name]
    box = entry.box
    inside = np.all((positions >= box.min) & (positions <= box.max), axis=1)
    if not inside.any():
        raise scene.error(
            f"{where}.box",
            "selects no vertex",
            "a box that contains vertices of the cloth at t = 0",
        )
    return np.flatnonzero(inside).astype(np.int32)


# -- strokes --------------------------------------------------------------------------------------
def scene_camera(scene, positions) -> Camera:
    """The scene's [camera]: as given, with eye/target fitted to ``positions`` when absent."""
    try:
        return camera_from_settings(scene.data.camera, positions)
    except ValueError as error:
        raise scene.error("camera", str(error)) from None


def apply_scene_stroke(scene, sim, index, camera=None):
    """Draws stroke ``index`` of the scene on ``sim`` now (and smooths if asked); returns the
    report. A stroke that misses raises SceneError naming it."""
    stroke = scene.data.strokes[index]
    where = f"strokes[{index}]"
    options = StrokeOptions(
        expansion=stroke.expansion,
        mass_scale=stroke.mass_scale,
        width=stroke.width,
        growth=stroke.growth,
        refine=stroke.refine,
        max_distance=stroke.max_distance,
        smooth=None if stroke.smooth is None else stroke.smooth.as_dict(),
    )
    if stroke.material is not None:
        path = StrokePath.material(stroke.material)
    elif stroke.points is not None:
        path = StrokePath.world(stroke.points)
    else:
        if scene.data.camera.eye is None:
            raise scene.error(
                f"{where}.screen",
                "a screen stroke needs a camera",
                "a [camera] table with eye and target",
            )
        camera = camera or scene_camera(scene, sim.cloth.positions)
        path = StrokePath.screen(stroke.screen, camera)
    try:
        report = sim.stroke(path, options)
    except RefinementTooLarge as error:
        raise scene.error(f"{where}.refine", str(error).removeprefix("refine: ")) from None
    except StrokeMissed as error:
        form = stroke.given(*STROKE_FORMS)[0]
        raise scene.error(
            f"{where}.{form}",
            f"the stroke misses the cloth at t = {sim.time:.4g} s ({error})",
            "a polyline over the cloth",
        ) from None
    return report
