"""Numerical damping of yore's integrators: a single linear mode against each scheme's analytic
amplification, and the energy a swinging sheet keeps against explicit (issue 39, item 4).

    python -m benchmarks.numerical_damping [--out bench-results] [--quick]

One thread (`yore.set_num_threads(1)`); writes numerical_damping.json and numerical_damping.png.

Part 1, one linear mode. A straight chain (`yore.Cloth.from_springs`) of N free masses m joined
by N + 1 springs of stiffness k, between two fixed ends, no damping, drag or gravity, displaced
along its axis in its lowest longitudinal mode u_j = A sin(π j / (N + 1)) from rest. Collinear
springs with positive lengths have exactly quadratic energies, so the motion is exactly linear:
the mode is a scalar oscillator of angular frequency ω = 2 √(k/m) sin(π / (2(N + 1))), and every
integrator's step is, on it, the one-step (amplification) matrix of that scheme for ẍ = −ω² x at
z = ωh. Each run is measured and compared with that matrix computed here, in numpy, from the
schemes' formulas (not from yore):
- explicit (symplectic Euler): v⁺ = v − hω² x, x⁺ = x + h v⁺;
- implicit (backward Euler) and tr-bdf2 (trapezoidal rule to tₙ + γh, γ = 2 − √2, then BDF2
  through yₙ, y_γ, yₙ₊₁) on y = (x, v): 2×2 matrices;
- bdf2 on y = (x, v), constant step: a two-step method, its characteristic polynomial
  (1 − 2μ/3) ζ² − (4/3) ζ + 1/3 with μ = ±iz, as the 4×4 companion matrix on (yₙ, yₙ₋₁);
- generalized-alpha (Chung & Hulbert 1993 in Arnold & Brüls' form, α_m = (2ρ∞ − 1)/(ρ∞ + 1),
  α_f = ρ∞/(ρ∞ + 1), γ = ½ − α_m + α_f, β = ¼(1 − α_m + α_f)²) on (x, v, a): 3×3.
The analytic decay per step is the modulus of the principal eigenvalue (the one that tends to
e^{iz} as z → 0, followed by continuation in z); the spectral radius (largest modulus, spurious
roots included) is recorded beside it.

The measured decay. A scheme's invariant (or decaying) quadratic form is not the physical energy:
the mode's energy ½ m (p² + ω² q²), p = q̇, swings within each period with the numerical phase
(symplectic Euler's by a factor (1 + z/2)/(1 − z/2) at z → 2), a period is not a whole number
of steps, and BDF2 and generalized-α carry spurious roots their first steps excite. So the decay
is not read from energy ratios. Instead the mode's projection (ω q_n, p_n) — q and p the
least-squares mode coordinates of positions and velocities, sampled after every step — is fitted
by a linear recurrence (the matrix-pencil method: block-Hankel matrices of MODE_LAGS lags,
rank-truncated SVD, the eigenvalues of the shift between them); the discrete motion is exactly
such a recurrence, so the fit is exact up to round-off, whatever the phase or spurious content.
The principal eigenvalue is the one carrying the largest amplitude in the sampled signal (the
start is the exact mode, so spurious roots carry only the startup error). Runs last
MODE_PERIODS periods (at least MODE_MIN_STEPS steps) and stop once the mode's energy falls below
MODE_FLOOR of its start (round-off, not Newton, then dominates the signal). Newton runs tight:
newton_tol 1e-12, truncation_fraction 0 (each step's system is linear, so Newton's first
iteration ends at round-off).
Explicit runs a chain of one free mass (ω = √(2k/m)): on an N-mass chain its highest mode,
≈ 2(N + 1)/π times faster than the lowest, would turn round-off into a blow-up long before the
lowest mode reaches z = 2 (the chain's limit is z < 2 tan(π/(2(N + 1))), 0.35 at N = 8); the one
mass shows the scheme on the whole of its stable range z < 2, where it does not dissipate.
Per row: integrator, ρ∞ (generalized-α), ωh, steps per period 2π/(ωh), measured and analytic
decay per step, their relative difference, the mode's energy kept after one period (decay^(2·2π/z))
measured and analytic, and the period elongation (z / arg λ − 1) measured and analytic.

Part 2, the swinging sheet's energy kept. The crossover's sheet (`hanging_cloth(resolution=N,
pin_spacing=1.0, mass=0.1, stretch_stiffness=k, bend_stiffness=k)`, bending equal), N ∈ {32, 64},
k = 2e5 N/m, let go from flat. Reference: explicit at half its limit, the limit bisected by the
crossover's stability search (`crossover.trial_limit`) and rounded down, as
`benchmarks.long_horizon` does, to a whole number of steps per 1/64 s (its `history` runs and
samples every run, every 1/64 s; a 1/32 s run every 1/32 s). Explicit at its limit is a row too:
how far a run that is not damped at all lands from the reference on a chaotic sheet (the
measures' floor). Each implicit family of `long_horizon.FAMILIES` the build accepts (yore's
defaults), and generalized-α at ρ∞ = 0.8 (SHEET_EXTRA_FAMILIES), runs at dt = 1/32, 1/64 and
1/128 s over 2.125 s, once per distinct set of resolved options (a family that resolves as an
earlier one does is listed in sheet_families_merged, not run again). Per run: the kinetic
energy kept at 1 s and at 2 s, each the run's mean kinetic energy over [t − 0.125, t + 0.125] s
over the reference's over the same sample times (a single instant sits on the swing's phase);
the kinetic-energy history's relative L2 over [0, 2] s and the centroid path (`long_horizon`'s
`run_measures`); CPU seconds of the stepping per simulated second (one run, thread clock). A
kept fraction above 1 is energy the integrator gained. A run whose CPU (spent, or extrapolated
from the steps done) passes MAX_RUN_SECONDS is aborted and its row says so. Unconverged steps
are counted per row (yore's warning about them is silenced here).

Cost: dominated by the 64² reference (explicit at half its limit over 2.125 s: a few CPU
minutes) and the implicit runs at 1/128 s; about half an hour in all on one thread. Part 1
takes seconds.

--quick: part 1 at ωh ∈ QUICK_OMEGA_H and ρ∞ ∈ QUICK_RHO_INFINITY; part 2 on one 10² sheet
(seconds).
"""

