"""The paper's two experiments as ready-made simulations.

Each function builds the cloth, its constraints and a `yore.Simulation`. Sizes and material are
keywords; ``integrator``, ``dt`` and integrator options are passed on to `yore.Simulation`
(without ``dt`` a stable default is chosen). The returned simulation carries a ``scene`` dict
with the scene's name and its constrained vertex indices (and, for the flat hanging cloth, its
pattern coordinates ``uv``, n×2 metres, also set as ``cloth.material_coordinates``).
"""

from __future__ import annotations

import math

import numpy as np

from ._core import Cloth
from .checks import check_factor
from .meshes import cylinder_mesh, cylinder_ring, grid_mesh, pattern_mesh
from .options import DEFAULT_INTEGRATOR, GRAVITY, MASS
from .options import STIFFNESS as OPTION_STIFFNESS
from .simulation import Simulation

__all__ = ["hanging_cloth", "rotating_cylinder", "stretched_sheet"]

# Default material of both scenes. The paper gives all springs the same constant; per-spring
# stiffness in N/m is independent of the mesh resolution for the in-plane response of a
# triangulated sheet, so these values keep their meaning when `resolution` changes.
STIFFNESS = OPTION_STIFFNESS  # N/m, structural and bending alike (paper §3)
DAMPING = 0.02  # N·s/m along each spring
DRAG = 0.3  # 1/s, still air


def _bending_arguments(bending, bend_stiffness, bending_modulus):
    """Cloth keywords of the scenes' bending choice: bending springs of bend_stiffness (default
    STIFFNESS), or quadratic bending of bending_modulus (N·m); Cloth checks the combination."""
    if bending == "springs" and bending_modulus is None:
        return {"bend_stiffness": STIFFNESS if bend_stiffness is None else bend_stiffness}
    arguments = {"bending": bending, "bending_modulus": bending_modulus}
    if bend_stiffness is not None:
        arguments["bend_stiffness"] = bend_stiffness
    return arguments


def _stretch_arguments(
    stretch, stretch_stiffness, young_modulus, poisson_ratio, membrane_strain=None
):
    """Cloth keywords of the scenes' stretch choice: structural springs of stretch_stiffness
    (default STIFFNESS), or a membrane of young_modulus and poisson_ratio (and its strain);
    Cloth checks the combination."""
    if (
        stretch == "springs"
        and young_modulus is None
        and poisson_ratio is None
        and membrane_strain is None
    ):
        return {"stretch_stiffness": STIFFNESS if stretch_stiffness is None else stretch_stiffness}
    arguments = {
        "stretch": stretch,
        "young_modulus": young_modulus,
        "poisson_ratio": poisson_ratio,
        "membrane_strain": membrane_strain,
    }
    if stretch_stiffness is not None:
        arguments["stretch_stiffness"] = stretch_stiffness
    return arguments


def _square_mesh(mesh, size, resolution):
    """(vertices, faces, size) of a size × size square in the x–y plane: "grid",
    "pattern" or "delaunay" (`hanging_cloth`'s ``mesh``)."""
    if mesh == "grid":
        V, F = grid_mesh(resolution, resolution, width=size, height=size)
    elif mesh in ("pattern", "delaunay"):
        if not isinstance(resolution, (int, np.integer)) or resolution < 2:
            raise ValueError(f"resolution must be an integer >= 2, got {resolution!r}")
        size = check_factor(size, "size", "m")
        V, F = _rectangle_mesh(mesh, size, size, math.sqrt(2.0) * size / (resolution - 1))
    else:
        raise ValueError(f'mesh must be "grid", "pattern" or "delaunay", got {mesh!r}')
    return V, F, size


