"""The code style is enforced (issue 54): every Python file passes `ruff check` and is as
`ruff format` writes it, and every C++ file is as `clang-format` writes it (the settings are in
pyproject.toml and .clang-format). To fix a failure: `.venv/bin/ruff format . && .venv/bin/ruff
check --fix .` and `clang-format -i <files>`."""

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUFF = Path(sys.executable).with_name("ruff")
CPP_FOLDERS = ("cpp", "tests/cpp")


def _run(command):
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)


def test_python_passes_ruff_check():
    done = _run([str(RUFF), "check", "--no-cache", "--output-format", "concise", "."])
    assert done.returncode == 0, done.stdout + done.stderr


def test_python_is_as_ruff_formats_it():
    done = _run([str(RUFF), "format", "--no-cache", "--check", "."])
    assert done.returncode == 0, done.stdout + done.stderr


def _cpp_files():
    return sorted(
        path
        for folder in CPP_FOLDERS
        for path in (ROOT / folder).rglob("*")
        if path.suffix in (".cpp", ".hpp")
    )


def test_cpp_is_as_clang_format_writes_it():
    clang_format = shutil.which("clang-format")
    assert clang_format, "clang-format is not installed (make setup installs it)"
    files = _cpp_files()
    assert len(files) > 50  # the core, the bindings and the C++ tests
    done = _run([clang_format, "--dry-run", "--Werror", *map(str, files)])
    assert done.returncode == 0, done.stderr[:4000]


def test_a_misformatted_file_is_caught(tmp_path):
    """The checks can fail: a badly spaced file is reported by both tools."""
    (tmp_path / "bad.py").write_text("x=( 1,2 )\n")
    done = _run([str(RUFF), "format", "--no-cache", "--check", str(tmp_path / "bad.py")])
    assert done.returncode == 1
    (tmp_path / ".clang-format").write_text((ROOT / ".clang-format").read_text())
    (tmp_path / "bad.cpp").write_text("int  f( int x ){return x;}\n")
    done = _run([shutil.which("clang-format"), "--dry-run", "--Werror", str(tmp_path / "bad.cpp")])
    assert done.returncode != 0