from __future__ import annotations

import json
import math
import time
import warnings

import numpy as np

import yore

from . import crossover as cx
from . import long_horizon as lh
from .common import arguments, machine_info, save

# -- part 1: the linear mode ---------------------------------------------------------------------
INTEGRATORS = ("explicit", "implicit", "bdf2", "tr-bdf2", "generalized-alpha")
RHO_INFINITY = (0.0, 0.5, 0.8, 0.9, 1.0)  # generalized-α's rows
OMEGA_H = tuple(float(z) for z in np.geomspace(0.05, 3.0, 12))  # 126 … 2.1 steps per period
QUICK_OMEGA_H = (0.05, 0.3, 1.0, 3.0)
QUICK_RHO_INFINITY = (0.0, 0.8, 1.0)
EXPLICIT_LIMIT = 2.0  # symplectic Euler is stable for ωh < 2
EXPLICIT_EXTRA = (1.9,)  # explicit's rows also run here, near its limit
CHAIN_FREE = 8  # free masses of the chain (explicit: 1, see the docstring)
CHAIN_MASS = 0.01  # kg per free mass
CHAIN_STIFFNESS = 100.0  # N/m per spring
CHAIN_SPACING = 0.1  # m, rest length of each spring
MODE_AMPLITUDE = 0.2  # × the spacing: the largest displacement of a mass
MODE_PERIODS = 4  # periods of the exact motion per run
MODE_MIN_STEPS = 24
MODE_FLOOR = 1e-12  # a run stops once the mode's energy is below this × its start
MODE_LAGS = 3  # block-Hankel lags of the fit (≥ 2 observed channels × 3 ≥ BDF2's 4 states)
MODE_RANK_TOLERANCE = 1e-9  # singular values below this × the largest are noise
TIGHT_NEWTON = {"newton_tol": 1e-12, "truncation_fraction": 0.0}
TR_BDF2_GAMMA = 2.0 - math.sqrt(2.0)

# -- part 2: the sheet -----------------------------------------------------------------------------
SIZES = (32, 64)
QUICK_SIZES = (10,)
STIFFNESS = 2e5  # N/m, bending springs as stiff ("equal")
RATES = (32, 64, 128)  # implicit steps per second
#: part 2's families beside long_horizon's: generalized-α at Chung & Hulbert's usual ρ∞ = 0.8
SHEET_EXTRA_FAMILIES = {
    "generalized-alpha rho 0.8": {"integrator": "generalized-alpha", "rho_infinity": 0.8}
}
TIMES = (1.0, 2.0)  # s: energy kept here ...
WINDOW = 0.125  # s: ... averaged over ± this
HISTORY_UNTIL = 2.0  # s: the kinetic-energy history's span
DURATION = max(TIMES) + WINDOW  # s, a multiple of 1/32 s (long_horizon's sampling needs it)
DAMPING_FLOOR = 1e-12  # the picture's 1 − |λ| axis starts here
MAX_RUN_SECONDS = 900.0  # CPU cap of one sheet run (extrapolated: long_horizon.history aborts it)
KEPT_CLIP = 1.5  # the picture's bars stop here (a run that gains energy is written in)


