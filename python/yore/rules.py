"""yore.rules: the one rule type every layer checks values with.

A `Rule` is shaped like the C++ ``OptionRule`` of the integrators' option tables
(cpp/bindings/options.hpp, which the bindings publish as ``option_rules`` and `from_core`
turns into Rules: the C++ table is where an option's rule is written): a kind
("flag", "count", "real", "choice", "text" or "custom"), bounds with open or closed ends,
choices, and whether None is allowed. ``rule(value)`` returns the value in its canonical form
(bool, int, float, str or None) or raises `Invalid` with the problem ("got float 3.5") and what
would be accepted (``rule.expected``). Each layer turns `Invalid` into its own error:

- `yore.options` (integrator options): `OptionError` "option NAME: got ...; expected ...";
- scene files (`yore.runs.schema`): `SceneError` "FILE:LINE: KEY: got ...; expected ...";
- state files (`yore.state`): "FILE: field FIELD: got ...; expected ...";
- arguments (`yore.checks`): "NAME must be ..., got ...".

The layers phrase ``expected`` in their own words (a scene file says "true or false", Python
says "True or False"): the phrase is an argument, the test is the rule's.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = [
    "Invalid",
    "Rule",
    "flag",
    "count",
    "real",
    "choice",
    "text",
    "custom",
    "show",
    "describe",
    "is_integer",
    "is_real",
]


class Invalid(ValueError):
    """A value a rule refuses: ``problem`` (what was given, e.g. "got str 'x'") and
    ``expected`` (what would be accepted)."""

    def __init__(self, problem, expected):
        super().__init__(f"{problem}; expected {expected}")
        self.problem, self.expected = problem, expected


def show(value) -> str:
    """A value as errors quote it: its type and its repr, cut at 60 characters."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(value).__name__} {text}"


def describe(value) -> str:
    """Like `show`, but a table, a list or an array is named, not printed."""
    if isinstance(value, np.ndarray):
        return f"an array of dtype {value.dtype} and shape {value.shape}"
    if isinstance(value, (dict, list)):
        return f"a {'table' if isinstance(value, dict) else 'list'}"
    return show(value)


