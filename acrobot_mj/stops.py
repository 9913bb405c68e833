"""Stopping a long computation: a stop (Ctrl-C, SIGTERM) raised from a signal handler and kept
until handled (a signal that lands in a C callback is dropped there and raised again at the next
:func:`check_stop`), and :class:`SafePoints`, which hold the stop signals until a loop's safe
points."""

from __future__ import annotations

import signal
import threading
from typing import Any, NoReturn

#: A stop (Ctrl-C, SIGTERM) that was raised and not yet handled. A signal that arrives while
#: numba loads compiled code lands in a ctypes callback, which reports the exception and drops
#: it; :func:`check_stop` raises it again where the episode loops can take it.
_PENDING: list[KeyboardInterrupt] = []


def raise_stop(stop: KeyboardInterrupt) -> NoReturn:
    """Raise ``stop`` from a signal handler, and keep it until :func:`clear_stop`."""
    _PENDING[:] = [stop]
    raise stop


def check_stop() -> None:
    """Raise the stop a signal asked for, if one was dropped before it was handled."""
    if _PENDING:
        raise _PENDING[0]


def clear_stop() -> None:
    """Forget the stop: it has been handled."""
    _PENDING.clear()


#: The signals that stop a run: Ctrl-C, SIGTERM, and a sweep driver's SIGUSR1 to its workers.
STOP_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGUSR1") if hasattr(signal, name)
)


class SafePoints:
    """Hold the stop signals while the block runs, and act on them at its safe points
    (:meth:`check`) or as it ends, by calling the handler each signal had (which raises). A
    training loop checks between episodes and between the steps of one (its checkpoint keeps
    the state after the last whole episode), so a stop never lands between an update of the
    learner and its record, nor inside an update. Only Python handlers are held, and only in
    the main thread."""

    def __init__(self) -> None:
        #: The signals held and not yet acted on: empty until a stop arrives.
        self.held: list[tuple[int, Any]] = []

    def __enter__(self) -> SafePoints:
        self.held.clear()
        self._handlers: dict[int, Any] = {}
        if threading.current_thread() is threading.main_thread():
            for number in STOP_SIGNALS:
                handler = signal.getsignal(number)
                if callable(handler):
                    self._handlers[number] = handler
                    signal.signal(number, self._hold)
        return self

    def _hold(self, signum: int, frame: Any) -> None:
        self.held.append((signum, frame))

    def check(self) -> None:
        """Act on the signals held so far (a handler's exception comes out here)."""
        while self.held:
            signum, frame = self.held.pop(0)
            self._handlers[signum](signum, frame)

    def __exit__(self, kind: type[BaseException] | None, *rest: object) -> None:
        for number, handler in self._handlers.items():
            signal.signal(number, handler)
        if kind is None:
            self.check()
