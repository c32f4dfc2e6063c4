"""benchmarks/numerical_damping.py: the analytic amplification of each scheme, the fit that
measures a run's decay, yore's runs on a linear mode against the analytic value, and the quick
run's JSON.

No assertion depends on wall time.
"""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks import long_horizon as lh
from benchmarks import numerical_damping as nd
from benchmarks import schema

ROOT = Path(__file__).resolve().parent.parent
STEPS = np.geomspace(0.01, 30.0, 25)  # ωh


def radius(integrator, z, rho=None):
    return float(np.max(np.abs(np.linalg.eigvals(nd.amplification(integrator, z, rho)))))


# -- the analytic side -----------------------------------------------------------------------------
@pytest.mark.parametrize("z", STEPS)
def test_backward_euler_decays_by_its_closed_form(z):
    # backward Euler on y' = J y multiplies each mode by 1/(1 − iωh): |λ| = 1/√(1 + (ωh)²)
    closed = 1.0 / math.sqrt(1.0 + z * z)
    assert nd.backward_euler_decay(z) == pytest.approx(closed, rel=1e-15)
    assert radius("implicit", z) == pytest.approx(closed, rel=1e-12)
    assert abs(nd.principal_eigenvalue("implicit", z)) == pytest.approx(closed, rel=1e-12)
    assert nd.analytic("implicit", z)["decay_per_step"] == pytest.approx(closed, rel=1e-12)


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8, 0.9, 1.0])
def test_generalized_alpha_radius_tends_to_rho_infinity_and_to_one(rho):
    # Chung & Hulbert's design: the spectral radius at ωh → ∞ is ρ∞ (the error is O(1/√(ωh))
    # at ρ∞ = 0 and O(1/ωh) above: within 1e-4 at 1e8), and the low modes keep their energy
    assert radius("generalized-alpha", 1e8, rho) == pytest.approx(rho, abs=1e-4)
    assert radius("generalized-alpha", 1e-3, rho) == pytest.approx(1.0, abs=1e-9)
    assert abs(nd.principal_eigenvalue("generalized-alpha", 1e-3, rho)) == pytest.approx(
        1.0, abs=1e-9
    )
    # and it never amplifies (unconditionally stable on linear problems)
    assert all(radius("generalized-alpha", z, rho) <= 1.0 + 1e-12 for z in STEPS)


def test_generalized_alpha_at_rho_one_is_the_trapezoidal_rule():
    # ρ∞ = 1: α_m = α_f = ½, γ = ½, β = ¼ (Newmark's average acceleration), whose principal
    # root is the trapezoidal rule's (1 + iz/2)/(1 − iz/2), of modulus 1
    assert nd.generalized_alpha_parameters(1.0) == (0.5, 0.5, 0.5, 0.25)
    for z in STEPS:
        expected = (1 + 0.5j * z) / (1 - 0.5j * z)
        assert nd.principal_eigenvalue("generalized-alpha", z, 1.0) == pytest.approx(
            expected, abs=1e-12
        )


def test_tr_bdf2_is_l_stable_and_second_order():
    assert radius("tr-bdf2", 1e6) < 1e-5
    assert all(radius("tr-bdf2", z) < 1.0 for z in STEPS)
    # second order: the one-step error |λ − e^{iz}| falls 8× when z halves (third power)
    errors = [abs(nd.principal_eigenvalue("tr-bdf2", z) - np.exp(1j * z)) for z in (0.02, 0.01)]
    assert errors[0] / errors[1] == pytest.approx(8.0, rel=0.02)


def test_bdf2_principal_root_solves_its_characteristic_polynomial():
    # (1 − 2μ/3) ζ² − (4/3) ζ + 1/3 = 0 with μ = iz: the principal root (→ 1 as z → 0) is the
    # companion matrix's eigenvalue followed from e^{iz}, the other root (→ 1/3) is spurious
    for z in (0.05, 0.5, 1.0, 3.0):
        roots = np.roots([1 - 2j * z / 3, -4 / 3, 1 / 3])
        principal = nd.principal_eigenvalue("bdf2", z)
        assert min(abs(roots - principal)) < 1e-12
        assert all(
            min(abs(np.linalg.eigvals(nd.amplification("bdf2", z)) - r)) < 1e-12 for r in roots
        )
    spurious = np.roots([1 - 2j * 1e-4 / 3, -4 / 3, 1 / 3])
    assert min(abs(spurious - 1 / 3)) < 1e-3


