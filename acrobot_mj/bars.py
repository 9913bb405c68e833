"""Progress bars on stderr: tqdm, imported only when a bar is shown. The one place the package
makes them (training's :mod:`acrobot_mj.train.progress`, sweeps, ``validate``)."""

from __future__ import annotations

import sys
from typing import Any


def make_bar(total: int | None, label: str, enabled: bool, unit: str) -> Any | None:
    """A tqdm bar of ``total`` ``unit`` (None: not known) on stderr, or None when not
    ``enabled``."""
    if not enabled:
        return None
    from tqdm import tqdm  # only when a bar is shown

    return tqdm(total=total, desc=label, unit=f" {unit}", file=sys.stderr, dynamic_ncols=True)


class Steps:
    """A bar over a command's steps, each named as it finishes; nothing when not ``enabled``."""

    def __init__(self, total: int | None, label: str, enabled: bool, unit: str = "steps") -> None:
        self.bar = make_bar(total, label, enabled, unit)

    def done(self, what: str = "", count: int = 1) -> None:
        """``count`` steps finished, the last of them ``what`` (if named)."""
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
