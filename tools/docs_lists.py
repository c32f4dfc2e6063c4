"""The documentation's lists of integrators, generated from the registry
(`yore.options.INTEGRATOR_SPECS`), so that a new integrator's registry row is all a page needs.

A page holds a generated list between the markers ``<!-- integrators -->`` and
``<!-- /integrators -->`` (one line: it may sit in a table cell). ``python tools/docs_lists.py``
rewrites every such list under ``docs/``; ``--check`` only reports the stale ones (exit 1), as
``tests/test_docs.py`` does.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"
START, END = "<!-- integrators -->", "<!-- /integrators -->"
_LIST = re.compile(re.escape(START) + r".*?" + re.escape(END))


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


def refreshed(text: str) -> str:
    """`text` with each marked list replaced by the registry's."""
    fresh = integrator_list()
    return _LIST.sub(lambda match: fresh, text)


def pages_with_lists(docs: Path = DOCS):
    """The Markdown pages under `docs` holding a marked list."""
    return sorted(path for path in docs.glob("*.md") if START in path.read_text("utf-8"))


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
