"""`yore.Simulation`: steps a `yore.Cloth` in time with a chosen integrator."""

from __future__ import annotations

import math
import time as _time
import warnings

import numpy as np

from . import _core
from ._core import Cloth, NotPositiveDefinite, SimulationDiverged
from .checks import MAX_STEPS, MIN_DT
from .options import (
    DEFAULT_INTEGRATOR,
    FIXED_DT,
    GRAVITY,
    INTEGRATOR_OPTIONS,
    INTEGRATOR_SPECS,
    INTEGRATORS,
    SMOOTHING_DEFAULTS,
    check_modes,
    check_option,
    options_in_force,
    resolve_options,
    show_value,
)
from . import progress as progress_bars, rules, settling, smoothing
from .results import Energy, Statistics
from .simulation_checks import check_integrator_and_options, checked_gravity, output_interval
from .simulation_state import (
    as_saved,
    check_history,
    check_projection_memory,
    check_state_keys,
)
from .stroke import StrokeOptions, StrokePath, StrokeReport, apply_stroke, check_factor

__all__ = ["Simulation", "INTEGRATORS", "INTEGRATOR_OPTIONS"]


#: Default time step of the implicit integrators, s (`yore.options.FIXED_DT`).
IMPLICIT_DT = FIXED_DT

# Wall time of one batch of steps: short enough for Ctrl-C and a live progress bar.
_BATCH_SECONDS = 0.1


#: Safety factor of the default explicit time step on ``Cloth.stable_time_step_bound()`` (the
#: state-independent Lanczos bound, which holds whatever shape the cloth takes; 0.98 covers the
#: Lanczos iteration's approach from below). The tighter current-state estimate
#: ``Cloth.stable_time_step()`` is not safe as a default: a heavy grid hung from two corners
#: stretches until its limit is 0.84× that estimate at its start (benchmarks/stable_dt.py and
#: tests/test_threads.py), while the bound stayed below every limit found by trying.
EXPLICIT_DT_SAFETY = 0.98


def default_explicit_dt(cloth: Cloth, safety: float = EXPLICIT_DT_SAFETY) -> float:
    """The default explicit time step (s): ``safety`` × ``cloth.stable_time_step_bound()`` (the
    state-independent estimate), rounded down to 1/N s; 1/60 s when nothing elastic limits the
    step. ``cloth.stable_time_step()`` is the tight estimate at the current state, and
    ``cloth.gershgorin_time_step()`` the cheapest, most conservative one."""
    stable = cloth.stable_time_step_bound()
    if not math.isfinite(stable):
        return 1.0 / 60.0
    if not safety * stable >= 1e-300:
        raise ValueError(
            f"no explicit time step is stable for this cloth (the bound is "
            f"{stable:.3g} s): its stiffnesses or masses are out of range"
        )
    return 1.0 / math.ceil(1.0 / (safety * stable))


