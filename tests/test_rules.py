"""yore.rules: the one rule type of options, scene files, state files and argument checks.

Each rule is checked at its bounds (open and closed ends), with the types each layer takes
(numpy's numbers in Python, only TOML's and JSON's own in files), and every layer is checked to
build its rules from it: no other module of yore defines a rule or an "invalid value" type."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

import yore
from yore import _core, rules
from yore.options import CORE_RULES, check_option
from yore.runs import schema

PACKAGE = Path(yore.__file__).resolve().parent
SOURCE = Path(__file__).resolve().parents[1] / "python" / "yore"


def test_a_real_rule_keeps_its_ends_open_or_closed():
    half_open = rules.real(0.0, 1.0)  # (0, 1]
    assert half_open(1) == 1.0 and isinstance(half_open(1), float)
    assert half_open(np.float32(0.5)) == 0.5
    for bad in (0.0, 1.0 + 1e-15, -1, math.inf, math.nan, True, "0.5", None, [0.5]):
        with pytest.raises(rules.Invalid) as error:
            half_open(bad)
        assert error.value.expected == "a finite number in (0, 1]"
        assert error.value.problem == f"got {rules.show(bad)}"
    closed = rules.real(0.0, 1.0, low_open=False, high_open=True)  # [0, 1)
    assert closed(0.0) == 0.0
    with pytest.raises(rules.Invalid):
        closed(1.0)
    assert rules.real(2.0).expected == "a finite number in (2, inf)"


def test_a_count_refuses_bools_floats_and_its_bounds():
    count = rules.count(1, 3)
    assert [count(v) for v in (1, np.int64(2), 3)] == [1, 2, 3]
    assert type(count(np.int64(2))) is int
    for bad in (0, 4, 2.0, True, np.bool_(True), "2"):
        with pytest.raises(rules.Invalid, match=r"expected an integer in \[1, 3\]"):
            count(bad)
    assert rules.count(0).expected == "an integer >= 0"
    assert rules.count(0)(10**30) == 10**30


def test_files_take_only_their_own_types():
    # A TOML or JSON value is never a numpy number: with python_types a numpy one is refused
    in_python = rules.real(0.0)
    in_a_file = rules.real(0.0, python_types=True)
    assert in_python(np.float64(2.0)) == 2.0
    assert in_a_file(2) == 2.0
    assert rules.flag(python_types=True).test(np.bool_(True)) == (False, None)
    assert rules.flag().test(np.bool_(True)) == (True, True)
    assert rules.count(0, python_types=True).test(np.int64(3))[0] is False


def test_choices_text_custom_and_none():
    choice = rules.choice("a", "b")
    assert choice("a") == "a"
    with pytest.raises(rules.Invalid, match=r"a name \(valid: a, b\)"):
        choice("c")
    with pytest.raises(rules.Invalid):
        choice(["a"])  # unhashable: refused, not a TypeError
    optional = choice.or_none()
    assert optional(None) is None and optional("b") == "b"
    assert optional.expected == "None or a name (valid: a, b)"
    with pytest.raises(rules.Invalid):
        choice(None)
    assert rules.text()("x") == "x"
    even = rules.custom(lambda v: (v % 2 == 0, v), "an even number")
    assert even(4) == 4
    with pytest.raises(rules.Invalid, match="an even number"):
        even(3)
    with pytest.raises(rules.Invalid):
        even("x")  # the test's TypeError is a refusal


def test_rules_from_the_core_tables_match_their_bounds():
    # every C++ option rule: a value at each bound is taken exactly when the bound is closed
    assert len(CORE_RULES) > 20
    for name, spec in CORE_RULES.items():
        rule = rules.from_core(spec)
        assert rule.kind == spec["kind"], name
        if spec["kind"] == "real":
            assert rule.test(spec["low"])[0] is (not spec["low_open"]), name
            if spec["high"] is not None:
                assert rule.test(spec["high"])[0] is (not spec["high_open"]), name
        elif spec["kind"] == "count":
            assert rule.test(int(spec["low"]))[0] and not rule.test(int(spec["low"]) - 1)[0]
            assert rule.test(int(spec["high"]))[0] and not rule.test(int(spec["high"]) + 1)[0]
        elif spec["kind"] == "choice":
            assert all(rule.test(c)[0] for c in spec["choices"]) and not rule.test("?")[0]


def test_the_layers_phrase_one_rule_in_their_own_words():
    # an option, a scene key, a state field and an argument refuse the same bad value
    with pytest.raises(
        ValueError,
        match=r"option max_newton: got float 2\.5; expected an "
        r"integer in \[1, ",
    ):
        check_option("implicit", "max_newton", 2.5)
    with pytest.raises(rules.Invalid) as error:
        schema.SMOOTH["iterations"].rule(2.5)
    assert error.value.problem == "got float 2.5"
    assert error.value.expected.startswith("an integer in [0, ")
    with pytest.raises(
        ValueError,
        match=r"smooth_rest_lengths iterations: got float 2\.5; "
        r"expected an integer in \[0, 100000\]",
    ):
        yore.scenes.hanging_cloth(resolution=5).smooth_rest_lengths(iterations=2.5, region="all")
    with pytest.raises(ValueError, match=r"refine must be an integer in \[0, 7\], got 2\.5"):
        yore.checks.check_integer(2.5, "refine", 0, 7)


def _defined_classes():
    found = []
    for path in sorted(SOURCE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                found.append((path.relative_to(SOURCE).as_posix(), node.name))
    return found


def test_no_module_but_rules_defines_a_rule_or_an_invalid_value():
    classes = _defined_classes()
    assert ("rules.py", "Rule") in classes and ("rules.py", "Invalid") in classes
    others = [
        (path, name)
        for path, name in classes
        if path != "rules.py"
        and (
            name.lstrip("_").endswith("Rule")
            or name.lstrip("_") == "Invalid"
            or name.endswith("Checker")
            and path != "state_schema.py"
        )
    ]
    assert others == []


def test_scene_file_checkers_are_rules():
    # every scalar key of the scene schema is checked by a yore.rules.Rule (lists of points,
    # vectors and tables have checkers of their own shape, which raise rules.Invalid)
    tables = (
        [table.keys for table in schema.SCHEMA.values() if table.keys]
        + list(schema.GENERATOR_KEYS.values())
        + [schema.SMOOTH, schema.BOX]
    )
    checkers = [key.rule for table in tables for key in table.values()]
    # "box" and "smooth" name nested tables, checked by their own schema (BOX, SMOOTH)
    assert {c for c in checkers if not isinstance(c, rules.Rule)} == {"box", "smooth"}
    kinds = {c.kind for c in checkers if isinstance(c, rules.Rule)}
    assert {"real", "count", "flag", "text", "custom"} <= kinds
    assert schema.Invalid is rules.Invalid


def test_core_option_rules_come_from_the_bound_tables():
    # the C++ tables are where the rules live: the bindings publish them, Python builds from them
    tables = (
        _core.ExplicitIntegrator,
        _core.ImplicitIntegrator,
        _core.LocalGlobalIntegrator,
        _core.ErrorControlledIntegrator,
    )
    names = {name for table in tables for name in table.option_rules}
    assert names == set(CORE_RULES)