# -- the analytic amplification --------------------------------------------------------------------
def generalized_alpha_parameters(rho_infinity):
    """(α_m, α_f, γ, β) of generalized-α at ρ∞ (Chung & Hulbert 1993, Arnold & Brüls 2007)."""
    rho = float(rho_infinity)
    alpha_m = (2.0 * rho - 1.0) / (rho + 1.0)
    alpha_f = rho / (rho + 1.0)
    gamma = 0.5 - alpha_m + alpha_f
    return alpha_m, alpha_f, gamma, 0.25 * (1.0 - alpha_m + alpha_f) ** 2


def amplification(integrator, z, rho_infinity=None):
    """The one-step matrix of `integrator` on ẍ = −ω² x at z = ωh (in units h = 1, ω = z):
    2×2 on (x, v) for explicit, implicit and tr-bdf2; 3×3 on (x, v, a) for generalized-alpha;
    4×4 on (xₙ, vₙ, xₙ₋₁, vₙ₋₁) for bdf2."""
    z = float(z)
    identity = np.eye(2)
    rate = np.array([[0.0, 1.0], [-z * z, 0.0]])  # y' = J y, y = (x, v), h = 1
    if integrator == "explicit":
        return np.array([[1.0 - z * z, 1.0], [-z * z, 1.0]])
    if integrator == "implicit":
        return np.linalg.inv(identity - rate)
    if integrator == "tr-bdf2":
        g = TR_BDF2_GAMMA
        stage = np.linalg.solve(identity - 0.5 * g * rate, identity + 0.5 * g * rate)
        a, b = 1.0 / (g * (2.0 - g)), (1.0 - g) ** 2 / (g * (2.0 - g))
        return np.linalg.solve(identity - (1.0 - g) / (2.0 - g) * rate, a * stage - b * identity)
    if integrator == "bdf2":
        # yₙ₊₁ − 4/3 yₙ + 1/3 yₙ₋₁ = 2/3 h J yₙ₊₁
        solve = np.linalg.inv(identity - 2.0 / 3.0 * rate)
        return np.block([[4.0 / 3.0 * solve, -1.0 / 3.0 * solve], [identity, np.zeros((2, 2))]])
    if integrator == "generalized-alpha":
        alpha_m, alpha_f, gamma, beta = generalized_alpha_parameters(rho_infinity)
        w2 = z * z
        new = np.array(
            [[1.0, 0.0, -beta], [0.0, 1.0, -gamma], [(1.0 - alpha_f) * w2, 0.0, 1.0 - alpha_m]]
        )
        old = np.array(
            [[1.0, 1.0, 0.5 - beta], [0.0, 1.0, 1.0 - gamma], [-alpha_f * w2, 0.0, -alpha_m]]
        )
        return np.linalg.solve(new, old)
    raise ValueError(f"no amplification matrix for integrator {integrator!r}")


def principal_eigenvalue(integrator, z, rho_infinity=None, steps=400):
    """The principal eigenvalue (upper half plane) of `amplification` at z: the one that tends to
    e^{iz} as z → 0, followed by continuation along a geometric grid of z."""
    path = np.geomspace(min(1e-4, z), z, steps)
    current = np.exp(1j * path[0])
    for value in path:
        eigenvalues = np.linalg.eigvals(amplification(integrator, value, rho_infinity))
        current = eigenvalues[np.argmin(np.abs(eigenvalues - current))]
    return complex(current)


def analytic(integrator, z, rho_infinity=None):
    """The scheme's decay per step (|principal eigenvalue|), its spectral radius (all
    eigenvalues), the mode's energy kept over one exact period and the period elongation."""
    principal = principal_eigenvalue(integrator, z, rho_infinity)
    radius = float(np.max(np.abs(np.linalg.eigvals(amplification(integrator, z, rho_infinity)))))
    decay = abs(principal)
    return {
        "decay_per_step": decay,
        "spectral_radius": radius,
        "energy_kept_per_period": decay ** (2.0 * 2.0 * math.pi / z),
        "period_elongation": z / abs(math.atan2(principal.imag, principal.real)) - 1.0,
    }


