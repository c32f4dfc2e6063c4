"""The modes of the integrators that some of their options serve (`yore.options.check_modes`
refuses an option given outside its mode: it would do nothing, silently)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Mode:
    """A mode of an integrator that some of its options serve: ``setting`` is the option whose
    value selects it (the mode counts only for integrators that take that option), ``on`` tells
    from that value whether the mode is in use, ``needs`` says how a user selects it, ``off``
    how the other modes read in a sentence, ``remedy`` what to pass instead of dropping."""

    setting: str
    on: Callable[[object], bool]
    needs: str
    off: Callable[[object], str]
    remedy: str


_ADAPTIVE_MODE = Mode(
    "adaptive",
    bool,
    'dt="auto" (error-controlled steps)',
    lambda value: "with a fixed dt",
    'pass dt="auto"',
)
_LAGGED_MODE = Mode(
    "lagged_factorization",
    bool,
    "lagged_factorization=True (CG on a kept factor)",
    lambda value: "without lagged_factorization",
    "pass lagged_factorization=True",
)
_PCG_MODE = Mode(
    "solver",
    lambda value: value == "pcg",
    'solver="pcg"',
    lambda value: f'with solver="{value}"',
    'pass solver="pcg"',
)
_CHOLMOD_MODE = Mode(
    "solver",
    lambda value: value == "cholmod",
    'solver="cholmod"',
    lambda value: f'with solver="{value}"',
    'pass solver="cholmod"',
)
_STRAIN_LIMIT_MODE = Mode(
    "strain_limit",
    lambda value: value is not None,
    "a strain_limit (e.g. strain_limit=1.1)",
    lambda value: "without one",
    "give strain_limit",
)
_STALE_PCG_MODE = Mode(
    "rebuild",
    lambda value: value == "stale-pcg",
    'rebuild="stale-pcg"',
    lambda value: f'with rebuild="{value}"',
    'pass rebuild="stale-pcg"',
)
_CHEBYSHEV_MODE = Mode(
    "acceleration",
    lambda value: value == "chebyshev",
    'acceleration="chebyshev"',
    lambda value: f'with acceleration="{value}"',
    'pass acceleration="chebyshev"',
)

#: The options that act only in one mode of their integrator (option → `Mode`), each read off
#: the C++ core: rtol, atol and max_steps only in bdf2's and tr-bdf2's error-controlled steps
#: (adaptive_steps.cpp, implicit.cpp); the lagged factor's CG bounds only with
#: lagged_factorization (newton.cpp); the CG backend's only with solver "pcg", CHOLMOD's
#: factorization and amalgamation only with solver "cholmod" (linear_solver.cpp: eigen-ldlt and
#: pcg take neither); strain_limit_passes only with a strain limit (explicit.cpp); local-global's
#: stale CG only with rebuild "stale-pcg" (local_global.cpp) and chebyshev_rho only with
#: Chebyshev acceleration (`make_local_global` passes 0 without it). `check_modes` refuses an
#: option given outside its mode: it would do nothing, silently. Not here, though equally idle:
#: newton_tol, max_newton, step_tol and truncation_fraction with linearized=True (one Newton
#: step, newton.cpp) — benchmarks.crossover names truncation_fraction on its linearized rows so
#: that their resolved options match its recorded runs (docs/limitations.md).
MODE_ONLY = {
    **dict.fromkeys(("rtol", "atol", "max_steps"), _ADAPTIVE_MODE),
    **dict.fromkeys(("lag_max_cg_iterations", "lag_cg_tol"), _LAGGED_MODE),
    **dict.fromkeys(("pcg_tol", "pcg_max_iterations"), _PCG_MODE),
    **dict.fromkeys(("factorization", "supernode_relaxation"), _CHOLMOD_MODE),
    "strain_limit_passes": _STRAIN_LIMIT_MODE,
    **dict.fromkeys(("stale_pcg_max_iterations", "stale_pcg_tol"), _STALE_PCG_MODE),
    "chebyshev_rho": _CHEBYSHEV_MODE,
}
