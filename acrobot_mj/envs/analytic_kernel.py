"""The analytic backend's kernels, compiled with numba (the ``fast`` extra; imported only when
an :class:`~acrobot_mj.envs.analytic_physics.AnalyticPhysics` is built).

The step is :func:`acrobot_mj.control.identification.lumped_step`, compiled
(:mod:`acrobot_mj.envs.model_step_jit`: the identified model's step too), so the Python and the
compiled step are one definition, bit for bit (no fastmath). The row kernels run it on every
row of a ``(N, 4)`` state array, on the calling thread (:func:`step_rows`) or on numba's threads
(:func:`step_rows_parallel`): each row is the same scalar code either way, so the numbers are
the same. :func:`scan` (and :func:`scan_parallel`) runs many decisions in one call, physics
only: the benchmark's ceiling.
"""

from __future__ import annotations

import os

try:
    from numba import config, njit, prange, set_num_threads
except ImportError as error:  # pragma: no cover  (the fast extra is missing)
    raise ImportError("the analytic backend needs numba: pip install acrobot-mj[fast]") from error

from acrobot_mj.envs.model_step_jit import lumped_step_jit  # after numba's own check

if "NUMBA_THREADING_LAYER" not in os.environ and config.THREADING_LAYER == "default":
    # A fork-safe pool for the threaded kernels (tbb, else numba's own workqueue): under GNU
    # OpenMP, numba's default where present, a process forked after the parallel kernels ran
    # aborts when it runs them itself (worker pools fork).
    config.THREADING_LAYER = "forksafe"


@njit(cache=True)
def _row(state, i, tau, theta, substeps):  # pragma: no cover  (compiled)
    q1, q2, v1, v2 = lumped_step_jit(
        state[i, 0], state[i, 1], state[i, 2], state[i, 3], tau,
        theta[0], theta[1], theta[2], theta[3], theta[4], theta[5], theta[6], theta[7], substeps,
    )  # fmt: skip
    state[i, 0], state[i, 1], state[i, 2], state[i, 3] = q1, q2, v1, v2


@njit(cache=True)
def step_rows(state, tau, theta, substeps):  # pragma: no cover  (compiled)
    """``substeps`` steps of every row of ``state`` (``(N, 4)``, in place) with torques ``tau``
    (``(N,)``) and ``theta = (a, b, c, d, e, dt, lim1, lim2)``, on the calling thread."""
    for i in range(state.shape[0]):
        _row(state, i, tau[i], theta, substeps)


@njit(cache=True, parallel=True)
def step_rows_parallel(state, tau, theta, substeps):  # pragma: no cover  (compiled)
    """:func:`step_rows` on numba's threads (rows split between them)."""
    for i in prange(state.shape[0]):
        _row(state, i, tau[i], theta, substeps)


@njit(cache=True)
def scan(state, taus, theta, substeps):  # pragma: no cover  (compiled)
    """``T`` decisions of every row ``i`` of ``state`` in one call, with torques ``taus[i]``
    (``(N, T)``, each row's contiguous): the physics alone, no task, no resets, on the calling
    thread."""
    for i in range(state.shape[0]):
        for t in range(taus.shape[1]):
            _row(state, i, taus[i, t], theta, substeps)


# Its own function, not scan compiled twice: numba's disk cache keys a function by its name
# and signature, not by its parallel flag.
@njit(cache=True, parallel=True)
def scan_parallel(state, taus, theta, substeps):  # pragma: no cover  (compiled)
    """:func:`scan` on numba's threads (rows split between them)."""
    for i in prange(state.shape[0]):
        for t in range(taus.shape[1]):
            _row(state, i, taus[i, t], theta, substeps)


def available_threads() -> int:
    """numba's threads (``NUMBA_NUM_THREADS``, by default one per CPU)."""
    return int(config.NUMBA_NUM_THREADS)


def set_threads(n: int) -> None:
    """Run the parallel kernels on ``n`` of numba's threads."""
    set_num_threads(n)
