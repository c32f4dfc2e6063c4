"""The contributor page (docs/contributing.md) tells the truth about the code: every repository
path it writes exists, every `file::name` is defined in that file, every dotted `yore.` name
resolves, every `make` target exists, and the three recipes describe the mechanisms the code
has: one registry row per integrator, one table row per growth mode, and the command line's
`_add_<name>` / `handlers` registration with its one-line errors and exit code 2.

The page's markup is what makes this mechanical: paths and names in backticks, paths from the
repository root, `file::name` for a name defined in a file. Code blocks are not read."""

import ast
import importlib
import importlib.util
import re
from pathlib import Path

import pytest

import yore
import yore.cli
from yore import _core
from yore.options import (
    GROWTH_MODES,
    INTEGRATOR_OPTIONS,
    INTEGRATOR_SPECS,
    INTEGRATORS,
    IntegratorSpec,
)

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGE = DOCS / "contributing.md"
TOP_LEVEL = ("CMakeLists.txt", "Makefile", "README.md", "pyproject.toml")
FOLDERS = (
    "bench-results",
    "benchmarks",
    "cmake",
    "cpp",
    "docs",
    "examples",
    "python",
    "tests",
    "tools",
)


def _page():
    return PAGE.read_text(encoding="utf-8")


def _prose(text):
    """The text without its fenced code blocks."""
    return re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)


def _spans(text):
    """The inline code spans of the prose."""
    return re.findall(r"`([^`\n]+)`", _prose(text))


def _repository_path(span):
    """The repository path a span names (before any `::name`), or None."""
    path = span.split("::", 1)[0]
    if " " in path:
        return None
    if path in TOP_LEVEL or path.split("/", 1)[0] in FOLDERS and "/" in path:
        return path
    return None


def missing_paths(text, root=ROOT):
    """(paths checked, those that do not exist). A placeholder such as <unit> matches any name,
    but something must match it."""
    paths = sorted({p for p in map(_repository_path, _spans(text)) if p})
    missing = [p for p in paths if not any(root.glob(re.sub(r"<[^>]+>", "*", p).rstrip("/")))]
    return paths, missing


def _python_module(path):
    """The module a python/ file is ("python/yore/runs/schema.py" → "yore.runs.schema")."""
    name = path[len("python/") : -len(".py")].replace("/", ".")
    return name[: -len(".__init__")] if name.endswith(".__init__") else name


def _undefined(path, name, root):
    """Why `path::name` does not hold, or None when it does."""
    file = root / path
    if not file.is_file():
        return "no such file"
    if path.startswith("python/") and path.endswith(".py"):
        target = importlib.import_module(_python_module(path))
        for part in name.split("."):
            if not hasattr(target, part):
                return f"{part} is not defined"
            target = getattr(target, part)
        return None
    source = file.read_text(encoding="utf-8")
    if path.endswith(".py"):  # tests and benchmarks are read, not imported
        top = re.escape(name.split(".")[0])
        found = re.search(rf"^(def|class) {top}\b|^{top}\s*=", source, re.M)
        return None if found else f"{name} is not defined at the top level"
    for word in re.split(r"::|\.", name):  # C++, CMake: each part of a qualified name occurs
        if not re.search(rf"\b{re.escape(word)}\b", source):
            return f"{word} does not occur"
    return None


def undefined_names(text, root=ROOT):
    """(`file::name` spans checked, [(span, why) for those whose file does not define the name])."""
    spans = sorted({s for s in _spans(text) if "::" in s and _repository_path(s)})
    wrong = []
    for span in spans:
        why = _undefined(*span.split("::", 1), root)
        if why:
            wrong.append((span, why))
    return spans, wrong


