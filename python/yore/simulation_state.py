"""A simulation's state as a document: the keys `yore.Simulation.state` writes and
`Simulation.from_state` reads back, and the checks of its parts a hand-made or older state may
get wrong (which keys, the integrator's history, Newton's projection memory), each a ValueError
that names the part; and the options of states saved before today's defaults, as they ran."""

from __future__ import annotations

from .documents import result_type
from .options import INTEGRATOR_SPECS

__all__ = [
    "SimulationState",
    "STATE_KEYS",
    "OPTIONAL_STATE_KEYS",
    "check_state_keys",
    "check_history",
    "check_projection_memory",
    "as_saved",
]

#: The keys every simulation state has.
STATE_KEYS = frozenset(
    {"cloth", "integrator", "options", "dt", "gravity", "history", "target_time"}
)
#: Keys absent from states saved before they existed: projection_memory (then: none yet),
#: dt_follows_cloth (then: False), integrator_restarts (then: False).
OPTIONAL_STATE_KEYS = frozenset({"projection_memory", "dt_follows_cloth", "integrator_restarts"})


#: `Simulation.state()`: the cloth's state, the integrator's name and options as they ran, dt,
#: gravity, the scheme's history, Newton's projection memory, the time `advance` aims at,
#: whether dt follows the cloth, and whether a resumed run restarts its integrator.
SimulationState = result_type(
    "SimulationState",
    (
        "cloth",
        "integrator",
        "options",
        "dt",
        "gravity",
        "history",
        "projection_memory",
        "target_time",
        "dt_follows_cloth",
        "integrator_restarts",
    ),
    """A simulation's state (`yore.Simulation.state`), a dict whose keys are also attributes:
    ``cloth`` (`yore.Cloth.state`), ``integrator``, ``options`` (as resolved), ``dt``,
    ``gravity``, ``history`` (None without one), ``projection_memory``, ``target_time``,
    ``dt_follows_cloth`` and ``integrator_restarts``.""",
)


def check_state_keys(state) -> None:
    """A dict with the state's keys, and its options a dict; ValueError otherwise."""
    if not isinstance(state, dict) or not STATE_KEYS <= set(state) <= STATE_KEYS | (
        OPTIONAL_STATE_KEYS
    ):
        got = sorted(state) if isinstance(state, dict) else type(state).__name__
        raise ValueError(f"not a simulation state: expected keys {sorted(STATE_KEYS)}, got {got}")
    options = state["options"]
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict, got {type(options).__name__}")


def check_history(history, fields, integrator) -> None:
    """An integrator's history: a dict of its ``fields`` (the last one "dt"; "next_dt" may
    come too), for an integrator that keeps one (``fields`` longer than "dt" alone)."""
    if (
        len(fields) == 1
        or not isinstance(history, dict)
        or not set(fields) <= set(history) <= {*fields, "next_dt"}
    ):
        got = sorted(history) if isinstance(history, dict) else type(history).__name__
        expected = (
            "None (it keeps none)"
            if len(fields) == 1
            else f"None or a dict with {', '.join(fields)}"
        )
        raise ValueError(f"history of integrator {integrator!r}: expected {expected}, got {got}")


def check_projection_memory(memory) -> tuple:
    """Newton's projection memory: (exact_skip, exact_backoff, shift, radius) of its dict."""
    keys = {"exact_skip", "exact_backoff"}
    optional = {"shift", "radius"}
    if not isinstance(memory, dict) or not keys <= set(memory) <= keys | optional:
        raise ValueError(
            "projection_memory must be a dict with exact_skip, "
            f"exact_backoff and (optional) shift and radius, got {memory!r}"
        )
    return (
        memory["exact_skip"],
        memory["exact_backoff"],
        memory.get("shift", 0.0),
        memory.get("radius", 0.0),
    )


def as_saved(integrator, options):
    """A state's options as its simulation ran them. States saved before the truncation test
    existed (no ``truncation_fraction``) ran Newton without it, without the mixed matrices
    unless asked, and with projection None meaning steihaug (the clamp for linearized or pcg):
    so they continue."""
    if (
        integrator not in INTEGRATOR_SPECS
        or not INTEGRATOR_SPECS[integrator].newton
        or not isinstance(options, dict)
        or "truncation_fraction" in options
    ):
        return options
    options = dict(options, truncation_fraction=0.0, mixed=options.get("mixed", False))
    if options.get("projection") is None and options.get("adaptive_projection") is None:
        options["projection"] = (
            "clamp" if options.get("linearized") or options.get("solver") == "pcg" else "steihaug"
        )
    return options