def test_symplectic_euler_keeps_the_amplitude_below_two_and_blows_up_above():
    for z in STEPS:
        r = radius("explicit", z)
        if z < 2.0:
            assert r == pytest.approx(1.0, abs=1e-12)
        else:
            assert r > 1.0


# -- the fit ---------------------------------------------------------------------------------------
def test_the_fit_recovers_a_damped_rotation_beside_a_weaker_spurious_root():
    # the principal pair (|λ| = 0.9, carrying the signal) and a spurious real root of larger
    # modulus (−0.95) but 1e-3 of the amplitude, as generalized-α's start excites one
    n = np.arange(60)
    principal = 0.9 * np.exp(0.4j)
    signal = np.vstack(
        [np.real(principal**n) + 1e-3 * (-0.95) ** n, np.imag(principal**n) - 2e-3 * (-0.95) ** n]
    )
    eigenvalues, amplitudes, residual = nd.fit_recurrence(signal)
    assert residual < 1e-12 and len(eigenvalues) == 3
    assert min(abs(eigenvalues + 0.95)) < 1e-10
    found = nd.measured_decay({"omega": 1.0, "q": signal[0], "p": signal[1]})
    assert found["decay_per_step"] == pytest.approx(0.9, rel=1e-12)
    assert found["argument"] == pytest.approx(0.4, rel=1e-12)


# -- yore's runs against the analytic value --------------------------------------------------------
# The chain's longitudinal motion is exactly linear (collinear springs of positive length have
# quadratic energies), so a tight Newton (newton_tol 1e-12 × the 0.1 m rest length, truncation
# off) leaves each step within ~1e-13 m of the exact step of the scheme, against a mode
# amplitude of 0.02 m: a relative error of ~5e-12 per step. 1e-8 on the decay per step is three
# orders above that and far below any change of a scheme's coefficients (generalized-α at
# ρ∞ = 0.9 and 1 differ by 5e-5 at ωh = 1; a TR-BDF2 with γ = ½ by more).
CASES = [
    ("explicit", None, 0.3),
    ("explicit", None, 1.9),
    ("implicit", None, 0.3),
    ("implicit", None, 2.0),
    ("bdf2", None, 0.3),
    ("bdf2", None, 2.0),
    ("tr-bdf2", None, 0.3),
    ("tr-bdf2", None, 2.0),
    ("generalized-alpha", 0.0, 0.3),
    ("generalized-alpha", 0.8, 2.0),
    ("generalized-alpha", 1.0, 1.0),
]


@pytest.mark.parametrize("integrator,rho,z", CASES)
def test_a_yore_run_decays_as_its_scheme_does(integrator, rho, z):
    why = nd.accepted(integrator)
    if why is not None:
        pytest.skip(f"{integrator} is not in this build: {why}")
    row = nd.mode_row(integrator, z, rho)
    assert abs(row["relative_difference"]) < 1e-8
    assert row["period_elongation"] == pytest.approx(
        row["analytic_period_elongation"], rel=1e-6, abs=1e-9
    )
    assert row["unconverged_steps"] == 0 and row["fit_residual"] < 1e-8
    assert row["energy_kept_per_period"] == pytest.approx(
        row["decay_per_step"] ** (2 * 2 * math.pi / z), rel=1e-12
    )
    if integrator != "explicit":  # linear: one Newton iteration per stage
        # TR-BDF2: two stages a step, but its first step is one backward-Euler solve
        stages = 2 * row["steps"] - 1 if integrator == "tr-bdf2" else row["steps"]
        assert row["newton_iterations"] == stages


