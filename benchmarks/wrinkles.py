"""Wrinkles that are physics, not mesh (issue 42): the stretched sheet of Cerda & Mahadevan
(2003) for the spring lattice and for the membrane side by side, and the paper's hanging-cloth
stroke at three resolutions.

    python -m benchmarks.wrinkles [--out bench-results] [--quick] [--resume | --collect]
        [--parts sheets strokes bands] [--band-bendings B ...] [--band-meshes grid pattern]

One thread. `yore.scenes.stretched_sheet`: a length × width sheet on a pattern mesh (the
default `pattern_mesh`: an equilateral lattice with rows along the length inside, CGAL along the
edges; rows on CGAL's Delaunay mesh throughout, `mesh="delaunay"`, show what pattern meshes
were before issue 52), clamped along its short edges and stretched by `strain`, quadratic
bending B, 1e-5 m of seeded noise, relaxed by `Simulation.settle` (with its saddle test) from
the flat stretched start. Per run, from the relaxed sheet's cross-section at mid-length (z
interpolated along the width): the wavelength (peak of the zero-padded, Hann-windowed FFT), the
number of wrinkles (half the sign changes), the amplitude (largest |z| of the section), and
whether it is a mesh-scale zigzag (wavelength < 4 mean edges) or flat (amplitude under a tenth
of the noise, which relaxation takes off a stable flat state); the flat stretched state's stability (the true Hessian's Cholesky at it) and the
largest compression across the width in it (the membrane's second Piola–Kirchhoff S_yy over
its middle fifth). Per run also, after issue 52: the bending modulus the mesh realises (its
energy of the pattern rolled onto a cylinder across the width, over the continuum's), the
artificial modulus B_art the piecewise-linear interpolation adds (a wrinkle z = sin kv of the
measured wavelength has a spurious slope along u in every triangle not aligned with u, which
the flat state's tension S_uu charges like bending), measured from the library's own membrane
energy (`membrane_artificial_bending`: a probe wrinkle over the middle half of the length, the
continuum's energy subtracted) on the same mesh under a uniform tension along u scaled to the
run's (`tension_artificial_bending`; the flat state's probe, which also charges the
compression deficit, is kept beside it for the membrane as built and for the faces' constant
strain), the tension, points per wavelength, the wrinkled zone's length along u, and whether
the row is judged (wrinkled, at least three wrinkles across the width, not a zigzag, ≥ 8 points
per wavelength, |B_art| ≤ 0.1 B). The membrane runs
on pattern meshes and on grids aligned with the sheet (`stretched_sheet(mesh="grid")`, no
spurious slope), each base also from a second seed, and on Delaunay meshes (the base and the
mesh sizes). The prediction is Cerda & Mahadevan's
λ = (2π L)^½ (4 B / (Y γ))^¼ from the model's own Y: the membrane's, or the lattice's under an affine strain (the moduli of the
spring lattice from the energies of three small affine strains; an upper bound, since its
nodes may relax). Exponents of λ in B (16×), L (4×) and γ (4×) are fitted over the judged
runs only, per mesh kind, each value on its finest judged mesh. The stroke rows: `hanging_cloth` at resolutions 21, 31, 41,
springs and a membrane of the grid lattice's affine Y and ν, simulated 1 s, stroked along
v = 0.8 from u = 0.2 to 0.8 (the paper's stroke across the folds near the top), simulated 1 s
more: the wrinkle measure of the stroke's region and its fold depth (range of the wrinkle
height over the region). Since issue 52 also the stroke in physical units: `hanging_cloth` on a
grid and on a CGAL pattern mesh at 41, 81 and 161 vertices a side (membrane, fitted bending
1e-4 and 1e-2 N·m), every mesh started from one shape (the 161² grid's settled cloth, carried
by material coordinates) and settled; the zone about the band refined to 4 mm edges; stroked
with a band 6 cm wide along v = 0.8 (isotropic growth 1.1), displaced by 1e-5 m of seeded
noise (eight seeds) and settled again; fold depth, fold RMS, wrinkle measure (Gaussian
smoothing, σ = 5 cm) and wavelength over the same material band, sampled at the same material
points every 2 mm on every mesh; the seeds' means and standard errors (BAND_PROTOCOL says why).
With `--parts` a run does only some of sheets, strokes and bands and collects the others from
the journal; `--band-bendings` and `--band-meshes` split the bands between two processes.

Every finished run is journaled (one JSON per run under <out>/wrinkles-runs/, written
atomically): --resume skips them. Writes wrinkles.json and wrinkles.png.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import numpy as np

import yore
from yore import metrics

from . import common

NOISE = 1e-5
#: A relaxed sheet is flat when its section's largest |z| is below this: relaxation takes the
#: noise off a stable flat state to ~1e-11 m, while a wrinkle just past its threshold, small
#: as it is, stays (measured: 2.9e-5 m on the lattice at B = 1.6e-3, h = 0.0098 m).
FLAT = 0.1 * NOISE
YOUNG = 1e4  # N/m, the membrane's, and the springs' stiffness scale
POISSON = 0.5
B0 = 2.5e-5  # N·m
#: Each model's base run. The membrane's flat state gives way only on thin sheets, whose
#: wrinkles at onset are short (λ ≈ 2π (2B/|S_yy|)^½ with the compression S_yy ≈ 12 N/m of
#: the flat state): it needs B ≲ 1e-4 N·m and edges of a few mm (at 7–10 mm every membrane run
#: stayed flat, measured). The lattice wrinkles on coarser meshes and at larger B.
BASES = {
    "membrane": {
        "length": 1.0,
        "width": 0.5,
        "strain": 0.1,
        "edge_length": 0.005,
        "bending_modulus": B0,
    },
    "springs": {
        "length": 1.0,
        "width": 0.5,
        "strain": 0.1,
        "edge_length": 0.014,
        "bending_modulus": 4 * B0,
    },
}
SETTLE_SECONDS = 40.0  # pseudo-time cap of one relaxation
SETTLE_TOLERANCE = 1e-5  # m/s²: 1e-6 of the sheet's tension over its areal density
MESHES = {"membrane": [0.007, 0.005, 0.0035, 0.0025], "springs": [0.02, 0.014, 0.01]}
QUICK_BASE = {
    "length": 0.4,
    "width": 0.2,
    "strain": 0.1,
    "edge_length": 0.04,
    "bending_modulus": 4 * B0,
}
STROKE_RESOLUTIONS = [21, 31, 41]
QUICK_STROKE_RESOLUTIONS = [9, 13]
#: Issue 52's stroke against the mesh, in physical units: a band 6 cm wide along v = 0.8 from
#: u = 0.2 to 0.8, isotropic growth 1.1 (area × 1.21), on the hanging cloth with the membrane
#: and the fitted bending, settled before and after; measured over the material band (the
#: same region on every mesh) with a smoothing reach of 15 cm.
BAND = {"v": 0.8, "u": (0.2, 0.8), "width": 0.06, "growth": "isotropic", "expansion": 1.1}
BAND_BENDING = 1e-4  # N·m: a bending length (B / ρg)^⅓ ≈ 5 cm at 0.1 kg/m²
#: The band strokes' bending moduli (N·m): BAND_BENDING, whose band buckles into wrinkles of
#: 75–100 mm in one of a few states, and a stiff cloth's (bending length ≈ 21 cm), whose band
#: bulges as a whole
BAND_BENDINGS = (BAND_BENDING, 1e-2)
#: How a journaled band row's growth was weighted: a spring's weight the falloff's Simpson mean
#: along it (issue 52); rows without it took the smaller weight of its ends and are redone
BAND_WEIGHTS = "simpson"
BAND_REACH = 0.15  # m
BAND_RESOLUTIONS = [41, 81, 161]
QUICK_BAND_RESOLUTIONS = [9, 13]
BAND_SETTLE_SECONDS = 120.0  # pseudo-time cap; the 41² cloth settles in ~55 s
#: How a band row was run (journaled rows of another protocol are redone). Every mesh starts
#: from one shape: the hanging cloth settled on the BAND_START grid, carried to the mesh by its
#: material coordinates and settled there. Settled freely from the flat start, each mesh found
#: its own folds (the settled shapes of the grid at 41, 81 and 161 and the pattern mesh at 41
#: a side are 40–65 mm RMS apart: the hanging cloth's equilibrium is not unique), so the
#: stroke met a different cloth on every mesh. The band is refined (`refine`) until its edges
#: are at most BAND_EDGE, and the stroke's buckling, which has many near-equal outcomes (two
#: settles 0.03 mm apart ended 5 mm RMS apart in the band, their fold RMS 3–8 % apart), is run
#: from BAND_SEEDS seeded 1e-5 m displacements and measured as their mean.
BAND_PROTOCOL = "common start, refined zone, seeds"
BAND_START = {"mesh": "grid", "resolution": 161}
QUICK_BAND_START = {"mesh": "grid", "resolution": 13}
BAND_SAMPLE = 0.002  # m: the material grid the start is kept on and the band is measured on
BAND_EDGE = 0.004  # m: ~15 edges across the band, ≥ 8 a wrinkle of the band's (7–11 cm)
QUICK_BAND_EDGE = 0.05
#: The refined zone: the band and a band's width on each side, where its wrinkles reach (the
#: wrinkles of the same outcome on 81² and 161² meshes refined over the band alone differed by
#: 11–14 % in fold depth and RMS, the band's neighbours left at the base mesh's edges).
BAND_REFINE_WIDTH = 3 * BAND["width"]
BAND_SEEDS = tuple(range(8))
QUICK_BAND_SEEDS = (0, 1)
#: What `--parts` may name.
PARTS = ("sheets", "strokes", "bands")
#: The inside of each mesh kind's pattern mesh (`pattern_mesh`'s interior); rows journaled
#: before the lattice (issue 52) have none and are redone.
INTERIORS = {"pattern": "lattice", "delaunay": "delaunay"}
#: The summary's name of each (model, mesh, membrane strain) kind.
KINDS = {
    ("membrane", "pattern", "faces"): "membrane",
    ("membrane", "grid", "faces"): "membrane on an aligned grid",
    ("membrane", "delaunay", "faces"): "membrane on a Delaunay mesh",
    ("membrane", "pattern", "smoothed"): "membrane, smoothed strain",
    ("membrane", "grid", "smoothed"): "membrane, smoothed strain, on an aligned grid",
    ("membrane", "delaunay", "smoothed"): "membrane, smoothed strain, on a Delaunay mesh",
    ("springs", "pattern", None): "springs",
}


def current(row, model, mesh, strain="faces"):
    """Whether a journaled row measured today's models: the membrane's strain (the faces', the
    default, unless the row asks for the smoothed one) and the mesh kind's pattern interior."""
    return row.get("membrane_strain") == (strain if model == "membrane" else None) and row.get(
        "pattern_interior"
    ) == INTERIORS.get(mesh)


