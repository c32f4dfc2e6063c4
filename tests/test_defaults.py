"""Each default is written once — in a C++ struct (bound as a table) or in `yore.options` — and
every other place reads it: the bindings' signatures, `yore.Simulation`, `yore.StrokeOptions`,
`yore.scenes`, the scene-file schema and the viewer. Checked two ways: every consumer's
default equals the table's, and no module restates one as a literal beside its name."""

import ast
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

import yore
from yore import _core, options
from yore.runs import schema

SOURCE = Path(__file__).resolve().parents[1] / "python" / "yore"


def _binding_defaults(function):
    """name → default text of a pybind11 function's signature (its docstring's first line)."""
    signature = function.__doc__.splitlines()[0]
    return dict(re.findall(r"(\w+): [^=,]+ = ([^,)]+)", signature))


def test_stroke_defaults_come_from_the_core_structs():
    split, stroke = _core.split_defaults, _core.stroke_defaults
    assert options.STROKE_DEFAULTS == {
        "expansion": split["expansion"],
        "mass_scale": split["mass_scale"],
        "width": None if stroke["width"] == 0 else stroke["width"],
        "growth": stroke["growth"],
        "refine": stroke["refine"],
    }
    assert options.GROWTH_MODES == tuple(_core.growth_modes())
    assert len(set(options.GROWTH_MODES)) == len(options.GROWTH_MODES) >= 4
    assert yore.stroke.MIN_BARYCENTRIC == split["min_barycentric"]
    assert yore.stroke.MIN_ANGLE_DEGREES == split["min_angle_degrees"]
    # the binding's keyword defaults are the same structs'
    bound = _binding_defaults(_core.apply_stroke)
    assert float(bound["expansion"]) == split["expansion"]
    assert float(bound["mass_scale"]) == split["mass_scale"]
    assert float(bound["min_barycentric"]) == split["min_barycentric"]
    assert bound["growth"].strip("'\"") == stroke["growth"]
    assert float(bound["width"]) == stroke["width"] and int(bound["refine"]) == stroke["refine"]
    assert int(bound["max_vertices"]) == stroke["max_vertices"]
    assert float(bound["spacing_pixels"]) == stroke["spacing_pixels"]
    # ... and so are StrokeOptions' and the scene file's
    fields = yore.StrokeOptions()
    assert {
        name: getattr(fields, name) for name in options.STROKE_DEFAULTS
    } == options.STROKE_DEFAULTS
    strokes = schema.SCHEMA["strokes"].keys
    for name in ("expansion", "mass_scale", "growth", "refine"):
        assert strokes[name].default == options.STROKE_DEFAULTS[name], name


def test_smoothing_defaults_are_read_by_every_consumer():
    signature = inspect.signature(yore.Simulation.smooth_rest_lengths).parameters
    assert {
        name: signature[name].default for name in options.SMOOTHING_DEFAULTS
    } == options.SMOOTHING_DEFAULTS
    assert {
        name: schema.SMOOTH[name].default for name in options.SMOOTHING_DEFAULTS
    } == options.SMOOTHING_DEFAULTS
    for name, rule in options.SMOOTHING_RULES.items():
        assert schema.SMOOTH[name].rule.kind == rule.kind, name
        assert (schema.SMOOTH[name].rule.low, schema.SMOOTH[name].rule.high) == (
            rule.low,
            rule.high,
        )
    assert options.SMOOTHING_RULES["iterations"].high == options.MAX_SMOOTHING_ITERATIONS
    # a stroke's smoothing stage fills in the same defaults
    assert yore.stroke.check_smoothing(3) == {
        **options.SMOOTHING_DEFAULTS,
        "iterations": 3,
        "region": "stroke",
    }


def test_a_bare_cloth_and_the_scenes_take_their_materials_from_the_tables():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    F = np.array([[0, 1, 2], [1, 3, 2]])
    bare = yore.Cloth(V, F)
    defaults = _core.Cloth.defaults
    assert np.all(bare.springs.damping == defaults["damping"]) and bare.drag == defaults["drag"]
    kinds = bare.springs.kind
    assert np.all(bare.springs.stiffness[kinds == 0] == defaults["stretch_stiffness"])
    assert np.all(bare.springs.stiffness[kinds == 1] == defaults["bend_stiffness"])
    assert np.all(bare.masses == defaults["masses"])
    bound = _binding_defaults(_core.Cloth.__init__)
    assert float(bound["damping"]) == defaults["damping"]
    assert float(bound["drag"]) == defaults["drag"]
    assert options.POISSON_RATIO == defaults["poisson_ratio"]
    # the scenes' material: yore.scenes and scene files alike
    sim = yore.scenes.hanging_cloth(resolution=5)
    material = options.SCENE_MATERIAL
    assert np.all(sim.cloth.springs.damping == material["damping"])
    assert sim.cloth.drag == material["drag"]
    springs = sim.cloth.springs
    assert np.all(springs.stiffness[springs.kind == 0] == material["stretch_stiffness"])
    table = schema.SCHEMA["material"].keys
    for name in ("stretch_stiffness", "damping", "drag"):
        assert table[name].default == material[name], name


