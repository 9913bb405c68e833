"""What the command modules share: argument types and writing a command's JSON record."""

from __future__ import annotations

import argparse
from typing import Any

from acrobot_mj.files import write_json


def positive_int(text: str) -> int:
    """An argparse type: an integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def write_record(path: str | None, data: dict[str, Any]) -> None:
    """Write ``data`` as JSON to ``path`` (when given) and say so."""
    if path:
        write_json(path, data)
        print(f"wrote {path}")
