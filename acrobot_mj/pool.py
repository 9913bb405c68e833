"""A process pool whose workers stop with the driver: :class:`WorkerPool`, the package's one pool
(seeds, sweeps, the swing-up search).

Each worker has a pipe of its own and takes one call at a time, so a worker that dies (a kill,
a crash) holds no lock another process waits on. Workers ignore SIGINT (a Ctrl-C reaches the
whole process group: the driver decides) and never run the driver's stop handler. A stop
interrupts the running calls, which save their checkpoints, or with ``terminate=True`` kills
the workers at once (calls that hold nothing to save, such as IPOPT solves running in C). A
worker never prints a traceback: a call's exception goes back to the driver."""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.connection import Connection, wait
from typing import Any

from acrobot_mj.stops import STOP_SIGNALS, check_stop, raise_stop

#: In a worker: the driver's stop flag and pid, whether its calls save on a stop (else it
#: leaves at once), and whether a call is running.
_STOP: Any = None


_PARENT = 0


_SAVES = True


_RUNNING = False


#: Seconds a worker gets to leave once its pipe is closed, before it is killed.
LEAVE_SECONDS = 1.0
#: Seconds between the driver's checks for a stop while it waits for the workers.
CHECK_SECONDS = 0.2


def _interrupt(signum: int, frame: Any) -> None:
    # A running call that saves is interrupted (it saves what it has); otherwise there is
    # nothing to save, and a SIGTERM (or any stop, where calls do not save) ends the worker.
    if _RUNNING and _SAVES:
        raise_stop(KeyboardInterrupt("stopped by the driver"))
    if signum == signal.SIGTERM or not _SAVES:
        os._exit(128 + signum)


def _watch(stop: Any, parent: int) -> None:
    """In a worker: wait for the driver's stop, or its death, then interrupt the running call
    that saves; otherwise leave at once if the driver is gone or calls do not save (an idle
    worker of a driver that stopped leaves with the pool)."""
    while not stop.value and os.getppid() == parent:
        time.sleep(CHECK_SECONDS)
    if _RUNNING and _SAVES:
        os.kill(os.getpid(), signal.SIGUSR1)
    elif os.getppid() != parent or not _SAVES:
        os._exit(1)


def _start_worker(stop: Any, parent: int, mask: Any, saves: bool) -> None:
    """In a worker: its own stop handlers, then the signals the driver blocked while it forked."""
    global _STOP, _PARENT, _SAVES
    _STOP, _PARENT, _SAVES = stop, parent, saves
    if not hasattr(signal, "SIGUSR1"):  # pragma: no cover
        return
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGUSR1, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)  # a group's SIGTERM: as the driver's stop
    threading.Thread(target=_watch, args=(stop, parent), daemon=True).start()
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _unless_stopped(function: Callable[..., Any], args: tuple) -> Any:
    """In a worker: ``function(*args)``, unless the driver has stopped the pool since it sent
    the call."""
    global _RUNNING
    _RUNNING = True  # before the stop is read: a stop after this interrupts the call
    try:
        if _STOP is not None and _STOP.value:
            return None
        return function(*args)
    finally:
        _RUNNING = False
        if _PARENT and os.getppid() != _PARENT:  # the driver is gone: so is this worker,
            os._exit(1)  # once its run has saved what it had


def _serve(conn: Connection, stop: Any, parent: int, mask: Any, saves: bool) -> None:
    """A worker's life: ``(function, args)`` calls from ``conn``, each answered with
    ``(True, result)`` or ``(False, exception)``, until the driver sends None or is gone."""
    _start_worker(stop, parent, mask, saves)
    while True:
        try:
            call = conn.recv()
        except (EOFError, OSError):  # the driver is gone
            return
        if call is None:
            return
        function, args = call
        try:
            reply: tuple[bool, Any] = (True, _unless_stopped(function, args))
        except BaseException as error:  # the driver raises it, or drops it after a stop
            reply = (False, error)
        try:
            conn.send(reply)
        except (EOFError, OSError):
            return
        except Exception as error:  # a result or exception that does not pickle
            conn.send((False, RuntimeError(f"a worker's reply does not pickle: {error}")))


class _Worker:
    """A worker process and the driver's end of its pipe."""

    def __init__(self, context: Any, stop: Any, mask: Any, saves: bool) -> None:
        self.conn, theirs = context.Pipe()
        self.process = context.Process(
            target=_serve, args=(theirs, stop, os.getpid(), mask, saves), daemon=True
        )
        self.process.start()
        theirs.close()  # the driver reads an end of file when the worker dies

    def end(self, deadline: float) -> None:
        """Wait for the worker to leave until ``deadline`` (``time.monotonic``), then kill it."""
        self.process.join(max(0.0, deadline - time.monotonic()))
        if self.process.exitcode is None:
            self.process.kill()
            self.process.join()


