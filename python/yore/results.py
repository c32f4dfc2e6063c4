"""What yore reports, as typed results (`yore.documents.Result`: dicts whose fields are also
attributes): `Statistics` (``Simulation.stats``), `Energy` (``Simulation.energy()``,
``Cloth.energy()``), `ClothState` (``Cloth.state()``), `MembraneStatus`
(``Cloth.membrane_status()``), `QuadraticBending` (``Cloth.quadratic_bending``),
`NewtonSystem` (``ImplicitIntegrator.newton_system``), what a run
records at each frame (`FrameMeasure`) and of each stroke (`StrokeEntry`), a stroke's measured
effect (`StrokeEffect`), and the core's mesh queries: `RayHits` (``pick_rays``), `FaceSplit`
(``split_faces_1to3``) and `FaceRefinement` (``refine_faces_1to4``). The core's bindings build
the ones they return by name from this module."""

from __future__ import annotations

import numpy as np

from . import _core
from ._core import Cloth
from .documents import result_type

__all__ = [
    "Statistics",
    "Energy",
    "ClothState",
    "MembraneStatus",
    "QuadraticBending",
    "NewtonSystem",
    "FrameMeasure",
    "StrokeEntry",
    "StrokeEffect",
    "RayHits",
    "FaceSplit",
    "FaceRefinement",
]

Statistics = result_type(
    "Statistics",
    (
        "integrator",
        "dt",
        "time",
        "steps",
        "wall_seconds",
        "steps_per_second",
        "phases",
        "counters",
        "active_terms",
        "vertices",
        "springs",
        "topology_version",
        "threads",
    ),
    """A simulation's statistics: its integrator and dt; time, s; steps and wall seconds so far
    and their ratio; ``phases``, cumulative wall time per phase; ``counters``, cumulative counts
    and the last step's figures; ``active_terms``, the model terms in use; vertex and spring
    counts, the topology's version and the threads in use.""",
)

Energy = result_type(
    "Energy",
    ("kinetic", "spring", "gravity", "bending", "membrane", "total"),
    """A cloth's energies, J: kinetic, in its springs, gravitational, in its bending and
    membrane terms (0 where the cloth has none), and their total.""",
)

ClothState = result_type(
    "ClothState",
    Cloth.state_fields["required"] + Cloth.state_fields["optional"],
    """A cloth's state as ``Cloth.state()`` gives it (the fields of ``Cloth.state_fields``):
    positions, velocities, masses, faces, the springs' arrays, the material's constants, the
    vertices' states and drivers, the clock.""",
)

MembraneStatus = result_type(
    "MembraneStatus",
    ("clamped_rest_faces", "collapsed_faces", "rest_area", "current_area"),
    """The membrane's faces now (``Cloth.membrane_status()``): rest triangles clamped because
    their edge lengths (nearly) no longer close a triangle, faces collapsed below 1e-3 of their
    rest area, and the rest and current areas, m² (all zero with springs).""",
)

QuadraticBending = result_type(
    "QuadraticBending",
    ("size", "hinges", "indptr", "indices", "data", "rest_positions"),
    """Quadratic bending's matrix Q (``Cloth.quadratic_bending``): its size n, the interior
    edges (hinges), the symmetric n×n scalar matrix per unit modulus in CSR (indptr, indices,
    data; both triangles) and the rest positions (n×3, m) it was built from.""",
)

NewtonSystem = result_type(
    "NewtonSystem",
    (
        "energy",
        "gradient",
        "hessian_data",
        "hessian_indices",
        "hessian_indptr",
        "size",
        "direction",
        "free_vertices",
    ),
    """The backward-Euler incremental potential at given positions
    (``ImplicitIntegrator.newton_system``): its energy, J, gradient, N, the Hessian's lower
    triangle in CSC (data, indices, indptr, size), the solver's Newton direction and the free
    vertices (the unknowns).""",
)

FrameMeasure = result_type(
    "FrameMeasure",
    (
        "time",
        "kinetic",
        "spring",
        "gravity",
        "total",
        "area",
        "rest_area",
        "vertices",
        "faces",
        "bending",
        "membrane",
        "membrane_collapsed_faces",
    ),
    """What a run records at each frame: time, s; energies, J (bending and membrane for the
    cloths that have them); area and rest area, m²; vertex and face counts; the membrane's
    collapsed faces.""",
)

