"""Watching a run as it trains: one progress bar (tqdm, on stderr) over all its learners, and
per-episode scalars for TensorBoard (:mod:`.tensorboard`) if asked.

A :class:`Monitor` is handed down a run's training paths (seeds, lockstep, population,
learner): each finished episode of any learner reaches :meth:`Monitor.episode`, so a run of
ten learners shows one bar of all their episodes (or decisions, under a decision cap) with the
median length of the last 20 episodes and the successes so far. tqdm is imported only when a
bar is shown.
"""

from __future__ import annotations

import contextlib
import time
from collections import deque
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from acrobot_mj.bars import make_bar
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.records import History
from acrobot_mj.train.stats import RECENT
from acrobot_mj.train.tensorboard import Board

#: Seconds between redraws of the bar's statistics (tqdm redraws the count more often).
POSTFIX_EVERY = 0.5


def run_total(config: TrainConfig) -> tuple[int, str]:
    """What a run's bar counts to: all its learners' episodes, or decisions under a cap."""
    cap = config.learner_decisions
    if cap > 0:
        return cap * config.population, "decisions"
    return config.episodes * config.population, "episodes"


class Progress:
    """A tqdm bar of ``total`` episodes (or decisions, ``unit``) on stderr, with the recent
    median length and the successes; nothing at all (and no tqdm) when not ``enabled``."""

    def __init__(self, total: int, label: str, enabled: bool, unit: str = "episodes") -> None:
        self.unit = unit
        self.recent: deque[int] = deque(maxlen=RECENT)
        self.successes, self._shown = 0, 0.0
        self.bar = make_bar(total, label, enabled, unit)

    def skip(self, history: History) -> None:
        """Count a resumed learner's episodes as done (before it trains on)."""
        self.recent.extend(history.episode_lengths[-RECENT:])
        self.successes += sum(history.episode_successes)
        if self.bar is not None:
            done = history.steps if self.unit == "decisions" else len(history)
            self.bar.n += done
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
        return f"median {median:.0f} decisions (last {RECENT}), {self.successes} successes"

    def retract(self, units: int, successes: int) -> None:
        """Take back ``units`` counted and ``successes`` (a log that was cut back)."""
        self.successes -= successes
        if self.bar is not None and units:
            self.bar.update(-units)

    def advance(self, count: int = 1) -> None:
        """Count ``count`` units done without episode statistics (a finished trial)."""
        if self.bar is not None:
            self.bar.update(count)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(self.stats(), refresh=False)
            self.bar.close()
            self.bar = None


class Monitor:
    """What watches a run's episodes: its :class:`Progress` bar and, if asked, a TensorBoard
    :class:`~acrobot_mj.train.tensorboard.Board`; ``name`` is the learner's TensorBoard run
    (``seed_3/learner_1``; empty for a run of one learner)."""

    def __init__(self, bar: Progress, board: Board | None = None, name: str = "") -> None:
        self.bar, self.board, self.name = bar, board, name

    def scoped(self, name: str) -> Monitor:
        """The same bar and board, for a learner ``name`` inside this one's run."""
        return Monitor(self.bar, self.board, f"{self.name}/{name}" if self.name else name)

    def restored(self, history: History) -> None:
        """A resumed learner's episodes so far."""
        self.bar.skip(history)

    def episode(self, index: int, length: int, total: float, success: bool) -> None:
        """Learner ``name``'s episode ``index`` finished."""
        self.bar.episode(length, success)
        if self.board is not None:
            self.board.add(self.name, index, length, total, success)

    def close(self) -> None:
        self.bar.close()
        if self.board is not None:
            self.board.close()


@contextlib.contextmanager
def watching(
    progress: bool | Monitor,
    total: tuple[int, str],
    label: str,
    tensorboard: str | Path | None = None,
) -> Iterator[Monitor]:
    """``progress`` if it is a :class:`Monitor` already (a learner of a bigger run), else a new
    one of ``total`` (count, unit) with a bar if ``progress`` and a board in ``tensorboard`` if
    given, closed at the end."""
    if isinstance(progress, Monitor):
        if tensorboard is not None:
            raise ValueError("give tensorboard to the run's outermost call, not to a learner")
        yield progress
        return
    board = None if tensorboard is None else Board(tensorboard)
    monitor = Monitor(Progress(total[0], label, bool(progress), total[1]), board)
    try:
        yield monitor
    finally:
        monitor.close()
