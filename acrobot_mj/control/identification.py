"""System identification: the acrobot's dynamics recovered from observed transitions.

The manipulator equations (:mod:`acrobot_mj.physics.dynamics`) are linear in five lumped
parameters ``theta = (a, b, c, d, e)``:

    d11 = a + 2 b cos q2,  d12 = c + b cos q2,  d22 = c              [kg m^2]
    h1 = -b sin q2 (dq2^2 + 2 dq1 dq2),  h2 = b sin q2 dq1^2         [N m]
    phi2 = e cos(q1 + q2),  phi1 = d cos q1 + phi2                   [N m]

(for the report's acrobot ``a = m1 lc1^2 + m2 (l1^2 + lc2^2) + I1 + I2 = 3.5``,
``b = m2 l1 lc2 = 0.5``, ``c = m2 lc2^2 + I2 = 1.25``, ``d = (m1 lc1 + m2 l1) g = 14.7``,
``e = m2 lc2 g = 4.9``). A learner that knows this structure and the env's step (semi-implicit
Euler at ``dt``, ``frame_skip`` steps per decision, the velocity limits) but none of the values
identifies them from transitions ``(state, torque, next state)``: a linear least-squares guess
from finite-difference accelerations, refined by Levenberg-Marquardt on the exact discrete map.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from acrobot_mj.physics.params import AcrobotParams

#: A transition: state (q1, q2, dq1, dq2) [rad, rad/s], elbow torque [N m], next state.
Transition = tuple[Sequence[float], float, Sequence[float]]


@dataclass(frozen=True)
class StepStructure:
    """What the learner is told about the env's step: the physics step ``dt`` [s], the steps
    per decision and the velocity limits [rad/s] (none of the inertial parameters)."""

    dt: float = 0.05
    frame_skip: int = 4
    max_vel1: float = 4 * math.pi
    max_vel2: float = 9 * math.pi


#: The acrobot env's step: 0.05 s, 4 steps per decision (the book's 0.2 s), its velocity limits.
BOOK_STEP = StepStructure()


def lumped(p: AcrobotParams) -> tuple[float, float, float, float, float]:
    """The lumped parameters ``(a, b, c, d, e)`` of a parameter set (the truth, for checks)."""
    a = p.m1 * p.lc1**2 + p.m2 * (p.l1**2 + p.lc2**2) + p.I1 + p.I2
    return (a, p.m2 * p.l1 * p.lc2, p.m2 * p.lc2**2 + p.I2, (p.m1 * p.lc1 + p.m2 * p.l1) * p.g,
            p.m2 * p.lc2 * p.g)  # fmt: skip


def lumped_step(q1, q2, v1, v2, tau, a, b, c, d, e, dt, lim1, lim2, frame_skip) -> tuple:
    """One decision of the lumped model ``(a, b, c, d, e)`` from ``(q1, q2, v1, v2)`` with
    torque ``tau`` [N m]: ``frame_skip`` semi-implicit Euler steps of ``dt`` [s] (the angles
    moved with the new velocity), then the velocities clipped to ``lim1``, ``lim2`` [rad/s],
    as the env clips after each ``mj_step``, a NaN left as it is (as ``np.clip`` leaves it, so
    a diverged state is seen, not clipped). Plain floats and arithmetic only, so numba compiles
    this very function (:mod:`acrobot_mj.envs.model_step_jit`); the identified model and the
    vector env's analytic backend both step with it."""
    for _ in range(frame_skip):
        c2, s2 = math.cos(q2), math.sin(q2)
        d11, d12 = a + 2 * b * c2, c + b * c2
        phi2 = e * math.cos(q1 + q2)
        f1 = b * s2 * (v2 * v2 + 2 * v1 * v2) - d * math.cos(q1) - phi2
        f2 = tau - b * s2 * v1 * v1 - phi2
        det = d11 * c - d12 * d12
        v1 = v1 + dt * (c * f1 - d12 * f2) / det
        v2 = v2 + dt * (d11 * f2 - d12 * f1) / det
        q1, q2 = q1 + dt * v1, q2 + dt * v2  # as MuJoCo's Euler: the new, unclipped velocity
        if v1 > lim1:  # then the env's limits (NaN kept, as np.clip keeps it)
            v1 = lim1
        elif v1 < -lim1:
            v1 = -lim1
        if v2 > lim2:
            v2 = lim2
        elif v2 < -lim2:
            v2 = -lim2
    return q1, q2, v1, v2


def advance(x: Sequence[float], tau: float, theta: Sequence[float], s: StepStructure) -> tuple:
    """One decision: ``s.frame_skip`` semi-implicit Euler steps of the lumped model, velocities
    clipped after each (the env's step), on Python floats (:func:`lumped_step`)."""
    return lumped_step(*x, tau, *theta, s.dt, s.max_vel1, s.max_vel2, s.frame_skip)


def residuals(theta: Sequence[float], data: Sequence[Transition], s: StepStructure) -> np.ndarray:
    """Predicted minus observed next states, flattened."""
    return np.array([np.subtract(advance(x, tau, theta, s), x2) for x, tau, x2 in data]).ravel()


def initial_guess(data: Sequence[Transition], s: StepStructure) -> np.ndarray:
    """Least squares on the equations, linear in theta, with accelerations and states taken
    by finite differences over each decision (rough: a decision is 0.2 s)."""
    rows, rhs, span = [], [], s.dt * s.frame_skip
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
    data: Sequence[Transition], s: StepStructure = BOOK_STEP, iterations: int = 50
) -> tuple[np.ndarray, float]:
    """The lumped parameters that best predict ``data`` and the RMS prediction error [rad,
    rad/s] (Levenberg-Marquardt from :func:`initial_guess`). Fewer than 3 transitions, or
    data without torque, cannot fix the five values and are refused."""
    if len(data) < 3 or not any(tau for _, tau, _ in data):
        raise ValueError("identification needs at least 3 transitions, some with torque")
    theta = initial_guess(data, s)
    r = residuals(theta, data, s)
    cost, damping = float(r @ r), 1e-2
    for _ in range(iterations):
        jac = np.empty((r.size, 5))
        for j in range(5):
            h = 1e-7 * max(1.0, abs(theta[j]))
            jac[:, j] = (residuals(theta + h * np.eye(5)[j], data, s) - r) / h
        hess, grad = jac.T @ jac, jac.T @ r
        while damping < 1e12:
            step = np.linalg.solve(hess + damping * np.diag(np.diag(hess)), -grad)
            trial = residuals(theta + step, data, s)
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


def realise(theta: Sequence[float], s: StepStructure, max_torque: float = 1.0) -> AcrobotParams:
    """Physical parameters with the dynamics of the lumped ``theta``, for the model-based tools
    that take :class:`AcrobotParams` (trajectory optimisation, LQR, TVLQR).

    Five lumped values cannot fix nine physical ones: every choice of the gauge below gives the
    same equations of motion, to rounding (``tests/test_plan.py`` checks another gauge). The
    gauge is ``m1 = m2 = l1 = 1`` (``l2`` does not enter the dynamics; it is set to 1 too): then
    ``lc2 = b``, ``g = e / b``, ``I2 = c - b^2``, ``lc1 = d / g - 1`` and
    ``I1 = a - lc1^2 - 1 - b^2 - I2``. These are not claims about the real acrobot's masses or
    lengths; a realisation with a value <= 0 is refused (no physical acrobot has this model)."""
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
    return AcrobotParams(
        **values,
        max_torque=max_torque,
        max_vel1=s.max_vel1,
        max_vel2=s.max_vel2,
        dt=s.dt,
    )