def sheet_runs(quick):
    """(label, model, parameters) of the stretched-sheet runs: the base, B over 16×, L over 4×,
    γ over 4×, three meshes (the membrane on pattern meshes and aligned grids, each base with a
    second seed), and for the springs B up to 64× at every mesh (their threshold)."""
    runs = []

    def add(label, model, **changes):
        parameters = dict(QUICK_BASE if quick else BASES[model], **changes)
        parameters.setdefault("mesh", "pattern")
        parameters.setdefault("seed", 0)
        key = (model, tuple(sorted(parameters.items())))
        if key not in {(m, tuple(sorted(p.items()))) for _, m, p in runs}:
            runs.append((label, model, parameters))

    # the membrane on pattern meshes (a lattice inside, the default) and, beside them, on grids
    # aligned with the sheet (no interpolation slope along the wrinkles: the reference); a
    # second seeded start of each base; on CGAL's Delaunay meshes throughout (what pattern
    # meshes were before issue 52) the base and the meshes only
    for model, mesh in (
        ("membrane", "pattern"),
        ("membrane", "grid"),
        ("springs", "pattern"),
        ("membrane", "delaunay"),
    ):
        add("base", model, mesh=mesh)
        if mesh == "delaunay":
            for edge in MESHES[model] if not quick else []:
                add("mesh", model, edge_length=edge, mesh=mesh)
            # and the smoothed strain (`membrane_strain="smoothed"`) on every mesh kind: no
            # interpolation bending on point-symmetric stars in any direction, a low-pass of
            # ~0.25 (kh)² (issue 52)
            for smoothed_mesh in ("pattern", "grid", "delaunay"):
                add("base", model, mesh=smoothed_mesh, membrane_strain="smoothed")
                for edge in MESHES[model] if not quick else []:
                    add(
                        "mesh",
                        model,
                        edge_length=edge,
                        mesh=smoothed_mesh,
                        membrane_strain="smoothed",
                    )
            continue
        if model == "membrane":
            add("seed", model, mesh=mesh, seed=1)
        if quick:
            add("B", model, bending_modulus=B0, mesh=mesh)
            continue
        factors = (0.25, 1, 4) if model == "membrane" else (1, 4, 16)
        for factor in factors:
            add("B", model, bending_modulus=factor * B0, mesh=mesh)
        if model == "membrane":  # the smallest B again on a mesh with 8 points a wavelength
            add("B", model, bending_modulus=0.25 * B0, mesh=mesh, edge_length=0.003)
            if mesh == "grid":  # its 3 mm grid (2.4 mm mean edge) gives 7.9 points
                add("B", model, bending_modulus=0.25 * B0, mesh=mesh, edge_length=0.0025)
        for length in (0.5, 2.0):
            add("L", model, length=length, mesh=mesh)
        for strain in (0.05, 0.2):
            add("strain", model, strain=strain, mesh=mesh)
        for edge in MESHES[model]:
            add("mesh", model, edge_length=edge, mesh=mesh)
    for edge in MESHES["springs"] if not quick else []:
        for factor in (1, 16, 64, 256):
            add("threshold", "springs", edge_length=edge, bending_modulus=factor * B0)
    return runs


def lattice_moduli(V, F, stiffness):
    """The spring lattice's in-plane moduli under affine strains (J/m² per strain²): energies of
    three small strains give C11, C22, C12; returns (Y along u under uniaxial stress, ν)."""
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0
    )
    d = V[edges[:, 1], :2] - V[edges[:, 0], :2]
    length = np.linalg.norm(d, axis=1)
    n = d / length[:, None]
    a, b = V[F[:, 1], :2] - V[F[:, 0], :2], V[F[:, 2], :2] - V[F[:, 0], :2]
    area = 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum()

    def energy(exx, eyy):  # small strain: ΔL = L n·εn, energy Σ ½ k ΔL² per area
        stretch = length * (n[:, 0] ** 2 * exx + n[:, 1] ** 2 * eyy)
        return 0.5 * stiffness * np.sum(stretch**2) / area

    e = 1e-4
    c11, c22 = 2 * energy(e, 0) / e**2, 2 * energy(0, e) / e**2
    c12 = (energy(e, e) - energy(e, 0) - energy(0, e)) / e**2
    return c11 - c12**2 / c22, c12 / c22


def predicted_wavelength(length, bending, young, strain):
    return math.sqrt(2 * math.pi * length) * (4 * bending / (young * strain)) ** 0.25


def section(positions, length, strain, width, edge):
    """z along the width at mid-length: (y, z) on 4096 points, interpolated from the vertices
    within one mean edge of the plane x = L(1 + γ)/2."""
    middle = 0.5 * length * (1 + strain)
    near = np.flatnonzero(np.abs(positions[:, 0] - middle) < edge)
    order = np.argsort(positions[near, 1])
    y, z = positions[near[order], 1], positions[near[order], 2]
    grid = np.linspace(max(y.min(), 0.0), min(y.max(), width), 4096)
    return grid, np.interp(grid, y, z)


def wavelength_of(y, z):
    """Wavelength (m) of the largest peak of the Hann-windowed spectrum, zero-padded 16×, and
    the number of wrinkles (half the sign changes of z)."""
    span = y[-1] - y[0]
    values = (z - z.mean()) * np.hanning(len(z))
    padded = 16 * len(z)
    spectrum = np.abs(np.fft.rfft(values, padded))
    frequencies = np.fft.rfftfreq(padded, d=span / (len(z) - 1))
    lowest = 1.5 / span  # a wave that fits the width at least 1.5 times
    usable = frequencies >= lowest
    peak = frequencies[usable][np.argmax(spectrum[usable])]
    crossings = int(np.count_nonzero(np.diff(np.sign(z)) != 0))
    return 1.0 / peak, crossings / 2.0


def face_stress(uv, F, P):
    """The membrane's second Piola–Kirchhoff stress per face (f×2×2, N/m; St. Venant–Kirchhoff,
    plane stress, YOUNG and POISSON) at positions P, with rest triangles from the pattern uv."""
    mu = YOUNG / (2 * (1 + POISSON))
    lam = YOUNG * POISSON / (1 - POISSON**2)
    rest = np.stack([uv[F[:, 1]] - uv[F[:, 0]], uv[F[:, 2]] - uv[F[:, 0]]], axis=2)
    now = np.stack([P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]], axis=2)
    G = now @ np.linalg.inv(rest)
    E = 0.5 * (np.transpose(G, (0, 2, 1)) @ G - np.eye(2))
    return 2 * mu * E + lam * np.trace(E, axis1=1, axis2=2)[:, None, None] * np.eye(2)


