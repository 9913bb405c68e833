"""Checks before work: arguments (each error names the argument, what it must be and what it
got), memory and open files; and where a stop (Ctrl-C, SIGTERM) may land: between episodes
(:class:`SafePoints`), or raised again where a C callback dropped it (:func:`check_stop`)."""

from __future__ import annotations

import math
import os
import signal
import threading
from typing import Any, NoReturn

import numpy as np


def check_int(name: str, value: Any, minimum: int, maximum: int | None = None) -> int:
    """``value`` as an int, refused unless it is an integer in ``[minimum, maximum]``."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < minimum or (maximum is not None and value > maximum):
        bound = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ValueError(f"{name} must be {bound}, got {value}")
    return int(value)


def check_float(name: str, value: Any, minimum: float = -math.inf,
                maximum: float = math.inf) -> float:  # fmt: skip
    """``value`` as a float, refused unless it is a finite real number in ``[minimum, maximum]``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {value!r} ({type(value).__name__})")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    if not minimum <= value <= maximum:
        raise ValueError(f"{name} must be in [{minimum:g}, {maximum:g}], got {value:g}")
    return value


def check_step_size(alpha: Any) -> float:
    """A learning rate ``alpha`` in (0, 1]: zero learns nothing."""
    value = check_float("alpha", alpha)  # a finite real number
    if not 0.0 < value <= 1.0:
        raise ValueError(f"alpha must be in (0, 1], got {value:g}")
    return value


def check_bool(name: str, value: Any) -> bool:
    """``value``, refused unless it is ``True`` or ``False``."""
    if not isinstance(value, bool):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return value


def memory_available() -> int | None:
    """Bytes of memory this machine can give now (Linux's ``MemAvailable``; else its total)."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - neither Linux nor POSIX
        return None


def check_open_files(what: str, count: int) -> None:
    """Refuse ``what``, before it opens ``count`` files at once, where this process may not
    (its soft limit is raised to the hard one first, as far as that goes)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not POSIX
        return
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    needed = count + 256  # the interpreter, libraries and the rest of the run
    if needed > soft and (hard == resource.RLIM_INFINITY or soft < hard):
        soft = hard if hard != resource.RLIM_INFINITY else max(needed, soft)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    if needed > soft:
        raise ValueError(f"{what} keep {count:,} files open; this process may open {soft:,} "
                         "(ulimit -n): use fewer at once")  # fmt: skip


def _size(nbytes: float) -> str:
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:,.1f} {unit}"
    return f"{nbytes:,.0f} B"


def check_memory(what: str, nbytes: float) -> None:
    """Refuse ``what``, before it is allocated, if it needs more memory than there is."""
    available = memory_available()
    if available is not None and nbytes > available:
        raise ValueError(f"{what} needs {_size(nbytes)} of memory; this machine has "
                         f"{_size(available)} free")  # fmt: skip


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
    training loop checks between episodes, so a stop never lands between an update of the
    learner and its record. Only Python handlers are held, and only in the main thread."""

    def __enter__(self) -> SafePoints:
        self._held: list[tuple[int, Any]] = []
        self._handlers: dict[int, Any] = {}
        if threading.current_thread() is threading.main_thread():
            for number in STOP_SIGNALS:
                handler = signal.getsignal(number)
                if callable(handler):
                    self._handlers[number] = handler
                    signal.signal(number, self._hold)
        return self

    def _hold(self, signum: int, frame: Any) -> None:
        self._held.append((signum, frame))

    def check(self) -> None:
        """Act on the signals held so far (a handler's exception comes out here)."""
        while self._held:
            signum, frame = self._held.pop(0)
            self._handlers[signum](signum, frame)

    def __exit__(self, kind: type[BaseException] | None, *rest: object) -> None:
        for number, handler in self._handlers.items():
            signal.signal(number, handler)
        if kind is None:
            self.check()


def check_settings(config: type, data: Any, what: str) -> None:
    """Refuse keys of ``data`` that are not fields of the dataclass ``config``, naming them and
    the known ones (``what``: the settings' name in the error)."""
    import dataclasses

    names = sorted(f.name for f in dataclasses.fields(config))
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise ValueError(f"unknown {what} settings {unknown}; known: {names}")
