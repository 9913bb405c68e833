"""A learner's episode log, ``episodes.jsonl``: one JSON object per finished training episode
(``episode``, ``length``, ``return``, ``success``, and ``wall_seconds`` and ``learner`` where
known), flushed as it ends and cut back, atomically, to its checkpoint's episodes on resume."""

from __future__ import annotations

import itertools
import json
import os
import time
from pathlib import Path
from typing import IO, Any

from acrobot_mj.files import check_regular, write_atomic


def log_line(row: dict[str, Any]) -> bytes:
    """One line of the log (strict JSON: a non-finite return has no place in it)."""
    return (json.dumps(row, allow_nan=False) + "\n").encode()


def _write(path: Path, rows: list[dict[str, Any]]) -> None:
    write_atomic(path, lambda f: f.writelines(log_line(row) for row in rows))


def read_rows(path: Path, count: int) -> list[dict[str, Any]]:
    """The first ``count`` complete lines of a log as dicts (a line cut short by a kill is not
    one). Raises ``ValueError`` for a line that is not a JSON object, ``OSError`` if unreadable."""
    rows: list[dict[str, Any]] = []
    check_regular(path)  # a pipe would wait for a writer forever
    with open(path, "rb") as lines:
        for line in itertools.islice(lines, count):
            if not line.endswith(b"\n"):
                break
            try:
                row = json.loads(line)
            except RecursionError:
                raise ValueError(f"line {len(rows) + 1} is nested too deeply") from None
            if not isinstance(row, dict):
                raise ValueError(f"line {len(rows) + 1} is not a JSON object")
            rows.append(row)
    return rows


class EpisodeLog:
    """Appends a learner's episodes to ``path`` as they finish, and to ``tee`` if given."""

    def __init__(self, path: Path, learner: int | None = None, tee: RunLog | None = None) -> None:
        self.path, self.learner, self.tee = path, learner, tee
        self._file: IO[bytes] | None = None
        self._offset, self._clock = 0.0, time.perf_counter()

    def start(self, history: Any) -> None:
        """Keep exactly ``history``'s episodes in the file (its first ``len(history)`` lines,
        else lines made from ``history``), atomically; then append after them."""
        self.close()
        count = len(history)
        try:
            kept = read_rows(self.path, count) if count else []
        except (OSError, ValueError):
            kept = []
        if len(kept) != count:  # no log, or an older run's: the history is all there is
            lists = history.episode_lengths, history.episode_returns, history.episode_successes
            own = {} if self.learner is None else {"learner": self.learner}
            kept = [
                {"episode": k, "length": n, "return": r, "success": s, **own}
                for k, (n, r, s) in enumerate(zip(*lists, strict=True))
            ]
        _write(self.path, kept)
        last = kept[-1].get("wall_seconds") if kept else None
        self._offset = float(last) if isinstance(last, (int, float)) else 0.0
        self._clock = time.perf_counter()
        self._file = open(self.path, "ab")  # kept open: closed by close()

    def append(self, episode: int, length: int, total: float, success: bool) -> None:
        """Log one finished episode and flush it to the OS (a kill -9 keeps it)."""
        row = {"episode": episode, "length": length, "return": total, "success": success}
        row["wall_seconds"] = round(self._offset + time.perf_counter() - self._clock, 6)
        if self.learner is not None:
            row["learner"] = self.learner
        if self._file is None:
            raise RuntimeError(f"{self.path}: start() the episode log before appending to it")
        self._file.write(log_line(row))
        self._file.flush()
        if self.tee is not None:
            self.tee.append(row)

    def sync(self) -> None:
        """Make the lines logged so far durable (before a checkpoint counts them)."""
        if self._file is not None:
            self._file.flush()
            os.fsync(self._file.fileno())

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def concatenate(target: Path, sources: list[Path], counts: list[int]) -> tuple[int, float]:
    """Write ``target`` (atomically) as the first ``counts[k]`` lines of each ``sources[k]``:
    one run's log of its learners' (numbered through, ``learner`` set to ``k``, the times
    running on). Returns the last source's first episode number and start time there."""
    rows: list[dict[str, Any]] = []
    offset, episode = 0.0, 0
    for k, (source, count) in enumerate(zip(sources, counts, strict=True)):
        start = (episode, offset)
        own = read_rows(source, count) if count else []
        if len(own) != count:
            raise ValueError(f"{source} holds {len(own)} episodes, its learner ran {count}")
        rows.extend(_renumbered(row, start, k) for row in own)
        episode += count
        offset += float(own[-1].get("wall_seconds", 0.0)) if own else 0.0
    _write(target, rows)
    return start if sources else (0, 0.0)


def _renumbered(row: dict[str, Any], start: tuple[int, float], learner: int) -> dict[str, Any]:
    moved = {**row, "episode": start[0] + row["episode"], "learner": learner}
    if "wall_seconds" in row:
        moved["wall_seconds"] = round(start[1] + row["wall_seconds"], 6)
    return moved


class RunLog:
    """A population run's own ``episodes.jsonl`` while learner ``len(sources) - 1`` trains: the
    lines of the learners before it and its own so far (``sources``, ``counts``), then each
    line the learner logs, renumbered."""

    def __init__(self, path: Path, sources: list[Path], counts: list[int]) -> None:
        self.learner = len(sources) - 1
        self._start = concatenate(path, sources, counts)
        self._file = open(path, "ab")  # kept open: closed by close()

    def append(self, row: dict[str, Any]) -> None:
        self._file.write(log_line(_renumbered(row, self._start, self.learner)))
        self._file.flush()

    def close(self) -> None:
        self._file.close()
