"""Quadratic bending (Bergou, Wardetzky, Harmon, Zorin & Grinspun 2006): the kernel against finite
differences, invariants and a closed form on a cylinder, every integrator with the term, the
stable-step estimates, saved states, strokes and the argument checks."""

import json
import zipfile

import numpy as np
import pytest

import yore
from tests.newton_systems import dense_hessian
from yore import _core
from yore.runs import SceneError, load_scene
from yore.state import load_state, save_state

NO_GRAVITY = (0.0, 0.0, 0.0)


def dense_q(cloth):
    """Q (n×n, per unit modulus) from the cloth's CSR view."""
    q = cloth.quadratic_bending
    n = q["size"]
    Q = np.zeros((n, n))
    for row in range(n):
        for p in range(q["indptr"][row], q["indptr"][row + 1]):
            Q[row, q["indices"][p]] += q["data"][p]
    return Q


def on_cylinder(V, radius):
    """The flat sheet V (z = 0) rolled, isometrically, onto a cylinder of axis ∥ y."""
    u = V[:, 0]
    return np.column_stack(
        [radius * np.sin(u / radius), V[:, 1], radius * (1.0 - np.cos(u / radius))]
    )


def strip(modulus=3e-3, nx=9, ny=5, radius=0.3, stretch_stiffness=50.0):
    """A 0.4 m × 0.2 m strip, rest flat, started bent onto a cylinder of `radius`."""
    V, F = yore.grid_mesh(nx, ny, width=0.4, height=0.2)
    cloth = yore.Cloth(
        V,
        F,
        masses=1e-3,
        stretch_stiffness=stretch_stiffness,
        bending="quadratic",
        bending_modulus=modulus,
    )
    cloth.positions = on_cylinder(V, radius)
    return cloth


def test_q_is_symmetric_psd_kills_translations_and_gives_the_cloths_energy():
    cloth = strip()
    Q = dense_q(cloth)
    assert np.array_equal(Q, Q.T)
    # rows sum to zero (K_e's weights do): a translation has no bending energy; round-off of
    # the cotangent sums, relative to the largest entry
    assert np.abs(Q.sum(axis=1)).max() <= 1e-12 * np.abs(Q).max()
    assert np.linalg.eigvalsh(Q).min() >= -1e-10 * np.abs(Q).max()
    X = cloth.positions
    energy = cloth.energy(NO_GRAVITY)
    expected = 0.5 * cloth.bending_modulus * np.einsum("ic,ij,jc->", X, Q, X)
    assert energy["bending"] == pytest.approx(expected, rel=1e-12)
    assert energy["total"] == pytest.approx(
        energy["kinetic"] + energy["spring"] + energy["gravity"] + energy["bending"]
    )
    # interior edges of a 9 × 5 grid: all edges minus the boundary ones
    assert cloth.quadratic_bending["hinges"] == (8 * 5 + 9 * 4 + 8 * 4) - 2 * (8 + 4)
    assert cloth.bending_hinges == cloth.quadratic_bending["hinges"]  # without the matrix's copy
    assert cloth.spring_count == 8 * 5 + 9 * 4 + 8 * 4  # structural springs only


def _newton_system(cloth, integrator, X):
    return integrator.newton_system(cloth, NO_GRAVITY, 0.01, X)


