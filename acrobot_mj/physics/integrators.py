"""The acrobot's discrete step, written once for numpy, CasADi symbols and numba: the torque
held, ``(q1, q2, dq1, dq2)`` advanced by one of :data:`METHODS`, then the velocities clipped to
their limits as the envs do (a NaN is kept, so divergence shows)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acrobot_mj.compiled import compiled, jitable, prange, without_dispatch
from acrobot_mj.physics import xp as FLOATS
from acrobot_mj.physics.dynamics import accelerations
from acrobot_mj.physics.params import REPORT, AcrobotParams, Lumped
from acrobot_mj.physics.xp import ARRAY

#: By the code :func:`step` takes: ``dq += dt ddq`` then ``q += dt dq`` (MuJoCo's Euler, the
#: envs'); classical RK4; ``q += dt dq`` with ``dq += dt ddq`` (the report's, gaining energy).
METHODS = ("semi_implicit_euler", "rk4", "explicit_euler")
#: The envs' ``integrator`` names (MuJoCo's) and the methods they are.
ENV_INTEGRATORS = {"euler": "semi_implicit_euler", "rk4": "rk4"}
#: No velocity limits.
UNLIMITED = (math.inf, math.inf)


def steps_in(seconds: float, dt: float) -> int:
    """The steps of ``dt`` [s] that cover ``seconds`` [s]: rounded up, where a float's last
    digits do not count (``100 s / 0.05 s`` is 2000 steps)."""
    return math.ceil(seconds / dt - 1e-9)


@jitable
def limit_velocities(dq1, dq2, max_vel, xp=FLOATS):
    """``(dq1, dq2)`` [rad/s] clipped to ``max_vel = (|dq1|, |dq2|)`` [rad/s], as every
    physics step ends; a NaN is kept."""
    return xp.clip(dq1, -max_vel[0], max_vel[0]), xp.clip(dq2, -max_vel[1], max_vel[1])


@jitable
def step(q1, q2, dq1, dq2, tau, theta: Lumped, dt, max_vel, substeps=1, method=0, xp=FLOATS):
    """``substeps`` steps of ``dt`` [s] from ``(q1, q2, dq1, dq2)`` [rad, rad/s] with torque
    ``tau`` [N m] held, by ``METHODS[method]``, each clipped to ``max_vel = (|dq1|, |dq2|)``."""
    for _ in range(substeps):
        if method == 0:
            a1, a2 = accelerations(q1, q2, dq1, dq2, tau, theta, xp)
            dq1, dq2 = dq1 + dt * a1, dq2 + dt * a2
            q1, q2 = q1 + dt * dq1, q2 + dt * dq2
        elif method == 1:
            half = 0.5 * dt
            k1 = accelerations(q1, q2, dq1, dq2, tau, theta, xp)
            v1, v2 = dq1 + half * k1[0], dq2 + half * k1[1]
            k2 = accelerations(q1 + half * dq1, q2 + half * dq2, v1, v2, tau, theta, xp)
            w1, w2 = dq1 + half * k2[0], dq2 + half * k2[1]
            k3 = accelerations(q1 + half * v1, q2 + half * v2, w1, w2, tau, theta, xp)
            u1, u2 = dq1 + dt * k3[0], dq2 + dt * k3[1]
            k4 = accelerations(q1 + dt * w1, q2 + dt * w2, u1, u2, tau, theta, xp)
            sixth = dt / 6.0
            q1 = q1 + sixth * (dq1 + 2.0 * v1 + 2.0 * w1 + u1)
            q2 = q2 + sixth * (dq2 + 2.0 * v2 + 2.0 * w2 + u2)
            dq1 = dq1 + sixth * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
            dq2 = dq2 + sixth * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
        else:
            a1, a2 = accelerations(q1, q2, dq1, dq2, tau, theta, xp)
            q1, q2 = q1 + dt * dq1, q2 + dt * dq2
            dq1, dq2 = dq1 + dt * a1, dq2 + dt * a2
        dq1, dq2 = limit_velocities(dq1, dq2, max_vel, xp)
    return q1, q2, dq1, dq2


@jitable
def step_rows(state, tau, constants, substeps, method):
    """:func:`step` of every row of ``state`` ``(N, 4)`` in place, torques ``tau`` ``(N,)``,
    ``constants = (a, b, c, d, e, dt, |dq1|, |dq2|)``."""
    theta = (constants[0], constants[1], constants[2], constants[3], constants[4])
    dt, max_vel = constants[5], (constants[6], constants[7])
    for i in prange(state.shape[0]):
        new = step(
            state[i, 0],
            state[i, 1],
            state[i, 2],
            state[i, 3],
            tau[i],
            theta,
            dt,
            max_vel,
            substeps,
            method,
        )
        state[i, 0], state[i, 1], state[i, 2], state[i, 3] = new


@jitable
def step_one(q1, q2, dq1, dq2, tau, a, b, c, d, e, dt, max1, max2, substeps, method) -> tuple:
    """:func:`step` of one state on flat floats (one state's cheapest compiled call)."""
    return step(q1, q2, dq1, dq2, tau, (a, b, c, d, e), dt, (max1, max2), substeps, method)


@dataclass(frozen=True)
class Stepping:
    """A decision but for the dynamics: ``substeps`` steps of ``dt`` [s] by ``method``, the
    velocity limits ``max_vel`` [rad/s] (what an identifying learner is told of the env)."""

    dt: float = REPORT.dt
    substeps: int = 1
    max_vel: tuple[float, float] = REPORT.max_vel
    method: str = "semi_implicit_euler"

    def constants(self, theta: Sequence[float] | np.ndarray) -> np.ndarray:
        return np.array([*theta, self.dt, *self.max_vel], dtype=np.float64)

    def advance(
        self, theta: Sequence[float] | np.ndarray, states: ArrayLike, torques: ArrayLike
    ) -> NDArray:
        """One decision of every state ``(N, 4)`` under ``torques`` ``(N,)``: new states."""
        new, tau = np.array(states, dtype=np.float64), np.asarray(torques, dtype=np.float64)
        code = method_code(self.method)
        compiled(step_rows)(new, tau, self.constants(theta), self.substeps, code)
        return new


def method_code(method: str) -> int:
    if method not in METHODS:
        raise ValueError(f"unknown integrator {method!r}; choose one of {list(METHODS)}")
    return METHODS.index(method)


def _states(x: ArrayLike) -> NDArray:
    x = np.asarray(x, dtype=np.float64)
    if x.shape[-1:] != (4,):
        raise ValueError(f"expected states (q1, q2, dq1, dq2) of shape (..., 4), got {x.shape}")
    return x


def step_states(
    x: ArrayLike,
    tau: ArrayLike = 0.0,
    p: AcrobotParams = REPORT,
    substeps: int = 1,
    method: str = "semi_implicit_euler",
    limits: bool = True,
) -> NDArray:
    """:func:`step` of states ``x`` ``(..., 4)`` under torques ``tau`` ``(...)`` on ``p`` (its
    ``dt`` and, with ``limits``, its velocity limits). One state under one torque takes the
    compiled :func:`step_one` (the same numbers, a tenth of the time)."""
    x, code = _states(x), method_code(method)
    max_vel = p.max_vel if limits else UNLIMITED
    tau = np.asarray(tau, dtype=np.float64)
    if x.ndim == 1 and tau.ndim == 0:
        one = compiled(step_one)(*x.tolist(), float(tau), *p.lumped, p.dt, *max_vel, substeps, code)
        return np.array(one, dtype=np.float64)
    new = step(*np.moveaxis(x, -1, 0), tau, p.lumped, p.dt, max_vel, substeps, code, ARRAY)
    return np.stack(np.broadcast_arrays(*new), -1)


class OneStep:
    """:func:`step_states` of one state under one torque on ``p`` by ``method``, on floats:
    ``OneStep(p, method)(q1, q2, dq1, dq2, tau)`` is the new ``(q1, q2, dq1, dq2)``, the
    compiled :func:`step_one` called without numba's type dispatch (the same numbers, about a
    microsecond less a call). A copy or a pickle finds the machine code again."""

    def __init__(self, p: AcrobotParams, method: str) -> None:
        self.p, self.method = p, method
        floats = tuple(float(v) for v in (*p.lumped, p.dt, *p.max_vel))
        self._constants = (*floats, 1, method_code(method))
        self._direct: Callable[..., tuple[float, float, float, float]] | None = None

    def __call__(self, *state_tau: float) -> tuple[float, float, float, float]:
        """The state after one step from ``(q1, q2, dq1, dq2, tau)``, 5 floats."""
        if self._direct is None:
            kernel, args = compiled(step_one), (0.0, 0.0, 0.0, 0.0, 0.0, *self._constants)
            kernel(*args)  # compiled for these types (floats, two ints), every call's
            self._direct = without_dispatch(kernel, args)
        return self._direct(*state_tau, *self._constants)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_direct": None}


def state_derivative(x: ArrayLike, tau: ArrayLike = 0.0, p: AcrobotParams = REPORT) -> NDArray:
    """``dx/dt = (dq, ddq)`` [rad/s, rad/s^2] of states ``(..., 4)``."""
    x = _states(x)
    ddq = accelerations(*np.moveaxis(x, -1, 0), np.asarray(tau, dtype=float), p.lumped, ARRAY)
    return np.concatenate([x[..., 2:], np.stack(np.broadcast_arrays(*ddq), -1)], -1)


def simulate(
    x0: ArrayLike,
    torques: ArrayLike,
    method: str = "semi_implicit_euler",
    p: AcrobotParams = REPORT,
    limits: bool = True,
) -> NDArray:
    """States ``(T + 1, ..., 4)`` from ``x0`` ``(..., 4)``, one step per torque ``(T, ...)``."""
    states = [_states(x0)]
    for tau in np.asarray(torques, dtype=np.float64):
        states.append(step_states(states[-1], tau, p, method=method, limits=limits))
    return np.stack(states)