def realized_bending(uv, F, bending_modulus, radius=0.5):
    """The bending modulus the mesh's bending energy realises (N·m): the pattern rolled
    isometrically onto a cylinder of `radius` about an axis along u (so it bends across the
    width, as the wrinkles do), its energy over the continuum ½ A / R²."""
    V = np.column_stack([uv, np.zeros(len(uv))])
    cloth = yore.Cloth(V, F, bending="quadratic", bending_modulus=bending_modulus)
    angle = uv[:, 1] / radius
    cloth.positions = np.column_stack(
        [uv[:, 0], radius * np.sin(angle), radius * (1 - np.cos(angle))]
    )
    area = metrics.area(V, F)
    return cloth.energy((0.0, 0.0, 0.0))["bending"] / (0.5 * area / radius**2)


def fitted_gradient_weights(uv, F, vertices):
    """Per vertex p of `vertices`: (patch, C) with C (2 × m) the weights that give the gradient
    at p of the least-squares quadratic through p's 1-ring (grown by the next ring until 6 or
    more points pose a well-conditioned fit, in coordinates whitened by the patch's spread:
    the fit of the fitted bending energy), so ∇f(p) ≈ C f[patch]."""
    ring = [set() for _ in range(len(uv))]
    for a, b, c in F:
        ring[a].update((b, c))
        ring[b].update((a, c))
        ring[c].update((a, b))
    out = {}
    for p in vertices:
        patch = set(ring[p]) | {p}
        while True:
            index = np.array(sorted(patch))
            d = uv[index] - uv[p]
            spread = d.T @ d / len(index)
            if len(index) >= 6 and np.linalg.det(spread) > 1e-12 * np.trace(spread) ** 2:
                to_white = np.linalg.inv(np.linalg.cholesky(spread))
                s = d @ to_white.T
                design = np.column_stack(
                    [np.ones(len(index)), s, s[:, 0] ** 2, s[:, 0] * s[:, 1], s[:, 1] ** 2]
                )
                sigma = np.linalg.svd(design, compute_uv=False)
                if sigma[-1] >= 1e-2 * sigma[0]:
                    out[p] = (index, to_white.T @ np.linalg.pinv(design)[1:3])
                    break
            grown = set().union(*(ring[q] for q in patch)) - patch
            if not grown:
                raise ValueError(f"vertex {p}: no well-posed fit")
            nearest = min(grown, key=lambda q: float(np.sum((uv[q] - uv[p]) ** 2)))
            patch.add(nearest)
    return out


def artificial_bending(uv, F, stress, wavelength, middle, gradients="linear"):
    """B_art (N·m): the bending modulus the interpolation error adds. A wrinkle z = sin(k v + φ)
    has no slope along u, but its piecewise-linear interpolant has one, g_u, in every triangle
    whose edges are not aligned with u; under the flat state's stress S it costs
    ½ Σ_f A_f (S_uu g_u² + 2 S_uv g_u g_v) beyond the continuum's ½ ∫ S_vv z_v², which acts
    as ½ B_art ∫ z_vv² = ½ B_art k⁴ ∫ z². Over the faces in `middle` (where wrinkles form),
    averaged over four phases φ. gradients="fitted": the same for a membrane whose face
    gradient is the mean of its corners' fitted gradients (`fitted_gradient_weights`), the
    remedy measured first; not built, since a fitted gradient per vertex fails the patch test
    (a homogeneous stress is not in balance). The library's membranes are measured by
    `membrane_artificial_bending`."""
    if gradients not in ("linear", "fitted"):
        raise ValueError(f'gradients must be "linear" or "fitted", got {gradients!r}')
    fits = fitted_gradient_weights(uv, F, np.unique(F[middle])) if gradients == "fitted" else None
    k = 2 * math.pi / wavelength
    a, b = uv[F[:, 1]] - uv[F[:, 0]], uv[F[:, 2]] - uv[F[:, 0]]
    twice_area = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    area = 0.5 * np.abs(twice_area)
    spurious, reference = 0.0, 0.0
    for phase in np.arange(4) * math.pi / 4:
        z = np.sin(k * uv[:, 1] + phase)
        dz1, dz2 = z[F[:, 1]] - z[F[:, 0]], z[F[:, 2]] - z[F[:, 0]]
        gu = (dz1 * b[:, 1] - dz2 * a[:, 1]) / twice_area
        gv = (dz2 * a[:, 0] - dz1 * b[:, 0]) / twice_area
        if fits is not None:  # the faces in `middle` only: their corners' fitted gradients
            at = {p: C @ z[index] for p, (index, C) in fits.items()}
            for f in np.flatnonzero(middle):
                gu[f], gv[f] = np.mean([at[p] for p in F[f]], axis=0)
        density = stress[:, 0, 0] * gu**2 + 2 * stress[:, 0, 1] * gu * gv
        spurious += np.sum((area * density)[middle])
        reference += np.sum((area * (z[F] ** 2).mean(axis=1))[middle]) * k**4
    return float(spurious / reference)


#: The probe wrinkle's amplitudes (m): small enough that the membrane's quartic terms are
#: under 1e-2 of its artificial bending at these moduli, large enough for round-off; the two
#: amplitudes cancel the quartic term (Richardson).
PROBE_AMPLITUDE = 1e-6


def _subtriangle_points(uv, F):
    """Quadrature of ∫ over each face: 12 points (the edge midpoints of its four midpoint
    subtriangles, exact for quadratics on each) with equal weights, as (f, 12, 2) points."""
    a, b, c = uv[F[:, 0]], uv[F[:, 1]], uv[F[:, 2]]
    ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
    points = []
    for p, q, r in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)):
        points += [(p + q) / 2, (q + r) / 2, (r + p) / 2]
    return np.stack(points, axis=1)


def membrane_artificial_bending(cloth, uv, F, stress, wavelength, length):
    """B_art of the library's own membrane (N·m), measured from its energy at the cloth's
    current flat state: a probe wrinkle z = a w(u) sin(k v + φ), w = sin²(π s) over the middle
    half of the length (s from 0 at u = L/4 to 1 at 3L/4), adds the membrane energy
    ½ ∫ ∇zᵀ S ∇z dA of the continuum (S the flat state's stress per face, ∇z exact, 12-point
    quadrature per face) plus what the discretization adds, ½ B_art ∫ z_vv² ≈ ½ B_art k⁴ ∫ z²;
    four phases, two amplitudes (the quartic term cancelled). For constant-strain faces this is
    the interpolation's spurious slope under the tension (`artificial_bending`'s "linear"); the
    fitted strain's is what remains of it (issue 52)."""
    k = 2 * math.pi / wavelength
    u0, u1 = 0.25 * length, 0.75 * length
    flat = np.array(cloth.positions)

    def window(u):
        s = np.clip((u - u0) / (u1 - u0), 0.0, 1.0)
        return np.sin(math.pi * s) ** 2, math.pi / (u1 - u0) * np.sin(2 * math.pi * s)

    points = _subtriangle_points(uv, F)
    a_, b_ = uv[F[:, 1]] - uv[F[:, 0]], uv[F[:, 2]] - uv[F[:, 0]]
    area = 0.5 * np.abs(a_[:, 0] * b_[:, 1] - a_[:, 1] * b_[:, 0])
    w_vertex = window(uv[:, 0])[0]
    w_point, dw_point = window(points[..., 0])
    before = cloth.energy((0.0, 0.0, 0.0))["membrane"]
    increments, continuum, squared = [], 0.0, 0.0
    for amplitude in (PROBE_AMPLITUDE, 2 * PROBE_AMPLITUDE):
        increase = 0.0
        for phase in np.arange(4) * math.pi / 4:
            probe = flat.copy()
            probe[:, 2] += amplitude * w_vertex * np.sin(k * uv[:, 1] + phase)
            cloth.positions = probe
            increase += cloth.energy((0.0, 0.0, 0.0))["membrane"] - before
            if amplitude == PROBE_AMPLITUDE:
                angle = k * points[..., 1] + phase
                gu = dw_point * np.sin(angle)
                gv = w_point * k * np.cos(angle)
                density = (
                    stress[:, None, 0, 0] * gu * gu
                    + 2 * stress[:, None, 0, 1] * gu * gv
                    + stress[:, None, 1, 1] * gv * gv
                )
                continuum += 0.5 * np.sum(area * density.mean(axis=1))
                squared += np.sum(area * ((w_point * np.sin(angle)) ** 2).mean(axis=1))
        increments.append(increase / amplitude**2)
    cloth.positions = flat
    quadratic = (4 * increments[0] - increments[1]) / 3  # per a², the quartic term cancelled
    # continuum and squared were summed at amplitude 1 (per a²)
    return float((quadratic - continuum) / (0.5 * k**4 * squared))


