"""Progress bars on stderr: tqdm, imported only when a bar is shown. :class:`Steps` counts a
command's steps, :class:`EpisodeBar` a run's episodes with their recent statistics."""

from __future__ import annotations

import sys
import time
from collections import deque
from collections.abc import Sequence
from typing import Any

import numpy as np

#: Seconds between redraws of an episode bar's statistics.
POSTFIX_EVERY = 0.5


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


class EpisodeBar:
    """A bar of ``total`` episodes (or decisions, ``unit``) with the median length of the last
    ``window`` episodes and the successes; nothing at all (and no tqdm) when not ``enabled``."""

    def __init__(self, total: int, label: str, enabled: bool, unit: str, window: int) -> None:
        self.unit, self.window = unit, window
        self.recent: deque[int] = deque(maxlen=window)
        self.successes, self._shown = 0, 0.0
        self.bar = make_bar(total, label, enabled, unit)

    def skip(self, lengths: Sequence[int], successes: Sequence[bool]) -> None:
        """Count a resumed learner's episodes (their ``lengths`` and ``successes``) as done."""
        self.recent.extend(lengths[-self.window :])
        self.successes += sum(successes)
        if self.bar is not None:
            self.bar.n += int(sum(lengths)) if self.unit == "decisions" else len(lengths)
            self.bar.last_print_n = self.bar.n  # not a burst of speed
            self.bar.refresh()

    def episode(self, length: int, success: bool) -> None:
        """One finished episode of any learner."""
        self.recent.append(length)
        self.successes += bool(success)
        if self.bar is None:
            return
        now = time.monotonic()
        if now - self._shown >= POSTFIX_EVERY:
            self._shown = now
            self.bar.set_postfix_str(self.stats(), refresh=False)
        self.bar.update(length if self.unit == "decisions" else 1)

    def stats(self) -> str:
        """The bar's statistics: ``median 87 decisions (last 20), 12 successes``."""
        if not self.recent:
            return ""
        median = float(np.median(self.recent))
        return f"median {median:.0f} decisions (last {self.window}), {self.successes} successes"

    def retract(self, units: int, successes: int) -> None:
        """Take back ``units`` and ``successes`` counted (a log that was cut back)."""
        self.successes -= successes
        if self.bar is not None and units:
            self.bar.update(-units)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(self.stats(), refresh=False)
            self.bar.close()
            self.bar = None