# over 60 lines: a docstring for its 19 parameters (the code is 35 lines)
def hanging_cloth(
    size=1.0,
    resolution=21,
    pin_spacing=0.8,
    mass=MASS,
    stretch_stiffness=None,
    bend_stiffness=None,
    damping=DAMPING,
    drag=DRAG,
    integrator=DEFAULT_INTEGRATOR,
    dt=None,
    gravity=GRAVITY,
    bending="springs",
    bending_modulus=None,
    stretch="springs",
    young_modulus=None,
    poisson_ratio=None,
    mesh="grid",
    membrane_strain=None,
    **options,
) -> Simulation:
    """A square cloth hung from two points (paper §3.1, Fig. 3).

    The cloth's pattern is a size × size square; its rest lengths come from the flat pattern.
    It starts horizontal (the x–z plane at y = 0), gathered along x to ``pin_spacing`` of its
    width, with the two corners of its edge z = 0 fixed, ``pin_spacing · size`` apart. Gravity
    pulls it down: it swings, hangs from the two points, and the slack between them forms the
    folds near the top that the paper strokes along.

    size : edge length, m. resolution : vertices per edge (>= 2). pin_spacing : distance of the
    two fixed corners as a fraction of the width, in (0, 1]. mass : total mass, kg, spread
    uniformly over the vertices (the paper's choice). stretch_stiffness, bend_stiffness : N/m
    per spring (both default 200; bend_stiffness not with quadratic bending, stretch_stiffness
    not with the membrane). damping : N·s/m per spring. drag : 1/s. bending : "springs" (the
    paper's, default), "quadratic" (fitted, the same on any mesh) or "hinge" (Bergou et al.
    2006) with bending_modulus, N·m (see `yore.Cloth`); rest shape = the flat pattern.
    stretch : "springs" (the paper's, default) or "membrane" (St. Venant–Kirchhoff triangles)
    with young_modulus, N/m, and poisson_ratio; membrane_strain "smoothed" or "faces" (default:
    `yore.Cloth`'s choice).
    mesh : "grid" (`grid_mesh`, resolution × resolution vertices, default), "pattern" (a
    `pattern_mesh` of the square whose longest edge is the grid's diagonal, √2 · size /
    (resolution − 1), about as many vertices: an equilateral lattice inside, CGAL's triangles
    along the edges) or "delaunay" (the same with CGAL's isotropic triangles throughout).
    """
    pin_spacing = float(pin_spacing)
    if not 0.0 < pin_spacing <= 1.0:
        raise ValueError(f"pin_spacing must be in (0, 1], got {pin_spacing}")
    V, F, size = _square_mesh(mesh, size, resolution)
    uv = V[:, :2].copy()
    pattern = np.column_stack([uv[:, 0], np.zeros(len(uv)), uv[:, 1]])
    # grid_mesh's faces are counter-clockwise about +z; mapping (u, v) → (u, 0, v) flips them to
    # clockwise about +y, i.e. the cloth's front faces up.
    cloth = Cloth(
        pattern,
        F,
        masses=_per_vertex(mass, len(pattern)),
        damping=damping,
        drag=drag,
        **_bending_arguments(bending, bend_stiffness, bending_modulus),
        **_stretch_arguments(
            stretch, stretch_stiffness, young_modulus, poisson_ratio, membrane_strain
        ),
    )
    gathered = pattern.copy()
    gathered[:, 0] = 0.5 * size + pin_spacing * (pattern[:, 0] - 0.5 * size)
    cloth.positions = gathered
    cloth.material_coordinates = uv  # the flat pattern, for sim.stroke_material
    # the corners of the edge z = 0 (the outline's first two points: vertices of either mesh)
    pinned = np.array(
        [
            np.argmin(np.hypot(uv[:, 0], uv[:, 1])),
            np.argmin(np.hypot(uv[:, 0] - uv[:, 0].max(), uv[:, 1])),
        ],
        dtype=np.int32,
    )
    cloth.fix(pinned)
    sim = Simulation(cloth, integrator=integrator, dt=dt, gravity=gravity, **options)
    sim.scene = {"name": "hanging_cloth", "fixed": pinned, "uv": uv}
    return sim


def rotating_cylinder(
    radius=0.25,
    height=0.5,
    rings=13,
    segments=32,
    mass=MASS,
    omega=2.0 * math.pi,
    stretch_stiffness=None,
    bend_stiffness=None,
    damping=DAMPING,
    drag=DRAG,
    integrator=DEFAULT_INTEGRATOR,
    dt=None,
    gravity=GRAVITY,
    bending="springs",
    bending_modulus=None,
    stretch="springs",
    young_modulus=None,
    poisson_ratio=None,
    membrane_strain=None,
    **options,
) -> Simulation:
    """An open cylinder held at its top rim, which rotates about the axis (paper §3.2, Fig. 4).

    The tube's axis is y, from y = 0 to y = height; the top rim is driven: it turns about the
    axis through (0, height, 0) at ``omega`` rad/s (counter-clockwise seen from above, as in the
    paper) from t = 0, and the rest of the tube is dragged round by its springs.

    radius, height : m. rings : vertex rings (>= 2). segments : vertices per ring (>= 3).
    mass : total mass, kg, uniform over the vertices. omega : rad/s. Material (bending and
    stretch) as hanging_cloth; quadratic bending takes the tube's faces as the rest shape, so, like a
    tube sewn from flat cloth, it has bending energy at rest (the model's rest state is flat).
    """
    V, F = cylinder_mesh(radius, height, rings, segments)
    cloth = Cloth(
        V,
        F,
        masses=_per_vertex(mass, len(V)),
        damping=damping,
        drag=drag,
        **_bending_arguments(bending, bend_stiffness, bending_modulus),
        **_stretch_arguments(
            stretch, stretch_stiffness, young_modulus, poisson_ratio, membrane_strain
        ),
    )
    rim = cylinder_ring(rings, segments, -1)
    cloth.drive_rotation(rim, center=(0.0, height, 0.0), axis=(0.0, 1.0, 0.0), omega=omega)
    sim = Simulation(cloth, integrator=integrator, dt=dt, gravity=gravity, **options)
    # A tube has no flat pattern without a seam, so it gets no material coordinates
    # (sim.stroke_material needs them); use sim.stroke or sim.stroke_screen.
    sim.scene = {
        "name": "rotating_cylinder",
        "driven": rim,
        "axis_center": np.array([0.0, height, 0.0]),
        "omega": omega,
    }
    return sim


