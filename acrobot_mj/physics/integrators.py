"""Fixed-step integrators over :mod:`acrobot_mj.physics.dynamics`.

A state ``x = (q1, q2, dq1, dq2)`` [rad, rad/s] has shape ``(..., 4)``; ``tau`` [N m] has shape
``(...)`` and is held constant over the step ``dt`` [s].

- :func:`explicit_euler_step`: ``q' = q + dt dq``, ``dq' = dq + dt ddq`` (the report's "forward
  Euler"; it pumps energy into the pendulum).
- :func:`semi_implicit_euler_step`: ``dq' = dq + dt ddq``, then ``q' = q + dt dq'`` (MuJoCo's
  ``Euler`` integrator, which the environment uses).
- :func:`rk4_step`: classical fourth-order Runge-Kutta (MuJoCo's ``RK4``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acrobot_mj.physics.dynamics import DEFAULT_PARAMS, forward_dynamics
from acrobot_mj.physics.params import AcrobotParams

Step = Callable[[ArrayLike, ArrayLike, float, AcrobotParams], NDArray]


def _state(x: ArrayLike) -> NDArray:
    x = np.asarray(x, dtype=np.float64)
    if x.shape[-1:] != (4,):
        raise ValueError(f"expected states (q1, q2, dq1, dq2) of shape (..., 4), got {x.shape}")
    return x


def state_derivative(x: ArrayLike, tau: ArrayLike = 0.0, p: AcrobotParams = DEFAULT_PARAMS):
    """``dx/dt = (dq, ddq)`` [rad/s, rad/s^2], shape ``(..., 4)``."""
    x = _state(x)
    dq = x[..., 2:]
    return np.concatenate([dq, forward_dynamics(x[..., :2], dq, tau, p)], -1)


def explicit_euler_step(x, tau=0.0, dt: float | None = None, p=DEFAULT_PARAMS) -> NDArray:
    """One forward (explicit) Euler step of ``dt`` [s] (default ``p.dt``)."""
    x = _state(x)
    dt = p.dt if dt is None else dt
    return x + dt * state_derivative(x, tau, p)


def semi_implicit_euler_step(x, tau=0.0, dt: float | None = None, p=DEFAULT_PARAMS) -> NDArray:
    """One semi-implicit (symplectic) Euler step: velocities first, then positions."""
    x = _state(x)
    dt = p.dt if dt is None else dt
    dq = x[..., 2:] + dt * forward_dynamics(x[..., :2], x[..., 2:], tau, p)
    return np.concatenate([x[..., :2] + dt * dq, dq], -1)


def rk4_step(x, tau=0.0, dt: float | None = None, p=DEFAULT_PARAMS) -> NDArray:
    """One classical Runge-Kutta step (weights 1/6, 1/3, 1/3, 1/6), ``tau`` held constant."""
    x = _state(x)
    dt = p.dt if dt is None else dt
    k1 = state_derivative(x, tau, p)
    k2 = state_derivative(x + 0.5 * dt * k1, tau, p)
    k3 = state_derivative(x + 0.5 * dt * k2, tau, p)
    k4 = state_derivative(x + dt * k3, tau, p)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


STEPS: dict[str, Step] = {
    "explicit_euler": explicit_euler_step,
    "semi_implicit_euler": semi_implicit_euler_step,
    "rk4": rk4_step,
}


def clip_velocity(x: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """Clip ``dq1`` to ``+-p.max_vel1`` and ``dq2`` to ``+-p.max_vel2`` (the task's limits)."""
    x = _state(x).copy()
    x[..., 2] = np.clip(x[..., 2], -p.max_vel1, p.max_vel1)
    x[..., 3] = np.clip(x[..., 3], -p.max_vel2, p.max_vel2)
    return x


def simulate(
    x0: ArrayLike,
    torques: ArrayLike,
    method: str = "semi_implicit_euler",
    dt: float | None = None,
    p: AcrobotParams = DEFAULT_PARAMS,
    clip: bool = True,
) -> NDArray:
    """Integrate from ``x0`` (``(..., 4)``) under ``torques`` (``(T, ...)``, one per step).

    Velocities are clipped after every step when ``clip`` is true, as the environment does.
    Returns the states, shape ``(T + 1, ..., 4)``, the first being ``x0``.
    """
    if method not in STEPS:
        raise ValueError(f"unknown integrator {method!r}; choose one of {sorted(STEPS)}")
    step = STEPS[method]
    x = _state(x0)
    torques = np.asarray(torques, dtype=np.float64)
    states = [x]
    for tau in torques:
        x = step(x, tau, dt, p)
        if clip:
            x = clip_velocity(x, p)
        states.append(x)
    return np.stack(states)
