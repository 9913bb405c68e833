"""Progress bars on stderr: tqdm, imported only when a bar is shown."""

from __future__ import annotations

import sys
from typing import Any


def make_bar(total: int | None, label: str, enabled: bool, unit: str) -> Any | None:
    """A tqdm bar of ``total`` (None: unknown) ``unit`` on stderr, or None if not ``enabled``."""
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=label, unit=f" {unit}", file=sys.stderr, dynamic_ncols=True)


class Steps:
    """A bar over a command's steps, each named as it finishes; nothing when not ``enabled``."""

    def __init__(self, total: int | None, label: str, enabled: bool, unit: str = "steps") -> None:
        self.bar = make_bar(total, label, enabled, unit)

    def done(self, what: str = "", count: int = 1) -> None:
        if self.bar is not None:
            if what:
                self.bar.set_postfix_str(what, refresh=False)
            self.bar.update(count)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self) -> Steps:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