def tension_artificial_bending(model, parameters, tension, wavelength):
    """B_art (N·m) the judged rows are held to: what the interpolation's spurious slope along u
    costs under the tension (issue 52's B_art ≈ c h² S_uu), without the compression deficit
    the flat-state probe also holds. The same probe (`membrane_artificial_bending`) on the
    same mesh, stretched uniformly by the run's strain along u and relaxed across (S_vv = 0,
    S_uv = 0 exactly), scaled to the run's measured tension. Why the compression is left out:
    the piecewise-linear interpolant reads ∫ z_v² short by ~(kh)²/12, so under the flat
    state's compression S_vv the probe charges ~|S_vv| h² k⁴ like bending; but a wrinkled sheet
    takes up its slack, the compression is whatever buckles it, and the deficit only scales
    the slack: minimising (B k² + T π² / (k L)²)(1 + (kh)²/12) gives B (1 + (kh)²/6), an
    error proportional to B (λ 2.6 % long at 8 points a wavelength), not an added
    |S_vv| h². The aligned grid shows it: its probe reads 0.40 B and 0.21 B at h = 5.6 and
    4.0 mm (B = 2.5e-5), which as bending would make λ converge from above by 9 % and 5 %; it
    converges from below."""
    if model != "membrane":
        return None
    sim = make(model, parameters, noise=0.0)
    cloth, uv = sim.cloth, sim.scene["uv"]
    F = cloth.faces
    mu = YOUNG / (2 * (1 + POISSON))
    lam = YOUNG * POISSON / (1 - POISSON**2)
    stretch = 1 + parameters["strain"]
    e_uu = 0.5 * (stretch**2 - 1)
    e_vv = -lam * e_uu / (2 * mu + lam)  # St. Venant–Kirchhoff: S_vv = 0
    P = np.column_stack([uv[:, 0] * stretch, uv[:, 1] * math.sqrt(1 + 2 * e_vv), np.zeros(len(uv))])
    cloth.positions = P
    S = face_stress(uv, F, P)
    probe = membrane_artificial_bending(cloth, uv, F, S, wavelength, parameters["length"])
    return float(probe * tension / S[:, 0, 0].mean())


#: The fewest wrinkles across the width a judged row has (see `judge`).
MIN_JUDGED_WRINKLES = 3


def judge(row):
    """Set the row's tension B_art (`tension_artificial_bending`; a row journaled before it
    keeps its flat-state probe under `flat_state_probe_bending`) and whether it is judged for
    the exponents and the targets: wrinkled, at least three wrinkles across the width (on
    fewer the spectrum's peak is the width's own lowest mode, not a length the material sets),
    resolved (8 points a wavelength), not a zigzag, and the interpolation adds at most a tenth
    of B under the tension."""
    if "flat_state_probe_bending" not in row:
        row["flat_state_probe_bending"] = row.pop("artificial_bending", None)
    if row.get("artificial_bending") is None and row["model"] == "membrane":
        parameters = {
            k: row[k]
            for k in ("length", "width", "strain", "edge_length", "bending_modulus", "mesh", "seed")
        }
        if row.get("membrane_strain") == "smoothed":
            parameters["membrane_strain"] = "smoothed"
        row["artificial_bending"] = tension_artificial_bending(
            row["model"],
            parameters,
            row["tension"],
            row["wavelength"] or row["predicted_wavelength"],
        )
    row.setdefault("artificial_bending", None)
    b_art, wavelength = row["artificial_bending"], row["wavelength"]
    row["judged"] = bool(
        wavelength is not None
        and (row["wrinkles"] or 0) >= MIN_JUDGED_WRINKLES
        and not row["zigzag"]
        and wavelength / row["mean_edge"] >= 8
        and (b_art is None or abs(b_art) <= 0.1 * row["bending_modulus"])
    )
    return row


def flat_state_check(model, parameters, wavelength):
    """The flat stretched state (relaxed without leaving the plane): whether it is stable (the
    true Hessian's Cholesky); for the membrane its largest compression across the width and
    mean tension along the length over the middle fifth (S_vv, S_uu, N/m) and, for a wrinkle
    of `wavelength`, the interpolation's artificial bending modulus B_art under that stress
    over the middle half (None for springs)."""
    sim = make(model, parameters, noise=0.0)
    sim.settle(max_seconds=SETTLE_SECONDS, tolerance=SETTLE_TOLERANCE, check_stability=False)
    cloth = sim.cloth
    stable = not yore.settling.is_saddle(cloth, (0.0, 0.0, 0.0))
    out = {
        "flat_state_stable": stable,
        "flat_state_compression": None,
        "tension": None,
        "flat_state_probe_bending": None,
        "artificial_bending_faces": None,
    }
    if model == "membrane":
        uv, F = sim.scene["uv"], cloth.faces
        S = face_stress(uv, F, cloth.positions)
        centre = uv[F].mean(axis=1)
        offset = np.abs(centre[:, 0] - 0.5 * parameters["length"])
        fifth = offset < 0.1 * parameters["length"]
        out["flat_state_compression"] = float(-S[fifth, 1, 1].min())
        out["tension"] = float(S[fifth, 0, 0].mean())
        # B_art of the membrane as built (faces or smoothed strain, issue 52), and of the same state
        # with the faces' constant strain (a state without "membrane_strain" loads so): what
        # the membrane carried before
        out["flat_state_probe_bending"] = membrane_artificial_bending(
            cloth, uv, F, S, wavelength, parameters["length"]
        )
        faces_state = cloth.state()
        faces_state.pop("membrane_strain", None)
        out["artificial_bending_faces"] = membrane_artificial_bending(
            yore.Cloth.from_state(faces_state), uv, F, S, wavelength, parameters["length"]
        )
    return out


def make(model, parameters, noise=NOISE):
    options = dict(
        length=parameters["length"],
        width=parameters["width"],
        strain=parameters["strain"],
        edge_length=parameters["edge_length"],
        bending_modulus=parameters["bending_modulus"],
        noise=noise,
        mesh=parameters.get("mesh", "pattern"),
        seed=parameters.get("seed", 0),
    )
    if model == "membrane":
        return yore.scenes.stretched_sheet(
            stretch="membrane",
            young_modulus=YOUNG,
            poisson_ratio=POISSON,
            membrane_strain=parameters.get("membrane_strain"),
            **options,
        )
    return yore.scenes.stretched_sheet(stretch="springs", stretch_stiffness=YOUNG, **options)


def sheet_run(label, model, parameters):
    start = time.process_time()
    sim = make(model, parameters)
    settled = sim.settle(max_seconds=SETTLE_SECONDS, tolerance=SETTLE_TOLERANCE)
    cloth = sim.cloth
    F, uv = cloth.faces, sim.scene["uv"]
    h = mean_edge(uv, F)
    y, z = section(
        cloth.positions, parameters["length"], parameters["strain"], parameters["width"], h
    )
    amplitude = float(np.abs(z).max())
    flat = amplitude < FLAT
    wavelength, count = wavelength_of(y, z)
    if model == "membrane":
        young, nu = YOUNG, POISSON
    else:
        young, nu = lattice_moduli(np.column_stack([uv, np.zeros(len(uv))]), F, YOUNG)
    predicted = predicted_wavelength(
        parameters["length"], parameters["bending_modulus"], young, parameters["strain"]
    )
    flat_state = flat_state_check(model, parameters, predicted if flat else wavelength)
    # the wrinkled zone: the span along the length (pattern u) of the vertices whose height is
    # over a tenth of the largest
    heights = np.abs(cloth.positions[:, 2])
    lifted = uv[heights > 0.1 * heights.max(), 0] if heights.max() > FLAT else np.zeros(0)
    zone = float(lifted.max() - lifted.min()) if len(lifted) else 0.0
    realized = realized_bending(uv, F, parameters["bending_modulus"])
    zigzag = bool(not flat and wavelength < 4 * h)
    row = {
        "label": label,
        "model": model,
        **parameters,
        "vertices": int(cloth.vertex_count),
        "membrane_strain": cloth.membrane_strain,
        "pattern_interior": INTERIORS.get(parameters.get("mesh", "pattern")),
        "mean_edge": h,
        "young": float(young),
        "poisson": float(nu),
        "predicted_wavelength": predicted,
        "realized_bending": realized,
        "points_per_wavelength": None if flat else float(wavelength / h),
        "wrinkled_zone": zone,
        "flat": bool(flat),
        "amplitude": amplitude,
        "wavelength": None if flat else float(wavelength),
        "wrinkles": None if flat else count,
        "zigzag": zigzag,
        "settle": {
            k: settled[k]
            for k in ("seconds", "converged", "residual_acceleration", "saddles_escaped", "stable")
        },
        **flat_state,
        "section": {"y": y[::64].tolist(), "z": z[::64].tolist()},
    }
    judge(row)
    row["cpu_seconds"] = time.process_time() - start
    return row


