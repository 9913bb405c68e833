"""What the command modules share: argument types, the progress flag and writing a command's
JSON record."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Protocol

from acrobot_mj.files import write_json


class Commands(Protocol):
    """What ``ArgumentParser.add_subparsers()`` returns: each command adds its parser to it."""

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser: ...


def positive_int(text: str) -> int:
    """An argparse type: an integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def seed(text: str) -> int:
    """An argparse type: a seed, an integer >= 0 (numpy's seeding takes no other)."""
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"a seed must be an integer >= 0, got {value}")
    return value


def add_progress(p: argparse.ArgumentParser) -> None:
    """``--progress/--no-progress``: a bar on stderr, by default when stderr is a terminal."""
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )


def show_progress(args: argparse.Namespace) -> bool:
    """Whether to show a bar: as asked, else when stderr is a terminal."""
    return sys.stderr.isatty() if args.progress is None else args.progress


def write_record(path: str | None, data: dict[str, Any]) -> None:
    """Write ``data`` as JSON to ``path`` (when given) and say so."""
    if path:
        write_json(path, data)
        print(f"wrote {path}")