StrokeEntry = result_type(
    "StrokeEntry",
    (
        "stroke",
        "time",
        "faces_split",
        "faces_skipped",
        "vertices_added",
        "springs_added",
        "springs_removed",
        "area_before",
        "rest_area_before",
        "rest_area_after",
        "missed_fraction",
        "locate_seconds",
        "subdivide_seconds",
        "growth",
        "width",
        "refine",
        "faces_refined",
        "faces_bisected",
        "springs_grown",
        "rest_length_added",
        "mass_added",
        "new_vertices",
        "region_faces",
        "line_vertices",
        "reanalyze_seconds",
    ),
    """What a run records of a stroke it drew (``yore.StrokeReport``'s figures as JSON values):
    its index and time, what it split, added and removed, the areas before and after, its
    timings, growth, width and refinement, and the vertices and faces it made; the
    factorization's re-analysis time where the integrator has one.""",
)

StrokeEffect = result_type(
    "StrokeEffect",
    ("wrinkle", "wrinkle_plain", "wrinkle_ratio", "spike_index", "spike_index_plain"),
    """A stroke's effect (`yore.metrics.stroke_effect`): the region's wrinkle measure with and
    without the stroke, m, their ratio, and the spike index with and without it.""",
)


def active_terms(cloth, gravity, options) -> dict:
    """The model terms a simulation's cloth uses (`Statistics.active_terms`): gravity, spring
    damping, drag, bending springs, strain limiting (an integrator option), fixed and driven
    vertices, and, for cloths that chose them, quadratic bending's hinges and the membrane's
    faces (with those whose rest triangle was clamped or that are collapsed now)."""
    kinds = cloth.springs.kind
    active = {
        "gravity": bool(np.any(np.asarray(gravity) != 0.0)),
        "spring_damping": bool(np.any(cloth.springs.damping > 0.0)),
        "drag": cloth.drag > 0.0,
        "bending_springs": int(np.count_nonzero(kinds == 1)),
        "strain_limiting": options.get("strain_limit") is not None,
        "fixed_vertices": int(cloth.fixed_vertices.size),
        "driven_vertices": int(cloth.driven_vertices.size),
    }
    if cloth.bending in ("quadratic", "hinge"):
        # the number of interior edges (hinges) of its mesh, 0 when the modulus is 0 (no term)
        active["quadratic_bending"] = (
            int(cloth.bending_hinges) if cloth.bending_modulus > 0.0 else 0
        )
    if cloth.stretch == "membrane":
        status = cloth.membrane_status()
        active["membrane_faces"] = int(cloth.face_count)
        active["membrane_clamped_rest_faces"] = int(status["clamped_rest_faces"])
        active["membrane_collapsed_faces"] = int(status["collapsed_faces"])
    return active


def simulation_statistics(
    cloth, *, integrator, dt, steps, wall_seconds, phases, counters, active_terms, thread_usage
) -> Statistics:
    """`yore.Simulation.stats`: the integrator's counters and phases with the run's figures."""
    return Statistics(
        {
            "integrator": integrator,
            "dt": dt,
            "time": cloth.time,
            "steps": steps,
            "wall_seconds": wall_seconds,
            "steps_per_second": steps / wall_seconds if wall_seconds > 0 else 0.0,
            "phases": phases,
            "counters": counters,
            "active_terms": active_terms,
            "vertices": cloth.vertex_count,
            "springs": cloth.spring_count,
            "topology_version": cloth.topology_version,
            "threads": {
                "configured": _core.max_threads(),
                "blas": _core.blas_threads(),
                **thread_usage,
            },
        }
    )


RayHits = result_type(
    "RayHits",
    ("faces", "barycentric"),
    """Each ray's first hit on a cloth (``pick_rays``): the face it hit (-1 where it missed)
    and the barycentric coordinates of the hit (k×3, zero where it missed).""",
)

_SUBDIVISION = ("vertices", "faces", "parents", "new_vertex_corners", "new_vertex_weights")

FaceSplit = result_type(
    "FaceSplit",
    (*_SUBDIVISION, "split_faces", "faces_skipped", "moved_inward"),
    """The paper's 1→3 split of a mesh (``split_faces_1to3``): the new mesh (vertices, faces,
    each face's parent, each new vertex's corners and weights), the faces split and skipped,
    and how many split points the min_barycentric rule moved inward.""",
)

FaceRefinement = result_type(
    "FaceRefinement",
    (*_SUBDIVISION, "refined_faces", "bisected_faces", "split_edges"),
    """A 1→4 refinement with its conforming closure (``refine_faces_1to4``): the new mesh
    (vertices, faces, each face's parent, each new vertex's corners and weights), the faces
    refined 1→4 and bisected, and the edges split.""",
)
