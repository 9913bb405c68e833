"""Record a run's AI Olympics scores for the docs' tables: its ``olympics.json`` without the
episodes (acrobot_mj.olympics.results.summary), with the command that made it, as
``acrobot_mj/olympics/recorded/NAME.json``; then rewrite the tables.

    python scripts/record_olympics.py runs/tree-g3 tree-held-out \\
        "acrobot-mj olympics tree --scores global --seed 3 --seeds 8 --out runs/tree-g3"
    python scripts/settings_tables.py
"""

from __future__ import annotations

import argparse
import sys

from acrobot_mj.olympics.results import record_summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="the run's folder, or its olympics.json")
    parser.add_argument("name", help="the recorded file's name, without .json")
    parser.add_argument("command", help="the command that made the run")
    parser.add_argument("--note", default="", help="what else a reader should know of the run")
    args = parser.parse_args(argv)
    print(f"wrote {record_summary(args.run, args.name, args.command, args.note)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
