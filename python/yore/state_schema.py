"""The state file's schema (`yore.state` reads and writes the files): every field of a
simulation's state checked by name, type, dtype, shape, range and finiteness, with sizes
consistent across the cloth, its constraints, drivers and the integrator's history. Every
error names the file and the dotted field."""

from __future__ import annotations


import numpy as np

from . import rules
from ._core import Cloth
from .checks import MAX_TIME, MIN_DT
from .options import INTEGRATOR_OPTIONS, INTEGRATOR_SPECS, INTEGRATORS, check_option


def show_value(value):
    return rules.describe(value)


def _got(value):
    return f"got {rules.describe(value)}"


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

    def real(self, value, field, low=None, low_open=False, high=None):
        bounds = "" if low is None else f" {'>' if low_open else '>='} {low:g}"
        bounds += "" if high is None else f"{' and' if bounds else ''} <= {high:g}"
        return self.check(
            rules.real(
                low,
                high,
                low_open=low_open,
                expected=f"a finite number{bounds}",
                problem=_got,
                python_types=True,
            ),
            value,
            field,
        )

    def integer(self, value, field, low, high):
        return self.check(rules.count(low, high, problem=_got, python_types=True), value, field)

    def array(self, value, field, dtype, shape, low=None, high=None, low_open=False, allowed=None):
        """An ndarray of exactly ``dtype``; ``shape`` with None for any length; float arrays
        finite; values in [low, high] (or (low, high] with low_open) or in ``allowed``."""
        expected = (
            f"an array of dtype {np.dtype(dtype)} and shape "
            + "("
            + ", ".join("k" if d is None else str(d) for d in shape)
            + ("," if len(shape) == 1 else "")
            + ")"
        )
        if (
            not isinstance(value, np.ndarray)
            or value.dtype != np.dtype(dtype)
            or value.ndim != len(shape)
            or any(d is not None and d != got for d, got in zip(shape, value.shape))
        ):
            raise self.error(field, f"got {show_value(value)}", expected)
        if value.size == 0:
            return value
        self._check_entries(value, field, low, high, low_open, allowed)
        return value

    def _check_entries(self, value, field, low, high, low_open, allowed):
        """array's value checks: finite floats, values in ``allowed``, within the bounds."""
        bounds = []  # (entries out of range, what was expected)
        if value.dtype.kind == "f":
            bounds.append((~np.isfinite(value), "finite numbers"))
        if allowed is not None:
            bounds.append(
                (~np.isin(value, allowed), "values in {" + ", ".join(map(str, allowed)) + "}")
            )
        for bad, expected in bounds:
            if bad.any():
                raise self.error(field, f"entry {_index(bad)} is {value[bad][0]}", expected)
        if low is not None:
            bad = (value <= low) if low_open else (value < low)
            if bad.any():
                raise self.error(
                    field,
                    f"entry {_index(bad)} is {value[bad][0]}",
                    f"values {'>' if low_open else '>='} {low}",
                )
        if high is not None:
            bad = value > high
            if bad.any():
                raise self.error(
                    field, f"entry {_index(bad)} is {value[bad][0]}", f"values <= {high}"
                )


def _index(mask):
    where = np.argwhere(mask)[0]
    return int(where[0]) if len(where) == 1 else tuple(int(i) for i in where)


#: The keys of a cloth's state (`yore.Cloth.state`): those every state has, and those a state
#: saved before quadratic bending, the membrane, the fitted operator or the smoothed strain
#: lacks — the binding's one list (``Cloth.state_fields``), which its writer and reader use.
_CLOTH_FIELDS = Cloth.state_fields["required"]
_CLOTH_OPTIONAL_FIELDS = Cloth.state_fields["optional"]
_SIMULATION_FIELDS = ("cloth", "integrator", "options", "dt", "gravity", "history", "target_time")
_DRIVER_FIELDS = ("vertices", "reference", "center", "axis", "omega", "start_time")
#: A flag of a state file (JSON's true or false).
_FLAG = rules.flag("true or false", problem=_got, python_types=True)
#: Smallest positive normal double: a mass below it is refused (1/m would overflow).
_TINY = float(np.finfo(np.float64).tiny)


def check_simulation(field, simulation):
    """The schema of a version-1 state (`Simulation.state`, `yore.Cloth.state`)."""
    integrator = _check_stepping(field, simulation)
    n = _check_cloth(field, simulation["cloth"])
    _check_projection_memory(field, simulation.get("projection_memory"), integrator)
    _check_history(field, simulation, integrator, n)


def _check_stepping(field, simulation):
    """The integrator, its options, dt, gravity and the clock's target; the integrator."""
    field.keys(
        simulation,
        "simulation",
        _SIMULATION_FIELDS,
        optional=("projection_memory", "dt_follows_cloth", "integrator_restarts"),
    )
    integrator = simulation["integrator"]
    if not isinstance(integrator, str) or integrator not in INTEGRATORS:
        raise field.error(
            "simulation.integrator",
            f"got {show_value(integrator)}",
            "one of " + ", ".join(INTEGRATORS),
        )
    options = field.keys(
        simulation["options"], "simulation.options", (), tuple(INTEGRATOR_OPTIONS[integrator])
    )
    for name, value in options.items():
        try:
            check_option(integrator, name, value)
        except ValueError as error:
            raise field.error(f"simulation.options.{name}", str(error)) from None
    field.real(simulation["dt"], "simulation.dt", MIN_DT)
    field.array(simulation["gravity"], "simulation.gravity", np.float64, (3,))
    if simulation["target_time"] is not None:
        field.real(simulation["target_time"], "simulation.target_time")
    for name in ("dt_follows_cloth", "integrator_restarts"):
        if name in simulation:
            field.check(_FLAG, simulation[name], f"simulation.{name}")

    return integrator


