"""The identified model's decision compiled with numba: :func:`acrobot_mj.control.identification.
advance`, the same operations in the same order on the same floats, so the same numbers bit for
bit (``tests/test_compiled.py``). :class:`~acrobot_mj.envs.model_env.ModelEnv` uses it with
``compiled=True`` (the ``fast`` extra; numba is imported only then)."""

from __future__ import annotations

import math

try:
    from numba import njit
except ImportError as error:  # pragma: no cover  (the fast extra is missing)
    raise ImportError(
        "the compiled model step needs numba: pip install acrobot-mj[fast]"
    ) from error


@njit(cache=True)
def _clip(v: float, limit: float) -> float:
    """``min(limit, max(-limit, v))`` with Python's own rules (``max(x, y)`` is ``y`` only if
    ``y > x``)."""
    low = v if v > -limit else -limit
    return low if low < limit else limit


@njit(cache=True)
def advance(x, tau, theta, dt, lim1, lim2, frame_skip):
    """``frame_skip`` semi-implicit Euler steps of the lumped model ``theta`` from state ``x``
    (a 4-tuple) with torque ``tau`` [N m], velocities clipped after each; returns the state."""
    a, b, c, d, e = theta
    q1, q2, v1, v2 = x
    for _ in range(frame_skip):
        c2, s2 = math.cos(q2), math.sin(q2)
        d11, d12 = a + 2 * b * c2, c + b * c2
        phi2 = e * math.cos(q1 + q2)
        f1 = b * s2 * (v2 * v2 + 2 * v1 * v2) - d * math.cos(q1) - phi2
        f2 = tau - b * s2 * v1 * v1 - phi2
        det = d11 * c - d12 * d12
        v1 = _clip(v1 + dt * (c * f1 - d12 * f2) / det, lim1)
        v2 = _clip(v2 + dt * (d11 * f2 - d12 * f1) / det, lim2)
        q1, q2 = q1 + dt * v1, q2 + dt * v2
    return q1, q2, v1, v2
