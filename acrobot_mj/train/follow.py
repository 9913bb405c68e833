"""Following episode logs that other processes write (``train --seeds --jobs J``): a thread of
the driver reads the lines each worker's run adds to its ``episodes.jsonl`` and shows them on
the driver's one :class:`~acrobot_mj.train.progress.Progress` bar."""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

from acrobot_mj.train.progress import Progress

#: Seconds between reads of the logs.
EVERY = 0.5


class LogFollower:
    """Reads the complete lines added to ``paths`` every :data:`EVERY` seconds (while in a
    ``with`` block, and once more at its end) into ``bar``. A log replaced by a new file (a
    resume cuts it back) is read again from its start, its earlier lines taken off the bar."""

    def __init__(self, paths: list[Path], bar: Progress) -> None:
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
            try:
                self._read(path)
            except OSError:  # not there yet, or being replaced: the next poll reads it
                continue

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
                continue  # not an episode's line: nothing to show
            units += length if self.bar.unit == "decisions" else 1
            successes += success
            self.bar.episode(length, success)
        self._seen[path] = (inode, offset + end, units, successes)
