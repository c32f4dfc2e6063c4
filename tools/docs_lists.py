"""The documentation's lists of integrators, generated from the registry
(`yore.options.INTEGRATOR_SPECS`), so that a new integrator's registry row is all a page needs.

A page holds a generated list between the markers ``<!-- integrators -->`` and
``<!-- /integrators -->`` (one line: it may sit in a table cell), or a generated table (name,
summary, the work of a step) between ``<!-- integrator-table -->`` and
``<!-- /integrator-table -->``. ``python tools/docs_lists.py`` rewrites every such list and table
under ``docs/``; ``--check`` only reports the stale ones (exit 1), as ``tests/test_docs.py``
does.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"
START, END = "<!-- integrators -->", "<!-- /integrators -->"
_LIST = re.compile(re.escape(START) + r".*?" + re.escape(END))
TABLE_START, TABLE_END = "<!-- integrator-table -->", "<!-- /integrator-table -->"
_TABLE = re.compile(re.escape(TABLE_START) + r".*?" + re.escape(TABLE_END), re.S)


def short_summary(summary: str) -> str:
    """A registry summary up to its first parenthesis or semicolon."""
    return re.split(r" \(|;", summary, maxsplit=1)[0].strip()


def integrator_list() -> str:
    """Every registered integrator, in the registry's order: its name and short summary."""
    from yore.options import INTEGRATOR_SPECS

    items = [
        f'`"{name}"` ({short_summary(spec.summary)})' for name, spec in INTEGRATOR_SPECS.items()
    ]
    return f"{START}{', '.join(items)}{END}"


def step_work(spec) -> str:
    """What one step of an integrator does, from its registry row."""
    if spec.error_controlled:
        return "internal steps its tolerance chooses, one factor kept across them"
    if spec.newton:
        return "Newton iterations, each a sparse Cholesky factorization and solve"
    if spec.conditionally_stable:
        return "one force evaluation"
    return "iterations, each a solve with one constant factor"


def integrator_table() -> str:
    """Every registered integrator as a Markdown table: name, summary, the work of a step."""
    from yore.options import INTEGRATOR_SPECS

    lines = [TABLE_START, "| integrator | method | per step |", "|---|---|---|"]
    lines += [
        f'| `"{name}"` | {spec.summary} | {step_work(spec)} |'
        for name, spec in INTEGRATOR_SPECS.items()
    ]
    return "\n".join(lines + [TABLE_END])


def refreshed(text: str) -> str:
    """`text` with each marked list and table replaced by the registry's."""
    fresh, table = integrator_list(), integrator_table()
    return _TABLE.sub(lambda match: table, _LIST.sub(lambda match: fresh, text))


def pages_with_lists(docs: Path = DOCS):
    """The Markdown pages under `docs` holding a marked list or table."""
    return sorted(
        path
        for path in docs.glob("*.md")
        if START in path.read_text("utf-8") or TABLE_START in path.read_text("utf-8")
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="report stale pages, write none")
    arguments = parser.parse_args(argv)
    stale = []
    for path in pages_with_lists():
        text = path.read_text("utf-8")
        fresh = refreshed(text)
        if fresh != text:
            stale.append(path)
            if not arguments.check:
                path.write_text(fresh, encoding="utf-8")
    for path in stale:
        print(f"{'stale' if arguments.check else 'rewrote'}: {path.relative_to(DOCS.parent)}")
    return 1 if stale and arguments.check else 0


if __name__ == "__main__":
    sys.exit(main())