def backward_euler_decay(z):
    """The closed form of backward Euler's decay per step: 1/√(1 + z²)."""
    return 1.0 / math.sqrt(1.0 + z * z)


# -- the measured mode -----------------------------------------------------------------------------
def chain(free, mass=CHAIN_MASS, stiffness=CHAIN_STIFFNESS, spacing=CHAIN_SPACING):
    """(cloth, rest positions ((free + 2)×3, m), mode shape (free,), ω rad/s): a straight chain
    along x of `free` masses between two fixed ends, no damping or drag, and its lowest
    longitudinal mode."""
    rest = np.zeros((free + 2, 3))
    rest[:, 0] = spacing * np.arange(free + 2)
    edges = np.array([[i, i + 1] for i in range(free + 1)])
    cloth = yore.Cloth.from_springs(rest, edges, masses=mass, stiffness=stiffness, damping=0.0)
    cloth.fix([0, free + 1])
    shape = np.sin(math.pi * np.arange(1, free + 1) / (free + 1))
    omega = 2.0 * math.sqrt(stiffness / mass) * math.sin(math.pi / (2 * (free + 1)))
    return cloth, rest, shape, omega


def mode_history(integrator, z, free=CHAIN_FREE, periods=MODE_PERIODS, **options):
    """Runs the chain from its lowest mode at dt = z/ω: the mode coordinates (q, p) (m, m/s)
    after every step from the first on, until MODE_FLOOR or `periods` periods (at least
    MODE_MIN_STEPS steps), the steps taken, their Newton iterations and ω. The state before the
    first step is left out: BDF2, generalized-α and TR-BDF2 start with a backward-Euler step,
    and the scheme's own recurrence holds from the state after it."""
    cloth, rest, shape, omega = chain(free)
    positions = rest.copy()
    positions[1:-1, 0] += MODE_AMPLITUDE * CHAIN_SPACING * shape
    cloth.positions = positions
    sim = yore.Simulation(
        cloth, integrator=integrator, dt=z / omega, gravity=(0.0, 0.0, 0.0), **options
    )
    steps = max(MODE_MIN_STEPS, math.ceil(periods * 2.0 * math.pi / z))
    norm = float(shape @ shape)
    q, p = [], []
    for n in range(steps + 1):
        if n:
            sim.step(1, progress=False)
        q.append(float((np.asarray(cloth.positions)[1:-1, 0] - rest[1:-1, 0]) @ shape) / norm)
        p.append(float(np.asarray(cloth.velocities)[1:-1, 0] @ shape) / norm)
        if (omega * q[-1]) ** 2 + p[-1] ** 2 < MODE_FLOOR * (omega * q[0]) ** 2:
            break
    counters = sim.stats["counters"]
    return {
        "q": np.array(q[1:]),
        "p": np.array(p[1:]),
        "omega": omega,
        "steps": len(q) - 1,
        "newton_iterations": int(counters.get("newton_iterations", 0)),
        "unconverged_steps": int(counters.get("unconverged_steps", 0)),
    }


def fit_recurrence(signal, lags=MODE_LAGS, tolerance=MODE_RANK_TOLERANCE):
    """The linear recurrence a sampled signal (channels × samples) follows, by the matrix-pencil
    method: its eigenvalues, each one's amplitude in the signal (the norm of its coefficient
    vector at sample 0) and the fit's relative residual."""
    signal = np.asarray(signal, float)
    channels, count = signal.shape
    columns = count - lags
    if columns < 2:
        raise ValueError(f"{count} samples cannot fit a recurrence of {lags} lags")
    hankel = np.vstack([signal[:, j : j + columns + 1] for j in range(lags)])
    before, after = hankel[:, :-1], hankel[:, 1:]
    u, s, vt = np.linalg.svd(before, full_matrices=False)
    rank = int(np.sum(s > tolerance * s[0]))
    shift = u[:, :rank].T @ after @ vt[:rank].T / s[:rank]
    eigenvalues = np.linalg.eigvals(shift)
    powers = eigenvalues[None, :] ** np.arange(count)[:, None]  # samples × modes
    coefficients, *_ = np.linalg.lstsq(powers, signal.T.astype(complex), rcond=None)
    residual = np.linalg.norm(powers @ coefficients - signal.T) / np.linalg.norm(signal)
    return eigenvalues, np.linalg.norm(coefficients, axis=1), float(residual)


