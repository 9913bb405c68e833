"""System identification: the lumped ``theta = (a, b, c, d, e)`` from transitions ``(state,
torque, next state)`` and the env's :class:`~acrobot_mj.physics.integrators.Stepping`: least
squares on finite differences, refined by Levenberg-Marquardt on the exact discrete map."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from acrobot_mj.physics.integrators import Stepping
from acrobot_mj.physics.params import AcrobotParams

#: A transition: state (q1, q2, dq1, dq2) [rad, rad/s], elbow torque [N m], next state.
Transition = tuple[Sequence[float], float, Sequence[float]]


def residuals(
    theta: Sequence[float] | np.ndarray, data: Sequence[Transition], told: Stepping
) -> np.ndarray:
    """Predicted minus observed next states, flattened."""
    states = np.array([x for x, _, _ in data], dtype=np.float64)
    torques = np.array([tau for _, tau, _ in data], dtype=np.float64)
    predicted = told.advance(theta, states, torques)
    return (predicted - np.array([x2 for _, _, x2 in data], dtype=np.float64)).ravel()


def initial_guess(data: Sequence[Transition], told: Stepping) -> np.ndarray:
    """Least squares on the equations (linear in theta), accelerations by finite differences."""
    rows, rhs, span = [], [], told.dt * told.substeps
    for x, tau, x2 in data:
        q1, q2, v1, v2 = ((np.asarray(x) + np.asarray(x2)) / 2).tolist()
        a1, a2 = (x2[2] - x[2]) / span, (x2[3] - x[3]) / span
        c2, s2, cq = math.cos(q2), math.sin(q2), math.cos(q1 + q2)
        rows += [
            [a1, 2 * c2 * a1 + c2 * a2 - s2 * (v2 * v2 + 2 * v1 * v2), a2, math.cos(q1), cq],
            [0.0, c2 * a1 + s2 * v1 * v1, a1 + a2, 0.0, cq],
        ]
        rhs += [0.0, tau]
    return np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]


def identify(
    data: Sequence[Transition], told: Stepping, iterations: int = 50
) -> tuple[np.ndarray, float]:
    """The lumped parameters that best predict ``data`` and the RMS error [rad, rad/s]."""
    if len(data) < 3 or not any(tau for _, tau, _ in data):
        raise ValueError("identification needs at least 3 transitions, some with torque")
    theta = initial_guess(data, told)
    r = residuals(theta, data, told)
    cost, damping = float(r @ r), 1e-2
    for _ in range(iterations):
        jac = np.empty((r.size, 5))
        for j in range(5):
            h = 1e-7 * max(1.0, abs(theta[j]))
            jac[:, j] = (residuals(theta + h * np.eye(5)[j], data, told) - r) / h
        hess, grad = jac.T @ jac, jac.T @ r
        while damping < 1e12:
            step = np.linalg.solve(hess + damping * np.diag(np.diag(hess)), -grad)
            trial = residuals(theta + step, data, told)
            if float(trial @ trial) < cost:
                theta, r, cost, damping = theta + step, trial, float(trial @ trial), damping / 3
                break
            damping *= 4
        else:
            break
        if np.max(np.abs(step)) < 1e-12:
            break
    if not np.all(np.isfinite(theta)):
        raise ValueError("identification diverged: the data do not fit the acrobot's structure")
    return theta, math.sqrt(cost / r.size)


def realise(
    theta: Sequence[float] | np.ndarray, told: Stepping, max_torque: float = 1.0
) -> AcrobotParams:
    """Physical parameters with the dynamics of the lumped ``theta`` in the gauge ``m1 = m2 =
    l1 = l2 = 1`` (five values cannot fix nine); ValueError if one comes out <= 0."""
    a, b, c, d, e = (float(v) for v in theta)
    if not (b > 0 and e > 0):
        raise ValueError(f"the identified parameters {list(theta)} have no physical acrobot")
    g = e / b
    lc1, i2 = d / g - 1.0, c - b * b
    values = {"lc1": lc1, "lc2": b, "I1": a - lc1 * lc1 - 1.0 - b * b - i2, "I2": i2, "g": g}
    bad = sorted(name for name, value in values.items() if not value > 0)
    if bad:
        raise ValueError(
            f"the identified parameters {list(theta)} have no physical acrobot ({bad} <= 0 in "
            "the gauge m1 = m2 = l1 = 1)"
        )
    limits = {"max_vel1": told.max_vel[0], "max_vel2": told.max_vel[1]}
    return AcrobotParams(**values, **limits, max_torque=max_torque, dt=told.dt)
