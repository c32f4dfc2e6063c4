"""yore's input limits are one table (cpp/include/yore/platform/limits.hpp, `yore.limits`): the
Python modules name theirs from it, the core checks its own against the same constants, and the
Limitations page quotes the table's numbers."""

import ast
import re
from pathlib import Path

import numpy as np
import pytest

import yore
from yore import _cpu
from yore.limits import LIMITS

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "python" / "yore"


def test_the_table_holds_counts_as_ints_and_quantities_as_positive_floats():
    assert len(LIMITS) > 25 and dict(LIMITS) == _cpu.limits
    for name, value in LIMITS.items():
        assert re.fullmatch(r"(max|min)_[a-z_]+", name), name
        assert isinstance(value, (int, float)) and not isinstance(value, bool), name
        assert value > 0, name
        assert getattr(LIMITS, name) == value
    assert isinstance(LIMITS.max_mesh_vertices, int) and isinstance(LIMITS.min_dt, float)


def _module_limits(path):
    """(name, value expression) of every module-level MAX_* / MIN_* assignment of a file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target = node.targets[0]
            if isinstance(target, ast.Name) and re.match(r"(MAX|MIN)_", target.id):
                yield target.id, node.value


def test_no_module_writes_a_limit_of_its_own():
    # a limit is read from the table (or derived from one, or from a core table): an
    # assignment whose value names nothing is a number written a second time
    own = []
    seen = 0
    for path in sorted(PACKAGE.rglob("*.py")):
        for name, value in _module_limits(path):
            seen += 1
            if not any(isinstance(n, (ast.Name, ast.Attribute)) for n in ast.walk(value)):
                own.append(f"{path.relative_to(ROOT)}: {name}")
    assert seen > 25 and own == []


@pytest.mark.parametrize(
    ("module", "name", "key"),
    [
        ("yore.meshes", "MAX_MESH_VERTICES", "max_mesh_vertices"),
        ("yore.checks", "MAX_IMAGE_PIXELS", "max_image_pixels"),
        ("yore.checks", "MIN_DT", "min_dt"),
        ("yore.stroke", "MAX_REFINE", "max_refine"),
        ("yore.state", "MAX_STATE_VERTICES", "max_state_vertices"),
        ("yore.runs.schema", "MAX_INTEGER", "max_integer"),
        ("yore.sweep.spec", "MAX_CELLS", "max_cells"),
    ],
)
def test_the_modules_names_are_the_tables_values(module, name, key):
    import importlib

    assert getattr(importlib.import_module(module), name) == LIMITS[key]


def test_the_core_checks_its_limits_at_the_tables_values():
    V, F = yore.grid_mesh(3, 3)
    top = LIMITS.max_material_value
    yore.Cloth(V, F, masses=1e-3, stretch_stiffness=top)  # at the limit: accepted
    with pytest.raises(ValueError, match="stretch_stiffness"):
        yore.Cloth(V, F, masses=1e-3, stretch_stiffness=np.nextafter(top, np.inf))
    with pytest.raises(ValueError, match="mass"):
        yore.Cloth(V, F, masses=np.nextafter(top, np.inf))
    # a stroke's refinement passes: the core's own check, at the table's value
    sim = yore.Simulation(yore.Cloth(V, F, masses=1e-3), integrator="explicit", dt=1e-4)
    with pytest.raises(ValueError, match="refine"):
        sim.stroke(
            yore.StrokePath.material([[0.1, 0.5], [0.9, 0.5]]),
            yore.StrokeOptions(refine=LIMITS.max_refine + 1),
        )


def _spaced(number):
    return f"{number:,}".replace(",", " ")


@pytest.mark.parametrize(
    ("key", "text"),
    [
        ("max_mesh_vertices", "{} vertices"),
        ("max_image_side", "1–{} px"),
        ("max_image_pixels", "{} px in all"),
        ("max_threads", "1–{}"),
        ("max_steps", "at most {} steps"),
        ("max_refined_vertices", "at most {} vertices"),
        ("max_state_vertices", "at most {}"),
        ("max_smoothing_iterations", "smoothing iterations {}"),
        ("max_view_stroke_samples", "at most {} samples"),
    ],
)
def test_the_limitations_page_quotes_the_table(key, text):
    page = (ROOT / "docs" / "limitations.md").read_text(encoding="utf-8")
    table = page[page.index("## Input limits") :]
    assert text.format(_spaced(LIMITS[key])) in table