def _resolve(dotted):
    """Whether a dotted name resolves: the longest prefix that is a module (found, not
    imported: `yore.__main__` would run the command), then attributes of it."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        module = ".".join(parts[:cut])
        try:
            spec = importlib.util.find_spec(module)
        except (ImportError, ValueError):
            spec = None
        if spec is None:
            continue
        if cut == len(parts):
            return True
        target = importlib.import_module(module)
        for part in parts[cut:]:
            if not hasattr(target, part):
                return False
            target = getattr(target, part)
        return True
    return False


def unresolved_dotted_names(text):
    """(dotted Python names checked, those that do not resolve); `_core.x` is yore._core's."""
    names = sorted({s for s in _spans(text) if re.fullmatch(r"(yore|_core)(\.[A-Za-z_]\w*)+", s)})
    wrong = [n for n in names if not _resolve(n if n.startswith("yore") else f"yore.{n}")]
    return names, wrong


def missing_make_targets(text, root=ROOT):
    """(make targets named, in code spans or at the start of code-block lines, and those the
    Makefile does not define)."""
    named = [m.group(1) for s in _spans(text) for m in [re.fullmatch(r"make ([\w-]+)", s)] if m]
    named += re.findall(r"^make ([\w-]+)", text, re.M)
    makefile = (root / "Makefile").read_text(encoding="utf-8")
    targets = sorted(set(named))
    return targets, [t for t in targets if not re.search(rf"^{re.escape(t)}:", makefile, re.M)]


# -- the page's references ---------------------------------------------------------------------
def test_every_repository_path_on_the_page_exists():
    paths, missing = missing_paths(_page())
    assert len(paths) >= 40, paths  # the reader found the page's paths
    assert missing == []


def test_every_file_qualified_name_is_defined_in_its_file():
    spans, wrong = undefined_names(_page())
    assert len(spans) >= 40, spans
    assert {s.split("::")[0].rsplit(".", 1)[-1] for s in spans} >= {"hpp", "cpp", "py"}
    assert wrong == []


def test_every_dotted_python_name_resolves():
    names, wrong = unresolved_dotted_names(_page())
    assert len(names) >= 15, names
    assert wrong == []


def test_every_make_target_the_page_names_exists():
    targets, missing = missing_make_targets(_page())
    assert {"test", "test-fast", "bench"} <= set(targets)
    assert missing == []


def test_the_checkers_find_what_is_wrong(tmp_path):
    (tmp_path / "Makefile").write_text("test:\n\techo\n")
    (tmp_path / "cpp").mkdir()
    (tmp_path / "cpp" / "a.hpp").write_text("struct Present {};\n")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "test_a.py").write_text("def test_here():\n    pass\n")
    text = (
        "`cpp/a.hpp` and `cpp/gone.hpp`, `cpp/<unit>.hpp` and `cpp/<unit>.cpp`;\n"
        "`cpp/a.hpp::Present`, `cpp/a.hpp::Absent`, `tests/test_a.py::test_here`,\n"
        "`tests/test_a.py::test_gone`, `tests/test_a.py::pass`; `make test`,\n"
        "`make no-such-target`.\n"
        "```sh\nmake another-missing-target\n`cpp/in-a-code-block.hpp`\n```\n"
    )
    assert missing_paths(text, tmp_path)[1] == ["cpp/<unit>.cpp", "cpp/gone.hpp"]
    assert [span for span, _ in undefined_names(text, tmp_path)[1]] == [
        "cpp/a.hpp::Absent",
        "tests/test_a.py::pass",
        "tests/test_a.py::test_gone",
    ]
    assert missing_make_targets(text, tmp_path)[1] == ["another-missing-target", "no-such-target"]
    # python/ files are imported: their names are attributes of the module
    text = (
        "`python/yore/options.py::INTEGRATOR_SPECS`, `python/yore/options.py::NO_SUCH`,\n"
        "`python/yore/simulation.py::Simulation.step`,\n"
        "`python/yore/simulation.py::Simulation.no_such_method`; `yore.options.GROWTH_MODES`,\n"
        "`yore.options.NO_SUCH`, `yore.no_such_module`, `_core.growth_modes`, `_core.nothing`\n"
    )
    assert [span for span, _ in undefined_names(text)[1]] == [
        "python/yore/options.py::NO_SUCH",
        "python/yore/simulation.py::Simulation.no_such_method",
    ]
    assert unresolved_dotted_names(text)[1] == [
        "_core.nothing",
        "yore.no_such_module",
        "yore.options.NO_SUCH",
    ]