#: The options whose defaults the tables hold, with those defaults.
def _registered_defaults():
    registered = {**options.SMOOTHING_DEFAULTS, **options.STROKE_DEFAULTS}
    registered.update({name: value for name, value in options.SCENE_MATERIAL.items()})
    registered.update(
        {
            "min_barycentric": yore.stroke.MIN_BARYCENTRIC,
            "min_angle_degrees": yore.stroke.MIN_ANGLE_DEGREES,
        }
    )
    return {
        name: value
        for name, value in registered.items()
        if isinstance(value, (int, float, str)) and not isinstance(value, bool)
    }


#: Names a registered option shares with a different quantity in one module.
OTHER_QUANTITIES = {
    ("metrics.py", "iterations"): "Taubin smoothing passes of the wrinkle "
    "measure, not rest-length smoothing"
}


def _restatements(tree, registered):
    """(line, name, value) of every keyword default, keyword argument, dict entry or
    assignment that binds a registered option's name to a literal equal to its default."""
    found = []

    def literal(node):
        return (
            isinstance(node, ast.Constant)
            and isinstance(node.value, (int, float, str))
            and not isinstance(node.value, bool)
        )

    for node in ast.walk(tree):
        pairs = []
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            arguments = node.args
            positional = arguments.posonlyargs + arguments.args
            pairs += list(
                zip(
                    [a.arg for a in positional[len(positional) - len(arguments.defaults) :]],
                    arguments.defaults,
                )
            )
            pairs += [
                (a.arg, d)
                for a, d in zip(arguments.kwonlyargs, arguments.kw_defaults)
                if d is not None
            ]
        elif isinstance(node, ast.Call):
            pairs += [(k.arg, k.value) for k in node.keywords if k.arg]
        elif isinstance(node, ast.Dict):
            pairs += [
                (k.value, v)
                for k, v in zip(node.keys, node.values)
                if isinstance(k, ast.Constant) and isinstance(k.value, str)
            ]
        for name, value in pairs:
            if name in registered and literal(value) and value.value == registered[name]:
                found.append((node.lineno, name, value.value))
    return found


def test_no_module_restates_a_registered_default():
    registered = _registered_defaults()
    assert {"iterations", "strength", "expansion", "damping", "drag"} <= set(registered)
    found = []
    for path in sorted(SOURCE.rglob("*.py")):
        if path.name in ("options.py", "defaults.py"):  # the registry and the defaults it reads
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        module = path.relative_to(SOURCE).as_posix()
        found += [
            (module, *hit)
            for hit in _restatements(tree, registered)
            if (module, hit[1]) not in OTHER_QUANTITIES
        ]
    assert found == []


def test_the_restatement_finder_finds_one():
    tree = ast.parse(
        "def smooth(iterations=10):\n    pass\nx = {'drag': 0.3}\n"
        "f(strength=0.5)\ng(strength=0.25)\n"
    )
    registered = {"iterations": 10, "drag": 0.3, "strength": 0.5}
    assert _restatements(tree, registered) == [
        (1, "iterations", 10),
        (3, "drag", 0.3),
        (4, "strength", 0.5),
    ]


@pytest.mark.parametrize("name", ["StrokeMissed", "RefinementTooLarge"])
def test_yores_exceptions_live_in_the_core_and_are_re_exported(name):
    error = getattr(_core, name)
    assert issubclass(error, ValueError)
    assert getattr(yore.stroke, name) is error
    assert error.__doc__
    if name == "StrokeMissed":
        assert yore.StrokeMissed is error


def test_bad_material_names_its_argument_as_data():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    F = np.array([[0, 1, 2]])
    for arguments, name in (
        ({"damping": -1.0}, "damping"),
        ({"drag": 1e13}, "drag"),
        ({"stretch_stiffness": "x"}, "stretch_stiffness"),
        ({"masses": np.array([1.0, 0.0, 1.0])}, "masses"),
        ({"stretch": "membrane", "young_modulus": 1.0, "poisson_ratio": 1.5}, "poisson_ratio"),
    ):
        with pytest.raises(yore.ArgumentError) as error:
            yore.Cloth(V, F, **arguments)
        assert error.value.argument == name
        assert str(error.value).startswith(name.rstrip("es"))  # the text names it too
        assert isinstance(error.value, ValueError)
    with pytest.raises(ValueError) as error:  # not an argument's fault: no argument
        yore.Cloth(V, np.array([[0, 1, 1]]))
    assert not isinstance(error.value, yore.ArgumentError)