def stroke_run(model, resolution, quick):
    """The paper's hanging cloth, stroked across its folds near the top."""
    start = time.process_time()
    kwargs = {}
    if model == "membrane":
        V, F = yore.grid_mesh(resolution, resolution)
        young, nu = lattice_moduli(V, F, yore.scenes.STIFFNESS)
        kwargs = {"stretch": "membrane", "young_modulus": young, "poisson_ratio": nu}
    sim = yore.scenes.hanging_cloth(resolution=resolution, integrator="implicit", **kwargs)
    seconds = 0.25 if quick else 1.0
    sim.advance(seconds)
    report = sim.stroke(yore.StrokePath.material([[0.2, 0.8], [0.8, 0.8]]))
    sim.advance(seconds)
    V, F = sim.cloth.positions, sim.cloth.faces
    region = np.asarray(report.region_faces)
    height = metrics.wrinkle_height(V, F)[np.unique(F[region])]
    return {
        "model": model,
        "resolution": resolution,
        "faces_split": len(report.new_vertices),
        "wrinkle_measure": metrics.wrinkle_measure(V, F, region),
        "fold_depth": float(height.max() - height.min()),
        "area_growth": float(report.rest_area_after / report.rest_area_before),
        "cpu_seconds": time.process_time() - start,
    }


def mean_edge(points, F):
    """The mesh's mean edge length (each edge once), in the units of `points`."""
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0
    )
    return float(np.linalg.norm(points[edges[:, 1]] - points[edges[:, 0]], axis=1).mean())


def band_scene(mesh, resolution, bending):
    """The band strokes' hanging cloth: the membrane of the 41² grid lattice's affine Y and ν,
    fitted (quadratic) bending `bending`, on `mesh` at `resolution`."""
    V, F = yore.grid_mesh(41, 41)
    young, nu = lattice_moduli(V, F, yore.scenes.STIFFNESS)
    return yore.scenes.hanging_cloth(
        resolution=resolution,
        mesh=mesh,
        stretch="membrane",
        young_modulus=young,
        poisson_ratio=nu,
        bending="quadratic",
        bending_modulus=bending,
        integrator="implicit",
    )


def sample_grid(sample=BAND_SAMPLE):
    """The material points (u, v) of the unit square every `sample` m, n×n×2 ([iu, iv])."""
    s = np.linspace(0.0, 1.0, int(round(1.0 / sample)) + 1)
    return np.stack(np.meshgrid(s, s, indexing="ij"), axis=-1)


def resample(uv, F, points, *fields):
    """Each piecewise-linear field of `fields` (per vertex, n×k) of the mesh (uv, F) in
    material coordinates at `points` (…×2), NaN outside the mesh: a list, one per field."""
    import matplotlib.tri as mtri

    flat = points.reshape(-1, 2)
    face = mtri.Triangulation(uv[:, 0], uv[:, 1], F).get_trifinder()(flat[:, 0], flat[:, 1])
    inside = face >= 0
    corners = np.asarray(F)[face[inside]]
    a, b, c = uv[corners[:, 0]], uv[corners[:, 1]], uv[corners[:, 2]]
    e1, e2, p = b - a, c - a, flat[inside] - a
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    w1 = (p[:, 0] * e2[:, 1] - p[:, 1] * e2[:, 0]) / det
    w2 = (e1[:, 0] * p[:, 1] - e1[:, 1] * p[:, 0]) / det
    out = []
    for values in fields:
        values = np.asarray(values, dtype=float)
        at = np.full((len(flat), values.shape[1]), np.nan)
        at[inside] = (
            (1 - w1 - w2)[:, None] * values[corners[:, 0]]
            + w1[:, None] * values[corners[:, 1]]
            + w2[:, None] * values[corners[:, 2]]
        )
        out.append(at.reshape(*points.shape[:-1], values.shape[1]))
    return out


def bilinear(field, uv):
    """The field given on `sample_grid` (m×m×k) at material points uv (n×2, clipped to the
    square)."""
    m = field.shape[0]
    x = np.clip(uv, 0.0, 1.0) * (m - 1)
    i = np.minimum(np.floor(x).astype(int), m - 2)
    a, b = (x - i)[:, :1], (x - i)[:, 1:]
    i0, i1 = i[:, 0], i[:, 1]
    return (
        field[i0, i1] * (1 - a) * (1 - b)
        + field[i0 + 1, i1] * a * (1 - b)
        + field[i0, i1 + 1] * (1 - a) * b
        + field[i0 + 1, i1 + 1] * a * b
    )


def gaussian_smooth(grid, sigma):
    """A Gaussian filter of standard deviation `sigma` (grid cells) over the first two axes of
    `grid` (m×m×k), the edges reflected."""
    pad = int(math.ceil(4 * sigma))
    g = np.pad(grid, ((pad, pad), (pad, pad), (0, 0)), mode="reflect")
    ku = np.fft.fftfreq(g.shape[0])[:, None]
    kv = np.fft.fftfreq(g.shape[1])[None, :]
    kernel = np.exp(-2.0 * (np.pi * sigma) ** 2 * (ku**2 + kv**2))
    out = np.real(np.fft.ifft2(np.fft.fft2(g, axes=(0, 1)) * kernel[:, :, None], axes=(0, 1)))
    return out[pad:-pad, pad:-pad]


def band_start_path(out, bending, quick):
    suffix = "" if bending == BAND_BENDING else f"-B{bending:g}"
    return Path(out) / "wrinkles-runs" / f"band-start{suffix}{'-quick' if quick else ''}.npz"


def band_start(out, bending, quick, resume):
    """The band strokes' common starting shape: the hanging cloth on the BAND_START mesh,
    settled, its positions sampled on `sample_grid` (float32, m) and kept (atomically) in the
    journal; reused when resuming or collecting."""
    path = band_start_path(out, bending, quick)
    if resume and path.exists():
        with np.load(path) as data:
            return data["positions"].astype(float)
    start = QUICK_BAND_START if quick else BAND_START
    sim = band_scene(start["mesh"], start["resolution"], bending)
    settled = sim.settle(max_seconds=2.0 if quick else BAND_SETTLE_SECONDS)
    uv = np.asarray(sim.cloth.material_coordinates)
    (field,) = resample(uv, sim.cloth.faces, sample_grid(), sim.cloth.positions)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(path.stem + ".tmp.npz")
    np.savez_compressed(
        temporary,
        positions=field.astype(np.float32),
        settled_seconds=settled["seconds"],
        converged=settled["converged"],
    )
    os.replace(temporary, path)
    return field.astype(np.float32).astype(float)


def refine_passes(uv, F, edge):
    """1→4 passes that bring the mesh's mean material edge to at most `edge` (each halves it)."""
    return max(0, math.ceil(math.log2(mean_edge(uv, F) / edge)))


def band_measures(uv, F, settled, normals, X):
    """The band's fold and wrinkles on `sample_grid` in material coordinates (the same points
    on every mesh, refined or not): the stroke's displacement along the settled normals (its
    range and RMS about its mean over the band), the wrinkle height (the surface minus its
    Gaussian smoothing of σ = BAND_REACH / 3 in material coordinates, along the smoothed
    normal; its RMS over the band) and the wavelength of that height along the band's centre
    line (from its sign changes), m."""
    points = sample_grid()
    Xs, Ss, Ns = resample(uv, F, points, X, settled, normals)
    if np.isnan(Xs).any():  # the FFT smoothing would spread it everywhere
        raise ValueError("some material sample points lie outside the mesh's pattern")
    Ns /= np.linalg.norm(Ns, axis=-1, keepdims=True)
    moved = np.einsum("ijk,ijk->ij", Xs - Ss, Ns)
    smooth = gaussian_smooth(Xs, BAND_REACH / 3.0 / BAND_SAMPLE)
    normal = np.cross(np.gradient(smooth, axis=0), np.gradient(smooth, axis=1))
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    height = np.einsum("ijk,ijk->ij", Xs - smooth, normal)
    u, v = points[..., 0], points[..., 1]
    u0, u1 = BAND["u"]
    band = (np.abs(v - BAND["v"]) < 0.5 * BAND["width"]) & (u > u0) & (u < u1)
    along = points[:, 0, 0]
    line = height[(along > u0) & (along < u1), int(round(BAND["v"] / BAND_SAMPLE))]
    crossings = int(np.count_nonzero(np.diff(np.sign(line - line.mean()))))
    return {
        "fold_depth": float(np.ptp(moved[band])),
        "fold_rms": float(np.std(moved[band])),
        "wrinkle_measure": float(np.sqrt(np.mean(height[band] ** 2))),
        "wrinkle_wavelength": float(2.0 * (u1 - u0) / max(crossings, 1)),
    }