def test_the_chain_mode_frequency_is_the_lowest_eigenfrequency():
    # ω² of the chain's lowest mode from its stiffness matrix (N free masses, fixed ends)
    cloth, rest, shape, omega = nd.chain(8)
    stiffness = (2 * np.eye(8) - np.eye(8, k=1) - np.eye(8, k=-1)) * nd.CHAIN_STIFFNESS
    lowest = np.linalg.eigvalsh(stiffness / nd.CHAIN_MASS)[0]
    assert omega == pytest.approx(math.sqrt(lowest), rel=1e-12)
    assert np.asarray(cloth.fixed_vertices).tolist() == [0, 9]
    assert np.allclose(np.asarray(cloth.masses)[1:-1], nd.CHAIN_MASS)


# -- the sheet's measures --------------------------------------------------------------------------
def table(kinetic, stride=1):
    """A long_horizon sample table with these kinetic energies at every stride-th grid point."""
    rows = np.zeros((len(kinetic), len(lh.COLUMNS)))
    rows[:, 0] = stride * np.arange(len(kinetic))
    rows[:, 1] = kinetic
    rows[:, 5] = kinetic
    return rows


def test_energy_kept_is_a_ratio_of_window_means_at_the_runs_own_times():
    grid = np.arange(round(nd.DURATION * lh.GRID_RATE) + 1)
    reference = table(1.0 + 0.5 * np.sin(grid))
    run = table(0.5 * (1.0 + 0.5 * np.sin(grid[::2])), stride=2)  # every 1/32 s, half as much
    assert nd.window_mean_ratio(run, reference, 1.0) == pytest.approx(0.5, rel=1e-12)
    assert nd.window_mean_ratio(run, reference, 2.0) == pytest.approx(0.5, rel=1e-12)
    found = nd.sheet_measures(
        {"snapshots": [np.zeros((0, 1, 3)), run]},
        {"snapshots": [np.zeros((0, 1, 3)), reference]},
        {"sheet_size": 1.0, "diagonal": math.sqrt(2)},
    )
    assert found["kinetic_energy_kept_at_1s"] == pytest.approx(0.5, rel=1e-12)
    assert found["kinetic_energy_history"] == pytest.approx(0.5, rel=1e-12)
    # the window is ±0.125 s: 17 points of the 1/64 s grid, 9 of the 1/32 s one
    times = grid / lh.GRID_RATE
    assert np.sum(np.abs(times - 1.0) <= nd.WINDOW + 1e-12) == 17


# -- the quick run ---------------------------------------------------------------------------------
@pytest.mark.slow  # a benchmark, if a small one (~10 s)
def test_the_quick_run_writes_both_parts(tmp_path):
    pytest.importorskip("matplotlib")
    result = subprocess.run(
        [sys.executable, "-m", "benchmarks.numerical_damping", "--out", str(tmp_path), "--quick"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "numerical_damping.png").read_bytes()[:4] == b"\x89PNG"
    data = json.loads((tmp_path / "numerical_damping.json").read_text())
    schema.check(data)
    assert data["quick"] and data["benchmark"] == "numerical_damping"
    for row in data["rows"]:
        assert abs(row["relative_difference"]) < 1e-8, row
        assert row["omega_h"] < 2.0 or row["integrator"] != "explicit"
    (reference,) = data["sheet_references"]
    assert reference["size"] == 10 and reference["reference_dt"] <= reference["trial_limit_dt"] / 2
    rows = data["sheet_rows"]
    assert rows[0]["family"] == "explicit at its limit"
    assert rows[0]["dt"] <= reference["trial_limit_dt"]
    assert {r["family"] for r in rows[1:]} == set(data["sheet_families"])
    assert {round(1 / r["dt"]) for r in rows[1:]} == set(nd.RATES)
    for r in rows:
        assert r["steps"] * r["dt"] == pytest.approx(nd.DURATION)
        if not (r["diverged"] or r["aborted"]):
            assert r["kinetic_energy_kept_at_1s"] > 0 and r["kinetic_energy_kept_at_2s"] > 0
            assert r["kinetic_energy_history"] >= 0
    backward = {round(1 / r["dt"]): r for r in rows if r["family"] == "implicit"}
    # backward Euler damps the swing the more the longer its step
    assert backward[32]["kinetic_energy_history"] > backward[128]["kinetic_energy_history"]
