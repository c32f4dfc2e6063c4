"""The C++ tests mirror the sources (tests/cpp/test_<unit>.cpp for cpp/src/<unit>.cpp, or a
test file whose opening comment names the unit), ctest runs every test file, and `_core`
exports only what Python code outside the tests uses (primitives are tested in C++)."""

import re
from pathlib import Path

from yore import _core

ROOT = Path(__file__).resolve().parents[1]
CPP_TESTS = ROOT / "tests" / "cpp"


def _opening_comment(path):
    lines = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("//"):
            break
        lines.append(line)
    return "\n".join(lines)


def test_every_source_unit_has_its_tests_where_it_lives():
    # units in topic folders (cpp/src/schemes/...) by their path under cpp/src
    source = ROOT / "cpp" / "src"
    units = sorted(p.relative_to(source).with_suffix("").as_posix() for p in source.rglob("*.cpp"))
    assert len(units) > 20
    test_files = sorted(CPP_TESTS.glob("test_*.cpp"))
    comments = {p.stem: _opening_comment(p) for p in test_files}
    for stem, comment in comments.items():
        # each file says which unit it mirrors, by path
        assert re.search(r"cpp/src/[\w/]+\.cpp", comment), f"{stem}: name the unit it tests"
    untested = [
        u
        for u in units
        if f"test_{u}" not in comments
        and not any(f"cpp/src/{u}.cpp" in c for c in comments.values())
    ]
    assert untested == []


def test_ctest_runs_every_test_file():
    text = (CPP_TESTS / "CMakeLists.txt").read_text(encoding="utf-8")
    listed = re.search(r"set\(YORE_TEST_UNITS(.*?)\)", text, re.S).group(1).split()
    files = sorted(p.stem.removeprefix("test_") for p in CPP_TESTS.glob("test_*.cpp"))
    assert sorted(listed) == files
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    test_target = re.search(r"^test: .*?(?=^\S)", makefile, re.S | re.M).group(0)
    assert "test-cpp" in test_target and "ctest" in makefile


def _python_text():
    sources = []
    for folder in ("python/yore", "benchmarks", "examples", "tools"):
        sources += [p.read_text(encoding="utf-8") for p in (ROOT / folder).rglob("*.py")]
    return "\n".join(sources)


def test_core_exports_only_what_python_code_uses():
    # Every public function of the module is called by the package, a benchmark, an example
    # or a tool; primitives only tests needed are tested in C++ (tests/cpp) instead.
    text = _python_text()
    exported = [
        name
        for name in dir(_core)
        if not name.startswith("_")
        and callable(getattr(_core, name))
        and not isinstance(getattr(_core, name), type)
    ]
    assert len(exported) > 5
    used = set(re.findall(r"_core\.(\w+)", text))
    for grouped, line in re.findall(r"from (?:\.+|yore\.)_core import (?:\(([^)]*)\)|(.*))", text):
        used |= {name.split(" as ")[0].strip() for name in (grouped or line).split(",")}
    unused = [name for name in exported if name not in used]
    assert unused == []
