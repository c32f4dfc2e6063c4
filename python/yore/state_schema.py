"""The state file's schema (`yore.state` reads and writes the files): every field of a
simulation's state declared once, in tables of `yore.rules` rules (`SIMULATION`, `CLOTH`,
`DRIVER`, `PROJECTION_MEMORY`), each checked by name, type, dtype, shape, range and finiteness,
with sizes consistent across the cloth, its constraints, drivers and the integrator's history;
what no single field can say (a spring joining a vertex to itself, the bending and membrane
fields that go together, the history the integrator keeps) is checked after the tables. Every
error names the file and the dotted field."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import rules
from ._core import Cloth
from .checks import MAX_TIME, MIN_DT
from .options import INTEGRATOR_OPTIONS, INTEGRATOR_SPECS, INTEGRATORS, check_option

__all__ = [
    "FieldChecker",
    "Array",
    "Maybe",
    "SIMULATION",
    "CLOTH",
    "DRIVER",
    "PROJECTION_MEMORY",
    "check_simulation",
    "show_value",
]


def show_value(value):
    return rules.describe(value)


def _got(value):
    return f"got {rules.describe(value)}"


def _index(mask):
    where = np.argwhere(mask)[0]
    return int(where[0]) if len(where) == 1 else tuple(int(i) for i in where)


# -- the rules of a state's values --------------------------------------------------------------


def _real(low=None, low_open=False, high=None):
    """A JSON number (Python's int or float, finite) within the bounds."""
    bounds = "" if low is None else f" {'>' if low_open else '>='} {low:g}"
    bounds += "" if high is None else f"{' and' if bounds else ''} <= {high:g}"
    return rules.real(
        low,
        high,
        low_open=low_open,
        expected=f"a finite number{bounds}",
        problem=_got,
        python_types=True,
    )


def _count(low, high):
    return rules.count(low, high, problem=_got, python_types=True)


#: A flag of a state file (JSON's true or false).
_FLAG = rules.flag("true or false", problem=_got, python_types=True)
#: Smallest positive normal double: a mass below it is refused (1/m would overflow).
_TINY = float(np.finfo(np.float64).tiny)


class Array(NamedTuple):
    """An array field: exactly ``dtype``; ``shape`` of lengths, each a number, None (any) or
    the name of a size the state sets ("n" vertices, "s" springs, "k" a driver's vertices);
    float arrays finite; entries in [low, high] ((low, high] with ``low_open``) or in
    ``allowed``. ``high`` may name a size too ("last": the largest vertex index)."""

    dtype: type
    shape: tuple
    low: object = None
    high: object = None
    low_open: bool = False
    allowed: tuple | None = None

    def rule(self, sizes) -> rules.Rule:
        """The `yore.rules.Rule` of this field in a state of these sizes."""
        shape = tuple(sizes[d] if isinstance(d, str) else d for d in self.shape)
        high = sizes[self.high] if isinstance(self.high, str) else self.high
        expected = (
            f"an array of dtype {np.dtype(self.dtype)} and shape ("
            + ", ".join("k" if d is None else str(d) for d in shape)
            + ("," if len(shape) == 1 else "")
            + ")"
        )

        def test(value):
            if (
                not isinstance(value, np.ndarray)
                or value.dtype != np.dtype(self.dtype)
                or value.ndim != len(shape)
                or any(d is not None and d != got for d, got in zip(shape, value.shape))
            ):
                return False, None
            if value.size:
                self._check_entries(value, high)
            return True, value

        return rules.custom(test, expected, problem=_got)

    def _check_entries(self, value, high):
        """`Invalid` naming the first entry out of the field's range."""
        tests = []  # (entries out of range, what was expected)
        if value.dtype.kind == "f":
            tests.append((~np.isfinite(value), "finite numbers"))
        if self.allowed is not None:
            phrase = "values in {" + ", ".join(map(str, self.allowed)) + "}"
            tests.append((~np.isin(value, self.allowed), phrase))
        if self.low is not None:
            below = (value <= self.low) if self.low_open else (value < self.low)
            tests.append((below, f"values {'>' if self.low_open else '>='} {self.low}"))
        if high is not None:
            tests.append((value > high, f"values <= {high}"))
        for bad, expected in tests:
            if bad.any():
                raise rules.Invalid(f"entry {_index(bad)} is {value[bad][0]}", expected)


class Maybe(NamedTuple):
    """A field that may be null (None): its value, when given, follows ``spec``."""

    spec: object


#: `yore.Simulation.state`'s fields (the cloth's are `CLOTH`; the options, the history and
#: the projection memory depend on the integrator and are checked after).
SIMULATION = {
    "cloth": None,
    "integrator": rules.choice(
        *INTEGRATORS, expected="one of " + ", ".join(INTEGRATORS), problem=_got
    ),
    "options": None,
    "dt": _real(MIN_DT),
    "gravity": Array(np.float64, (3,)),
    "history": None,
    "target_time": Maybe(_real()),
}
#: Fields absent from states saved before they existed.
SIMULATION_OPTIONAL = {
    "projection_memory": None,
    "dt_follows_cloth": _FLAG,
    "integrator_restarts": _FLAG,
}

_SPRING = Array(np.float64, ("s",), low=0.0)
_NONNEGATIVE = _real(0.0)
#: `yore.Cloth.state`'s fields that every state has, in the order they are checked: the
#: required keys of the binding's one list (``Cloth.state_fields``, which its writer and
#: reader use; tests/test_state.py holds the two equal). The bending and membrane fields
#: (`Cloth.state_fields["optional"]`, absent from states saved before those models) go
#: together and are checked after, by `_check_cloth_models`.
CLOTH = {
    "positions": Array(np.float64, (None, 3)),
    "velocities": Array(np.float64, ("n", 3)),
    "masses": Array(np.float64, ("n",), low=_TINY),
    "faces": Array(np.int32, (None, 3), low=0, high="last"),
    "spring_ends": Array(np.int32, (None, 2), low=0, high="last"),
    "spring_rest": _SPRING,
    "spring_reference": _SPRING,
    "spring_stiffness": _SPRING,
    "spring_damping": _SPRING,
    "spring_kind": Array(np.int8, ("s",), allowed=(0, 1)),
    "drag": _NONNEGATIVE,
    "stretch_stiffness": _NONNEGATIVE,
    "bend_stiffness": _NONNEGATIVE,
    "damping": _NONNEGATIVE,
    "material_coordinates": Maybe(Array(np.float64, ("n", 2))),
    "vertex_states": Array(np.uint8, ("n",), allowed=(0, 1, 2)),
    "drivers": None,
    "clock_origin": _real(-MAX_TIME, high=MAX_TIME),
    "clock_steps": _count(0, 2**62),
    "clock_dt": _NONNEGATIVE,
}
#: One driver of ``cloth.drivers``.
DRIVER = {
    "vertices": Array(np.int32, (None,), low=0, high="last"),
    "reference": Array(np.float64, ("k", 3)),
    "center": Array(np.float64, (3,)),
    "axis": Array(np.float64, (3,)),
    "omega": _real(),
    "start_time": _real(),
}
#: Newton's projection memory; shift and radius are absent from states saved before the
#: shifted and Steihaug projections existed (then: 0).
PROJECTION_MEMORY = {
    "exact_skip": _count(0, 32),
    "exact_backoff": _count(1, 32),
}
PROJECTION_MEMORY_OPTIONAL = {"shift": _real(0.0, high=1e12), "radius": _real(0.0)}


# -- checking -----------------------------------------------------------------------------------


class FieldChecker:
    """Checks of one state file's fields; every error names the file and the dotted field."""

    def __init__(self, path):
        self.path = path

    def error(self, field, problem, expected=None):
        text = f"{self.path}: field {field}: {problem}"
        return ValueError(text + (f"; expected {expected}" if expected else ""))

    def join(self, value, arrays, field):
        """Inverse of `_split`, with every ``{"$array": name}`` naming an array of the file."""
        if isinstance(value, dict):
            if set(value) == {"$array"}:
                name = value["$array"]
                if not isinstance(name, str) or name not in arrays:
                    raise self.error(
                        field,
                        f"refers to a missing array {show_value(name)}",
                        "an array stored in the file",
                    )
                return arrays[name]
            return {
                str(key): self.join(item, arrays, f"{field}.{key}") for key, item in value.items()
            }
        if isinstance(value, list):
            return [self.join(item, arrays, f"{field}[{k}]") for k, item in enumerate(value)]
        return value

    def keys(self, value, field, required, optional=()):
        if not isinstance(value, dict):
            raise self.error(field, f"got {show_value(value)}", "a table")
        missing = sorted(set(required) - set(value))
        unknown = sorted(set(value) - set(required) - set(optional))
        if missing:
            raise self.error(f"{field}.{missing[0]}", "missing")
        if unknown:
            raise self.error(
                f"{field}.{unknown[0]}",
                "unknown field",
                "one of " + ", ".join(sorted(set(required) | set(optional))),
            )
        return value

    def check(self, rule, value, field):
        """``value`` checked by a `yore.rules.Rule`; the error names the field."""
        try:
            return rule(value)
        except rules.Invalid as invalid:
            raise self.error(field, invalid.problem, invalid.expected) from None

    def table(self, values, where, schema, sizes=None, done=()):
        """The fields of ``schema`` that ``values`` holds, each checked by its rule (an `Array`
        made for ``sizes``; a `Maybe` passes None; a None rule is checked by the caller), but
        those in ``done``, which the caller checked first (the ones that set the sizes)."""
        for name, spec in schema.items():
            if name not in values or name in done:
                continue
            value = values[name]
            if isinstance(spec, Maybe):
                if value is None:
                    continue
                spec = spec.spec
            if isinstance(spec, Array):
                spec = spec.rule(sizes or {})
            if spec is not None:
                self.check(spec, value, f"{where}.{name}")
        return values


def check_simulation(field, simulation):
    """The schema of a version-1 state (`Simulation.state`, `yore.Cloth.state`)."""
    integrator = _check_stepping(field, simulation)
    n = _check_cloth(field, simulation["cloth"])
    _check_projection_memory(field, simulation.get("projection_memory"), integrator)
    _check_history(field, simulation, integrator, n)


def _check_stepping(field, simulation):
    """The integrator, its options, dt, gravity and the clock's target; the integrator."""
    field.keys(simulation, "simulation", tuple(SIMULATION), optional=tuple(SIMULATION_OPTIONAL))
    field.table(simulation, "simulation", {"integrator": SIMULATION["integrator"]})
    integrator = simulation["integrator"]
    options = field.keys(
        simulation["options"], "simulation.options", (), tuple(INTEGRATOR_OPTIONS[integrator])
    )
    for name, value in options.items():
        try:
            check_option(integrator, name, value)
        except ValueError as error:
            raise field.error(f"simulation.options.{name}", str(error)) from None
    field.table(
        simulation, "simulation", {**SIMULATION, **SIMULATION_OPTIONAL}, done=("integrator",)
    )
    return integrator


def _check_cloth(field, cloth):
    """The cloth's arrays, material, bending, membrane, drivers and clock; its vertex count."""
    # The bending fields came with quadratic bending: a file without them is bending springs;
    # the membrane's with the membrane: a file without them has springs that resist stretching.
    where = "simulation.cloth"
    field.keys(cloth, where, tuple(CLOTH), optional=Cloth.state_fields["optional"])
    positions = field.check(CLOTH["positions"].rule({}), cloth["positions"], where + ".positions")
    n = len(positions)
    if n == 0:
        raise field.error(where + ".positions", "holds no vertex", "at least one vertex")
    ends = field.check(
        CLOTH["spring_ends"].rule({"last": n - 1}), cloth["spring_ends"], where + ".spring_ends"
    )
    if len(ends) and (ends[:, 0] == ends[:, 1]).any():
        k = int(np.flatnonzero(ends[:, 0] == ends[:, 1])[0])
        raise field.error(
            where + ".spring_ends",
            f"spring {k} joins vertex {ends[k, 0]} to itself",
            "two different vertices per spring",
        )
    sizes = {"n": n, "last": n - 1, "s": len(ends)}
    field.table(cloth, where, CLOTH, sizes, done=("positions", "spring_ends"))
    _check_cloth_models(field, cloth, n)
    _check_drivers(field, cloth["drivers"], n)
    return n


def _check_cloth_models(field, cloth, n):
    """Quadratic bending's fields (or none with bending springs) and the membrane's."""
    bending = _check_bending_fields(field, cloth, n)
    _check_membrane_fields(field, cloth, bending)


def _check_bending_fields(field, cloth, n):
    """The bending model, its operator and its fields; returns the model."""
    where = "simulation.cloth."
    bending = cloth.get("bending", "springs")
    if bending not in ("springs", "quadratic", "hinge"):
        raise field.error(
            where + "bending", f"got {show_value(bending)}", '"springs", "quadratic" or "hinge"'
        )
    # "fitted" with bending "quadratic"; absent or null otherwise (a file written before the
    # fitted operator holds "quadratic" without it, and loads as the hinge energy it ran with)
    operator = cloth.get("bending_operator")
    if operator is not None and (bending != "quadratic" or operator != "fitted"):
        raise field.error(
            where + "bending_operator",
            f"got {show_value(operator)}",
            '"fitted" with bending "quadratic", else null',
        )
    if bending in ("quadratic", "hinge"):
        field.check(_NONNEGATIVE, cloth.get("bending_modulus"), where + "bending_modulus")
        rest = Array(np.float64, ("n", 3)).rule({"n": n})
        field.check(rest, cloth.get("bending_rest"), where + "bending_rest")
        return bending
    for name in ("bending_modulus", "bending_rest"):
        value = cloth.get(name)
        zero = isinstance(value, (int, float)) and not isinstance(value, bool) and value == 0
        if value is not None and not zero:
            raise field.error(
                where + name,
                f"got {show_value(value)}",
                "none (0 or null) with bending springs",
            )
    return bending


def _check_membrane_fields(field, cloth, bending):
    """The membrane's moduli and its strain (which needs bending's rest state)."""
    where = "simulation.cloth."
    if "young_modulus" in cloth:
        young = field.check(_NONNEGATIVE, cloth["young_modulus"], where + "young_modulus")
        if "poisson_ratio" in cloth:
            ratio = field.check(_real(), cloth["poisson_ratio"], where + "poisson_ratio")
            if not -1.0 < ratio < 1.0 or (young == 0.0 and ratio != 0.0):
                raise field.error(
                    where + "poisson_ratio",
                    f"got {show_value(ratio)}",
                    "a number in (-1, 1) with a membrane, 0 without one",
                )
    # "smoothed" for a membrane that reads the smoothed strain (it needs the rest state of bending
    # "quadratic" or "hinge"); absent or null for the faces' constant strain (files saved
    # before the smoothed strain load with the physics they ran with)
    strain = cloth.get("membrane_strain")
    membrane = isinstance(cloth.get("young_modulus"), (int, float)) and cloth["young_modulus"] > 0
    if strain is not None and (
        strain != "smoothed" or not membrane or bending not in ("quadratic", "hinge")
    ):
        raise field.error(
            where + "membrane_strain",
            f"got {show_value(strain)}",
            '"smoothed" with a membrane and bending "quadratic" or "hinge", else null',
        )


def _check_drivers(field, drivers, n):
    where = "simulation.cloth."
    if not isinstance(drivers, list):
        raise field.error(where + "drivers", f"got {show_value(drivers)}", "a list of drivers")
    for k, driver in enumerate(drivers):
        at = f"{where}drivers[{k}]"
        field.keys(driver, at, tuple(DRIVER))
        vertices = field.check(
            DRIVER["vertices"].rule({"last": n - 1}), driver["vertices"], at + ".vertices"
        )
        field.table(driver, at, DRIVER, {"last": n - 1, "k": len(vertices)}, done=("vertices",))
        if not driver["axis"].any():
            raise field.error(at + ".axis", "is zero", "a direction")


def _check_projection_memory(field, memory, integrator):
    if memory is not None:
        where = "simulation.projection_memory"
        if not INTEGRATOR_SPECS[integrator].newton:
            raise field.error(
                where, f"given for integrator {integrator!r}", "null (only Newton keeps one)"
            )
        field.keys(
            memory, where, tuple(PROJECTION_MEMORY), optional=tuple(PROJECTION_MEMORY_OPTIONAL)
        )
        field.table(memory, where, {**PROJECTION_MEMORY, **PROJECTION_MEMORY_OPTIONAL})


def _check_history(field, simulation, integrator, n):
    history = simulation["history"]
    if history is not None:
        fields = INTEGRATOR_SPECS[integrator].history(simulation["options"])
        if not fields:
            keeping = ", ".join(
                name
                for name, spec in INTEGRATOR_SPECS.items()
                if spec.history(INTEGRATOR_OPTIONS[name])
            )
            raise field.error(
                "simulation.history",
                f"given for integrator {integrator!r} with these options",
                f"null (only {keeping} and quasi-newton with method bdf2 keep a history)",
            )
        # next_dt: error-controlled BDF2's proposed step (absent elsewhere, and before it)
        schema = {
            **dict.fromkeys(fields, Array(np.float64, ("n", 3))),
            "dt": _real(MIN_DT),
            "next_dt": _real(MIN_DT),
        }
        field.keys(history, "simulation.history", (*fields, "dt"), optional=("next_dt",))
        field.table(history, "simulation.history", schema, {"n": n})