def band_run(mesh, resolution, quick, bending, seed, start):
    """One band stroke (BAND_PROTOCOL): `band_scene` on `mesh` at `resolution`, its positions
    set from the common `start` (`band_start`) and settled; the zone BAND_REFINE_WIDTH wide
    about the band refined to edges of at most BAND_EDGE (a stroke that grows nothing) and
    settled; stroked along BAND in material coordinates; displaced by NOISE
    (seeded by `seed`) and settled again. `band_measures` over the material band, and (for
    comparison with earlier rows) the fold depth and RMS over the band faces' corners and the
    mesh's own wrinkle measure (Taubin smoothing, `metrics.smoothing_iterations`: its reach
    in edges shrinks where the band is refined, so it is not comparable across meshes here);
    the rest area the stroke added (m²) and the band faces' area gain."""
    started = time.process_time()
    sim = band_scene(mesh, resolution, bending)
    uv0 = np.asarray(sim.cloth.material_coordinates)
    sim.cloth.positions = bilinear(start, uv0)
    seconds = 2.0 if quick else BAND_SETTLE_SECONDS
    before = sim.settle(max_seconds=seconds)
    u0, u1 = BAND["u"]
    F0 = np.asarray(sim.cloth.faces)
    passes = refine_passes(uv0, F0, QUICK_BAND_EDGE if quick else BAND_EDGE)
    path = yore.StrokePath.material([[u0, BAND["v"]], [u1, BAND["v"]]])
    # the zone refined first by a stroke that grows nothing (expansion 1), settled again (its
    # new vertices sat on chords), then the band grown
    refined = sim.stroke(
        path, width=BAND_REFINE_WIDTH, growth=BAND["growth"], expansion=1.0, refine=passes
    )
    if passes:
        sim.settle(max_seconds=seconds)
    report = sim.stroke(
        path, width=BAND["width"], growth=BAND["growth"], expansion=BAND["expansion"]
    )
    settled = np.array(sim.cloth.positions)
    F = np.asarray(sim.cloth.faces)
    normals = metrics.vertex_normals(settled, F)
    rng = np.random.default_rng(seed)
    sim.cloth.positions = settled + NOISE * rng.standard_normal(settled.shape)
    after = sim.settle(max_seconds=seconds)
    X = np.asarray(sim.cloth.positions)
    uv = np.asarray(sim.cloth.material_coordinates)
    centre = uv[F].mean(axis=1)
    band = np.flatnonzero(
        (np.abs(centre[:, 1] - BAND["v"]) < 0.5 * BAND["width"])
        & (centre[:, 0] > u0)
        & (centre[:, 0] < u1)
    )
    corners = np.unique(F[band])
    moved = np.einsum("ij,ij->i", X - settled, normals)[corners]
    height = metrics.wrinkle_height(X, F, metrics.smoothing_iterations(X, F, BAND_REACH))
    return {
        "mesh": mesh,
        "resolution": resolution,
        "bending_modulus": bending,
        "seed": seed,
        "protocol": BAND_PROTOCOL,
        "vertices": int(sim.cloth.vertex_count),
        "membrane_strain": sim.cloth.membrane_strain,
        "pattern_interior": INTERIORS.get(mesh),
        "band_weights": BAND_WEIGHTS,
        "refine": passes,
        "faces_refined": int(refined.faces_refined),
        "refine_width": BAND_REFINE_WIDTH,
        "band_faces": int(len(band)),
        "mean_edge": mean_edge(uv0, F0),
        "band_edge": mean_edge(uv, F[band]),
        **band_measures(uv, F, settled, normals, X),
        "corner_fold_depth": float(np.ptp(moved)),
        "corner_fold_rms": float(np.std(moved)),
        "taubin_wrinkle_measure": float(np.sqrt(np.mean(height[corners] ** 2))),
        "rest_area_added": float(report.rest_area_after - report.rest_area_before),
        "area_gain": float(report.rest_area_after / report.rest_area_before),
        "settled_before": bool(before["converged"]),
        "settled_after": bool(after["converged"]),
        "cpu_seconds": time.process_time() - started,
    }


def band_runs(quick):
    """(bending, mesh, resolution, seed) of the band strokes."""
    resolutions = QUICK_BAND_RESOLUTIONS if quick else BAND_RESOLUTIONS
    return [
        (bending, mesh, n, seed)
        for bending in BAND_BENDINGS
        for mesh in ("grid", "pattern")
        for n in resolutions
        for seed in (QUICK_BAND_SEEDS if quick else BAND_SEEDS)
    ]


def band_name(mesh, resolution, bending, seed):
    suffix = "" if bending == BAND_BENDING else f"-B{bending:g}"
    return f"band-{mesh}-{resolution}{suffix}-seed{seed}"


BAND_MEASURES = ("fold_depth", "fold_rms", "wrinkle_measure", "rest_area_added")


def band_groups(bands):
    """The band rows by (bending, mesh, resolution): their seeds."""
    groups = {}
    for b in bands:
        groups.setdefault((b["bending_modulus"], b["mesh"], b["resolution"]), []).append(b)
    return groups


def band_means(bands):
    """Per (bending, mesh, resolution): the seeds' mean and standard error of each of
    BAND_MEASURES (and the wavelength's mean)."""
    groups = band_groups(bands)
    out = []
    for (bending, mesh, n), mine in sorted(groups.items()):
        entry = {"bending_modulus": bending, "mesh": mesh, "resolution": n, "seeds": len(mine)}
        for key in (*BAND_MEASURES, "wrinkle_wavelength", "vertices", "cpu_seconds"):
            values = np.array([b[key] for b in mine], dtype=float)
            entry[key] = float(values.mean())
            entry[key + "_error"] = (
                float(values.std(ddof=1) / math.sqrt(len(values))) if len(values) > 1 else None
            )
        out.append(entry)
    return out


#: Two seeds' outcomes are the same state when their fold RMS are this close (relative). In
#: the committed rows the seeds of one state lie within 1.7 % of each other and most states
#: 8 % or more apart, but two on the 81² grid (6.71 and 6.88 mm) are only 2.5 % apart: that
#: split, and any state this rule chains together, is uncertain.
BAND_OUTCOME_GAP = 0.02


def band_outcomes(bands):
    """Per (bending, mesh, resolution), the distinct states its seeds settled into (seeds whose
    fold RMS lie within BAND_OUTCOME_GAP of the next, in order), each with its seeds and
    their mean measures, commonest first."""
    groups = band_groups(bands)
    out = []
    for (bending, mesh, n), mine in sorted(groups.items()):
        mine = sorted(mine, key=lambda b: b["fold_rms"])
        clusters = [[mine[0]]]
        for b in mine[1:]:
            if b["fold_rms"] - clusters[-1][-1]["fold_rms"] > BAND_OUTCOME_GAP * b["fold_rms"]:
                clusters.append([])
            clusters[-1].append(b)
        states = [
            {
                "seeds": sorted(b["seed"] for b in c),
                **{
                    key: float(np.mean([b[key] for b in c]))
                    for key in (*BAND_MEASURES, "wrinkle_wavelength")
                },
            }
            for c in clusters
        ]
        states.sort(key=lambda c: -len(c["seeds"]))
        out.append({"bending_modulus": bending, "mesh": mesh, "resolution": n, "states": states})
    return out


