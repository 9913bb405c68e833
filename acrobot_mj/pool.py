"""A process pool whose workers stop with the driver: :class:`WorkerPool`. Its workers ignore
SIGINT (a Ctrl-C reaches the whole process group: the driver decides) and are interrupted, saving
their checkpoints, when the driver stops or dies."""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from acrobot_mj.stops import raise_stop

#: In a worker: the driver's stop event and pid, and whether a call is running.
_STOP: Any = None


_PARENT = 0


_RUNNING = False


def _interrupt(signum: int, frame: Any) -> None:
    # Only a running call is interrupted: an idle worker waits on the pool's queue, and an
    # exception there can leave the queue's lock held, which hangs the pool's shutdown.
    if _RUNNING:
        raise_stop(KeyboardInterrupt("stopped by the driver"))


def _watch(stop: Any, parent: int) -> None:
    """In a worker: wait for the driver's stop, or its death, then interrupt the running call;
    an idle worker leaves with the pool (or at once, if the driver is gone)."""
    while not stop.wait(0.2) and os.getppid() == parent:
        pass
    if _RUNNING:
        os.kill(os.getpid(), signal.SIGUSR1)
    elif os.getppid() != parent:
        os._exit(1)


def _start_worker(stop: Any, parent: int) -> None:
    global _STOP, _PARENT
    _STOP, _PARENT = stop, parent
    if not hasattr(signal, "SIGUSR1"):  # pragma: no cover
        return
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGUSR1, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)  # a group's SIGTERM: as the driver's stop
    threading.Thread(target=_watch, args=(stop, parent), daemon=True).start()


def _unless_stopped(function: Callable[..., Any], *args: Any) -> Any:
    """In a worker: ``function(*args)``, unless the driver has stopped the pool (a pool hands
    workers a call or two ahead, which cancelling the queue does not reach)."""
    global _RUNNING
    _RUNNING = True  # before the stop is read: a stop after this interrupts the call
    try:
        if _STOP is not None and _STOP.is_set():
            return None
        return function(*args)
    finally:
        _RUNNING = False
        if _PARENT and os.getppid() != _PARENT:  # the driver is gone: so is this worker,
            os._exit(1)  # once its run has saved what it had


class WorkerPool:
    """A process pool whose workers stop with the driver (see the module docstring)."""

    def __init__(self, jobs: int | None) -> None:
        context = multiprocessing.get_context()
        self._stop = context.Event()
        self._pool = ProcessPoolExecutor(jobs, context, _start_worker, (self._stop, os.getpid()))

    def run(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[Future]:
        """Submit ``function(*args)`` for each of ``calls``; yield the futures as they finish
        (after a stop, calls a worker had already taken return None without running)."""
        return as_completed([self._pool.submit(_unless_stopped, function, *a) for a in calls])

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
