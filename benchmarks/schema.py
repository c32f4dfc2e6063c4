"""The shape of every benchmark's JSON: keys each file and each row must have. Checked by the
tests (on smoke-size runs) and by benchmarks.report before it writes docs/results.md."""

from __future__ import annotations

MACHINE = {"cpu", "logical_cores", "python", "yore", "blas_loaded", "thread_environment"}

SCHEMAS = {
    "build_ab": (
        {"benchmark", "machine", "quick", "baseline_label", "rounds", "rows", "this_runs"},
        {
            "grid",
            "factorize_seconds",
            "analyze_seconds",
            "newton_iteration_cpu_seconds",
            "explicit_cpu_seconds",
        },
    ),
    "explicit_step": (
        {
            "benchmark",
            "machine",
            "rows",
            "speedup_best_threads_vs_1",
            "stream_bandwidth_bytes_per_second",
        },
        {
            "grid",
            "vertices",
            "springs",
            "threads",
            "step_seconds_median",
            "bytes_per_step",
            "bandwidth_bound_seconds",
            "over_bandwidth_bound",
        },
    ),
    "factorization": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "dgemm_gflops",
            "dgemm_gflops_two_threads",
            "kernels",
            "kernel_summary",
            "targets",
        },
        {
            "grid",
            "dofs",
            "ordering_requested",
            "ordering_used",
            "supernode_relaxation",
            "blas_threads",
            "factor_nonzeros",
            "factor_flops",
            "analyze_seconds",
            "factorize_seconds",
            "factorize_gflops",
            "dgemm_gflops",
            "factorize_fraction_of_dgemm",
        },
    ),
    "implicit_step": (
        {"benchmark", "machine", "rows", "dense_matmul_gflops", "targets"},
        {
            "grid",
            "dofs",
            "ordering_used",
            "factor_nonzeros",
            "factor_flops",
            "explicit_step_seconds",
            "assemble_seconds",
            "factorize_seconds",
            "solve_seconds",
            "analyze_seconds",
            "step_over_factorize",
            "analyze_over_factorize",
            "analyze_over_explicit_step",
            "factorize_gflops",
            "factorize_fraction_of_dense",
        },
    ),
    "crossover": (
        {
            "benchmark",
            "machine",
            "rows",
            "summary",
            "quick",
            "clock",
            "families",
            "families_unavailable",
            "thresholds",
            "reference_tolerance",
            "sample_times",
            "settings",
            "sweep",
            "cells",
            "statuses",
        },
        {
            "size",
            "stretch_stiffness",
            "bending",
            "horizon",
            "method",
            "dt",
            "steps",
            "reference_converged",
            "diverged",
            "aborted",
        },
    ),
    "long_horizon": (
        {
            "benchmark",
            "machine",
            "rows",
            "summary",
            "quick",
            "families",
            "thresholds",
            "measures",
            "floor_fraction",
            "settings",
            "statuses",
        },
        {
            "size",
            "stretch_stiffness",
            "bending",
            "horizon",
            "method",
            "dt",
            "steps",
            "diverged",
            "aborted",
        },
    ),
    "numerical_damping": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "integrators",
            "integrators_unavailable",
            "rho_infinity",
            "chain",
            "sheet_families",
            "sheet_families_unavailable",
            "sheet_settings",
            "sheet_references",
            "sheet_rows",
            "summary",
        },
        {
            "integrator",
            "rho_infinity",
            "omega_h",
            "steps_per_period",
            "decay_per_step",
            "analytic_decay_per_step",
            "relative_difference",
            "energy_kept_per_period",
            "analytic_energy_kept_per_period",
            "period_elongation",
            "analytic_period_elongation",
        },
    ),
    "error_control": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "horizon",
            "output_interval",
            "velocity_time",
            "thresholds",
            "cells",
        },
        {"size", "stiffness", "integrator", "error", "cpu_seconds"},
    ),
    "vibration_floor": (
        {"benchmark", "machine", "rows", "quick", "horizon", "cells"},
        {"size", "stiffness", "family", "setting"},
    ),
    "wrinkles": (
        {"benchmark", "machine", "rows", "quick", "settings", "strokes", "summary"},
        {
            "label",
            "model",
            "length",
            "width",
            "strain",
            "edge_length",
            "bending_modulus",
            "mean_edge",
            "predicted_wavelength",
            "wavelength",
            "flat",
            "zigzag",
            "amplitude",
            "flat_state_stable",
            "cpu_seconds",
        },
    ),
    "bending_consistency": (
        {"benchmark", "machine", "rows", "quick", "radius", "bending_modulus", "cost", "summary"},
        {"kind", "edge_length", "vertices", "faces", "quadratic", "hinge"},
    ),
    "interpolation_bending": (
        {"benchmark", "machine", "rows", "quick", "settings", "summary"},
        {"kind", "strain", "degrees", "vertices", "mean_edge", "kh", "c_leak", "c_compression"},
    ),
    "rebuild_cost": (
        {
            "benchmark",
            "machine",
            "rows",
            "dense_matmul_gflops",
            "quick",
            "local_global",
            "quasi_newton",
        },
        {
            "case",
            "ordering_used",
            "dofs",
            "factor_nonzeros",
            "factor_flops",
            "explicit_step_seconds",
            "implicit_step_seconds",
            "factorize_seconds",
            "analyze_seconds",
            "step_after_stroke_seconds",
            "analyze_over_factorize",
            "analyze_over_implicit_step",
            "analyze_over_explicit_step",
            "factorize_gflops",
            "factorize_fraction_of_dense",
        },
    ),
    "scaling": (
        {"benchmark", "machine", "rows", "slopes", "quick"},
        {"grid", "vertices", "explicit_step_seconds", "implicit_linearized_step_seconds"},
    ),
    "newton_projection": (
        {"benchmark", "machine", "rows", "quick", "target", "target_met"},
        {
            "scene",
            "projection",
            "median_iterations",
            "mean_iterations",
            "max_iterations",
            "rejected_per_step",
            "unconverged_steps",
            "cpu_seconds_per_simulated_second",
            "deviation",
            "step_deviation",
            "step_deviation_over_truncation",
        },
    ),
    "factor_reuse": (
        {"benchmark", "machine", "rows", "quick", "dt", "stretch_stiffness", "variants"},
        {
            "variant",
            "resolution",
            "steps",
            "planned_steps",
            "stopped_by_cpu_cap",
            "newton_per_step",
            "fresh_factorizations_per_step",
            "factor_reuses_per_step",
            "thrown_away_per_step",
            "unconverged_steps",
            "cpu_seconds_per_simulated_second",
            "deviation_from_default",
        },
    ),
    "newton_stop": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "dt",
            "stretch_stiffness",
            "resolution",
            "duration",
            "size",
            "reference_dt",
            "reference_check",
            "default_fraction",
            "goal",
            "goal_met",
        },
        {
            "integrator",
            "truncation_fraction",
            "default",
            "steps",
            "iterations",
            "mean_iterations",
            "median_iterations",
            "max_iterations",
            "thrown_away_per_step",
            "unconverged_steps",
            "cpu_seconds_per_simulated_second",
            "error",
            "rms_error",
            "from_tight",
            "from_tight_over_tight_error",
        },
    ),
    "newton_predictor": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "resolution",
            "stretch_stiffness",
            "duration",
            "size",
            "sample_dt",
            "comparisons",
            "goal",
            "goal_met",
        },
        {
            "scheme",
            "run",
            "predictor",
            "dt",
            "steps",
            "stages",
            "newton_iterations",
            "factorizations",
            "thrown_away",
            "iterations_per_stage",
            "factorizations_per_stage",
            "factorizations_per_step",
            "kinetic_energy",
        },
    ),
    "truncation_fraction": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "size",
            "duration",
            "default_fraction",
            "references",
        },
        {"cell", "dt", "truncation_fraction"},
    ),
    "sensitivity": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "left_out",
            "epsilons",
            "seed",
            "thresholds",
            "reference_fraction",
            "floor_aware",
        },
        {
            "size",
            "stretch_stiffness",
            "bending",
            "horizon",
            "steps",
            "dt",
            "scale",
            "reference_converged",
            "reference_error",
            "repeat_distance",
            "floor",
            "growth",
            "judgeable",
            "cpu_seconds_per_run",
        },
    ),
    "threads": (
        {"benchmark", "machine", "rows", "cells", "target_ratio", "target_met", "quick"},
        {
            "scene",
            "load",
            "mode",
            "threads_configured",
            "threads_used",
            "step_seconds_median",
            "repeats",
        },
    ),
    "stability_map": (
        {"benchmark", "machine", "rows", "stiffness_values", "dt_values", "quick"},
        {"integrator", "stiffness", "dt", "state"},
    ),
    "pictures": (
        {
            "benchmark",
            "machine",
            "rows",
            "quick",
            "renderer",
            "start_seconds_median",
            "pick_seconds_median",
        },
        {"width", "height", "pixels", "factor", "vertices", "render_seconds_median", "repeats"},
    ),
    "stable_dt": (
        {"benchmark", "machine", "rows", "steps", "safety", "quick"},
        {
            "scene",
            "stiffness",
            "damped",
            "gershgorin_dt",
            "bound_dt",
            "estimate_dt",
            "found_dt",
            "default_dt",
            "default_ratio",
        },
    ),
}