class Simulation:
    """A cloth, an integrator, a time step and gravity.

    Parameters
    ----------
    cloth : yore.Cloth
        The cloth to simulate (the simulation steps it in place).
    integrator : str
        One of ``yore.INTEGRATORS``, the names of the registry
        ``yore.options.INTEGRATOR_SPECS`` (each row's ``summary`` says what it is):
        ``"explicit"``, the paper's symplectic Euler, is the reference; the others are
        implicit (the Integrators page of the documentation has them all, and which one to use).
    dt : float or "auto", optional
        Time step, s. Default: explicit, ``EXPLICIT_DT_SAFETY`` (0.98) × the state-independent
        stable-step bound, rounded down to 1/N s (``default_explicit_dt``); the others 1/60 s.
        For the error-controlled integrators (``"cvode"``, ``"arkode"``, and ``"bdf2"`` or
        ``"tr-bdf2"`` with ``dt="auto"``) dt is the output interval: inside one, the steps are
        chosen by the tolerance (``rtol``, ``atol``), and `advance` lands exactly on the time
        asked.
        "auto": error-controlled steps with an output interval of 1/60 s.
    gravity : (3,) array_like
        Gravitational acceleration, m/s².
    **options
        Integrator options. explicit: ``strain_limit`` (e.g. 1.1, default None = off),
        ``strain_limit_passes`` (4), ``divergence_energy_factor`` (10). implicit, bdf2,
        generalized-alpha and tr-bdf2 (generalized-alpha also takes ``rho_infinity``, in [0, 1]):
        ``linearized`` (False), ``newton_tol`` (1e-5: Newton stops when ``max |∇ᵢE|·h̃²/mᵢ``, the
        gradient as a displacement, is below newton_tol × the mean rest length; the step's
        start passes only if no vertex's net force exceeds newton_tol × its weight),
        ``step_tol`` (0 = off: Newton also stops after a full step that moved no vertex by
        more than step_tol × the mean rest length, the model's distance to the solution;
        counted in ``step_test_stops``), ``truncation_fraction`` (0.1: Newton also stops
        once its estimated distance to the solution is below this fraction of the step's
        estimated local truncation error, as stiff integrators do; 0 = off; counted in
        ``truncation_stops``); a step that
        reaches ``max_newton`` (1000) is accepted, counted in ``unconverged_steps`` and warned
        about with a RuntimeWarning once per call), ``projection`` (None | "clamp" | "abs" |
        "exact" | "trust-region" | "shifted" | "steihaug", see `yore.options`; None: "clamp"),
        ``predictor`` (None | "start" | "inertial" | "extrapolated"; None: "start" when
        linearized, else "inertial"), ``mixed`` (None = on with the clamp, off otherwise: Newton's matrices
        take the springs' forces from the step's linearization, the mixed formulation, which
        saves ~40 % of the clamp's iterations on stiff sheets), ``solver`` ("cholmod" | "eigen-ldlt" | "pcg"), ``ordering``
        ("amd" | "metis" | "natural"), ``factorization`` ("supernodal" | "simplicial"),
        ``pcg_tol`` (1e-12), ``pcg_max_iterations`` (20000), ``divergence_energy_factor`` (10),
        ``adaptive_projection`` (the older name of two projections: True = "exact", try the
        exact Hessian first and project spring Hessians to PSD only when the factorization
        finds it indefinite; False = "clamp", always project; None = as ``projection`` says).
        Every system solved is SPD either way.
        ``lagged_factorization`` (False: keep the factor over iterations and steps, solve by CG
        preconditioned with it, refactor when CG needs more than ``lag_max_cg_iterations`` (20)
        to reach ``lag_cg_tol`` (1e-10); CG runs on the projected Hessian, or with "steihaug"
        on the exact one at the trust-region solver's own tolerance; after the k-th failed CG
        in a row the next min(2^(k-1), 32) iterations refactor without trying).

        local-global: ``iterations`` (300: the cap per step), ``tolerance`` (1e-3: a step
        stops once its estimated distance to the backward-Euler solution is below this × the
        mean rest length; 0 = no test; a step at the cap is counted in ``unconverged_steps``
        and a call with any warns once), ``acceleration`` ("chebyshev" | "none"),
        ``chebyshev_rho`` (0.997), ``ordering``, ``factorization``, ``rebuild`` ("fresh" |
        "reuse-ordering" | "stale-pcg"), ``stale_pcg_max_iterations`` (30), ``stale_pcg_tol``,
        ``record_objective``, ``divergence_energy_factor``.

        quasi-newton: ``method`` ("backward-euler" | "bdf2"), ``lbfgs_history`` (8 pairs, kept
        within a step), ``newton_tol`` (1e-5, Newton's residual test), ``max_newton`` (1000:
        the iteration cap, counted and warned about as for Newton), ``predictor`` ("inertial"
        | "start" | "extrapolated"), ``ordering``, ``factorization`` ("simplicial": it solves
        faster),
        ``divergence_energy_factor``.

    Raises
    ------
    ValueError
        Unknown integrator or option name (the message lists the valid ones), an option of the
        wrong type or out of range (see `check_option`: booleans must be True/False, counts
        integers up to `MAX_STEP_ITERATIONS`, tolerances finite), bad dt or gravity, and an
        option given for a mode not in use, which would do nothing
        (`yore.options.InactiveOptionError`, see `yore.options.MODE_ONLY`: e.g. ``rtol``
        with a fixed dt, ``pcg_tol`` without ``solver="pcg"``). Only the options passed
        here are judged, never the defaults, nor a state's options in `from_state`.
    NotImplementedError
        An integrator of the API that this version does not build yet.
    """

    def __init__(self, cloth, integrator=DEFAULT_INTEGRATOR, dt=None, gravity=GRAVITY, **options):
        # the options passed here are the user's: each is judged against the mode in use
        self._build(cloth, integrator, dt, gravity, options, given=tuple(options))

    def _build(self, cloth, integrator, dt, gravity, options, given):
        """The constructor's work; ``given`` names the options a user chose (`check_modes`
        refuses those that act only in a mode not in use), not those a state file holds."""
        check_integrator_and_options(cloth, integrator, options)
        # the defaults filled in; dt="auto" selects error control (checked below)
        self._options = options_in_force(
            integrator,
            {name: check_option(integrator, name, value) for name, value in options.items()},
            dt,
        )
        self._gravity = checked_gravity(gravity)
        self._cloth = cloth
        self._integrator_name = integrator
        self._spec = INTEGRATOR_SPECS[integrator]
        dt = output_interval(dt, integrator, self._options)
        check_modes(integrator, given, self._options)
        # Error-controlled: dt is an output interval, inside which the steps are chosen.
        self._error_controlled = self._spec.error_controlled or bool(self._options.get("adaptive"))
        self._integrator = self._spec.make(self._options)
        # An explicit dt left to the default follows the cloth: a stroke that refines faces or
        # adds light vertices lowers the stable step, and the default is re-derived then.
        self._dt_follows_cloth = dt is None and self._spec.conditionally_stable
        if dt is None:
            dt = default_explicit_dt(cloth) if self._spec.conditionally_stable else FIXED_DT
        self._dt = check_factor(dt, "dt", "s")
        if self._dt < MIN_DT:
            raise ValueError(f"dt must be at least {MIN_DT:g} s, got {self._dt:g}")
        self._wall_seconds = 0.0
        self._target_time = None  # the time the last advance() aimed at
        self._pending_reports = []  # stroke reports waiting for the next step's re-analysis time
        self._last_stroke = None

    # -- properties -----------------------------------------------------------------------
    @property
    def cloth(self) -> Cloth:
        """The simulated cloth."""
        return self._cloth

    @property
    def integrator(self) -> str:
        """Name of the integrator."""
        return self._integrator_name

    @property
    def options(self) -> dict:
        """Integrator options as given, defaults filled in (None where the integrator decides
        from the others; `resolved_options` says what it decided)."""
        return dict(self._options)

    @property
    def resolved_options(self) -> dict:
        """Integrator options in force: `options` with every None decided
        (`yore.options.resolve_options`), e.g. the Hessian projection Newton uses."""
        return resolve_options(self._integrator_name, self._options)

    @property
    def dt(self) -> float:
        """Time step, s."""
        return self._dt

    @property
    def dt_follows_cloth(self) -> bool:
        """True when the step follows the cloth: an explicit simulation whose dt was left to
        the default re-derives it after a stroke that lowers the stable step. `keep_dt` ends
        that."""
        return self._dt_follows_cloth

    def keep_dt(self) -> None:
        """Keeps the step as it is from now on, whatever strokes do to the stable step (a run
        that schedules strokes and frames in steps of one dt needs this)."""
        self._dt_follows_cloth = False

    @property
    def gravity(self) -> np.ndarray:
        """Gravitational acceleration, m/s² (a copy)."""
        return self._gravity.copy()

    @property
    def time(self) -> float:
        """Simulated time, s."""
        return self._cloth.time

    # -- saving and restoring -----------------------------------------------------------------
    def state(self) -> dict:
        """Everything needed to continue this simulation exactly: the cloth's state
        (`yore.Cloth.state`), integrator name and options, dt, gravity, BDF2's history and
        Newton's projection memory (which steps try the exact Hessian).
        `Simulation.from_state` rebuilds it; `yore.save_state` writes it to a file."""
        history = memory = None
        if self._spec.history(self._options):
            history = self._integrator.history(self._cloth)
        if self._spec.newton:
            memory = self._integrator.projection_memory()
        # the options as resolved: a state continues with what ran, whatever later defaults
        return {
            "cloth": self._cloth.state(),
            "integrator": self._integrator_name,
            "options": dict(self.resolved_options),
            "dt": self._dt,
            "gravity": self._gravity.copy(),
            "history": history,
            "projection_memory": memory,
            "target_time": self._target_time,
            "dt_follows_cloth": self._dt_follows_cloth,
            # SUNDIALS' memory cannot be saved: the resumed run restarts its integrator
            "integrator_restarts": self._spec.error_controlled,
        }

    @classmethod
    def from_state(cls, state) -> Simulation:
        """Rebuilds a simulation from `state`'s dict; the next step gives the same numbers, bit
        for bit, as the next step of the simulation it was taken from (see `yore.state` for the
        two options that keep a factor across steps and so continue only to solver
        tolerance). Raises ValueError on a malformed state."""
        check_state_keys(state)
        cloth = Cloth.from_state(state["cloth"])
        # A state holds every option as it ran, defaults included (also those of modes not in
        # use): none of them is a user's choice to judge.
        sim = cls.__new__(cls)
        sim._build(
            cloth,
            state["integrator"],
            state["dt"],
            state["gravity"],
            as_saved(state["integrator"], state["options"]),
            given=(),
        )
        history = state["history"]
        if history is not None:
            fields = (*sim._spec.history(sim._options), "dt")
            check_history(history, fields, sim._integrator_name)
            sim._integrator.set_history(cloth, history)
        memory = state.get("projection_memory")
        if memory is not None:
            sim._integrator.set_projection_memory(*check_projection_memory(memory))
        target = state["target_time"]
        sim._target_time = None if target is None else float(target)
        follows = state.get("dt_follows_cloth", False)
        if not isinstance(follows, (bool, np.bool_)):
            raise ValueError(f"dt_follows_cloth must be a bool, got {follows!r}")
        sim._dt_follows_cloth = bool(follows) and sim._spec.conditionally_stable
        return sim

    # -- stepping ---------------------------------------------------------------------------
    def step(self, n: int = 1, progress=None) -> None:
        """Advances ``n`` steps of ``dt``.

        Raises ``yore.SimulationDiverged`` (with ``.step``, ``.time``, ``.dt``, ``.stable_dt``)
        if the run blows up; the cloth is then restored to its state before this call.
        ``progress``: True/False forces a progress bar
        on/off; None shows one when the run takes longer than a few seconds.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n must be a non-negative integer, got {n!r}")
        if n > MAX_STEPS:
            raise ValueError(
                f"n: {n} steps in one call is more than the limit of {MAX_STEPS}; "
                "call step repeatedly for longer runs"
            )
        self._run(int(n), progress)

    def advance(self, seconds: float, progress=None) -> int:
        """Advances by ``seconds`` of simulated time in whole steps; returns the number of steps.

        Repeated calls aim at the sum of the requested durations, so a loop of
        ``advance(1/30)`` stays within dt/2 of the frame times instead of drifting. The
        error-controlled integrators (cvode, arkode, bdf2 and tr-bdf2 with dt="auto") land
        exactly on the time asked: whole output intervals, then one shortened to the target.
        """
        if not _DURATION.test(seconds)[0]:
            raise ValueError(f"seconds must be {_DURATION.expected}, got {show_value(seconds)}")
        seconds = float(seconds)
        start = self.time
        if self._target_time is not None and abs(self._target_time - start) <= 0.5 * self._dt:
            start = self._target_time
        target = start + seconds
        ratio = (target - self.time) / self._dt
        if not ratio <= MAX_STEPS + 1:  # (1e308 s overflowed the step count: OverflowError)
            raise ValueError(
                f"advance: {seconds:g} s at dt = {self._dt:.6g} s is {ratio:.4g} "
                f"steps, more than the limit of {MAX_STEPS} per call"
            )
        if self._error_controlled:
            # dt is an output interval: whole intervals, then one to the target itself
            steps = max(0, int(np.floor(ratio * (1 + 1e-12))))
        else:
            steps = max(0, int(round(ratio)))
        if steps > MAX_STEPS:
            raise ValueError(
                f"advance: {seconds:g} s at dt = {self._dt:.6g} s is {steps} steps, "
                f"more than the limit of {MAX_STEPS} per call"
            )
        self._run(steps, progress)
        if self._error_controlled:
            rest = target - self.time
            if rest > 1e-9 * self._dt:
                self._run(1, progress, dt=rest)
                steps += 1
        self._target_time = target
        return steps

    def settle(
        self,
        max_seconds: float = 10.0,
        tolerance: float = 0.02,
        progress=None,
        check_stability: bool = True,
    ) -> dict:
        """Brings the cloth to rest at a static equilibrium before an experiment, by proximal
        point iteration (pseudo-time stepping): backward-Euler steps of `yore.settling.SETTLE_DT` from rest,
        the velocities zeroed after each, so every step minimises the potential plus
        ½‖x − xₖ‖²_M / h² and the sequence descends to a local minimum of the potential
        (gravity, springs, bending) — whatever the stiffness, and without simulating the
        swings. Each step is solved by Newton (Levenberg–Marquardt shifted, tight tolerance)
        in an integrator of its own: this simulation's integrator, options and dt are not
        used or changed. It stops when the residual acceleration of the cloth at rest, the
        mass-weighted RMS of M⁻¹ f (m/s², f the net force at zero velocity), is at most
        ``tolerance`` (0.02 is 0.2 % of gravity) and the state is stable, or after
        ``max_seconds`` of pseudo-time. A small residual alone cannot tell a minimum from a
        saddle: a flat stretched sheet is in balance before it wrinkles. So, with
        ``check_stability`` (the default), a state that meets the tolerance is accepted only if
        the true Hessian of the potential plus M/h² is positive definite (a Cholesky
        factorization succeeds); otherwise it is a saddle, the free vertices are moved by
        random displacements of ``yore.settling.SETTLE_PERTURBATION`` mean rest lengths (RMS; a fixed seed)
        and the relaxation goes on, at most ``yore.settling.SETTLE_MAX_ESCAPES`` times. Afterwards the
        velocities are zero and the clock is where it was, so strokes and outputs keep their
        times; BDF2 starts afresh (the velocities were edited).

        Returns {"seconds": pseudo-time spent, "steps": steps taken, "converged": bool,
        "residual_acceleration": the last step's, m/s², "saddles_escaped": saddles pushed off,
        "stable": whether the last state passed the stability test (None when it was not
        tested)}. Raises ValueError for bad arguments or a cloth with driven vertices (a driven
        cloth has no rest to settle to), SimulationDiverged if a step does."""
        started = _time.perf_counter()
        try:
            result = settling.settle(
                self._cloth, self._gravity, max_seconds, tolerance, progress, check_stability
            )
        finally:
            self._wall_seconds += _time.perf_counter() - started
        self._target_time = None
        return result

    def _run(self, steps: int, progress, dt=None) -> None:
        if steps == 0:
            return
        dt = self._dt if dt is None else dt
        cloth = self._cloth
        saved = (cloth.positions, cloth.velocities, cloth.time)  # copies
        before = self._integrator.statistics
        analyzed_before = before.phases.get("analyze_seconds", 0.0)
        unconverged_before = before.counters.get("unconverged_steps", 0)
        done, batch, bar = 0, 1, None
        started = _time.perf_counter()
        try:
            while done < steps:
                count = min(batch, steps - done)
                self._integrator.advance(self._cloth, self._gravity, dt, count)
                if self._pending_reports:
                    analyzed = self._integrator.statistics.phases.get("analyze_seconds", 0.0)
                    for report in self._pending_reports:
                        report.reanalyze_seconds = analyzed - analyzed_before
                    self._pending_reports = []
                done += count
                elapsed = _time.perf_counter() - started
                rate = done / max(elapsed, 1e-9)
                batch = max(1, int(rate * _BATCH_SECONDS))
                if bar is None and progress is not False and done < steps:
                    remaining = (steps - done) / rate
                    # The rate is trusted only after a few batches (the first step also prepares).
                    if progress or (
                        elapsed > 2.5 * _BATCH_SECONDS
                        and elapsed + remaining > progress_bars.AFTER_SECONDS
                    ):
                        bar = progress_bars.open_bar(steps, done, "yore", progress)
                elif bar is not None:
                    bar.update(count)
                    bar.set_postfix_str(f"t={self.time:.3f} s")
        except SimulationDiverged as error:
            # Batches before the failing one may already hold a growing instability: go back to
            # the state before this call, which the caller knows to be good.
            self._restore(saved)
            error.args = (
                f"{error.args[0]} The cloth was restored to t = {saved[2]:.6g} s, "
                "its state before this call.",
            )
            raise
        except NotPositiveDefinite as error:
            # A step's matrix (M/dt² + the projected stiffness) failed to factor: with a dt far
            # beyond the cloth's time scales the mass term sinks below the stiffness's round-off
            self._restore(saved)
            error.args = (
                f"{error.args[0]} (a step of dt = {dt:g} s from t = {saved[2]:.6g} s; a smaller "
                "dt keeps the mass term M/dt² above the stiffness's round-off). The cloth was "
                f"restored to t = {saved[2]:.6g} s.",
            )
            raise
        finally:
            self._wall_seconds += _time.perf_counter() - started
            if bar is not None:
                bar.close()
        self._warn_unconverged(steps, unconverged_before)

    def _restore(self, saved) -> None:
        """Puts the cloth back to ``saved`` (positions, velocities, time)."""
        cloth = self._cloth
        cloth.positions, cloth.velocities = saved[0], saved[1]
        cloth.time = saved[2]

    def _warn_unconverged(self, steps, unconverged_before) -> None:
        """One RuntimeWarning per call for the steps it accepted unconverged, if any."""
        after = self._integrator.statistics.counters
        unconverged = after.get("unconverged_steps", 0) - unconverged_before
        if unconverged:
            # once per call: the steps were taken at their last iterate, never silently
            cap, tolerance = self._spec.cap
            detail = (
                f"reached the iteration cap ({cap} = {self._options[cap]}) before the "
                f"tolerance ({tolerance} = {self._options[tolerance]:g})"
            )
            if "last_error_estimate" in after:
                detail += (
                    f" (last error estimate {after['last_error_estimate']:.3g} mean rest lengths)"
                )
            warnings.warn(
                f"{self._integrator_name}: {unconverged} of {steps} steps {detail}; "
                "they were accepted unconverged "
                "(stats['counters']['unconverged_steps'])",
                RuntimeWarning,
                stacklevel=4,
            )

    # -- strokes ----------------------------------------------------------------------------
    def stroke(self, path, options=None, **changes) -> StrokeReport:
        """Adds wrinkles along a stroke (the paper's partial area expansion).

        path : a `yore.StrokePath` — ``StrokePath.world(points)`` (a 3-D polyline near the
        cloth, metres; a bare (k, 3) array means this), ``StrokePath.screen(pixels, camera)``
        (pixels of a `yore.Camera`: rays through the current surface, nearest hit) or
        ``StrokePath.material(uv)`` (the cloth's rest-pattern coordinates).
        options : a `yore.StrokeOptions` (or a dict of its fields; None: the defaults), and
        ``changes`` any of its fields by name: expansion (eq. (1): 1.1), mass_scale (0.95 or
        "conserve"), width (m; None: the faces the stroke crosses), growth ("paper" |
        "isotropic" | "along" | "across"), refine (1→4 passes of the band first),
        max_distance (3-D paths: default 5 % of the cloth's bounding-box diagonal), smooth
        (rest-length smoothing as the last stage; its result lands in
        ``report.extra["smoothing"]``). See `yore.stroke` for the rules.
        Returns a `yore.stroke.StrokeReport`; raises `yore.StrokeMissed` if nothing is hit,
        ValueError on bad input.
        """
        if self._cloth.face_count == 0:
            raise ValueError("a spring network has no faces to stroke")
        path = StrokePath.of(path)
        options = StrokeOptions.of(options, **changes)
        if options.max_distance is not None and path.space != "world":
            raise ValueError(
                f"max_distance is for 3-D (world) paths, not a {path.space} path "
                "(its samples are found by rays or in the rest pattern)"
            )
        report = self._trace_and_apply(path, options)
        if options.smooth is not None:
            smooth = options.smooth
            report.extra["smoothing"] = self.smooth_rest_lengths(
                iterations=smooth["iterations"],
                strength=smooth["strength"],
                region="all" if smooth["region"] == "all" else None,
                conserve=smooth["conserve"],
            )
        return report

    def _trace_and_apply(self, path, options) -> StrokeReport:
        """The stroke traced in its path's space (closest points, rays or the rest pattern)
        and applied."""
        if path.space == "world":
            max_distance = options.max_distance
            if max_distance is None:
                X = self._cloth.positions
                max_distance = 0.05 * float(np.linalg.norm(X.max(axis=0) - X.min(axis=0)))
            return self._apply_stroke("closest", path, options, max_distance=max_distance)
        if path.space == "screen":
            d0, dx, dy = path.camera.pixel_rays()
            return self._apply_stroke(
                "rays",
                path,
                options,
                eye=np.asarray(path.camera.eye, float),
                base_direction=d0,
                direction_per_pixel_x=dx,
                direction_per_pixel_y=dy,
            )
        uv = self._cloth.material_coordinates
        if uv is None:
            raise ValueError(
                "the cloth has no material coordinates; set cloth.material_coordinates (n×2) first"
            )
        tolerance = 1e-9 * float(np.linalg.norm(uv.max(axis=0) - uv.min(axis=0)))
        return self._apply_stroke("material", path, options, max_distance=tolerance)

    def stroke_screen(self, points_px, camera, **options) -> StrokeReport:
        """Deprecated: ``stroke(StrokePath.screen(points_px, camera), **options)``."""
        warnings.warn(
            "Simulation.stroke_screen is deprecated; use "
            "sim.stroke(yore.StrokePath.screen(points_px, camera), ...)",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.stroke(StrokePath.screen(points_px, camera), **options)

    def stroke_material(self, points_uv, **options) -> StrokeReport:
        """Deprecated: ``stroke(StrokePath.material(points_uv), **options)``."""
        warnings.warn(
            "Simulation.stroke_material is deprecated; use "
            "sim.stroke(yore.StrokePath.material(points_uv), ...)",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.stroke(StrokePath.material(points_uv), **options)

    def _apply_stroke(self, trace, path, options, **trace_options):
        """Applies the stroke in one call of the core, which traces it (again after each
        refinement pass) the way ``trace`` names ("closest", "rays" or "material")."""
        report = apply_stroke(self._cloth, trace, path.points, options, **trace_options)
        self._pending_reports.append(report)
        self._last_stroke = report
        if self._dt_follows_cloth:
            # never raised (the run keeps its step), lowered when the stroke lowered the bound
            lowered = default_explicit_dt(self._cloth)
            if lowered < self._dt:
                report.extra["dt_before"] = self._dt
                report.extra["dt_after"] = lowered
                self._dt = lowered
        return report

    def smooth_rest_lengths(
        self,
        iterations=SMOOTHING_DEFAULTS["iterations"],
        strength=SMOOTHING_DEFAULTS["strength"],
        region=None,
        conserve=SMOOTHING_DEFAULTS["conserve"],
    ) -> dict:
        """Laplacian smoothing of rest lengths (the paper's remedy for uneven surfaces).

        The smoothed field is the ratio rest / reference length of each spring (1 for untouched
        springs, ``expansion`` for a stroke's new ones); each iteration moves a spring's ratio by
        ``strength`` towards the mean ratio around its two ends. ``region``: vertex indices whose
        springs are smoothed, "all", or None for the last stroke's region and one ring around it.
        With ``conserve`` (default) smoothing redistributes the expansion and creates none: the
        smoothed excess (rest − reference) of the smoothed springs is scaled so that its sum, the
        added rest length over the region, is what it was (averaging ratios alone spreads
        a short spring's ratio to longer neighbours and raised a stroke's added rest length by
        29 %, 0.550 → 0.708 m). ``conserve=False`` is the plain ratio smoothing.
        No re-analysis follows (the topology is unchanged). Returns the ratio-field roughness
        before and after (`yore.metrics.rest_ratio_roughness`) and the added rest length (m)
        before and after.

        Raises ValueError unless ``iterations`` is an integer in [0, `MAX_SMOOTHING_ITERATIONS`],
        ``strength`` a number in (0, 1] and ``region`` None, "all" or integer vertex indices in
        range (floats and booleans are refused, not rounded).
        """
        smoothing.checked_arguments(iterations, strength, conserve)  # before the region
        if region is None:
            if self._last_stroke is None:
                raise ValueError("no stroke yet: give region (vertex indices or 'all')")
            region = smoothing.around_faces(self._cloth, self._last_stroke.region_faces)
        return smoothing.smooth_rest_lengths(self._cloth, iterations, strength, region, conserve)

    # -- measurements -----------------------------------------------------------------------
    def energy(self) -> Energy:
        """Kinetic, spring, gravitational and (quadratic) bending energy and their total, J."""
        return Energy(self._cloth.energy(self._gravity))

    @property
    def restarts_on_resume(self) -> bool:
        """Whether a simulation rebuilt from this one's `state` starts its integrator afresh
        (cvode and arkode: SUNDIALS' step history is not saved; see `restart_integrator`)."""
        return bool(self._spec.error_controlled)

    def restart_integrator(self) -> None:
        """Makes an error-controlled integrator (cvode, arkode) start afresh at the next step,
        as it does in a simulation rebuilt from a `state` (SUNDIALS' step history cannot be
        saved). A run that calls this wherever another was resumed takes the same steps as that
        one from there, bit for bit; ``yore run`` calls it at every frame. No effect on the other
        integrators, whose history the state keeps."""
        if self._spec.error_controlled:
            self._integrator.request_restart()

    def stable_dt(self) -> float:
        """Estimated largest stable explicit time step for the cloth as it is now, s."""
        return self._cloth.stable_time_step()

    @property
    def stats(self) -> Statistics:
        """Counters, wall time per phase (s) and the model terms that are active.

        ``phases``: cumulative wall time per phase (explicit: forces, update, constraints,
        checks; implicit: assemble, analyze, factorize, solve). ``counters``: cumulative counts
        and the last step's figures (implicit: newton_iterations, line_search_backtracks,
        analyses, factorizations, factor_nonzeros, factor_flops, ordering, last_residual, ...).
        Cheap enough to read after every step; the stable explicit step is not here:
        ``stable_dt()`` estimates it (an eigenvalue run that costs about half an implicit step,
        36 ms at 64², 0.3 s at 128²).
        """
        cloth = self._cloth
        statistics = self._integrator.statistics
        steps, phases, counters = statistics.steps, statistics.phases, statistics.counters
        kinds = cloth.springs.kind
        damping = cloth.springs.damping
        active = {
            "gravity": bool(np.any(self._gravity != 0.0)),
            "spring_damping": bool(np.any(damping > 0.0)),
            "drag": cloth.drag > 0.0,
            "bending_springs": int(np.count_nonzero(kinds == 1)),
            "strain_limiting": self._options.get("strain_limit") is not None,
            "fixed_vertices": int(cloth.fixed_vertices.size),
            "driven_vertices": int(cloth.driven_vertices.size),
        }
        if cloth.bending in ("quadratic", "hinge"):
            # the constant-matrix bending term, reported for cloths that chose it: the number
            # of interior edges (hinges) of its mesh, 0 when the modulus is 0 (no term at all)
            active["quadratic_bending"] = (
                int(cloth.bending_hinges) if cloth.bending_modulus > 0.0 else 0
            )
        if cloth.stretch == "membrane":
            # the continuum membrane, reported for cloths that chose it: its faces, and those
            # whose rest triangle was clamped or that are collapsed now
            status = cloth.membrane_status()
            active["membrane_faces"] = int(cloth.face_count)
            active["membrane_clamped_rest_faces"] = int(status["clamped_rest_faces"])
            active["membrane_collapsed_faces"] = int(status["collapsed_faces"])
        return Statistics(
            {
                "integrator": self._integrator_name,
                "dt": self._dt,
                "time": self.time,
                "steps": steps,
                "wall_seconds": self._wall_seconds,
                "steps_per_second": steps / self._wall_seconds if self._wall_seconds > 0 else 0.0,
                "phases": phases,
                "counters": counters,
                "active_terms": active,
                "vertices": cloth.vertex_count,
                "springs": cloth.spring_count,
                "topology_version": cloth.topology_version,
                "threads": {
                    "configured": _core.max_threads(),
                    "blas": _core.blas_threads(),
                    **getattr(self._integrator, "thread_usage", {}),
                },
            }
        )

    def __repr__(self) -> str:
        return (
            f"<yore.Simulation {self._integrator_name} dt={self._dt:.3g} s "
            f"t={self.time:.4g} s, {self._cloth!r}>"
        )


_DURATION = rules.real(0.0, low_open=False, expected="a finite number >= 0")
_FLAG = rules.flag()