def band_summary(bands):
    """Per bending modulus and mesh kind, the change of each measure's seed mean between its
    two finest resolutions, and that change's standard error (issue 52's target: < 5 %
    between 81 and 161)."""
    out = {}
    means = band_means(bands)
    states = {
        (o["bending_modulus"], o["mesh"], o["resolution"]): o["states"]
        for o in band_outcomes(bands)
    }
    for bending in BAND_BENDINGS:
        for mesh in ("grid", "pattern"):
            mine = sorted(
                (m for m in means if m["mesh"] == mesh and m["bending_modulus"] == bending),
                key=lambda m: m["resolution"],
            )
            if len(mine) < 2:
                continue
            a, b = mine[-2], mine[-1]
            entry = {"resolutions": [a["resolution"], b["resolution"]], "seeds": b["seeds"]}
            for key in BAND_MEASURES:
                scale = max(abs(b[key]), 1e-300)
                entry[f"{key}_change"] = abs(b[key] - a[key]) / scale
                errors = [e for e in (a[key + "_error"], b[key + "_error"]) if e is not None]
                entry[f"{key}_change_error"] = (
                    math.sqrt(sum(e * e for e in errors)) / scale if errors else None
                )
            # the finer mesh's commonest state against the coarser's state nearest to it (in
            # fold RMS): the same buckled state, when both meshes found it
            finer = states[(bending, mesh, b["resolution"])]
            coarser = states[(bending, mesh, a["resolution"])]
            state = finer[0]
            match = min(coarser, key=lambda c: abs(c["fold_rms"] - state["fold_rms"]))
            entry["states"] = [len(coarser), len(finer)]
            entry["commonest_state_seeds"] = [len(match["seeds"]), len(state["seeds"])]
            for key in BAND_MEASURES:
                entry[f"{key}_state_change"] = abs(state[key] - match[key]) / max(
                    abs(state[key]), 1e-300
                )
            out[f"{mesh}, B = {bending:g}"] = entry
    return out


def finest_judged(rows, key):
    """Per value of `key`, the judged row on the finest mesh: an exponent is fitted over
    converged rows, whichever mesh resolves each (a small B's short wavelength needs a finer
    mesh than a large B's)."""
    best = {}
    for r in rows:
        if r.get("judged") and (r[key] not in best or r["mean_edge"] < best[r[key]]["mean_edge"]):
            best[r[key]] = r
    return list(best.values())


def fit_exponent(rows, key):
    """Slope of log λ against log `key` over the judged rows (resolved, not zigzags, B_art at
    most a tenth of B: issue 52), None with fewer than two values of `key`."""
    points = [(r[key], r["wavelength"]) for r in rows if r.get("judged")]
    if len(points) < 2 or len({p[0] for p in points}) < 2:
        return None
    x, y = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(x, y, 1)[0])


def summarize(rows, strokes, quick=False):
    out = {}
    for (model, mesh, strain), kind in KINDS.items():
        base_run = BASES[model] if not quick else QUICK_BASE
        mine = [
            r
            for r in rows
            if r["model"] == model
            and r.get("mesh", "pattern") == mesh
            and r.get("seed", 0) == 0
            and r.get("membrane_strain") == strain
        ]
        if not mine:
            continue
        base = [r for r in mine if r["label"] in ("base", "B", "L", "strain", "mesh")]
        at = {
            key: finest_judged(
                [
                    r
                    for r in base
                    if all(
                        r[k] == base_run[k]
                        for k in ("bending_modulus", "length", "strain")
                        if k != key
                    )
                ],
                key,
            )
            for key in ("bending_modulus", "length", "strain")
        }
        meshes = sorted(
            (
                r
                for r in base
                if r["length"] == base_run["length"]
                and r["strain"] == base_run["strain"]
                and r["bending_modulus"] == base_run["bending_modulus"]
            ),
            key=lambda r: -r["edge_length"],
        )
        finest = [r["wavelength"] for r in meshes[-2:]]
        seeds = [
            (r, o)
            for r in mine
            for o in rows
            if o.get("seed", 0) != 0
            and o["model"] == model
            and o.get("mesh", "pattern") == mesh
            and o.get("membrane_strain") == strain
            and all(o[k] == r[k] for k in ("bending_modulus", "length", "strain", "edge_length"))
        ]
        out[kind] = {
            "judged": sum(bool(r.get("judged")) for r in mine),
            "realized_bending_ratio": [
                r["realized_bending"] / r["bending_modulus"]
                for r in mine
                if r.get("realized_bending")
            ],
            "artificial_over_bending": [
                r["artificial_bending"] / r["bending_modulus"]
                for r in mine
                if r.get("artificial_bending") is not None
            ],
            "second_seed_wavelength_change": [
                abs(o["wavelength"] - r["wavelength"]) / r["wavelength"]
                for r, o in seeds
                if r["wavelength"] is not None and o["wavelength"] is not None
            ],
            "exponents": {key: fit_exponent(group, key) for key, group in at.items()},
            "expected": {"bending_modulus": 0.25, "length": 0.5, "strain": -0.25},
            "wrinkled": sum(r["wavelength"] is not None for r in mine),
            "zigzags": sum(r["zigzag"] for r in mine),
            "runs": len(mine),
            "ratio_to_prediction": [
                r["wavelength"] / r["predicted_wavelength"]
                for r in mine
                if r["wavelength"] is not None
            ],
            "finest_meshes_change": (
                abs(finest[1] - finest[0]) / finest[1]
                if len(finest) == 2 and None not in finest
                else None
            ),
            "min_wavelength_over_edge": min(
                (r["wavelength"] / r["mean_edge"] for r in mine if r["wavelength"] is not None),
                default=None,
            ),
        }
    threshold = {}
    for r in rows:
        if r["model"] != "springs":
            continue
        entry = threshold.setdefault(
            f"{r['edge_length']:g}",
            {"mean_edge": r["mean_edge"], "wrinkled_up_to": None, "flat_from": None},
        )
        if r["wavelength"] is not None:
            entry["wrinkled_up_to"] = max(entry["wrinkled_up_to"] or 0.0, r["bending_modulus"])
        else:
            entry["flat_from"] = min(entry["flat_from"] or math.inf, r["bending_modulus"])
    out["springs_threshold"] = threshold
    stroke_summary = {}
    for model in ("springs", "membrane"):
        mine = sorted((s for s in strokes if s["model"] == model), key=lambda s: s["resolution"])
        if len(mine) >= 2:
            a, b = mine[-2]["wrinkle_measure"], mine[-1]["wrinkle_measure"]
            c, d = mine[-2]["fold_depth"], mine[-1]["fold_depth"]
            stroke_summary[model] = {
                "wrinkle_measure_change": abs(b - a) / max(b, 1e-300),
                "fold_depth_change": abs(d - c) / max(d, 1e-300),
            }
    out["stroke"] = stroke_summary
    return out


def journal_path(out, name):
    return Path(out) / "wrinkles-runs" / f"{name}.json"


def journaled(out, name, resume, compute, still_good=lambda value: True, collect=False):
    """The journaled run `name` if resuming (or collecting) and it is still good, else
    compute() journaled atomically; with collect, None instead of computing."""
    path = journal_path(out, name)
    if (resume or collect) and path.exists():
        value = json.loads(path.read_text(encoding="utf-8"))
        if still_good(value):
            return value
    if collect:
        return None
    value = compute()
    write_journal(out, name, value)
    return value


def write_journal(out, name, value):
    """Journal one run atomically (a temporary file, then a rename)."""
    path = journal_path(out, name)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".tmp")
    temporary.write_text(json.dumps(value), encoding="utf-8")
    os.replace(temporary, path)


def run_name(model, parameters):
    def shown(value):
        return value if isinstance(value, str) else f"{value:g}"

    return model + "-" + "-".join(f"{k}={shown(parameters[k])}" for k in sorted(parameters))