def _rectangle_mesh(mesh, length, width, edge_length):
    """(vertices, faces) of a length × width rectangle with longest edges ``edge_length``:
    "grid", "pattern" or "delaunay" (`stretched_sheet`'s ``mesh``)."""
    if mesh == "grid":
        spacing = check_factor(edge_length, "edge_length", "m") / math.sqrt(2.0)
        V, F = grid_mesh(
            max(2, math.ceil(length / spacing) + 1),
            max(2, math.ceil(width / spacing) + 1),
            width=length,
            height=width,
        )
    elif mesh in ("pattern", "delaunay"):
        V, F = pattern_mesh(
            [[0.0, 0.0], [length, 0.0], [length, width], [0.0, width]],
            edge_length=edge_length,
            interior="lattice" if mesh == "pattern" else "delaunay",
        )
    else:
        raise ValueError(f'mesh must be "pattern", "delaunay" or "grid", got {mesh!r}')
    return V, F


# over 60 lines: a docstring for its 17 parameters (the code is 37 lines)
def stretched_sheet(
    length=1.0,
    width=0.5,
    strain=0.1,
    edge_length=0.02,
    stretch="membrane",
    young_modulus=1e4,
    poisson_ratio=0.5,
    stretch_stiffness=None,
    bending_modulus=1e-4,
    density=0.1,
    noise=1e-5,
    seed=0,
    integrator=DEFAULT_INTEGRATOR,
    dt=None,
    mesh="pattern",
    membrane_strain=None,
    **options,
) -> Simulation:
    """A sheet clamped along its two short edges and stretched (Cerda & Mahadevan 2003's
    setting, where Poisson contraction held back by the clamps compresses the middle across the
    width and wrinkles along the length may form).

    The pattern is a length × width rectangle (u along the length) meshed by `pattern_mesh`
    (longest edge ``edge_length``: an equilateral lattice with rows along u inside, CGAL's
    triangles along the edges; ``mesh="delaunay"``: CGAL's isotropic triangles throughout),
    or with ``mesh="grid"`` by `grid_mesh`
    aligned with its sides (squares of side ``edge_length``/√2 split by alternating diagonals,
    so the longest edge is ``edge_length`` too: a wrinkle along u has no spurious slope along u
    in any triangle, the reference for the pattern mesh's interpolation error); it starts in
    the z = 0 plane stretched uniformly along u by 1 + ``strain``, with its two short edges
    clamped (fixed) there, and ``noise`` m (RMS, seeded) of random height so that a flat state that is not stable can
    leave it. No gravity. Bending is quadratic (``bending_modulus``, N·m); stretching is the
    membrane (``young_modulus`` N/m, ``poisson_ratio``, the default) or springs (``stretch =
    "springs"`` with ``stretch_stiffness``); ``membrane_strain`` "smoothed" (the default) or
    "faces" (see `yore.Cloth`). Area density kg/m². Relax it with
    ``sim.settle(...)``; Cerda & Mahadevan's wavelength is
    ``(2π length)^½ (4 B / (Y strain))^¼`` for a sheet of 2-D modulus Y.

    The simulation's ``scene`` holds "clamped" (the fixed vertices) and "uv" (the pattern)."""
    length = check_factor(length, "length", "m")  # a negative width meshed the mirror image
    width = check_factor(width, "width", "m")
    strain = float(strain)
    if not (math.isfinite(strain) and strain > -1.0):
        raise ValueError(f"strain must be finite and > -1, got {strain}")
    noise = float(noise)
    if not (math.isfinite(noise) and noise >= 0.0):
        raise ValueError(f"noise must be finite and >= 0 (m), got {noise}")
    V, F = _rectangle_mesh(mesh, length, width, edge_length)
    uv = V[:, :2].copy()
    cloth = Cloth(
        V,
        F,
        density=density,
        damping=0.0,
        drag=0.0,
        bending="quadratic",
        bending_modulus=bending_modulus,
        **_stretch_arguments(
            stretch,
            stretch_stiffness,
            young_modulus if stretch == "membrane" else None,
            poisson_ratio if stretch == "membrane" else None,
            membrane_strain,
        ),
    )
    start = V.copy()
    start[:, 0] *= 1.0 + strain
    start[:, 2] = np.random.default_rng(seed).normal(0.0, noise, len(V))
    clamped = np.flatnonzero((uv[:, 0] <= 0.0) | (uv[:, 0] >= length)).astype(np.int32)
    start[clamped, 2] = 0.0
    cloth.positions = start
    cloth.material_coordinates = uv
    cloth.fix(clamped)
    sim = Simulation(cloth, integrator=integrator, dt=dt, gravity=(0.0, 0.0, 0.0), **options)
    sim.scene = {"name": "stretched_sheet", "clamped": clamped, "uv": uv}
    return sim


def _per_vertex(total_mass, count):
    total_mass = float(total_mass)
    if not math.isfinite(total_mass) or total_mass <= 0.0:
        raise ValueError(f"mass (total, kg) must be finite and > 0, got {total_mass}")
    return total_mass / count