def test_the_implicit_gradient_and_hessian_of_the_term_match_finite_differences():
    # The same cloth with and without the term: their incremental potentials differ by the
    # bending term alone, so the differences isolate its energy, gradient and Hessian.
    V, F = yore.grid_mesh(4, 4, width=0.3, height=0.3)
    rng = np.random.default_rng(1)
    X = on_cylinder(V, 0.2) + rng.normal(0.0, 0.003, V.shape)
    with_term = yore.Cloth(
        V, F, masses=0.01, stretch_stiffness=50.0, bending="quadratic", bending_modulus=0.02
    )
    without = yore.Cloth(V, F, masses=0.01, stretch_stiffness=50.0, bend_stiffness=0.0)
    for cloth in (with_term, without):
        cloth.positions = X
        cloth.fix([0, 3])
    a, b = _core.ImplicitIntegrator(), _core.ImplicitIntegrator()
    free = _newton_system(with_term, a, X)["free_vertices"]
    assert len(free) == 14

    def bending(Y):
        sa, sb = _newton_system(with_term, a, Y), _newton_system(without, b, Y)
        return (
            sa["energy"] - sb["energy"],
            np.asarray(sa["gradient"]) - sb["gradient"],
            dense_hessian(sa) - dense_hessian(sb),
        )

    energy, gradient, hessian = bending(X)
    assert energy == pytest.approx(with_term.energy(NO_GRAVITY)["bending"], rel=1e-9)
    h = 1e-5
    numeric_gradient, numeric_hessian = [], []
    for k in range(3 * len(free)):
        up, down = X.copy(), X.copy()
        up[free[k // 3], k % 3] += h
        down[free[k // 3], k % 3] -= h
        e_up, g_up, _ = bending(up)
        e_down, g_down, _ = bending(down)
        numeric_gradient.append((e_up - e_down) / (2 * h))
        numeric_hessian.append((g_up - g_down) / (2 * h))
    # The term is quadratic: central differences are exact but for round-off, which the
    # subtraction of two potentials (~1e-3 J) amplifies to ~1e-16/h relative: 1e-7 is safe.
    assert np.abs(np.array(numeric_gradient) - gradient).max() <= 1e-7 * np.abs(gradient).max()
    numeric_hessian = np.column_stack(numeric_hessian)
    assert np.abs(numeric_hessian - hessian).max() <= 1e-7 * np.abs(hessian).max()
    # and the assembled Hessian is κ Q ⊗ I₃ on the free vertices
    expected = np.kron(0.02 * dense_q(with_term)[np.ix_(free, free)], np.eye(3))
    assert np.abs(hessian - expected).max() <= 1e-9 * np.abs(expected).max()


def test_a_flat_sheet_has_no_bending_energy_or_force_in_any_rigid_or_planar_affine_pose():
    V, F = yore.grid_mesh(7, 6, width=0.5, height=0.4)
    cloth = yore.Cloth(V, F, bending="quadratic", bending_modulus=0.1)
    Q = dense_q(cloth)
    rng = np.random.default_rng(2)
    rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    stretch = np.diag([1.3, 0.7, 1.0])  # a planar affine map keeps every hinge flat
    for X in (V, V @ rotation.T + [0.3, -1.0, 2.0], V @ stretch.T @ rotation.T):
        cloth.positions = X
        # zero up to the round-off of Q's entries (~|Q|·|x|·1e-16 per row)
        scale = np.abs(Q).max() * np.abs(X).max() * 1e-13
        assert np.abs(0.1 * Q @ X).max() <= scale
        assert abs(cloth.energy(NO_GRAVITY)["bending"]) <= scale * np.abs(X).max() * len(X)
    # so a flat sheet at rest stays where it is (springs at rest too, no gravity)
    cloth.positions = V
    sim = yore.Simulation(cloth, integrator="explicit", dt=1e-4, gravity=NO_GRAVITY)
    sim.step(20)
    assert np.abs(cloth.positions - V).max() <= 1e-14


@pytest.mark.parametrize("n", [9, 17])
def test_a_strip_rolled_onto_a_cylinder_has_the_closed_form_discrete_energy(n):
    # Rolled along x, only the hinges of the edges along y bend: their two faces lie in planes
    # parallel to the axis whose normals differ by θ = h_x/R; both faces are shortened across
    # the edge by the chord ratio c = 2R sin(h_x/2R)/h_x, so |K_e x| = 2 h_y c sin(θ/2). The
    # diagonal and x-edges join faces of one plane (the strip between two rulings). Per bent
    # hinge ½ κ |K_e x|² / (h_x h_y), over the (n − 2)(n − 1) interior y-edges.
    radius, modulus, size = 0.5, 2e-3, 1.0
    V, F = yore.grid_mesh(n, n, width=size, height=size)
    cloth = yore.Cloth(V, F, bending="hinge", bending_modulus=modulus)
    cloth.positions = on_cylinder(V, radius)
    h = size / (n - 1)
    chord = 2 * radius * np.sin(h / (2 * radius)) / h
    per_hinge = 0.5 * modulus / (h * h) * (2 * h * chord * np.sin(h / (2 * radius))) ** 2
    expected = (n - 2) * (n - 1) * per_hinge
    # the kernel sums ~n² terms of similar size: round-off ~1e-13 relative
    assert cloth.energy(NO_GRAVITY)["bending"] == pytest.approx(expected, rel=1e-11)


def equilateral_mesh(n):
    """A unit-wide sheet of n columns of near-equilateral triangles, rows offset by half an edge."""
    h = 1.0 / (n - 1)
    rows = int(round(1.0 / (h * np.sqrt(3) / 2))) + 1
    V = np.array(
        [
            [i * h + (0.5 * h if j % 2 else 0.0), j * h * np.sqrt(3) / 2, 0.0]
            for j in range(rows)
            for i in range(n)
        ]
    )
    F = []
    for j in range(rows - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            F += [[a, b, c], [b, d, c]] if j % 2 == 0 else [[a, b, d], [a, d, c]]
    return V, np.array(F, dtype=np.int32)


@pytest.mark.parametrize(
    "mesh, degrees",
    [
        ("grid", 0.0),
        ("grid", 90.0),
        ("equilateral", 0.0),
        ("equilateral", 90.0),
        ("equilateral", 30.0),
    ],
)
def test_the_cylinder_energy_approaches_the_continuum_value_with_refinement(mesh, degrees):
    # Continuum (isometric bending of a plate of rigidity κ): E = ½ κ ∫ (2H)² dA = ½ κ A / R²
    # on a cylinder of radius R (2H = 1/R). The sheet is turned by `degrees` in its plane and
    # rolled about y, so the rulings run along the grid lines, across them at 45°, or along and
    # across an equilateral mesh's rows: the limit must not depend on the mesh's directions. The
    # error (boundary hinges missing, O(h²) chords) must fall with refinement, to a few % at
    # 33 vertices a side.
    radius, modulus = 0.5, 2e-3
    turn = np.radians(degrees)
    rotation = np.array(
        [[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]]
    )
    errors = []
    for n in (9, 17, 33):
        V, F = yore.grid_mesh(n, n) if mesh == "grid" else equilateral_mesh(n)
        V = V @ rotation.T
        cloth = yore.Cloth(V, F, bending="quadratic", bending_modulus=modulus)
        cloth.positions = on_cylinder(V, radius)
        continuum = 0.5 * modulus * yore.metrics.area(V, F) / radius**2
        errors.append(abs(cloth.energy(NO_GRAVITY)["bending"] - continuum) / continuum)
    assert errors[0] < 0.15 and errors[2] < 0.04, errors
    assert errors[1] < 0.8 * errors[0] and errors[2] < 0.8 * errors[1], errors


def turned(V, degrees):
    turn = np.radians(degrees)
    return (
        V
        @ np.array([[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]]).T
    )


def cylinder_ratio(V, F, bending, radius=0.5, modulus=2e-3):
    """Bending energy of the flat sheet (V, F) rolled onto a cylinder, over ½ κ A / R²."""
    cloth = yore.Cloth(V, F, bending=bending, bending_modulus=modulus)
    cloth.positions = on_cylinder(V, radius)
    return cloth.energy(NO_GRAVITY)["bending"] / (
        0.5 * modulus * yore.metrics.area(V, F) / radius**2
    )


def test_the_hinge_energy_depends_on_the_mesh_directions():
    # Why "quadratic" is no longer the hinge energy (issue 52): grid_mesh alternates its
    # diagonals, and a cylinder whose rulings cross its lines at 45° gets ≈ 1.5 × ½ κ ∫ (2H)²
    # dA; CGAL's isotropic pattern meshes get 1.12–1.16× at every h (measured), not 1×.
    V, F = yore.grid_mesh(33, 33)
    assert 1.4 < cylinder_ratio(turned(V, 45.0), F, "hinge") < 1.6
    V, F = yore.pattern_mesh(
        [[0, 0], [1, 0], [1, 0.5], [0, 0.5]], edge_length=0.04, interior="delaunay"
    )
    assert 1.08 < cylinder_ratio(V, F, "hinge") < 1.2


@pytest.mark.parametrize(
    "mesh", ["grid 0°", "grid 45°", "grid 30°", "pattern", "delaunay", "equilateral"]
)
def test_the_fitted_energy_is_the_continuum_energy_on_any_mesh(mesh):
    # The cylinder of issue 52's target (within 2 % on every mesh kind and size), already at 9
    # vertices across: measured 0.2 % at h = 0.04 m and 0.01 % at 0.01 m; the tolerance leaves
    # room for the O(h²) chords, and refinement must not move it away.
    ratios = []
    for h in (0.08, 0.04, 0.02):
        if mesh in ("pattern", "delaunay"):
            V, F = yore.pattern_mesh(
                [[0, 0], [1, 0], [1, 0.5], [0, 0.5]],
                edge_length=h,
                interior="lattice" if mesh == "pattern" else "delaunay",
            )
        elif mesh == "equilateral":
            V, F = equilateral_mesh(int(round(1 / h)) + 1)
        else:
            n = int(round(1 / h)) + 1
            V, F = yore.grid_mesh(n, (n - 1) // 2 + 1, width=1.0, height=0.5)
            V = turned(V, float(mesh.split()[1].rstrip("°")))
        ratios.append(cylinder_ratio(V, F, "quadratic"))
    assert all(abs(r - 1) < 0.01 for r in ratios), ratios
    assert abs(ratios[-1] - 1) < 0.002, ratios


def test_the_fitted_hessian_is_exact_for_quadratic_fields_on_an_irregular_mesh():
    # Each vertex's least-squares quadratic reproduces a quadratic field exactly, so a sheet
    # lifted to z = ½ (a u² + 2b uv + c v²) (not isometric: the energy is still ½ κ Σ_p A_p
    # |H|²_F with H its constant Hessian) stores ½ κ A (a² + 2b² + c²) to round-off — on
    # every vertex, the boundary's grown patches included. Affine maps (in-plane stretch,
    # shear, tilt) store nothing.
    V, F = yore.pattern_mesh(
        [[0, 0], [0.6, 0], [0.5, 0.4], [0.1, 0.3]], edge_length=0.07, interior="delaunay"
    )
    modulus, a, b, c = 3e-3, 1.7, -0.6, 0.4
    cloth = yore.Cloth(V, F, bending="quadratic", bending_modulus=modulus)
    u, v = V[:, 0], V[:, 1]
    X = V.copy()
    X[:, 2] = 0.5 * (a * u * u + 2 * b * u * v + c * v * v)
    cloth.positions = X
    expected = 0.5 * modulus * yore.metrics.area(V, F) * (a * a + 2 * b * b + c * c)
    assert cloth.energy(NO_GRAVITY)["bending"] == pytest.approx(expected, rel=1e-9)
    affine = np.array([[1.3, 0.2, 0.0], [-0.1, 0.8, 0.0], [0.4, -0.7, 1.0]])
    cloth.positions = V @ affine.T + [0.1, 0.2, 0.3]
    assert abs(cloth.energy(NO_GRAVITY)["bending"]) <= 1e-9 * expected  # round-off of W


def test_a_mesh_too_small_to_fit_is_refused_naming_the_other_models():
    # Two triangles hold 4 vertices: no quadratic fits; the hinge energy serves them.
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    F = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int32)
    with pytest.raises(ValueError, match="6 well spread.*hinge"):
        yore.Cloth(V, F, bending="quadratic", bending_modulus=1e-3)
    assert yore.Cloth(V, F, bending="hinge", bending_modulus=1e-3).bending == "hinge"


def test_explicit_and_implicit_agree_on_a_short_run_and_converge_at_first_order():
    # A rolled strip springs open under its bending (no gravity), 0.02 s. Backward Euler and
    # BDF2 (started by a backward-Euler step) differ from symplectic Euler by O(dt): halving dt
    # must about halve the gap, and at dt = 5e-5 s it is below 3 % of the motion (measured
    # 1.4 % for backward Euler, 0.25 % for BDF2).
    gaps = {}
    for dt in (1e-4, 5e-5):
        steps = int(round(0.02 / dt))
        finals = {}
        for integrator, options in (
            ("explicit", {}),
            ("implicit", dict(newton_tol=1e-12, max_newton=100, truncation_fraction=0.0)),
            ("bdf2", dict(newton_tol=1e-12, max_newton=100, truncation_fraction=0.0)),
        ):
            cloth = strip()
            start = cloth.positions
            yore.Simulation(
                cloth, integrator=integrator, dt=dt, gravity=NO_GRAVITY, **options
            ).step(steps)
            finals[integrator] = cloth.positions
        motion = np.abs(finals["explicit"] - start).max()
        assert motion > 1e-3  # the strip does move (the term acts)
        gaps[dt] = {
            name: np.abs(finals[name] - finals["explicit"]).max() / motion
            for name in ("implicit", "bdf2")
        }
    for name in ("implicit", "bdf2"):
        assert gaps[5e-5][name] < 0.03, gaps
        assert gaps[5e-5][name] < 0.6 * gaps[1e-4][name], gaps


@pytest.mark.parametrize(
    "integrator, options, tolerance",
    [
        # a residual of 1e-10 mean rest lengths as a displacement: far below 1e-7 m
        ("quasi-newton", dict(newton_tol=1e-10, max_newton=5000), 1e-7),
        # plain local-global, 3000 iterations: measured 1.8e-9 m from Newton's step
        ("local-global", dict(iterations=3000, tolerance=0.0, acceleration="none"), 1e-7),
    ],
)
def test_quasi_newton_and_local_global_converge_to_newtons_step_with_the_term(
    integrator, options, tolerance
):
    def scene(name, **kwargs):
        return yore.scenes.hanging_cloth(
            resolution=9,
            pin_spacing=1.0,
            bending="quadratic",
            bending_modulus=1e-3,
            integrator=name,
            **kwargs,
        )

    reference = scene("implicit", newton_tol=1e-12, max_newton=200, truncation_fraction=0.0)
    reference.step(3)
    sim = scene(integrator, **options)
    sim.step(3)
    assert (
        sim.stats["active_terms"]["quadratic_bending"]
        == reference.cloth.quadratic_bending["hinges"]
    )
    moved = np.abs(reference.cloth.positions - scene("implicit").cloth.positions).max()
    assert moved > 1e-3
    assert np.abs(sim.cloth.positions - reference.cloth.positions).max() <= tolerance


def test_every_stable_step_estimate_falls_as_the_modulus_grows():
    V, F = yore.grid_mesh(9, 9)
    steps = []
    for modulus in (0.0, 1e-3, 1e-2, 1e-1):
        cloth = yore.Cloth(
            V, F, masses=1e-3, stretch_stiffness=100.0, bending="quadratic", bending_modulus=modulus
        )
        steps.append(
            [cloth.gershgorin_time_step(), cloth.stable_time_step_bound(), cloth.stable_time_step()]
        )
    steps = np.array(steps)
    assert np.all(np.diff(steps, axis=0) < 0), steps
    assert np.all(steps[:, 0] <= steps[:, 1])  # Gershgorin stays the most conservative
    # at κ = 0.1 N·m bending dominates: the explicit default step (below the bound) is stable,
    # 1.5× the tight estimate is not
    cloth = strip(modulus=0.1)
    bound = cloth.stable_time_step_bound()
    yore.Simulation(cloth, integrator="explicit", dt=0.9 * bound, gravity=NO_GRAVITY).step(300)
    assert np.isfinite(cloth.energy(NO_GRAVITY)["total"])
    cloth = strip(modulus=0.1)
    with pytest.raises(yore.SimulationDiverged):
        yore.Simulation(
            cloth, integrator="explicit", dt=1.5 * cloth.stable_time_step(), gravity=NO_GRAVITY
        ).step(2000)


def test_the_state_round_trips_and_a_saved_quadratic_run_resumes_bit_for_bit(tmp_path):
    sim = yore.scenes.hanging_cloth(
        resolution=7, bending="quadratic", bending_modulus=1e-3, integrator="implicit"
    )
    sim.step(2)
    state = sim.cloth.state()
    assert state["bending"] == "quadratic" and state["bending_modulus"] == 1e-3
    copy = yore.Cloth.from_state(state)
    assert copy.bending == "quadratic" and copy.bending_modulus == 1e-3
    assert np.array_equal(dense_q(copy), dense_q(sim.cloth))
    path = save_state(tmp_path / "run.npz", sim)
    loaded, _ = load_state(path)
    sim.step(3)
    loaded.step(3)
    assert np.array_equal(loaded.cloth.positions, sim.cloth.positions)
    assert loaded.cloth.bending == "quadratic"


def test_a_state_file_from_before_quadratic_bending_loads_as_bending_springs(tmp_path):
    sim = yore.scenes.hanging_cloth(resolution=5)
    path = save_state(tmp_path / "new.npz", sim)
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    document = json.loads(str(np.load(path)["__document__"][()]))
    for key in ("bending", "bending_modulus", "bending_rest", "bending_operator"):
        document["simulation"]["cloth"].pop(key)
    old = tmp_path / "old.npz"
    np.savez(tmp_path / "doc.npz", __document__=np.array(json.dumps(document)))
    with zipfile.ZipFile(tmp_path / "doc.npz") as archive:
        members["__document__.npy"] = archive.read("__document__.npy")
    with zipfile.ZipFile(old, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    loaded, _ = load_state(old)
    assert loaded.cloth.bending == "springs" and loaded.cloth.bending_modulus == 0.0
    assert np.array_equal(loaded.cloth.springs.kind, sim.cloth.springs.kind)
    state = sim.cloth.state()
    for key in ("bending", "bending_modulus", "bending_rest", "bending_operator"):
        state.pop(key)
    assert yore.Cloth.from_state(state).bending == "springs"


def _rewrite_document(path, out, edit):
    """A copy of the state file `path` at `out` with its JSON document changed by edit(doc)."""
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    document = json.loads(str(np.load(path)["__document__"][()]))
    edit(document)
    np.savez(out.with_suffix(".doc.npz"), __document__=np.array(json.dumps(document)))
    with zipfile.ZipFile(out.with_suffix(".doc.npz")) as archive:
        members["__document__.npy"] = archive.read("__document__.npy")
    with zipfile.ZipFile(out, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return out


def test_a_quadratic_state_from_before_the_fitted_operator_resumes_as_the_hinge_energy(tmp_path):
    # Before issue 52 "quadratic" meant the hinge Q and files carried no bending_operator: such
    # a file must go on with the energy it ran with, bit for bit, not switch operators.
    sim = yore.scenes.hanging_cloth(
        resolution=7, bending="hinge", bending_modulus=1e-3, integrator="implicit"
    )
    sim.step(2)
    path = save_state(tmp_path / "hinge.npz", sim)

    def as_old(document):
        cloth = document["simulation"]["cloth"]
        assert cloth["bending"] == "hinge" and cloth.get("bending_operator") is None
        cloth["bending"] = "quadratic"
        cloth.pop("bending_operator", None)

    old = _rewrite_document(path, tmp_path / "old.npz", as_old)
    loaded, _ = load_state(old)
    assert loaded.cloth.bending == "hinge"
    assert np.array_equal(dense_q(loaded.cloth), dense_q(sim.cloth))
    sim.step(3)
    loaded.step(3)
    assert np.array_equal(loaded.cloth.positions, sim.cloth.positions)
    # a fitted state names its operator; any other value is refused, naming the field
    fitted = save_state(
        tmp_path / "fitted.npz",
        yore.scenes.hanging_cloth(resolution=7, bending="quadratic", bending_modulus=1e-3),
    )
    assert load_state(fitted)[0].cloth.bending == "quadratic"

    def forged(document):
        document["simulation"]["cloth"]["bending_operator"] = "cotangent"

    with pytest.raises(ValueError, match="bending_operator"):
        load_state(_rewrite_document(fitted, tmp_path / "forged.npz", forged))
    # and Cloth.from_state, given a dict directly, refuses the same (any type) naming it
    state = load_state(fitted)[0].cloth.state()
    for bad in (3, "cotangent"):
        with pytest.raises(ValueError, match="bending_operator"):
            yore.Cloth.from_state({**state, "bending_operator": bad})
    with pytest.raises(ValueError, match="bending_operator"):
        yore.Cloth.from_state({**state, "bending": "hinge"})  # "fitted" names quadratic only


@pytest.mark.parametrize("integrator", ["implicit", "explicit", "local-global", "quasi-newton"])
def test_a_stroke_rebuilds_q_and_the_term_keeps_working(integrator):
    sim = yore.scenes.hanging_cloth(
        resolution=9, bending="quadratic", bending_modulus=1e-3, integrator=integrator
    )
    sim.step(2)
    before = sim.cloth.quadratic_bending
    report = sim.stroke(yore.StrokePath.material([[0.2, 0.5], [0.8, 0.5]]))
    after = sim.cloth.quadratic_bending
    added = len(report.new_vertices)
    assert added > 0
    # a 1→3 split adds three interior edges per face: the hinges grow by 3 per new vertex
    assert after["hinges"] == before["hinges"] + 3 * added
    assert after["size"] == sim.cloth.vertex_count
    # new vertices' rest points are where they were added in the flat pattern (u, 0, v): the
    # rest state stays flat, so Q still has no energy at rest (Q · rest = 0)
    rest = after["rest_positions"]
    assert np.abs(rest[:, 1]).max() <= 1e-12
    uv = sim.cloth.material_coordinates
    assert np.abs(rest[:, [0, 2]] - uv).max() <= 1e-12
    cloth_at_rest = yore.Cloth.from_state(sim.cloth.state())
    cloth_at_rest.positions = rest
    # zero but for the cancellation in ½κ Σ x·Qx: ~1e-16 of κ |Q|max |x|² per stored entry
    scale = 1e-3 * np.abs(after["data"]).max() * len(after["data"]) * np.abs(rest).max() ** 2
    assert abs(cloth_at_rest.energy(NO_GRAVITY)["bending"]) <= 1e-15 * scale
    assert sim.stats["active_terms"]["quadratic_bending"] == after["hinges"]
    assert not np.any(sim.cloth.springs.kind == 1)  # still no bending springs
    sim.step(5)
    energy = sim.energy()
    assert np.isfinite(energy["total"]) and energy["bending"] > 0.0


def test_a_zero_modulus_is_no_term_and_the_default_stays_bending_springs():
    V, F = yore.grid_mesh(6, 5)
    default, springs = yore.Cloth(V, F), yore.Cloth(V, F, bending="springs")
    assert default.bending == "springs" and default.quadratic_bending is None
    assert default.bending_hinges == 0
    a, b = default.state(), springs.state()
    for key in a:
        if isinstance(a[key], np.ndarray):
            assert np.array_equal(a[key], b[key]), key
        else:
            assert a[key] == b[key], key
    # κ = 0: exactly the springs-free run (structural springs only)
    zero = yore.Cloth(V, F, bending="quadratic", bending_modulus=0.0)
    plain = yore.Cloth(V, F, bend_stiffness=0.0)
    runs = []
    for cloth in (zero, plain):
        cloth.fix([0, 5])
        sim = yore.Simulation(cloth, integrator="implicit", dt=1 / 120)
        sim.step(3)
        runs.append(cloth.positions)
    assert np.array_equal(runs[0], runs[1])
    assert sim.stats["active_terms"]["bending_springs"] == 0
    zero_sim = yore.Simulation(zero, dt=1e-4)
    assert zero_sim.stats["active_terms"]["quadratic_bending"] == 0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(bending="curvature"), '"springs", "quadratic" or "hinge"'),
        (dict(bending="quadratic"), "needs bending_modulus"),
        (dict(bending="quadratic", bending_modulus=-1.0), "bending_modulus"),
        (dict(bending="quadratic", bending_modulus=float("nan")), "bending_modulus"),
        (dict(bending="quadratic", bending_modulus=float("inf")), "bending_modulus"),
        (dict(bending_modulus=1.0), "bending_modulus is for"),
        (dict(bending="springs", bending_modulus=0.0), "bending_modulus is for"),
        (dict(bending="quadratic", bending_modulus=1.0, bend_stiffness=5.0), "no bending springs"),
    ],
)
def test_bad_bending_arguments_are_value_errors(kwargs, message):
    V, F = yore.grid_mesh(4, 4)
    with pytest.raises(ValueError, match=message):
        yore.Cloth(V, F, **kwargs)


def test_scene_functions_and_scene_files_pass_the_bending_choice_on():
    sim = yore.scenes.rotating_cylinder(
        rings=5, segments=8, bending="quadratic", bending_modulus=2e-4
    )
    assert sim.cloth.bending == "quadratic" and sim.cloth.bending_modulus == 2e-4
    with pytest.raises(ValueError, match="no bending springs"):
        yore.scenes.hanging_cloth(
            resolution=5, bending="quadratic", bending_modulus=1e-3, bend_stiffness=10.0
        )
    base = '[mesh]\ngenerator = "grid"\nnx = 5\nny = 4\n\n[simulation]\nduration = 0.1\n\n'
    scene = load_scene(text=base + '[material]\nbending = "quadratic"\nbending_modulus = 1e-3\n')
    sim, _ = scene.build()
    assert sim.cloth.bending == "quadratic" and sim.cloth.bending_modulus == 1e-3
    assert not np.any(sim.cloth.springs.kind == 1)
    sim, _ = load_scene(text=base).build()
    assert sim.cloth.bending == "springs" and np.any(sim.cloth.springs.kind == 1)
    for material, key in (
        ('bending = "quadratic"\n', "material.bending_modulus"),
        ("bending_modulus = 1e-3\n", "material.bending_modulus"),
        (
            'bending = "quadratic"\nbending_modulus = 1e-3\nbend_stiffness = 5\n',
            "material.bend_stiffness",
        ),
        ('bending = "hinge"\n', "material.bending_modulus"),
        ('bending = "cotangent"\n', "material.bending"),
        ('bending = "quadratic"\nbending_modulus = -1\n', "material.bending_modulus"),
    ):
        with pytest.raises(SceneError) as caught:
            load_scene(text=base + "[material]\n" + material).build()
        assert caught.value.key == key, material


def test_refining_a_quadratic_cloth_keeps_its_flat_rest_and_rebuilds_q():
    # 1→4 refinement puts midpoints into the rest state by the affine fit of their
    # neighbours: on a flat cloth they land on the rest midpoints, so the refined cloth still
    # has no bending energy at rest, and Q gains the new hinges.
    V, F = yore.grid_mesh(7, 7)
    cloth = yore.Cloth(V, F, masses=1e-3, bending="quadratic", bending_modulus=1e-3)
    cloth.material_coordinates = V[:, :2]
    sim = yore.Simulation(cloth, integrator="implicit", gravity=NO_GRAVITY)
    hinges = cloth.quadratic_bending["hinges"]
    report = sim.stroke(
        yore.StrokePath.material([[0.2, 0.5], [0.8, 0.5]]),
        growth="isotropic",
        refine=1,
        width=0.2,
        expansion=1.0,
    )
    assert report.faces_refined > 0
    assert cloth.quadratic_bending["hinges"] > hinges
    rest = cloth.quadratic_bending["rest_positions"]
    assert np.abs(rest[:, 2]).max() < 1e-12  # the new rest points lie in the flat rest plane
    assert abs(cloth.energy(NO_GRAVITY)["bending"]) < 1e-12
    sim.step(2)
    assert np.isfinite(cloth.positions).all()
    # flat, unloaded and not grown: nothing moves
    assert np.abs(cloth.positions[:, 2]).max() < 1e-9
