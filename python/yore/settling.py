"""Settling a cloth to a static equilibrium before an experiment (`yore.Simulation.settle`):
proximal-point descent by backward-Euler steps from rest, with a stability test that tells a
minimum from a saddle and pushes the cloth off saddles.

Each step of `SETTLE_DT` starts from rest and its velocities are zeroed after it, so it
minimises the potential plus ½‖x − xₖ‖²_M / h² and the sequence descends to a local minimum of
the potential (gravity, springs, bending) whatever the stiffness. Each step is solved by Newton
(Levenberg–Marquardt shifted, tight tolerance) in an integrator of its own. A small residual
alone cannot tell a minimum from a saddle, so a state that meets the tolerance is accepted
only if the true Hessian of the potential plus M/h² is positive definite (a Cholesky
factorization succeeds); otherwise the free vertices are moved by random displacements of
`SETTLE_PERTURBATION` mean rest lengths (RMS, a fixed seed) and the relaxation goes on."""

from __future__ import annotations

import math
import time as _time

import numpy as np

from . import _core
from ._core import Cloth
from .checks import MAX_SETTLE_SECONDS
from . import progress as progress_bars
from .rules import flag, is_real, show as show_value

__all__ = [
    "SETTLE_DT",
    "SETTLE_PERTURBATION",
    "SETTLE_MAX_ESCAPES",
    "settle",
    "is_saddle",
    "residual_acceleration",
]

#: Pseudo-time step of `Simulation.settle`'s backward-Euler relaxation, s.
SETTLE_DT = 0.5
#: A state `Simulation.settle` found to be a saddle is pushed off it by random displacements
#: of the free vertices of this RMS, in mean structural rest lengths, before it settles on.
SETTLE_PERTURBATION = 1e-3
#: Most saddles one `Simulation.settle` call pushes off before it reports not converged.
SETTLE_MAX_ESCAPES = 20

_FLAG = flag()


def is_saddle(cloth, gravity) -> bool:
    """Whether the cloth's positions are not a stable rest: the true (unprojected) Hessian of
    the potential plus the relaxation's M/h² (h = SETTLE_DT) is not positive definite. At a
    stable minimum the Hessian is positive semidefinite, so the sum is definite; on a saddle
    (a flat stretched sheet before it wrinkles) it is not, whatever the residual says."""
    probe = _core.ImplicitIntegrator(method="backward-euler")
    try:
        probe.newton_system(
            cloth, np.asarray(gravity, dtype=float), SETTLE_DT, cloth.positions, projection="exact"
        )
    except _core.NotPositiveDefinite:
        return True
    return False


def residual_acceleration(cloth, gravity) -> float:
    """Mass-weighted RMS of M⁻¹ f at the cloth's positions and zero velocity, m/s²: one
    symplectic-Euler step of a copy from rest gives v = dt M⁻¹ f exactly (damping and drag
    vanish at v = 0), so nothing is recomputed by hand."""
    probe = Cloth.from_state(cloth.state())
    probe.velocities = np.zeros_like(probe.velocities)
    dt = 1e-9
    _core.ExplicitIntegrator().advance(probe, np.asarray(gravity, dtype=float), dt, 1)
    v, m = probe.velocities, probe.masses
    return math.sqrt(float(np.einsum("i,ij,ij->", m, v, v)) / float(m.sum())) / dt


def _checked_arguments(cloth, gravity, max_seconds, tolerance, check_stability):
    """(max_seconds, tolerance) as floats; ValueError naming what is wrong."""
    for name, value in (("max_seconds", max_seconds), ("tolerance", tolerance)):
        if not is_real(value):  # a number, not a string or None that float() would take
            raise ValueError(f"{name} must be a finite number, got {show_value(value)}")
    max_seconds, tolerance = float(max_seconds), float(tolerance)
    if not math.isfinite(max_seconds) or not 0.0 <= max_seconds <= MAX_SETTLE_SECONDS:
        raise ValueError(f"max_seconds must be in [0, {MAX_SETTLE_SECONDS:g}] s, got {max_seconds}")
    if not math.isfinite(tolerance) or tolerance <= 0.0:
        raise ValueError(f"tolerance must be finite and > 0, got {tolerance}")
    if cloth.driven_vertices.size:
        raise ValueError(
            "settle needs a cloth without driven vertices (a driven cloth "
            "keeps moving: it has no rest to settle to)"
        )
    if cloth.fixed_vertices.size == 0 and np.any(gravity != 0.0):
        raise ValueError(
            "settle needs a fixed vertex: a free cloth falls under gravity "
            "forever and has no rest to settle to"
        )
    if not _FLAG.test(check_stability)[0]:
        raise ValueError(
            f"check_stability must be {_FLAG.expected}, got {show_value(check_stability)}"
        )
    return max_seconds, tolerance


