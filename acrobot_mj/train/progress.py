"""A one-line progress bar for training runs, on stderr."""

from __future__ import annotations

import sys
import time

from acrobot_mj.train.records import History
from acrobot_mj.train.stats import RECENT, recent_median


class Progress:
    """A one-line progress bar on stderr, redrawn at most every 0.5 s (and only if enabled)."""

    def __init__(self, total: int, label: str, enabled: bool) -> None:
        self.total, self.label, self.enabled = total, label, enabled
        self.start = self.last = time.perf_counter()

    def update(self, done: int, history: History) -> None:
        now = time.perf_counter()
        if not self.enabled or (now - self.last < 0.5 and done < self.total):
            return
        self.last = now
        bar = "#" * int(30 * done / self.total)
        end = "\n" if done >= self.total else ""
        sys.stderr.write(
            f"\r{self.label} [{bar:<30}] {done}/{self.total} episodes, last {RECENT}: median "
            f"{recent_median(history.episode_lengths):.0f} decisions, "
            f"{sum(history.episode_successes)} successes, "
            f"{now - self.start:.0f} s{end}"
        )
        sys.stderr.flush()