def is_integer(value) -> bool:
    """An integer and not a bool (Python's or numpy's)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def is_real(value) -> bool:
    """A finite real number and not a bool."""
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, (bool, np.bool_))
        and math.isfinite(value)
    )


def _problem(value):
    return f"got {show(value)}"


class Rule:
    """How one value is checked. ``kind``: "flag" | "count" | "real" | "choice" | "text" |
    "custom"; ``low``/``high`` the bounds (None: unbounded), ``low_open``/``high_open``
    whether they are excluded; ``choices`` the names a choice takes; ``optional``: None is
    allowed (and returned). ``expected``: the phrase errors quote; ``problem``: value → the
    phrase saying what was given (default "got TYPE REPR"). ``test``: for "custom", value →
    (ok, converted), or `Invalid` raised with a problem of its own (which element of a list)."""

    def __init__(
        self,
        kind,
        *,
        expected,
        low=None,
        high=None,
        low_open=False,
        high_open=False,
        choices=(),
        optional=False,
        problem=_problem,
        test=None,
        python_types=False,
    ):
        self.kind, self.low, self.high = kind, low, high
        self.low_open, self.high_open = low_open, high_open
        self.choices, self.optional, self.expected = tuple(choices), optional, expected
        self._problem, self._custom = problem, test
        # python_types: exactly Python's int/float/bool (TOML's and JSON's), numpy's refused
        self._python_types = python_types

    def __repr__(self):
        return f"Rule({self.kind!r}, expected={self.expected!r})"

    def _within(self, number):
        if self.low is not None and (number < self.low or (self.low_open and number == self.low)):
            return False
        return self.high is None or not (
            number > self.high or (self.high_open and number == self.high)
        )

    def test(self, value):
        """(ok, the value in canonical form)."""
        if value is None and self.optional:
            return True, None
        kind_test = _KIND_TESTS.get(self.kind)
        try:
            return kind_test(self, value) if kind_test is not None else self._custom(value)
        except Invalid:
            raise  # a custom test's own account of the problem
        except (TypeError, ValueError, OverflowError):
            return False, None

    def _test_flag(self, value):
        types = bool if self._python_types else (bool, np.bool_)
        return isinstance(value, types), bool(value) if isinstance(value, types) else None

    def _test_count(self, value):
        ok = (
            (not isinstance(value, bool) and isinstance(value, int))
            if self._python_types
            else is_integer(value)
        )
        return ok and self._within(value), int(value) if ok else None

    def _test_real(self, value):
        ok = (
            (
                not isinstance(value, bool)
                and isinstance(value, (int, float))
                and math.isfinite(value)
            )
            if self._python_types
            else is_real(value)
        )
        return ok and self._within(float(value)), float(value) if ok else None

    def _test_choice(self, value):
        ok = isinstance(value, str) and value in self.choices
        return ok, value if ok else None

    def _test_text(self, value):
        return isinstance(value, str), value

    def __call__(self, value):
        """The value in canonical form, or `Invalid`."""
        ok, checked = self.test(value)
        if not ok:
            raise Invalid(self._problem(value), self.expected)
        return checked

    check = __call__

    def or_none(self, expected=None) -> "Rule":
        """This rule with None allowed (``expected`` default: "None or ...")."""
        rule = Rule(
            self.kind,
            expected=expected or f"None or {self.expected}",
            low=self.low,
            high=self.high,
            low_open=self.low_open,
            high_open=self.high_open,
            choices=self.choices,
            optional=True,
            problem=self._problem,
            test=self._custom,
            python_types=self._python_types,
        )
        return rule


def _bounds(low, high, low_open, high_open):
    return (
        ("(" if low_open else "[")
        + f"{low:g}, "
        + ("inf)" if high is None else f"{high:g}" + (")" if high_open else "]"))
    )


def flag(expected="True or False", **kw) -> Rule:
    return Rule("flag", expected=expected, **kw)


def count(low, high=None, expected=None, **kw) -> Rule:
    """An integer in [low, high] (high None: no upper bound)."""
    if expected is None:
        expected = f"an integer in [{low}, {high}]" if high is not None else f"an integer >= {low}"
    return Rule("count", expected=expected, low=low, high=high, **kw)


def real(low=None, high=None, low_open=True, high_open=False, expected=None, **kw) -> Rule:
    """A finite number between the bounds (by default (low, inf), the C++ tables' phrase
    "a finite number in (low, high]")."""
    if expected is None:
        expected = (
            "a finite number"
            if low is None and high is None
            else f"a finite number in {_bounds(low, high, low_open, high_open)}"
        )
    return Rule(
        "real", expected=expected, low=low, high=high, low_open=low_open, high_open=high_open, **kw
    )


def choice(*choices, expected=None, **kw) -> Rule:
    return Rule(
        "choice",
        expected=expected or f"a name (valid: {', '.join(choices)})",
        choices=choices,
        **kw,
    )


def text(expected="a string", **kw) -> Rule:
    return Rule("text", expected=expected, **kw)


def custom(test, expected, **kw) -> Rule:
    """A rule of its own: ``test(value)`` → (ok, converted), or raises `Invalid`."""
    return Rule("custom", expected=expected, test=test, **kw)


def from_core(spec) -> Rule:
    """A rule from one entry of a C++ option table's rules (``_core.*.option_rules``: kind,
    low, high, low_open, high_open, choices)."""
    kind = spec["kind"]
    if kind == "flag":
        return flag()
    if kind == "count":
        return count(int(spec["low"]), int(spec["high"]))
    if kind == "real":
        return real(
            spec["low"], spec["high"], low_open=spec["low_open"], high_open=spec["high_open"]
        )
    return choice(*spec["choices"])


#: Rule.test's test for each built-in kind (a "custom" rule has its own).
_KIND_TESTS = {
    "flag": Rule._test_flag,
    "count": Rule._test_count,
    "real": Rule._test_real,
    "choice": Rule._test_choice,
    "text": Rule._test_text,
}
