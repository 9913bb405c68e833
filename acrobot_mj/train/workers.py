"""Worker processes (seeds, sweeps) that stop when their driver says so, or dies.

Workers ignore SIGINT: a Ctrl-C at the terminal reaches the whole process group, and the driver
decides what happens. When the driver stops the pool (:meth:`WorkerPool.stop`), or dies, each
worker raises ``KeyboardInterrupt`` in its training, which saves its checkpoint and records the
run as interrupted; queued work is cancelled. Where signals are missing (Windows), workers run to
the end of their task.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from typing import Any

_CAN_SIGNAL = hasattr(signal, "SIGUSR1")
#: In a worker: the driver's stop event and pid.
_STOP: Any = None
_PARENT = 0


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt("stopped by the driver")


def _watch(stop: Any, parent: int) -> None:
    """In a worker: wait for the driver's stop, or its death, then interrupt the training."""
    while not stop.wait(0.5):
        if os.getppid() != parent:
            break
    os.kill(os.getpid(), signal.SIGUSR1)


def _start_worker(stop: Any, parent: int) -> None:
    global _STOP, _PARENT
    _STOP, _PARENT = stop, parent
    if not _CAN_SIGNAL:  # pragma: no cover
        return
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGUSR1, _interrupt)
    threading.Thread(target=_watch, args=(stop, parent), daemon=True).start()


def _unless_stopped(function: Callable[..., Any], *args: Any) -> Any:
    """In a worker: ``function(*args)``, unless the driver has stopped the pool (a pool hands
    workers a call or two ahead, which cancelling the queue does not reach)."""
    if _STOP is not None and _STOP.is_set():
        return None
    try:
        return function(*args)
    finally:
        if _PARENT and os.getppid() != _PARENT:  # the driver is gone: so is this worker,
            os._exit(1)  # once its run has saved what it had


class WorkerPool:
    """A process pool whose workers stop with the driver (see the module docstring)."""

    def __init__(self, jobs: int | None) -> None:
        context = multiprocessing.get_context()
        self._stop = context.Event()
        self._pool = ProcessPoolExecutor(
            max_workers=jobs,
            mp_context=context,
            initializer=_start_worker,
            initargs=(self._stop, os.getpid()),
        )

    def run(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[Future]:
        """Submit ``function(*args)`` for each of ``calls``; yield the futures as they finish
        (after a stop, calls a worker had already taken return None without running)."""
        futures = [self._pool.submit(_unless_stopped, function, *args) for args in calls]
        return as_completed(futures)

    def stop(self) -> None:
        """Cancel what has not started, interrupt what runs, and wait for it to save."""
        self._stop.set()
        try:
            self._pool.shutdown(wait=True, cancel_futures=True)
        except BrokenProcessPool:  # a worker interrupted while idle: nothing of it to save
            pass

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, kind: type | None, *exc: object) -> None:
        if kind is None:
            self._pool.shutdown(wait=True)
        else:
            self.stop()
