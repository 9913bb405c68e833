"""Watching a run as it trains: one :class:`~acrobot_mj.bars.EpisodeBar` over all its learners'
episodes, worker processes' logs followed into it, and per-episode scalars for TensorBoard if
asked."""

from __future__ import annotations

import contextlib
import json
import os
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from acrobot_mj.bars import EpisodeBar
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.records import RECENT, History

#: Seconds between reads of workers' logs.
EVERY = 0.5


def run_total(config: TrainConfig) -> tuple[int, str]:
    """What a run's bar counts to: all its learners' episodes, or decisions under a cap."""
    cap = config.learner_decisions
    count, unit = (cap, "decisions") if cap > 0 else (config.episodes, "episodes")
    return count * config.population, unit


class Monitor:
    """A run's :class:`~acrobot_mj.bars.EpisodeBar` and, if asked, its TensorBoard
    :class:`Board`; ``name`` is the learner's TensorBoard run (``seed_3/learner_1``; empty for a
    run of one learner)."""

    def __init__(self, bar: EpisodeBar, board: Board | None = None, name: str = "") -> None:
        self.bar, self.board, self.name = bar, board, name

    def scoped(self, name: str) -> Monitor:
        """The same bar and board, for a learner ``name`` inside this one's run."""
        return Monitor(self.bar, self.board, f"{self.name}/{name}" if self.name else name)

    def restored(self, history: History) -> None:
        self.bar.skip(history.episode_lengths, history.episode_successes)

    def episode(self, index: int, length: int, total: float, success: bool) -> None:
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
    """``progress`` if it is a :class:`Monitor` (a learner of a bigger run), else a new one of
    ``total`` (count, unit), with a bar if ``progress`` and a board in ``tensorboard``."""
    if isinstance(progress, Monitor):
        if tensorboard is not None:
            raise ValueError("give tensorboard to the run's outermost call, not to a learner")
        yield progress
        return
    board = None if tensorboard is None else Board(tensorboard)
    monitor = Monitor(EpisodeBar(total[0], label, bool(progress), total[1], RECENT), board)
    try:
        yield monitor
    finally:
        monitor.close()


class LogFollower:
    """Reads the complete lines added to ``paths`` into ``bar`` every :data:`EVERY` seconds in a
    ``with`` block, and once more at its end. A log replaced by a new file (a resume cuts it
    back) is read again from its start, its earlier lines taken off the bar."""

    def __init__(self, paths: list[Path], bar: EpisodeBar) -> None:
        self.paths, self.bar = paths, bar
        #: Per log: its file's inode, the bytes read, and the units and successes counted.
        self._seen: dict[Path, tuple[int, int, int, int]] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> LogFollower:
        if self.bar.bar is not None:  # nothing to show: nothing to read
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._thread.is_alive():
            self._stop.set()
            self._thread.join()
            self.poll()

    def _run(self) -> None:
        while not self._stop.wait(EVERY):
            self.poll()

    def poll(self) -> None:
        """Read what each log gained since the last poll."""
        for path in self.paths:
            with contextlib.suppress(OSError):  # not there yet, or being replaced: next time
                self._read(path)

    def _read(self, path: Path) -> None:
        with open(path, "rb") as f:
            inode, size = os.fstat(f.fileno()).st_ino, os.fstat(f.fileno()).st_size
            old, offset, units, successes = self._seen.get(path, (inode, 0, 0, 0))
            if old != inode or size < offset:  # a new file: count it again from its start
                self.bar.retract(units, successes)
                offset = units = successes = 0
            f.seek(offset)
            data = f.read()
        end = data.rfind(b"\n") + 1  # complete lines only: the rest is still being written
        for line in data[:end].splitlines():
            try:
                row = json.loads(line)
                length, success = int(row["length"]), bool(row["success"])
            except (ValueError, KeyError, TypeError):
                continue  # not an episode's line
            units += length if self.bar.unit == "decisions" else 1
            successes += success
            self.bar.episode(length, success)
        self._seen[path] = (inode, offset + end, units, successes)


def summary_writer() -> Any:
    """The ``SummaryWriter`` class of tensorboardX, or of torch; a one-line error without."""
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        try:
            from torch.utils.tensorboard import SummaryWriter
        except ImportError:
            raise ImportError(
                "--tensorboard needs tensorboardX (or torch with tensorboard): "
                "pip install acrobot-mj[tensorboard]"
            ) from None
    return SummaryWriter


class Board:
    """One ``SummaryWriter`` per learner under ``root``, opened at its first episode."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self._writer_class = summary_writer()  # fails here, before any training
        self._writers: dict[str, Any] = {}

    def add(self, name: str, index: int, length: int, total: float, success: bool) -> None:
        if name not in self._writers:
            self._writers[name] = self._writer_class(str(self.root / name))
        for tag, value in (("length", length), ("return", total), ("success", float(success))):
            self._writers[name].add_scalar(f"episode/{tag}", value, index)

    def close(self) -> None:
        for writer in self._writers.values():
            writer.close()
        self._writers.clear()