def measured_decay(history):
    """The principal eigenvalue of a run (`mode_history`): the fitted root in the upper half
    plane carrying the largest amplitude of (ω q, p); its modulus, the period elongation, the
    fit's residual and rank."""
    signal = np.vstack([history["omega"] * history["q"], history["p"]])
    eigenvalues, amplitudes, residual = fit_recurrence(signal)
    upper = [i for i, e in enumerate(eigenvalues) if e.imag >= 0.0]
    principal = eigenvalues[max(upper, key=lambda i: amplitudes[i])]
    return {
        "decay_per_step": float(abs(principal)),
        "argument": float(abs(math.atan2(principal.imag, principal.real))),
        "fit_residual": residual,
        "fit_rank": len(eigenvalues),
        "samples": len(history["q"]),
    }


def mode_row(integrator, z, rho_infinity=None):
    """One row of part 1: the run at z measured against the analytic matrix."""
    options = {} if integrator == "explicit" else dict(TIGHT_NEWTON)
    if rho_infinity is not None:
        options["rho_infinity"] = rho_infinity
    free = 1 if integrator == "explicit" else CHAIN_FREE
    history = mode_history(integrator, z, free=free, **options)
    found = measured_decay(history)
    exact = analytic(integrator, z, rho_infinity)
    decay = found["decay_per_step"]
    per_period = 2.0 * math.pi / z
    return {
        "integrator": integrator,
        "rho_infinity": rho_infinity,
        "omega_h": z,
        "steps_per_period": per_period,
        "free_masses": free,
        "omega": history["omega"],
        "dt": z / history["omega"],
        "steps": history["steps"],
        "decay_per_step": decay,
        "analytic_decay_per_step": exact["decay_per_step"],
        "relative_difference": decay / exact["decay_per_step"] - 1.0,
        "analytic_spectral_radius": exact["spectral_radius"],
        "energy_kept_per_period": decay ** (2.0 * per_period),
        "analytic_energy_kept_per_period": exact["energy_kept_per_period"],
        "period_elongation": z / found["argument"] - 1.0,
        "analytic_period_elongation": exact["period_elongation"],
        "fit_residual": found["fit_residual"],
        "fit_rank": found["fit_rank"],
        "newton_iterations": history["newton_iterations"],
        "unconverged_steps": history["unconverged_steps"],
    }


def accepted(integrator, **options):
    """Why this build refuses an integrator (the first line of yore's error), or None."""
    cloth = chain(1)[0]
    try:
        yore.Simulation(cloth, integrator=integrator, dt=1e-3, gravity=(0.0, 0.0, 0.0), **options)
    except (ValueError, TypeError, NotImplementedError) as error:
        return str(error).splitlines()[0]
    return None


def mode_rows(omega_h, rho_values, log=print):
    """Part 1: rows for every integrator this build has, and the ones left out with why."""
    rows, missing = [], {}
    for integrator in INTEGRATORS:
        why = accepted(integrator)
        if why is not None:
            missing[integrator] = why
            log(f"left out: {integrator}: {why}")
            continue
        variants = rho_values if integrator == "generalized-alpha" else (None,)
        for rho in variants:
            steps = omega_h
            if integrator == "explicit":
                steps = sorted(z for z in {*omega_h, *EXPLICIT_EXTRA} if z < EXPLICIT_LIMIT)
            for z in steps:
                row = mode_row(integrator, z, rho)
                rows.append(row)
                log(
                    f"{integrator:18s} {'' if rho is None else f'ρ∞={rho:g}':7s} ωh={z:.3g} "
                    f"decay {row['decay_per_step']:.9f} analytic "
                    f"{row['analytic_decay_per_step']:.9f} ({row['relative_difference']:+.1e})"
                )
    return rows, missing


# -- part 2: the sheet -----------------------------------------------------------------------------
def window_mean_ratio(table, ref_table, time, half_width=WINDOW):
    """Mean kinetic energy of a run over [time − half_width, time + half_width] over the
    reference's at the same sample times (tables as `long_horizon.history` writes them)."""
    points = table[:, 0].astype(int)
    times = points / lh.GRID_RATE
    inside = np.abs(times - time) <= half_width + 1e-12
    return float(table[inside, 1].mean() / ref_table[points[inside], 1].mean())


def sheet_measures(run, reference, scales):
    """Energy kept at TIMES (window means), and `long_horizon.run_measures` over
    [0, HISTORY_UNTIL] s."""
    positions, table = run["snapshots"]
    ref_positions, ref_table = reference["snapshots"]
    keep = table[:, 0] <= HISTORY_UNTIL * lh.GRID_RATE + 1e-9
    ref_keep = ref_table[:, 0] <= HISTORY_UNTIL * lh.GRID_RATE + 1e-9
    found = lh.run_measures(
        {"snapshots": [positions, table[keep]]},
        {"snapshots": [ref_positions, ref_table[ref_keep]]},
        scales,
        -1.0,
    )
    out = {f"kinetic_energy_kept_at_{t:g}s": window_mean_ratio(table, ref_table, t) for t in TIMES}
    out.update(
        {m: found[m] for m in ("kinetic_energy_history", "total_energy_history", "centroid_path")}
    )
    return out