#: keys of the "summary" table, where a benchmark's JSON has one the report reads
SUMMARIES = {
    "crossover": {"cells", "crossovers", "targets", "lines"},
    "long_horizon": {"cells", "targets", "lines", "table"},
    "numerical_damping": {"lines"},
}

#: further row tables of a benchmark's JSON beside "rows": {benchmark: {key: row keys}}; each
#: must be a non-empty list whose every row has the keys
TABLES = {
    "numerical_damping": {
        "sheet_rows": {
            "size",
            "stretch_stiffness",
            "family",
            "integrator",
            "dt",
            "steps",
            "duration",
            "diverged",
            "aborted",
        },
        "sheet_references": {"size", "trial_limit_dt", "reference_dt"},
    }
}


def check(payload: dict) -> None:
    """Raises ValueError naming the first missing key."""
    name = payload.get("benchmark")
    if name not in SCHEMAS:
        raise ValueError(f"unknown benchmark {name!r}")
    top, row_keys = SCHEMAS[name]
    missing = top - set(payload)
    if missing:
        raise ValueError(f"{name}: missing keys {sorted(missing)}")
    missing = MACHINE - set(payload["machine"])
    if missing:
        raise ValueError(f"{name}: machine info lacks {sorted(missing)}")
    missing = SUMMARIES.get(name, set()) - set(payload.get("summary", {}))
    if missing:
        raise ValueError(f"{name}: its summary lacks {sorted(missing)}")
    for table, keys in {"rows": row_keys, **TABLES.get(name, {})}.items():
        if not payload.get(table):
            raise ValueError(f"{name}: no {table}")
        for row in payload[table]:
            missing = keys - set(row)
            if missing:
                raise ValueError(f"{name}: a row of {table} lacks {sorted(missing)}: {row}")