def test_the_page_is_in_the_documentation_toctree():
    toctrees = re.findall(
        r"^```\{toctree\}\n(.*?)^```", (DOCS / "index.md").read_text("utf-8"), re.M | re.S
    )
    assert any("contributing" in tree.split() for tree in toctrees)


# -- the integrator recipe: one registry row ------------------------------------------------------
def _options_headings():
    """The integrator names of the bold headings of docs/integrators.md's Options section."""
    text = (DOCS / "integrators.md").read_text(encoding="utf-8")
    section = re.search(r"^## Options\n(.*?)(?=^## )", text, re.M | re.S).group(1)
    names = set()
    for heading in re.findall(r"^\*\*([a-z0-9 ,-]+)\*\*$", section, re.M):
        names.update(n for n in re.split(r",\s*|\s+and\s+", heading) if n)
    return names


def test_each_integrator_is_one_row_that_builds_a_core_integrator_the_page_names():
    named = [
        re.fullmatch(r"cpp/include/yore/(?:\w+/)*\w+\.hpp::(\w+Integrator)", span)
        for span in _spans(_page())
    ]
    page_classes = {match.group(1) for match in named if match}
    documented = _options_headings()
    built = set()
    for name in INTEGRATORS:
        spec = INTEGRATOR_SPECS[name]
        assert isinstance(spec, IntegratorSpec) and spec.name == name
        assert spec.options is INTEGRATOR_OPTIONS[name]
        core = spec.make(dict(spec.options))
        assert type(core).__module__ == "yore._native" and callable(core.advance), name
        built.add(type(core).__name__)
        assert name in documented, f"{name}: no options table in docs/integrators.md"
    # the page lists the core's integrator classes: those the registry builds, and no other
    assert page_classes - {"Integrator"} == built


# -- the stroke-mode recipe: one row of the growth table ------------------------------------------
def test_the_growth_modes_are_one_table_in_core_binding_registry_and_docs():
    header = (ROOT / "cpp/include/yore/stroke/growth.hpp").read_text(encoding="utf-8")
    body = re.search(r"enum class GrowthMode[^{]*\{(.*?)\};", header, re.S).group(1)
    enumerators = re.findall(r"^\s*(\w+) = (\d+),", body, re.M)
    assert [int(value) for _, value in enumerators] == list(range(len(enumerators)))
    table = (ROOT / "cpp/src/stroke/growth.cpp").read_text(encoding="utf-8")
    rows = re.findall(
        r'^\s*\{"(\w+)", (?:true|false), (?:true|false), (?:true|false)\},', table, re.M
    )
    assert (
        [name for name, _ in enumerators]
        == rows
        == list(_core.growth_modes())
        == list(GROWTH_MODES)
    )
    # one count, which the recipe tells a contributor to raise, sizes the table and the binding
    (count,) = re.findall(r"\bkGrowthModeCount = (\d+);", header)
    assert int(count) == len(GROWTH_MODES)
    assert "std::array<GrowthRule, kGrowthModeCount> kGrowthRules" in table
    binding = (ROOT / "cpp/bindings/stroke/bind_growth.cpp").read_text(encoding="utf-8")
    assert re.search(r"k < kGrowthModeCount;", binding) and not re.search(r"k < \d", binding)
    for page in ("strokes.md", "scene-files.md"):
        text = (DOCS / page).read_text(encoding="utf-8")
        growth_rows = [line for line in text.splitlines() if line.startswith("| `growth`")]
        assert len(growth_rows) == 1, page
        assert set(re.findall(r'`"(\w+)"`', growth_rows[0])) == set(GROWTH_MODES), page


SCENE = """\
[mesh]
generator = "grid"
nx = 5
ny = 5

[simulation]
duration = 0.1

[[strokes]]
time = 0.05
material = [[0.1, 0.5], [0.9, 0.5]]
growth = "{growth}"
"""