def draw(rows, strokes, path, means=()):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(21, 4.4))
    colours = {"membrane": "tab:blue", "springs": "tab:red"}
    ax = axes[0]
    for r in rows:
        if r["label"] == "base" or (r["label"] == "B" and r["bending_modulus"] == B0):
            ax.plot(
                r["section"]["y"],
                1e3 * np.array(r["section"]["z"]),
                color=colours[r["model"]],
                alpha=0.8,
                label=f"{r['model']}, B = {r['bending_modulus']:g} N·m",
            )
    ax.set_xlabel("y across the width (m)")
    ax.set_ylabel("z at mid-length (mm)")
    ax.set_title("cross-sections of the relaxed sheet")
    ax.legend(fontsize=7)
    ax = axes[1]
    for r in rows:
        if r["wavelength"] is None:
            continue
        marker = "x" if r["zigzag"] else "o"
        ax.loglog(r["predicted_wavelength"], r["wavelength"], marker, color=colours[r["model"]])
    lims = [0.01, 0.3]
    ax.loglog(lims, lims, "k:", label="measured = Cerda & Mahadevan")
    ax.set_xlabel("predicted wavelength (m), the model's own Y")
    ax.set_ylabel("measured wavelength (m)")
    ax.set_title("wavelength (x: mesh-scale zigzag); red springs, blue membrane")
    ax.legend(fontsize=7)
    ax = axes[2]
    for model in ("springs", "membrane"):
        mine = sorted((s for s in strokes if s["model"] == model), key=lambda s: s["resolution"])
        if mine:
            ax.plot(
                [s["resolution"] for s in mine],
                [1e3 * s["fold_depth"] for s in mine],
                "o-",
                color=colours[model],
                label=f"{model}: fold depth",
            )
            ax.plot(
                [s["resolution"] for s in mine],
                [1e3 * s["wrinkle_measure"] for s in mine],
                "s--",
                color=colours[model],
                label=f"{model}: wrinkle measure",
            )
    ax.set_xlabel("vertices per side")
    ax.set_ylabel("mm")
    ax.set_title("the hanging-cloth stroke against the mesh")
    ax.legend(fontsize=7)
    ax = axes[3]
    styles = {"grid": ("tab:green", "o"), "pattern": ("tab:purple", "s")}
    for m_kind, (colour, marker) in styles.items():
        for key, line in (("fold_rms", "-"), ("wrinkle_measure", "--")):
            mine = sorted(
                (m for m in means if m["mesh"] == m_kind and m["bending_modulus"] == BAND_BENDING),
                key=lambda m: m["resolution"],
            )
            if mine:
                ax.errorbar(
                    [m["resolution"] for m in mine],
                    [1e3 * m[key] for m in mine],
                    yerr=[1e3 * (m[key + "_error"] or 0.0) for m in mine],
                    fmt=marker + line,
                    color=colour,
                    capsize=3,
                    label=f"{m_kind}: {key.replace('_', ' ')}",
                )
    ax.set_xscale("log")
    sides = sorted({m["resolution"] for m in means})
    ax.set_xticks(sides, [str(n) for n in sides])
    ax.minorticks_off()
    ax.set_xlabel("vertices per side (band refined to the same edge)")
    ax.set_ylabel("mm (seeds' mean ± standard error)")
    ax.set_title(f"the band stroke against the mesh, B = {BAND_BENDING:g} N·m")
    if means:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    def extra(parser):
        parser.add_argument(
            "--resume", action="store_true", help="skip the runs already journaled in --out"
        )
        parser.add_argument(
            "--collect",
            action="store_true",
            help="run nothing: write the results of the runs journaled so far "
            "(today's models only)",
        )
        parser.add_argument(
            "--band-bendings",
            nargs="+",
            type=float,
            default=list(BAND_BENDINGS),
            help="the band strokes' bending moduli to run (the others are collected)",
        )
        parser.add_argument(
            "--band-meshes",
            nargs="+",
            choices=("grid", "pattern"),
            default=["grid", "pattern"],
            help="the band strokes' mesh kinds to run (the others are collected)",
        )
        parser.add_argument(
            "--parts",
            nargs="+",
            choices=PARTS,
            default=list(PARTS),
            help="the parts to run (the others' journaled runs are collected): the stretched "
            "sheets, the paper's strokes, the band strokes",
        )

    args = common.arguments(__doc__, argv, extra=extra)
    yore.set_num_threads(1)
    parts = set(args.parts)
    rows = []
    for label, model, parameters in sheet_runs(args.quick):
        # a run journaled when flat meant under 10× the noise is redone if it was not flat
        # by today's measure (its wavelength was not kept)
        # (and a run journaled before the smoothed strain or the lattice pattern meshes is
        # redone: its membrane or mesh is not today's)
        row = journaled(
            args.out,
            run_name(model, parameters),
            args.resume,
            lambda: sheet_run(label, model, parameters),
            lambda r: (
                not (r["flat"] and r["amplitude"] >= FLAT)
                and current(
                    r, model, parameters["mesh"], parameters.get("membrane_strain", "faces")
                )
            ),
            args.collect or "sheets" not in parts,
        )
        if row is None:
            continue
        # judged by today's criteria (cheap once B_art is measured); journaled again when that
        # changed the row or it was journaled before the tension B_art
        before = (row.get("judged"), "flat_state_probe_bending" in row)
        if before != (judge(row)["judged"], True):
            write_journal(args.out, run_name(model, parameters), row)
        row["label"] = label
        rows.append(row)
        print(
            f"  {label:9s} {model:8s} {parameters['mesh']:7s} seed {parameters['seed']} "
            f"B={parameters['bending_modulus']:g} "
            f"L={parameters['length']:g} γ={parameters['strain']:g} "
            f"h={row['mean_edge']:.4f}: λ={row['wavelength']} "
            f"(predicted {row['predicted_wavelength']:.4f}), amplitude "
            f"{row['amplitude']:.2e}, flat state stable {row['flat_state_stable']}, "
            f"B realised {row['realized_bending']:.3g}, B_art {row['artificial_bending']}, "
            f"judged {row['judged']}, "
            f"{row['cpu_seconds']:.0f} s",
            flush=True,
        )
    strokes = []
    for model in ("springs", "membrane"):
        for resolution in QUICK_STROKE_RESOLUTIONS if args.quick else STROKE_RESOLUTIONS:
            s = journaled(
                args.out,
                f"stroke-{model}-{resolution}",
                args.resume,
                lambda: stroke_run(model, resolution, args.quick),
                collect=args.collect or "strokes" not in parts,
            )
            if s is None:
                continue
            strokes.append(s)
            print(
                f"  stroke {model} {resolution}: measure {s['wrinkle_measure']:.3e}, fold "
                f"depth {s['fold_depth']:.3e}",
                flush=True,
            )
    bands, starts = [], {}

    def start_of(bending):
        if bending not in starts:
            starts[bending] = band_start(args.out, bending, args.quick, resume=args.resume)
        return starts[bending]

    collect_bands = args.collect or "bands" not in parts
    for bending, mesh, resolution, seed in band_runs(args.quick):
        # a part of the bands (two processes may share them: --band-bendings, --band-meshes)
        # collects the others from the journal
        mine = bending in args.band_bendings and mesh in args.band_meshes
        # a band journaled by another protocol (before the common start, the refined band and
        # the seeds), or before the smoothed strain, the lattice or the Simpson weights, is
        # redone (its start, membrane, mesh or growth is not today's)
        b = journaled(
            args.out,
            band_name(mesh, resolution, bending, seed),
            args.resume,
            lambda: band_run(mesh, resolution, args.quick, bending, seed, start_of(bending)),
            lambda b: (
                current(b, "membrane", mesh)
                and b.get("band_weights") == BAND_WEIGHTS
                and b.get("protocol") == BAND_PROTOCOL
            ),
            collect_bands or not mine,
        )
        if b is None:
            continue
        bands.append(b)
        print(
            f"  band stroke {mesh} {resolution} B={bending:g} seed {seed}: fold depth "
            f"{b['fold_depth']:.3e}, RMS {b['fold_rms']:.3e}, measure "
            f"{b['wrinkle_measure']:.3e}, wrinkles of {b['wrinkle_wavelength']:.3f} m, "
            f"{b['refine']} passes to {b['band_edge']:.4f} m, rest area + "
            f"{b['rest_area_added']:.3e} m², {b['cpu_seconds']:.0f} s",
            flush=True,
        )
    payload = {
        "benchmark": "wrinkles",
        "machine": common.machine_info(),
        "quick": args.quick,
        "settings": {
            "noise": NOISE,
            "young": YOUNG,
            "poisson": POISSON,
            "bases": ({m: QUICK_BASE for m in BASES} if args.quick else BASES),
            "settle_seconds": SETTLE_SECONDS,
            "settle_tolerance": SETTLE_TOLERANCE,
        },
        "rows": rows,
        "strokes": strokes,
        "band_strokes": bands,
        "band_means": band_means(bands),
        "band_outcomes": band_outcomes(bands),
        "band_settings": {
            **BAND,
            "bending_moduli": list(BAND_BENDINGS),
            "reach": BAND_REACH,
            "weights": BAND_WEIGHTS,
            "protocol": BAND_PROTOCOL,
            "start": QUICK_BAND_START if args.quick else BAND_START,
            "sample": BAND_SAMPLE,
            "edge": QUICK_BAND_EDGE if args.quick else BAND_EDGE,
            "seeds": list(QUICK_BAND_SEEDS if args.quick else BAND_SEEDS),
            "noise": NOISE,
        },
        "summary": {**summarize(rows, strokes, args.quick), "band_strokes": band_summary(bands)},
    }
    common.save(
        args.out, "wrinkles", payload, lambda path: draw(rows, strokes, path, payload["band_means"])
    )
    print(json.dumps(payload["summary"], indent=1))


if __name__ == "__main__":
    main()
