"""The C++ tree sits in topic folders mirrored across cpp/include/yore, cpp/src, cpp/bindings
and tests/cpp; the C++ tests mirror the sources (tests/cpp/<topic>/test_<unit>.cpp for
cpp/src/<topic>/<unit>.cpp, or a test file whose opening comment names the unit), ctest runs
every test file, and `_core` exports only what Python code outside the tests uses (primitives
are tested in C++)."""

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
    # units in topic folders (cpp/src/integrators/schemes/...) by their path under cpp/src
    source = ROOT / "cpp" / "src"
    units = sorted(p.relative_to(source).with_suffix("").as_posix() for p in source.rglob("*.cpp"))
    assert len(units) > 20
    test_files = sorted(CPP_TESTS.rglob("test_*.cpp"))
    comments = {
        p.relative_to(CPP_TESTS).with_suffix("").as_posix(): _opening_comment(p) for p in test_files
    }
    for stem, comment in comments.items():
        # each file says which unit it mirrors, by path
        assert re.search(r"cpp/src/[\w/]+\.cpp", comment), f"{stem}: name the unit it tests"
    untested = [
        u
        for u in units
        if f"{Path(u).parent.as_posix()}/test_{Path(u).name}" not in comments
        and not any(f"cpp/src/{u}.cpp" in c for c in comments.values())
    ]
    assert untested == []


TOPICS = ("cloth", "integrators", "solvers", "stroke", "geometry", "platform")


def test_the_tree_sits_in_topic_folders_mirrored_across_its_four_roots():
    # no unit at a root; every folder one of the topics (time schemes one level below theirs)
    roots = {
        "cpp/include/yore": "*.hpp",
        "cpp/src": "*.cpp",
        "cpp/bindings": "bind_*.cpp",
        "tests/cpp": "test_*.cpp",
    }
    for root, pattern in roots.items():
        assert sorted((ROOT / root).glob(pattern)) == [], root
        for path in (ROOT / root).rglob(pattern):
            assert path.relative_to(ROOT / root).parts[0] in TOPICS, path
    # a header's unit lives in the same topic folder under cpp/src (header-only units aside)
    for header in (ROOT / "cpp/include/yore").rglob("*.hpp"):
        topic = header.parent.name
        source = ROOT / "cpp/src" / topic / (header.stem + ".cpp")
        assert source.exists() or not list((ROOT / "cpp/src").rglob(header.stem + ".cpp")), header


def test_ctest_runs_every_test_file():
    text = (CPP_TESTS / "CMakeLists.txt").read_text(encoding="utf-8")
    listed = re.search(r"set\(YORE_TEST_UNITS(.*?)\)", text, re.S).group(1).split()
    files = sorted(
        f"{p.parent.relative_to(CPP_TESTS).as_posix()}/{p.stem.removeprefix('test_')}"
        for p in CPP_TESTS.rglob("test_*.cpp")
    )
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
