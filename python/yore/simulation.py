"""`yore.Simulation`: steps a `yore.Cloth` in time with a chosen integrator."""

from __future__ import annotations

import warnings

import numpy as np

from ._core import Cloth
from .checks import MIN_DT
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
from . import rules, settling, smoothing
from .results import Energy, Statistics, active_terms, simulation_statistics
from .step_runner import StepRunner, warn_unconverged
from .simulation_checks import (
    EXPLICIT_DT_SAFETY,
    check_integrator_and_options,
    checked_gravity,
    checked_step_count,
    default_explicit_dt,
    output_interval,
    steps_to,
)
from .simulation_state import (
    SimulationState,
    as_saved,
    check_history,
    check_projection_memory,
    check_state_keys,
)
from .stroke import StrokeOptions, StrokePath, StrokeReport, check_factor, trace_and_apply

__all__ = [
    "Simulation",
    "INTEGRATORS",
    "INTEGRATOR_OPTIONS",
    "EXPLICIT_DT_SAFETY",
    "default_explicit_dt",
]


#: Default time step of the implicit integrators, s (`yore.options.FIXED_DT`).
IMPLICIT_DT = FIXED_DT


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
        Integrator options, checked by name, type and range. Their names and defaults, per
        integrator, are ``yore.options.defaults(integrator)`` (None: decided from the others;
        `resolved_options` shows the decision); what each does is on the Integrators page of
        the documentation (its Options tables). The main ones: Newton's ``newton_tol``,
        ``max_newton``, ``truncation_fraction`` and ``projection``, the linear ``solver``,
        error control's ``rtol`` and ``atol`` (with dt="auto"), explicit's ``strain_limit``.
        A step that reaches the iteration cap is accepted, counted in
        ``stats["counters"]["unconverged_steps"]`` and warned about (a RuntimeWarning, once
        per call).

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
        self._runner = StepRunner()  # the steps' loop, and the wall time they took
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
    def state(self) -> SimulationState:
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
        return SimulationState(
            cloth=self._cloth.state(),
            integrator=self._integrator_name,
            options=dict(self.resolved_options),
            dt=self._dt,
            gravity=self._gravity.copy(),
            history=history,
            projection_memory=memory,
            target_time=self._target_time,
            dt_follows_cloth=self._dt_follows_cloth,
            # SUNDIALS' memory cannot be saved: the resumed run restarts its integrator
            integrator_restarts=self._spec.error_controlled,
        )

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
        self._run(checked_step_count(n), progress)

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
        steps = steps_to(target, self.time, self._dt, self._error_controlled, seconds)
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
        """Brings the cloth to rest at a static equilibrium before an experiment: backward-Euler
        steps of `yore.settling.SETTLE_DT` from rest, the velocities zeroed after each, descend
        to a local minimum of the potential without simulating the swings (`yore.settling` says
        how). This simulation's integrator, options and dt are not used or changed. It stops
        when the residual acceleration at rest (the mass-weighted RMS of M⁻¹ f, m/s²) is at
        most ``tolerance`` (0.02: 0.2 % of gravity) and, with ``check_stability``, the state is
        a minimum, not a saddle (a flat stretched sheet is in balance before it wrinkles: a
        saddle is pushed off by a small random displacement, at most
        `yore.settling.SETTLE_MAX_ESCAPES` times); or after ``max_seconds`` of pseudo-time.
        Afterwards the velocities are zero and the clock is where it was; BDF2 starts afresh.

        Returns {"seconds", "steps", "converged", "residual_acceleration" (m/s²),
        "saddles_escaped", "stable" (None when not tested)}. Raises ValueError for bad
        arguments or a cloth with driven vertices, SimulationDiverged if a step does."""
        result = self._runner.timed(
            lambda: settling.settle(
                self._cloth, self._gravity, max_seconds, tolerance, progress, check_stability
            )
        )
        self._target_time = None
        return result

    def _run(self, steps: int, progress, dt=None) -> None:
        if steps == 0:
            return
        unconverged_before = self._integrator.statistics.counters.get("unconverged_steps", 0)
        self._runner.run(
            self._integrator,
            self._cloth,
            self._gravity,
            self._dt if dt is None else dt,
            steps,
            progress,
            self._pending_reports,
            lambda: self.time,
        )
        warn_unconverged(
            self._integrator_name,
            self._spec,
            self._options,
            self._integrator.statistics.counters,
            steps,
            unconverged_before,
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
        report = self._record_stroke(trace_and_apply(self._cloth, path, options))
        if options.smooth is not None:
            smooth = options.smooth
            report.extra["smoothing"] = self.smooth_rest_lengths(
                iterations=smooth["iterations"],
                strength=smooth["strength"],
                region="all" if smooth["region"] == "all" else None,
                conserve=smooth["conserve"],
            )
        return report

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

    def _record_stroke(self, report):
        """A stroke just applied: its report waits for the next step's re-analysis time, is
        the last stroke (smoothing's default region), and lowers a default explicit dt that
        follows the cloth when the stroke lowered the bound (never raises it)."""
        self._pending_reports.append(report)
        self._last_stroke = report
        if self._dt_follows_cloth:
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
        statistics = self._integrator.statistics
        return simulation_statistics(
            self._cloth,
            integrator=self._integrator_name,
            dt=self._dt,
            steps=statistics.steps,
            wall_seconds=self._runner.wall_seconds,
            phases=statistics.phases,
            counters=statistics.counters,
            active_terms=active_terms(self._cloth, self._gravity, self._options),
            thread_usage=getattr(self._integrator, "thread_usage", {}),
        )

    def __repr__(self) -> str:
        return (
            f"<yore.Simulation {self._integrator_name} dt={self._dt:.3g} s "
            f"t={self.time:.4g} s, {self._cloth!r}>"
        )


_DURATION = rules.real(0.0, low_open=False, expected="a finite number >= 0")
_FLAG = rules.flag()
