"""One owner at a time for a run directory: an exclusive ``flock`` on ``DIR/.lock``, the file
naming the owner (docs/explain/reliability.md). A directory inside a held one counts as held,
unless its holder is ours: lock holders pass their pids to workers in
``ACROBOT_MJ_LOCK_OWNERS``."""

from __future__ import annotations

import errno
import json
import os
import socket
import sys
import time
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # pragma: no cover  (Windows: exclusive creation instead)
    fcntl = None  # type: ignore[assignment]  # a module or None: checked before each use

LOCK_FILE = ".lock"
OWNERS_VARIABLE = "ACROBOT_MJ_LOCK_OWNERS"
#: Directories this process holds: [file descriptor, depth] (the lock is re-entrant).
_HELD: dict[Path, list[Any]] = {}


class RunDirectoryBusy(RuntimeError):
    """Another live process owns the run directory."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, owned by someone else
        return True
    return True


def _owners() -> set[int]:
    text = os.environ.get(OWNERS_VARIABLE, "")
    return {int(p) for p in text.split(",") if p.strip().isdigit()} | {os.getpid()}


def _describe(owner: dict[str, Any]) -> str:
    started = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(owner.get("started", 0)))
    return (
        f"pid {owner.get('pid')} on {owner.get('host')} ({owner.get('command', '?')}, "
        f"since {started})"
    )


def _read_owner(path: Path) -> dict[str, Any] | None:
    if not path.is_file():  # none, or not a lock (a FIFO would block the read)
        return None
    try:
        owner = json.loads(path.read_text() or "null")
    except (OSError, ValueError):
        return None
    return owner if isinstance(owner, dict) and isinstance(owner.get("pid"), int) else None


def _held_by_other(path: Path) -> dict[str, Any] | None:
    """The owner of lock file ``path`` if a live process outside ours holds it."""
    owner = _read_owner(path)
    if owner is None or owner["pid"] in _owners():
        return None
    if fcntl is None:
        return owner if _alive(owner["pid"]) else None
    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return owner
    finally:
        os.close(fd)  # closing drops the probe's shared lock
    return None


def check_not_held(directory: str | Path) -> None:
    """Raise :class:`RunDirectoryBusy` naming the owner where a live process outside ours holds
    ``directory``: a run being created has no record yet, and is not "no run"."""
    owner = _held_by_other(Path(directory) / LOCK_FILE)
    if owner is not None:
        raise RunDirectoryBusy(
            f"{directory} is in use by {_describe(owner)}: wait for it or stop it first"
        )


class RunLock:
    """Hold ``directory`` (created if needed) for this process; raises :class:`RunDirectoryBusy`
    naming the owner if a live process outside ours holds it or a directory above it."""

    def __init__(self, directory: str | Path, command: str = "acrobot-mj", create: bool = True):
        self.directory = Path(directory).resolve()
        self.command, self.create = command, create
        self._noop = False
        #: True where the directory cannot be written (a read-only mount): read, not locked.
        self.read_only = False

    def __enter__(self) -> RunLock:
        if not self.create and not self.directory.is_dir():
            self._noop = True  # nothing there to protect; the caller reports what is missing
            return self
        held = _HELD.get(self.directory)
        if held is not None:
            held[1] += 1
            return self
        for parent in self.directory.parents:
            owner = _held_by_other(parent / LOCK_FILE)  # None where there is no lock file
            if owner is not None:
                raise RunDirectoryBusy(
                    f"{self.directory} is inside {parent}, which is in use by "
                    f"{_describe(owner)}: wait for it or stop it first"
                )
        self.directory.mkdir(parents=True, exist_ok=True)
        try:
            fd = self._acquire()
        except OSError as error:
            if self.create or error.errno not in (errno.EROFS, errno.EACCES):
                raise
            self._noop = self.read_only = True  # a directory this process cannot write
            return self
        _HELD[self.directory] = [fd, 1]
        os.environ[OWNERS_VARIABLE] = ",".join(str(p) for p in sorted(_owners()))
        return self

    def _acquire(self) -> int:
        path = self.directory / LOCK_FILE
        if path.exists() and not path.is_file():
            raise FileExistsError(
                f"{path} is not a lock file: remove it, or choose another directory"
            )
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            if fcntl is not None:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            elif _held_by_other(path) is not None:  # pragma: no cover
                raise BlockingIOError
        except BlockingIOError:
            os.close(fd)
            owner = _read_owner(path) or {"pid": "?", "host": "?"}
            raise RunDirectoryBusy(
                f"{self.directory} is in use by {_describe(owner)}: wait for it or stop it "
                "first (--force overwrites a finished run, never a running one)"
            ) from None
        previous = _read_owner(path)
        if previous is not None and previous["pid"] not in _owners():
            sys.stderr.write(
                f"acrobot-mj: taking over {self.directory} from "
                f"{_describe(previous)}, which no longer holds it\n"
            )
            _remove_temporaries(self.directory)
        record = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "command": self.command,
            "started": time.time(),
        }
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, json.dumps(record).encode(), 0)
        except OSError as error:  # a full disk: the lock holds without its owner's name
            if error.errno not in (errno.ENOSPC, errno.EDQUOT):
                os.close(fd)  # not held: nothing of it stays open
                raise
        return fd

    def __exit__(self, *exc: object) -> None:
        if self._noop:
            return
        held = _HELD[self.directory]
        held[1] -= 1
        if held[1] > 0:
            return
        del _HELD[self.directory]
        os.ftruncate(held[0], 0)  # a free lock: an empty file (unlinking it would race)
        if fcntl is not None:
            fcntl.flock(held[0], fcntl.LOCK_UN)
        os.close(held[0])


def _remove_temporaries(directory: Path) -> None:
    """Delete the ``.NAME.PID.tmp`` and ``.NAME.PID.tmp.EXT`` files (interrupted atomic writes,
    videos being encoded) of dead processes, in ``directory`` and below."""
    for tmp in (*directory.rglob(".*.tmp"), *directory.rglob(".*.tmp.*")):
        parts = tmp.name.split(".")
        at = len(parts) - 1 - parts[::-1].index("tmp")  # the last "tmp"; the pid before it
        if at >= 3 and parts[at - 1].isdigit() and not _alive(int(parts[at - 1])):
            tmp.unlink(missing_ok=True)
