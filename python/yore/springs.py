"""Per-spring kernels of the mass-spring model (the same C++ functions every integrator uses).

A spring joining ``xi`` and ``xj`` with rest length ``L`` and stiffness ``k`` stores the energy
``½ k (|xi − xj| − L)²``. Every function here takes batches: ``xi`` and ``xj`` of shape (s, 3) or
(3,) in metres, ``rest_length`` and ``stiffness`` scalars or (s,) arrays; a (3,) input gives an
unbatched result.
"""

from __future__ import annotations

import numpy as np

from . import _core

__all__ = ["energy", "gradient", "hessian", "damping_force"]


def _batch(xi, xj, *per_spring):
    xi = np.asarray(xi, dtype=np.float64)
    xj = np.asarray(xj, dtype=np.float64)
    single = xi.ndim == 1 and xj.ndim == 1
    xi2, xj2 = np.atleast_2d(xi), np.atleast_2d(xj)
    if xi2.shape != xj2.shape:
        raise ValueError(f"xi and xj must have the same shape, got {xi.shape} and {xj.shape}")
    if not (np.all(np.isfinite(xi2)) and np.all(np.isfinite(xj2))):
        raise ValueError("xi and xj must be finite")
    count = xi2.shape[0]
    scalars = []
    for name, value in per_spring:
        value = np.asarray(value, dtype=np.float64)
        if value.ndim == 0:
            value = np.full(count, float(value))
        if value.shape != (count,):
            raise ValueError(f"{name} must be a scalar or have shape ({count},), got {value.shape}")
        scalars.append(value)
    return single, xi2, xj2, scalars


def energy(xi, xj, rest_length, stiffness):
    """Spring energy ``½ k (|xi − xj| − L)²``, joules; shape (s,) (or a float for one spring)."""
    single, a, b, (rest, k) = _batch(xi, xj, ("rest_length", rest_length), ("stiffness", stiffness))
    out = _core.spring_energy(a, b, rest, k)
    return float(out[0]) if single else out


def gradient(xi, xj, rest_length, stiffness):
    """Gradient of the energy with respect to xi, newtons, shape (s, 3) or (3,).

    The gradient with respect to xj is its negative; the elastic force on xi is minus it.
    """
    single, a, b, (rest, k) = _batch(xi, xj, ("rest_length", rest_length), ("stiffness", stiffness))
    out = _core.spring_gradient(a, b, rest, k)
    return out[0] if single else out


def hessian(xi, xj, rest_length, stiffness, project_psd=True):
    """3×3 block K = ∂²E/∂xi², N/m, shape (s, 3, 3) or (3, 3); the 6×6 Hessian is [K −K; −K K].

    With ``project_psd`` the transverse factor (1 − L/ℓ) is clamped at 0 so that K is positive
    semidefinite also for a compressed spring (what an implicit solver needs).
    """
    single, a, b, (rest, k) = _batch(xi, xj, ("rest_length", rest_length), ("stiffness", stiffness))
    out = _core.spring_hessian(a, b, rest, k, bool(project_psd))
    return out[0] if single else out


def damping_force(xi, xj, vi, vj, damping):
    """Damping force on xi, −c ((vi − vj)·d̂) d̂, newtons, shape (s, 3) or (3,)."""
    single, a, b, (c,) = _batch(xi, xj, ("damping", damping))
    va = np.atleast_2d(np.asarray(vi, dtype=np.float64))
    vb = np.atleast_2d(np.asarray(vj, dtype=np.float64))
    out = _core.spring_damping_force(a, b, va, vb, c)
    return out[0] if single else out
