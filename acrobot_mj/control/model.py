"""The env's discrete map on the analytic model, on arrays of states, and its linearisation.

States are ``(q1, q2, dq1, dq2)`` [rad, rad/s] with shape ``(..., 4)``, torques in N m; the
analytic model matches the MuJoCo env to rounding (``tests/test_crosscheck.py``).
"""

from __future__ import annotations

import numpy as np

from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.angles import wrap_angle
from acrobot_mj.physics.params import AcrobotParams

P = AcrobotParams()
UPRIGHT = np.array([np.pi / 2, 0.0, 0.0, 0.0])
HANGING = np.array([-np.pi / 2, 0.0, 0.0, 0.0])


def step(
    x: np.ndarray,
    tau: np.ndarray,
    frame_skip: int = 1,
    method: str = "semi_implicit_euler",
    p: AcrobotParams = P,
) -> np.ndarray:
    """``frame_skip`` physics steps of ``method`` with the task's velocity clipping (the env's
    step, on arrays of states ``(..., 4)``)."""
    advance = integrators.STEPS[method]
    for _ in range(frame_skip):
        x = integrators.clip_velocity(advance(x, tau, p.dt, p), p)
    return x


def state_error(x: np.ndarray, reference: np.ndarray = UPRIGHT) -> np.ndarray:
    """``x - reference`` [rad, rad/s], shape ``(..., 4)``, with the angle differences wrapped to
    ``[-pi, pi)`` (a state one turn away is the same state)."""
    error = np.asarray(x, dtype=float) - reference
    error[..., :2] = wrap_angle(error[..., :2])
    return error


def tip_height(x: np.ndarray, p: AcrobotParams = P) -> np.ndarray:
    """Height of the tip above the pivot [m], shape ``(...)``."""
    return dynamics.tip_position(np.asarray(x)[..., :2], p)[..., 1]


def step_jacobians(
    x: np.ndarray, u: float = 0.0, method: str = "semi_implicit_euler", p: AcrobotParams = P
) -> tuple[np.ndarray, np.ndarray]:
    """Exact Jacobians ``(A, B)`` of one physics step of ``method`` at state ``x`` and torque
    ``u`` [N m] (velocity clipping inactive), from the analytic continuous Jacobian: ``A`` is
    ``(4, 4)``, ``B`` is ``(4, 1)``."""
    x = np.asarray(x, dtype=float)
    h = p.dt
    if method == "semi_implicit_euler":
        a_c, b_c = dynamics.linearize(x[:2], x[2:], u, p)
        eye = np.eye(2)
        aq, av, bu = a_c[2:, :2], a_c[2:, 2:], b_c[2:]
        a = np.block([[eye + h * h * aq, h * (eye + h * av)], [h * aq, eye + h * av]])
        return a, np.vstack([h * h * bu, h * bu])
    if method != "rk4":
        raise ValueError(f"method must be 'semi_implicit_euler' or 'rk4', got {method!r}")
    # The chain rule through the four stages, each stage's Jacobian at its own state.
    j_sum, g_sum = np.zeros((4, 4)), np.zeros((4, 1))
    j, g, slope = np.zeros((4, 4)), np.zeros((4, 1)), np.zeros(4)
    for weight, fraction in ((1, 0.0), (2, 0.5), (2, 0.5), (1, 1.0)):
        stage_x = x + fraction * h * slope  # the stage's state, from the previous slope
        a_c, b_c = dynamics.linearize(stage_x[:2], stage_x[2:], u, p)
        j = a_c @ (np.eye(4) + fraction * h * j)
        g = a_c @ (fraction * h * g) + b_c
        slope = integrators.state_derivative(stage_x, u, p)
        j_sum, g_sum = j_sum + weight * j, g_sum + weight * g
    return np.eye(4) + h / 6 * j_sum, h / 6 * g_sum


def discrete_model(
    x0: np.ndarray = UPRIGHT, frame_skip: int = 1, p: AcrobotParams = P
) -> tuple[np.ndarray, np.ndarray]:
    """Exact Jacobians of the env's step (semi-implicit Euler, ``frame_skip`` steps) at ``x0``
    with zero torque, from the analytic continuous Jacobian."""
    a, b = step_jacobians(x0, 0.0, p=p)
    a_k, b_k = np.eye(4), np.zeros((4, 1))
    for _ in range(frame_skip):  # torque held over the frame
        a_k, b_k = a @ a_k, a @ b_k + b
    return a_k, b_k