class WorkerPool:
    """A process pool of ``jobs`` workers (None: one per CPU) that stop with the driver (see
    the module docstring); ``terminate``: a stop kills the workers instead of interrupting their
    calls."""

    def __init__(self, jobs: int | None, *, terminate: bool = False) -> None:
        count = (os.cpu_count() or 1) if jobs is None else jobs
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f"jobs must be a whole number >= 1, got {jobs!r}")
        context = multiprocessing.get_context()
        # A flag without a lock: a multiprocessing Event waits, as it is set, for every worker
        # that waits on it, and a worker killed while it waited hung the driver there.
        self._stop, self._terminate = context.RawValue(ctypes.c_bool, False), terminate
        self._workers: list[_Worker] = []
        self._busy: dict[_Worker, int] = {}  # worker -> the index of its call
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)  # none lands mid-fork
        try:
            for _ in range(count):
                self._workers.append(_Worker(context, self._stop, mask, not terminate))
        except BaseException:
            self._end(0.0)
            raise
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        self._idle: list[_Worker] = list(self._workers)

    def _finished(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[tuple]:
        """``(index, ok, result or exception)`` of each of ``calls`` as it finishes."""
        todo = list(enumerate(calls))[::-1]
        while todo or self._busy:
            while todo and self._idle and not self._stop.value:
                worker, (index, args) = self._idle.pop(), todo.pop()
                try:
                    worker.conn.send((function, tuple(args)))
                except OSError:  # the worker died while idle: the call goes to another
                    todo.append((index, args))
                    continue
                except Exception as error:  # the call does not pickle
                    self._idle.append(worker)
                    yield index, False, error
                    continue
                self._busy[worker] = index
            if not self._busy:
                for index, _ in reversed(todo):
                    yield index, False, BrokenProcessPool("every worker of the pool has died")
                return
            ready: list[Any] = []
            while not ready:  # a stop a C callback dropped is raised here (stops.check_stop)
                check_stop()
                ready = wait([w.conn for w in self._busy], CHECK_SECONDS)
            for worker in [w for w in self._busy if w.conn in ready]:
                yield self._reply(worker)

    def _reply(self, worker: _Worker) -> tuple[int, bool, Any]:
        """The finished call of ``worker``: ``(index, ok, result or exception)``."""
        index = self._busy.pop(worker)
        try:
            ok, value = worker.conn.recv()
        except (EOFError, OSError):
            worker.process.join()
            code = worker.process.exitcode
            return index, False, BrokenProcessPool(f"a worker died (exit code {code}) in a call")
        self._idle.append(worker)
        return index, ok, value

    def run(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[Future]:
        """Run ``function(*args)`` for each of ``calls``; yield the futures, done, as they
        finish (a call the stop reached before it began returns None)."""
        for _, ok, value in self._finished(function, calls):
            future: Future = Future()
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)
            yield future

    def map(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[Any]:
        """``function(*args)`` for each of ``calls``, yielded in the order of ``calls`` (a
        call's exception is raised in its place)."""
        done: dict[int, tuple[bool, Any]] = {}
        following = 0
        for index, ok, value in self._finished(function, calls):
            done[index] = (ok, value)
            while following in done:
                ok, value = done.pop(following)
                following += 1
                if not ok:
                    raise value
                yield value

    def stop(self) -> None:
        """Cancel what has not started and interrupt what runs, waiting for it to save; or,
        with ``terminate``, kill the workers at once. A stop during the wait kills them."""
        self._stop.value = True
        if not self._terminate:
            try:
                self._drain()
            except BaseException:
                self._end(0.0)
                raise
        self._end(0.0 if self._terminate else LEAVE_SECONDS)

    def _drain(self) -> None:
        """Wait for every running call to answer (or its worker to die); drop the answers."""
        while self._busy:
            ready = wait([w.conn for w in self._busy])
            for worker in [w for w in self._busy if w.conn in ready]:
                self._reply(worker)

    def _end(self, wait_seconds: float) -> None:
        """Tell every worker to leave (idle ones do at once), then kill those still there after
        ``wait_seconds``."""
        for worker in self._workers:
            with contextlib.suppress(OSError):  # a worker already gone
                worker.conn.send(None)
            worker.conn.close()
        deadline = time.monotonic() + wait_seconds
        for worker in self._workers:
            worker.end(deadline)
        self._idle, self._busy = [], {}

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, kind: type | None, *exc: object) -> None:
        if kind is None:
            self._drain()
            self._end(LEAVE_SECONDS)
        else:
            self.stop()
