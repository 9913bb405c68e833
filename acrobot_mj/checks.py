"""Checks before work: arguments (each error names the argument, what it must be and what it
got), memory and open files. Where a stop may land is :mod:`acrobot_mj.stops`'; a config's
settings are checked by :mod:`acrobot_mj.settings`."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np


def check_int(name: str, value: Any, minimum: int, maximum: int | None = None) -> int:
    """``value`` as an int, refused unless it is an integer in ``[minimum, maximum]``."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < minimum or (maximum is not None and value > maximum):
        bound = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ValueError(f"{name} must be {bound}, got {value}")
    return int(value)


def check_state(name: str, value: Any) -> np.ndarray:
    """``value`` as a state ``(q1, q2, dq1, dq2)`` [rad, rad/s] of floats (a new array),
    refused unless it is 4 finite numbers."""
    x = np.array(value, dtype=float)
    if x.shape != (4,) or not all(map(math.isfinite, x.tolist())):
        raise ValueError(f"{name} must be 4 finite numbers, got {np.ravel(x).tolist()}")
    return x


def shown_number(value: object) -> str:
    """``value`` for a message: a huge integer (30 digits or more) by its count of digits, not
    hundreds of them."""
    if isinstance(value, (int, np.integer)) and abs(int(value)) >= 10**30:
        return f"an integer of {int(abs(int(value)).bit_length() * math.log10(2)) + 1} digits"
    return repr(value)


def check_float(
    name: str, value: Any, minimum: float = -math.inf, maximum: float = math.inf
) -> float:
    """``value`` as a float, refused unless it is a finite real number in ``[minimum, maximum]``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {value!r} ({type(value).__name__})")
    try:
        value = float(value)
    except OverflowError:  # an integer past float's range
        raise ValueError(f"{name} must be finite, got {shown_number(value)}") from None
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    if not minimum <= value <= maximum:
        raise ValueError(f"{name} must be in [{minimum:g}, {maximum:g}], got {value:g}")
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
        raise ValueError(
            f"{what} keep {count:,} files open; this process may open {soft:,} "
            "(ulimit -n): use fewer at once"
        )


def _size(nbytes: float) -> str:
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:,.1f} {unit}"
    return f"{nbytes:,.0f} B"


def check_memory(what: str, nbytes: float) -> None:
    """Refuse ``what``, before it is allocated, if it needs more memory than there is."""
    available = memory_available()
    if available is not None and nbytes > available:
        raise ValueError(
            f"{what} needs {_size(nbytes)} of memory; this machine has {_size(available)} free"
        )