def sheet_rows(size, families, cap_seconds=MAX_RUN_SECONDS, log=print):
    """Part 2 at one size: the reference's facts and a row per run (explicit at its limit and
    each implicit family at each of RATES)."""
    make = cx.sheet(size, STIFFNESS, "equal")
    probe = make()
    extent = np.ptp(np.asarray(probe.cloth.positions), axis=0)
    scales = {"sheet_size": float(extent.max()), "diagonal": float(np.linalg.norm(extent))}
    estimate = probe.stable_dt()
    limit, trials = cx.trial_limit(make, estimate)
    per_sample = math.ceil(1.0 / (lh.GRID_RATE * limit) - 1e-9)  # explicit's step ≤ the limit
    explicit = {"integrator": "explicit"}
    reference = lh.history(make, explicit, 2 * per_sample, 1, DURATION, -1.0)
    if "snapshots" not in reference:
        raise RuntimeError(f"{size}²: the reference (explicit at half its limit) diverged")
    info = {
        "size": size,
        "stretch_stiffness": STIFFNESS,
        "bending": "equal",
        "stable_dt_estimate": estimate,
        "trial_limit_dt": limit,
        "stability_trials": trials,
        "reference_dt": 1.0 / (2 * lh.GRID_RATE * per_sample),
        "reference_cpu_seconds": reference["cpu_seconds"],
        **scales,
    }
    log(
        f"{size}²: limit {limit:.3g} s, reference dt {info['reference_dt']:.3g} s "
        f"({reference['cpu_seconds']:.0f} CPU s)"
    )
    runs = [("explicit at its limit", explicit, per_sample, 1)]
    for family, options in families.items():
        for rate in RATES:
            runs.append(
                (family, options, max(1, rate // lh.GRID_RATE), max(1, lh.GRID_RATE // rate))
            )
    rows = []
    for family, options, per, stride in runs:
        result = lh.history(make, options, per, stride, DURATION, -1.0, cap_seconds)
        steps = per * (round(DURATION * lh.GRID_RATE) // stride)
        row = {
            "size": size,
            "stretch_stiffness": STIFFNESS,
            "family": family,
            "integrator": options["integrator"],
            "options": {k: v for k, v in options.items() if k != "integrator"},
            "dt": DURATION / steps,
            "steps": steps,
            "duration": DURATION,
            "diverged": bool(result.get("diverged")),
            "aborted": result.get("aborted"),
        }
        if "snapshots" in result:
            counters = result["counters"]
            row.update(
                sheet_measures(result, reference, scales),
                cpu_seconds=result["cpu_seconds"],
                cost_seconds_per_simulated_second=result["cpu_seconds"] / DURATION,
                newton_iterations_per_step=counters.get("newton_iterations", 0.0) / steps,
                unconverged_steps=int(counters.get("unconverged_steps", 0)),
                kinetic_energy=result["snapshots"][1][:, 1].tolist(),
                sample_seconds=stride / lh.GRID_RATE,
            )
            log(
                f"  {family:28s} dt={row['dt']:.3g} kept "
                + ", ".join(
                    f"{row[f'kinetic_energy_kept_at_{t:g}s']:.3f} at {t:g} s" for t in TIMES
                )
                + f"; history {row['kinetic_energy_history']:.3f}; "
                f"{row['cost_seconds_per_simulated_second']:.3g} CPU s/s"
            )
        else:
            log(
                f"  {family:28s} dt={row['dt']:.3g} "
                + ("diverged" if row["diverged"] else f"aborted: {row['aborted']}")
            )
        rows.append(row)
    info["reference_kinetic_energy"] = reference["snapshots"][1][:, 1].tolist()
    return rows, info


def sheet_families():
    """Part 2's families: `long_horizon.FAMILIES` but explicit and the error-controlled ones
    (their dt is an output interval, not a step), then SHEET_EXTRA_FAMILIES, those this build
    accepts; a family whose integrator and resolved options equal an earlier one's
    is measured once, under the earlier name. Returns ({name: options}, {name: why refused},
    {merged name: the name it runs under})."""
    table = {
        **{
            n: o for n, o in lh.FAMILIES.items() if n != "explicit" and n not in lh.ERROR_CONTROLLED
        },
        **SHEET_EXTRA_FAMILIES,
    }
    refused = {n: lh.refusal(o) for n, o in table.items()}
    accepted_ = {n: o for n, o in table.items() if refused[n] is None}
    resolved = cx.resolved_families(accepted_)
    families, merged, seen = {}, {}, {}
    for name, options in accepted_.items():
        identity = json.dumps([options["integrator"], resolved[name]], sort_keys=True)
        if identity in seen:
            merged[name] = seen[identity]
        else:
            seen[identity] = name
            families[name] = options
    return families, {n: why for n, why in refused.items() if why is not None}, merged


# -- main ------------------------------------------------------------------------------------------
def summary_lines(mode, sheet):
    """The largest |relative difference| per integrator, and per size the energy kept at 2 s
    by each family at 1/32 s."""
    lines = []
    for integrator in dict.fromkeys(r["integrator"] for r in mode):
        worst = max(abs(r["relative_difference"]) for r in mode if r["integrator"] == integrator)
        lines.append(
            f"{integrator}: measured decay per step within {worst:.1e} of the "
            "analytic value at every ωh"
        )
    for size in dict.fromkeys(r["size"] for r in sheet):
        coarse = [
            r
            for r in sheet
            if r["size"] == size
            and math.isclose(r["dt"], 1 / 32)
            and "kinetic_energy_kept_at_2s" in r
        ]
        if coarse:
            lines.append(
                f"{size}², 1/32 s: kinetic energy kept at 2 s "
                + ", ".join(f"{r['family']} {r['kinetic_energy_kept_at_2s']:.2f}" for r in coarse)
            )
    return lines


def main(argv=None):
    args = arguments(__doc__, argv)
    yore.set_num_threads(1)
    started = time.perf_counter()
    rho_values = QUICK_RHO_INFINITY if args.quick else RHO_INFINITY
    mode, missing = mode_rows(QUICK_OMEGA_H if args.quick else OMEGA_H, rho_values)
    families, unavailable, merged = sheet_families()
    for name, why in unavailable.items():
        print(f"left out of the sheet: {name}: {why}")
    for name, kept in merged.items():
        print(f"{name} runs as {kept} does (the same resolved options): measured once")
    sheet, references = [], []
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", cx.UNCONVERGED_WARNING, RuntimeWarning)  # counted
        for size in QUICK_SIZES if args.quick else SIZES:
            rows, info = sheet_rows(size, families)
            sheet += rows
            references.append(info)
    payload = {
        "benchmark": "numerical_damping",
        "machine": machine_info(),
        "quick": args.quick,
        "integrators": [i for i in INTEGRATORS if i not in missing],
        "integrators_unavailable": [f"{n}: {why}" for n, why in missing.items()],
        "rho_infinity": list(rho_values),
        "chain": {
            "free_masses": CHAIN_FREE,
            "explicit_free_masses": 1,
            "mass": CHAIN_MASS,
            "stiffness": CHAIN_STIFFNESS,
            "spacing": CHAIN_SPACING,
            "amplitude": MODE_AMPLITUDE * CHAIN_SPACING,
            "periods": MODE_PERIODS,
            "energy_floor": MODE_FLOOR,
            "lags": MODE_LAGS,
            "newton": TIGHT_NEWTON,
        },
        "rows": mode,
        "sheet_families": list(families),
        "sheet_families_unavailable": [f"{n}: {why}" for n, why in unavailable.items()],
        "sheet_families_merged": merged,
        "sheet_family_options": families,
        "sheet_settings": {
            "stretch_stiffness": STIFFNESS,
            "bending": "equal",
            "rates": list(RATES),
            "times": list(TIMES),
            "window": WINDOW,
            "history_until": HISTORY_UNTIL,
            "duration": DURATION,
            "sample_rate": lh.GRID_RATE,
            "clock": "time.thread_time() around the stepping; one thread",
        },
        "sheet_references": references,
        "sheet_rows": sheet,
        "summary": {"lines": summary_lines(mode, sheet)},
        "wall_seconds": time.perf_counter() - started,
    }
    save(args.out, "numerical_damping", payload, lambda path: plot(payload, path))
    for line in payload["summary"]["lines"]:
        print(line)
    return payload


# -- the picture -----------------------------------------------------------------------------------
def label(integrator, rho):
    return integrator if rho is None else f"{integrator} ρ∞={rho:g}"


def plot(payload, path):
    """Left: decay per step against ωh (markers measured, lines analytic), per integrator.
    Right, one axis per size: the kinetic energy kept at 1 s and 2 s per family and step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = list(dict.fromkeys(r["size"] for r in payload["sheet_rows"]))
    fig = plt.figure(figsize=(13, 10), layout="constrained")
    grid = fig.add_gridspec(2, max(2, len(sizes)))
    linear, logarithmic = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])
    axes = [None] + [fig.add_subplot(grid[1, k]) for k in range(len(sizes))]
    curves = list(dict.fromkeys((r["integrator"], r["rho_infinity"]) for r in payload["rows"]))
    colours = plt.cm.tab10(np.linspace(0, 1, 10))
    for k, (integrator, rho) in enumerate(curves):
        mine = [
            r for r in payload["rows"] if (r["integrator"], r["rho_infinity"]) == (integrator, rho)
        ]
        top = 0.999 * EXPLICIT_LIMIT if integrator == "explicit" else max(OMEGA_H)
        fine = np.geomspace(min(OMEGA_H) * 0.8, top, 80)
        exact = np.array([analytic(integrator, z, rho)["decay_per_step"] for z in fine])
        zs = np.array([r["omega_h"] for r in mine])
        measured = np.array([r["decay_per_step"] for r in mine])
        colour = colours[k % 10]
        linear.plot(fine, exact, color=colour, lw=1.0, label=label(integrator, rho))
        linear.plot(zs, measured, "o", color=colour, ms=4, mfc="none")
        # 1 − |λ| on a log scale: a non-dissipative scheme sits at the floor
        logarithmic.plot(
            fine,
            np.maximum(1.0 - exact, DAMPING_FLOOR),
            color=colour,
            lw=1.0,
            label=label(integrator, rho),
        )
        logarithmic.plot(
            zs, np.maximum(1.0 - measured, DAMPING_FLOOR), "o", color=colour, ms=4, mfc="none"
        )
    for ax in (linear, logarithmic):
        ax.set_xscale("log")
        ax.set_xlabel("ωh (2π / steps per period)")
    logarithmic.set_yscale("log")
    logarithmic.set_ylim(DAMPING_FLOOR / 3, 1.0)
    linear.set_ylabel("amplitude decay per step |λ|")
    logarithmic.set_ylabel(f"1 − |λ| (at {DAMPING_FLOOR:g}: none)")
    linear.set_title("one linear mode: measured (o) against analytic (lines)", fontsize=9)
    logarithmic.set_title("the same, as the amplitude lost per step", fontsize=9)
    linear.legend(fontsize=6)
    for ax, size in zip(axes[1:], sizes):
        rows = [
            r
            for r in payload["sheet_rows"]
            if r["size"] == size and "kinetic_energy_kept_at_1s" in r
        ]
        names = list(dict.fromkeys(r["family"] for r in rows))
        dts = sorted(
            {r["dt"] for r in rows if r["family"] != "explicit at its limit"}, reverse=True
        )
        width = 0.8 / max(1, 2 * len(names))
        for k, name in enumerate(names):
            for r in (r for r in rows if r["family"] == name):
                group = dts.index(r["dt"]) if r["dt"] in dts else -1
                for j, t in enumerate(TIMES):
                    x = group + (2 * k + j - (2 * len(names) - 1) / 2) * width
                    value = r[f"kinetic_energy_kept_at_{t:g}s"]
                    ax.bar(
                        x,
                        min(value, KEPT_CLIP),
                        width,
                        color=colours[k % 10],
                        alpha=0.45 if j == 0 else 1.0,
                        label=name if j == 1 and group in (-1, 0) else None,
                    )
                    if value > KEPT_CLIP:  # energy gained: the bar is cut, the value written
                        ax.text(
                            x,
                            KEPT_CLIP,
                            f"{value:.2g}",
                            rotation=90,
                            ha="center",
                            va="top",
                            fontsize=5,
                            color="w",
                        )
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_ylim(0.0, KEPT_CLIP)
        ax.set_xticks(
            range(-1, len(dts)), ["explicit\nat limit"] + [f"1/{round(1 / dt)} s" for dt in dts]
        )
        ax.set_ylabel(
            f"kinetic energy kept / reference's (pale: at {TIMES[0]:g} s, solid: at "
            f"{TIMES[1]:g} s; cut at {KEPT_CLIP:g})"
        )
        ax.set_title(f"{size}² sheet, k = {STIFFNESS:g} N/m, bending equal", fontsize=9)
        ax.legend(fontsize=6)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    main()