def _check_cloth(field, cloth):
    """The cloth's arrays, material, bending, membrane, drivers and clock; its vertex count."""
    # The bending fields came with quadratic bending: a file without them is bending springs;
    # the membrane's with the membrane: a file without them has springs that resist stretching.
    cloth = field.keys(
        cloth,
        "simulation.cloth",
        _CLOTH_FIELDS,
        optional=_CLOTH_OPTIONAL_FIELDS,
    )
    where = "simulation.cloth."
    positions = field.array(cloth["positions"], where + "positions", np.float64, (None, 3))
    n = len(positions)
    if n == 0:
        raise field.error(where + "positions", "holds no vertex", "at least one vertex")
    field.array(cloth["velocities"], where + "velocities", np.float64, (n, 3))
    field.array(cloth["masses"], where + "masses", np.float64, (n,), low=_TINY)
    field.array(cloth["faces"], where + "faces", np.int32, (None, 3), low=0, high=n - 1)
    ends = field.array(
        cloth["spring_ends"], where + "spring_ends", np.int32, (None, 2), low=0, high=n - 1
    )
    s = len(ends)
    if s and (ends[:, 0] == ends[:, 1]).any():
        k = int(np.flatnonzero(ends[:, 0] == ends[:, 1])[0])
        raise field.error(
            where + "spring_ends",
            f"spring {k} joins vertex {ends[k, 0]} to itself",
            "two different vertices per spring",
        )
    for name in ("spring_rest", "spring_reference", "spring_stiffness", "spring_damping"):
        field.array(cloth[name], where + name, np.float64, (s,), low=0.0)
    field.array(cloth["spring_kind"], where + "spring_kind", np.int8, (s,), allowed=(0, 1))
    for name in ("drag", "stretch_stiffness", "bend_stiffness", "damping"):
        field.real(cloth[name], where + name, 0.0)
    if cloth["material_coordinates"] is not None:
        field.array(
            cloth["material_coordinates"], where + "material_coordinates", np.float64, (n, 2)
        )
    field.array(cloth["vertex_states"], where + "vertex_states", np.uint8, (n,), allowed=(0, 1, 2))
    _check_cloth_models(field, cloth, n)
    _check_drivers(field, cloth["drivers"], n)
    field.real(cloth["clock_origin"], where + "clock_origin", -MAX_TIME, high=MAX_TIME)
    field.integer(cloth["clock_steps"], where + "clock_steps", 0, 2**62)
    field.real(cloth["clock_dt"], where + "clock_dt", 0.0)
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
        field.real(cloth.get("bending_modulus"), where + "bending_modulus", 0.0)
        field.array(cloth.get("bending_rest"), where + "bending_rest", np.float64, (n, 3))
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
        young = field.real(cloth["young_modulus"], where + "young_modulus", 0.0)
        if "poisson_ratio" in cloth:
            ratio = field.real(cloth["poisson_ratio"], where + "poisson_ratio")
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
        at = f"{where}drivers[{k}]."
        field.keys(driver, at[:-1], _DRIVER_FIELDS)
        vertices = field.array(
            driver["vertices"], at + "vertices", np.int32, (None,), low=0, high=n - 1
        )
        field.array(driver["reference"], at + "reference", np.float64, (len(vertices), 3))
        field.array(driver["center"], at + "center", np.float64, (3,))
        axis = field.array(driver["axis"], at + "axis", np.float64, (3,))
        if not axis.any():
            raise field.error(at + "axis", "is zero", "a direction")
        field.real(driver["omega"], at + "omega")
        field.real(driver["start_time"], at + "start_time")


def _check_projection_memory(field, memory, integrator):
    if memory is not None:
        if not INTEGRATOR_SPECS[integrator].newton:
            raise field.error(
                "simulation.projection_memory",
                f"given for integrator {integrator!r}",
                "null (only Newton keeps one)",
            )
        # shift, radius: absent from states saved before the shifted and steihaug projections
        # existed (then: 0)
        field.keys(
            memory,
            "simulation.projection_memory",
            ("exact_skip", "exact_backoff"),
            optional=("shift", "radius"),
        )
        field.integer(memory["exact_skip"], "simulation.projection_memory.exact_skip", 0, 32)
        field.integer(memory["exact_backoff"], "simulation.projection_memory.exact_backoff", 1, 32)
        if "shift" in memory:
            field.real(memory["shift"], "simulation.projection_memory.shift", 0.0, high=1e12)
        if "radius" in memory:
            field.real(memory["radius"], "simulation.projection_memory.radius", 0.0)


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
        field.keys(history, "simulation.history", (*fields, "dt"), optional=("next_dt",))
        for name in fields:
            field.array(history[name], f"simulation.history.{name}", np.float64, (n, 3))
        field.real(history["dt"], "simulation.history.dt", MIN_DT)
        if "next_dt" in history:
            field.real(history["next_dt"], "simulation.history.next_dt", MIN_DT)
