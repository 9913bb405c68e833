"""A process pool whose workers stop with the driver: :class:`WorkerPool`, the package's one pool
(seeds, sweeps, the swing-up search, the AI Olympics' episodes); and :class:`RayPool`, the same
calls as tasks on a :class:`Ray` cluster (sweeps and the AI Olympics with ``--backend ray``).

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
import socket
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from acrobot_mj.checks import check_int
from acrobot_mj.stops import STOP_SIGNALS, check_stop, raise_stop

#: Where a command's calls run: this machine's processes (``--jobs``), or a Ray cluster.
BACKENDS = ("local", "ray")

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


class Calls:
    """What both pools offer: :meth:`run` and :meth:`map`, from the ``(index, ok, result or
    exception)`` of each call as it finishes (:meth:`finished`)."""

    def finished(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[tuple]:
        """``(index, ok, result or exception)`` of each ``function(*args)`` of ``calls`` as it
        finishes."""
        raise NotImplementedError

    def run(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[Future]:
        """Run ``function(*args)`` for each of ``calls``; yield the futures, done, as they
        finish (a call the stop reached before it began returns None)."""
        for _, ok, value in self.finished(function, calls):
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
        for index, ok, value in self.finished(function, calls):
            done[index] = (ok, value)
            while following in done:
                ok, value = done.pop(following)
                following += 1
                if not ok:
                    raise value
                yield value


class WorkerPool(Calls):
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

    def finished(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[tuple]:
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


@dataclass(frozen=True)
class Ray:
    """A Ray cluster to run calls on as tasks: the one at ``address`` (``auto``, ``HOST:PORT``
    or ``ray://HOST:10001``), or, without one, a local Ray instance of ``num_cpus`` CPUs (None:
    every core) that listens on 127.0.0.1 only."""

    address: str | None = None
    num_cpus: int | None = None

    def __post_init__(self) -> None:
        if self.num_cpus is not None:
            check_int("num_cpus", self.num_cpus, 1)
            if self.address is not None:
                raise ValueError("--num-cpus sizes a local Ray instance: give no --address")
        if self.address is not None and not (isinstance(self.address, str) and self.address):
            raise ValueError(f"a Ray address must be a non-empty string, got {self.address!r}")

    def check(self) -> None:
        """Refuse an address where nothing listens, at once (Ray itself retries for minutes)."""
        if self.address is None:
            return
        host, _, port = self.address.split("://", 1)[-1].rpartition(":")
        if self.address == "auto" or not port.isdigit():
            return  # Ray's own resolution and errors
        try:
            socket.create_connection((host or "127.0.0.1", int(port)), timeout=5).close()
        except OSError as error:
            raise ConnectionError(f"no Ray cluster answers at {self.address}: {error}") from None


def backend_of(
    backend: str, jobs: int | None, address: str | None, num_cpus: int | None
) -> int | Ray | None:
    """What runs a command's calls, from its options: ``jobs`` processes (``backend``
    "local"), or a :class:`Ray` cluster ("ray": ``address``, or a local instance of
    ``num_cpus``); an unknown backend, or an option of the other one, refused in one line."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    given = {"--address": address, "--num-cpus": num_cpus, "--jobs": jobs}
    for option in ("--jobs",) if backend == "ray" else ("--address", "--num-cpus"):
        if given[option] is not None:
            other = "local" if backend == "ray" else "ray"
            raise ValueError(f"{option} is for --backend {other}, not {backend}")
    return Ray(address, num_cpus) if backend == "ray" else jobs


class RayPool(Calls):
    """Calls as tasks on a :class:`Ray` cluster (``pip install acrobot-mj[ray]``), with
    :class:`WorkerPool`'s :meth:`~Calls.run` and :meth:`~Calls.map`. Ray is started here
    unless this process is already connected, and shut down with the pool. An argument several
    calls share goes to Ray's object store once. A task's exception, or its worker's death, is
    its call's exception; on leaving early (an error, Ctrl-C) the tasks not finished are
    cancelled."""

    def __init__(self, cluster: Ray) -> None:
        cluster.check()
        if cluster.address is None:
            # A local instance listens on 127.0.0.1 only (Ray's single-machine mode; on Linux
            # its servers listen on every interface otherwise). Read when Ray is imported.
            os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
        try:
            import ray
        except ImportError as error:
            raise ImportError("the ray backend needs Ray: pip install acrobot-mj[ray]") from error
        self._ray, self._started = ray, not ray.is_initialized()
        if self._started:
            ray.init(
                cluster.address,
                num_cpus=cluster.num_cpus,
                include_dashboard=False,
                log_to_driver=False,
            )

    def finished(self, function: Callable[..., Any], calls: Iterable[tuple]) -> Iterator[tuple]:
        ray, calls = self._ray, [tuple(c) for c in calls]
        uses = Counter(id(a) for call in calls for a in call)
        stored = {}  # id -> the object store's reference of an argument several calls share
        for call in calls:
            for argument in call:
                if uses[id(argument)] > 1 and id(argument) not in stored and _storable(argument):
                    stored[id(argument)] = ray.put(argument)
        task = ray.remote(function)
        index_of = {
            task.remote(*(stored.get(id(a), a) for a in call)): i for i, call in enumerate(calls)
        }
        pending = list(index_of)
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                try:
                    yield index_of[done[0]], True, ray.get(done[0])
                except ray.exceptions.RayTaskError as error:  # the task raised: its exception
                    yield index_of[done[0]], False, error.cause or error
                except Exception as error:  # its worker died (a crash, out of memory)
                    yield index_of[done[0]], False, error
        finally:  # an error or Ctrl-C: the tasks not finished are given up, and the failures
            # of those finished are read (Ray would print each as an unhandled error)
            ended, pending = (
                ray.wait(pending, num_returns=len(pending), timeout=0) if pending else ([], [])
            )
            for ref in ended:
                with contextlib.suppress(Exception):
                    ray.get(ref)
            for ref in pending:
                ray.cancel(ref)

    def __enter__(self) -> RayPool:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._started:
            self._ray.shutdown()


def _storable(argument: Any) -> bool:
    """Whether an argument is worth a place in Ray's object store: not a number, a string or
    None (cheaper sent with each call)."""
    return not isinstance(argument, (str, bytes, int, float, bool, type(None)))
