"""Write the docs' generated tables: the configs' settings from their declarations
(acrobot_mj.settings.table), and any table a function of the package writes (the AI Olympics
scores from the recorded runs: acrobot_mj.olympics.tables).

A table sits between ``<!-- settings: MODULE.NAME -->`` and ``<!-- end settings -->`` in a page
of docs/ (``NAME`` a config class, or a function that returns the table); this rewrites every
such block. tests/test_settings.py checks that the committed pages equal what this writes.

    python scripts/settings_tables.py           # rewrite the pages
    python scripts/settings_tables.py --check   # exit 1 where a page differs
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
from pathlib import Path
from typing import Any

from acrobot_mj.settings import table

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted(p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts)
BLOCK = re.compile(r"(<!-- settings: ([\w.]+) -->\n)(.*?)(<!-- end settings -->)", re.S)


def named(dotted: str) -> Any:
    """The class or function ``module.NAME`` a block names."""
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def rendered(text: str) -> str:
    """``text`` with each block holding its class's table, or its function's."""

    def block(match: re.Match) -> str:
        start, dotted, _, end = match.groups()
        found = named(dotted)
        return f"{start}\n{table(found) if isinstance(found, type) else found()}\n{end}"

    return BLOCK.sub(block, text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 where a page differs")
    args = parser.parse_args(argv)
    stale = []
    for page in PAGES:
        text = page.read_text()
        new = rendered(text)
        if new != text:
            stale.append(page.relative_to(ROOT))
            if not args.check:
                page.write_text(new)
    for page in stale:
        print(f"{'differs' if args.check else 'wrote'}: {page}")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
