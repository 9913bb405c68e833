"""numba, the package's one compiler: mark a plain Python function ``@jitable`` and take its
compiled form with :func:`compiled` (the function itself where numba cannot load)."""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any

JITABLE: list[Callable[..., Any]] = []
_COMPILED: dict[tuple[Callable[..., Any], bool], Callable[..., Any]] = {}
_NUMBA: Any = None  # False where numba cannot load


def jitable(function: Callable[..., Any]) -> Callable[..., Any]:
    JITABLE.append(function)
    return function


def numba() -> Any:
    """The numba module, or None where it cannot load (said once on stderr)."""
    global _NUMBA
    if _NUMBA is None:
        try:
            import numba as module
            from numba.extending import register_jitable
        except Exception as error:  # ImportError, or a numba built for another numpy
            sys.stderr.write(
                f"acrobot-mj: numba cannot load ({type(error).__name__}: {error}); the kernels "
                "run as plain Python: the same numbers, about 50 times slower\n"
            )
            _NUMBA = False
            return None
        if "NUMBA_THREADING_LAYER" not in os.environ:
            # A fork-safe pool for the threaded kernels: a process forked after GNU OpenMP's
            # threads ran aborts when it runs them itself (worker pools fork).
            config: Any = module.config  # its settings are set from the environment at import
            config.THREADING_LAYER = "forksafe"
        for function in JITABLE:
            register_jitable(function)
        _NUMBA = module
    return _NUMBA or None


def compiled(
    function: Callable[..., Any],
    parallel: bool = False,
    cache: bool = True,
    calls: tuple[Callable[..., Any], ...] = (),
) -> Callable[..., Any]:
    """``function`` compiled by numba (or itself without numba). ``parallel``: its ``prange``
    loops run on numba's threads; ``cache``: kept on disk (not for closures, which numba cannot
    find again); ``calls``: functions it calls that are not ``@jitable`` (closures)."""
    key = (function, parallel)
    if key not in _COMPILED:
        nb = numba()
        for callee in calls if nb else ():
            nb.extending.register_jitable(callee)
        if nb and parallel:  # not cached: numba's cache keys a function by name, not this flag
            function.__globals__["prange"] = nb.prange  # a range to Python as well
        options = {"cache": cache and not parallel, "parallel": parallel}
        _COMPILED[key] = nb.njit(**options)(function) if nb else function
    return _COMPILED[key]


def without_dispatch(kernel: Callable[..., Any], args: tuple) -> Callable[..., Any]:
    """The machine code ``kernel`` (from :func:`compiled`) ran for ``args``, called without
    numba's type dispatch (about 1 us less a call). Only for a call whose argument types never
    change: numba does not check them there, so other types give wrong numbers."""
    overloads = getattr(kernel, "overloads", None)
    if overloads is None:  # plain Python
        return kernel
    dispatcher: Any = kernel  # a numba dispatcher
    return overloads[tuple(dispatcher.typeof_pyval(arg) for arg in args)].entry_point


def available_threads() -> int:
    """numba's threads (``NUMBA_NUM_THREADS``, one per CPU by default); 1 without numba."""
    nb = numba()
    return 1 if nb is None else int(nb.config.NUMBA_NUM_THREADS)


def set_threads(n: int) -> None:
    nb = numba()
    if nb is not None:
        nb.set_num_threads(n)


#: ``range`` to Python; numba's ``prange`` inside a kernel compiled with ``parallel=True``.
prange = range