def test_scene_files_take_every_growth_mode_and_no_other(tmp_path):
    path = tmp_path / "scene.toml"
    for growth in GROWTH_MODES:
        path.write_text(SCENE.format(growth=growth), encoding="utf-8")
        assert yore.load_scene(path).data["strokes"][0]["growth"] == growth
    path.write_text(SCENE.format(growth="sideways"), encoding="utf-8")
    with pytest.raises(ValueError, match="growth") as error:
        yore.load_scene(path)
    assert all(repr(mode) in str(error.value) for mode in GROWTH_MODES)


# -- the command recipe: _add_<name> in build_parser, a handler in _main -------------------------
def _cli_function(name, module="cli"):
    tree = ast.parse((ROOT / f"python/yore/{module}.py").read_text(encoding="utf-8"))
    return next(
        node for node in tree.body if isinstance(node, ast.FunctionDef) and node.name == name
    )


def _commands():
    parser = yore.cli.build_parser()
    return next(a for a in parser._actions if a.dest == "command").choices


def test_every_command_is_registered_as_the_recipe_says_and_documented_and_tested():
    commands = set(_commands())
    assert {"run", "check", "view"} <= commands
    added = {
        node.func.id
        for node in ast.walk(_cli_function("build_parser", "cli_parser"))
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and node.func.id.startswith("_add_")
    }
    (handlers,) = [
        node.value
        for node in ast.walk(_cli_function("_main"))
        if isinstance(node, ast.Assign)
        and isinstance(node.value, ast.Dict)
        and [t.id for t in node.targets if isinstance(t, ast.Name)] == ["handlers"]
    ]
    assert {key.value for key in handlers.keys} == commands
    tests = "".join(path.read_text(encoding="utf-8") for path in (ROOT / "tests").glob("test_*.py"))
    commands_page = (DOCS / "commands.md").read_text(encoding="utf-8")
    linked = [commands_page] + [
        (DOCS / link).read_text(encoding="utf-8")
        for link in set(re.findall(r"\]\(([\w-]+\.md)", commands_page))
    ]
    for command in sorted(commands):
        identifier = command.replace("-", "_")
        assert f"_add_{identifier}" in added, command
        value = handlers.values[[key.value for key in handlers.keys].index(command)]
        assert value.id == f"_{identifier}" and callable(getattr(yore.cli, value.id)), command
        words = command.split("-")  # "sweep-plot" is typed "yore sweep plot"
        assert any(f"yore {' '.join(words)}" in page for page in linked), command
        called = r"main\(\[\s*" + r",\s*".join(f'"{word}"' for word in words)
        assert re.search(called, tests), f"no test calls yore {' '.join(words)}"


def test_bad_input_is_one_line_starting_yore_error_and_exit_code_2(tmp_path, capsys):
    assert yore.cli.EXIT_BAD_INPUT == 2
    with pytest.raises(SystemExit) as usage:  # a usage error, from the parser
        yore.cli.main(["no-such-command"])
    assert usage.value.code == 2
    error = capsys.readouterr().err
    assert error.startswith("yore: error:") and error.count("\n") == 1
    # a ValueError or OSError raised by a handler
    assert yore.cli.main(["check", str(tmp_path / "missing.toml")]) == 2
    error = capsys.readouterr().err
    assert error.startswith("yore: error:") and error.count("\n") == 1


# -- benchmarks --------------------------------------------------------------------------------
@pytest.mark.parametrize("flag", ["--resume", "--merge"])
def test_the_page_names_the_benchmarks_that_take_resume_and_merge(flag):
    (item,) = re.findall(rf"^- `{flag}[^`]*`(.*?)(?=\n- |\n\n)", _prose(_page()), re.M | re.S)
    named = set(re.findall(r"`(benchmarks/\w+\.py)`", item))
    taking = {
        f"benchmarks/{path.name}"
        for path in (ROOT / "benchmarks").glob("*.py")
        if re.search(rf'\(\s*"{flag}"', path.read_text(encoding="utf-8"))
    }
    assert taking and named == taking