def _push_off_saddle(cloth, free, escape):
    """Moves the free vertices by random displacements of SETTLE_PERTURBATION mean structural
    rest lengths (RMS), seeded by the escape's number."""
    rest = cloth.springs.rest[cloth.springs.kind == 0]
    scale = SETTLE_PERTURBATION * float(rest.mean())
    moved = np.array(cloth.positions)
    moved[free] += np.random.default_rng(escape).normal(0.0, scale / math.sqrt(3.0), (len(free), 3))
    cloth.positions = moved


class _Relaxation:
    """The state of one settle: pseudo-time steps taken, the last residual, saddles escaped."""

    def __init__(self, cloth, gravity):
        self.cloth, self.gravity = cloth, gravity
        self.integrator = _core.ImplicitIntegrator(
            method="backward-euler",
            projection="shifted",
            predictor="start",
            newton_tol=1e-7,
            max_newton=200,
        )
        self.free = np.setdiff1d(np.arange(cloth.vertex_count), cloth.fixed_vertices)
        self.converged, self.acceleration, self.done = False, math.inf, 0
        self.escapes, self.stable = 0, None

    def step(self, tolerance, check_stability) -> bool:
        """One pseudo-time step from rest; True when the relaxation is over."""
        cloth = self.cloth
        before = cloth.positions
        self.integrator.advance(cloth, self.gravity, SETTLE_DT, 1)
        cloth.velocities = np.zeros_like(before)
        self.acceleration = residual_acceleration(cloth, self.gravity)
        if self.acceleration > tolerance:
            return False
        self.stable = (not is_saddle(cloth, self.gravity)) if check_stability else None
        if self.stable is not False:
            self.converged = True
            return True
        if self.escapes == SETTLE_MAX_ESCAPES:
            return True
        self.escapes += 1
        _push_off_saddle(cloth, self.free, self.escapes)
        self.stable = None  # the moved state is not tested yet
        return False


def settle(cloth, gravity, max_seconds, tolerance, progress, check_stability) -> dict:
    """Settles ``cloth`` as `yore.Simulation.settle` documents and returns its figures; the
    cloth's clock is left where it was and its velocities zero."""
    max_seconds, tolerance = _checked_arguments(
        cloth, gravity, max_seconds, tolerance, check_stability
    )
    start_time = cloth.time
    steps = int(math.ceil(max_seconds / SETTLE_DT - 1e-9)) if max_seconds > 0 else 0
    relaxation = _Relaxation(cloth, gravity)
    bar, started = None, _time.perf_counter()
    cloth.velocities = np.zeros_like(cloth.velocities)
    try:
        for relaxation.done in range(1, steps + 1):
            if relaxation.step(tolerance, check_stability):
                break
            if (
                bar is None
                and progress is not False
                and (progress or _time.perf_counter() - started > progress_bars.AFTER_SECONDS / 2)
            ):
                bar = progress_bars.open_bar(steps, relaxation.done, "yore settle", progress)
            elif bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    cloth.velocities = np.zeros_like(cloth.velocities)
    cloth.time = start_time
    return {
        "seconds": relaxation.done * SETTLE_DT,
        "steps": relaxation.done,
        "converged": relaxation.converged,
        "residual_acceleration": float(relaxation.acceleration),
        "saddles_escaped": relaxation.escapes,
        "stable": relaxation.stable,
    }
