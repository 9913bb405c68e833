"""Linear feedback: the exact linearisation of the env's step, infinite-horizon discrete LQR at
upright (its saturated form and basin, and the bound no controller with |tau| <= 1 N m can
beat), time-varying LQR along a swing-up, and sigma-delta modulation for {-1, 0, +1} torques.

TVLQR runs the discrete Riccati recursion backwards along the trajectory on the exact Jacobians
of the physics step at each ``(x_k, u_k)`` (:func:`step_jacobians`, no finite differences),
starting from the infinite-horizon LQR's cost at upright, so the two feedbacks join without a
seam."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import UPRIGHT, state_error
from acrobot_mj.physics.params import REPORT, AcrobotParams


def step_jacobians(
    x: np.ndarray, u: float = 0.0, method: str = "semi_implicit_euler", p: AcrobotParams = REPORT
) -> tuple[np.ndarray, np.ndarray]:
    """Exact Jacobians ``A`` ``(4, 4)`` and ``B`` ``(4, 1)`` of one physics step of ``method``
    at state ``x`` and torque ``u`` [N m] (limits inactive), from the analytic continuous
    Jacobian (no finite differences)."""
    x, h = np.asarray(x, dtype=float), p.dt
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
        stage = x + fraction * h * slope
        a_c, b_c = dynamics.linearize(stage[:2], stage[2:], u, p)
        j = a_c @ (np.eye(4) + fraction * h * j)
        g = a_c @ (fraction * h * g) + b_c
        slope = integrators.state_derivative(stage, u, p)
        j_sum, g_sum = j_sum + weight * j, g_sum + weight * g
    return np.eye(4) + h / 6 * j_sum, h / 6 * g_sum


def discrete_model(
    x0: np.ndarray = UPRIGHT, frame_skip: int = 1, p: AcrobotParams = REPORT
) -> tuple[np.ndarray, np.ndarray]:
    """Exact Jacobians of the env's decision (semi-implicit Euler, ``frame_skip`` steps, the
    torque held) at ``x0`` with zero torque."""
    a, b = step_jacobians(x0, 0.0, p=p)
    a_k, b_k = np.eye(4), np.zeros((4, 1))
    for _ in range(frame_skip):
        a_k, b_k = a @ a_k, a @ b_k + b
    return a_k, b_k


def dlqr(
    a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, tol: float = 1e-12
) -> tuple[np.ndarray, np.ndarray]:
    """Infinite-horizon discrete LQR by Riccati iteration: gain K (``u = -K x``) and cost P."""
    cost = q.copy()
    for _ in range(10_000):
        gain = np.linalg.solve(r + b.T @ cost @ b, b.T @ cost @ a)
        new = q + a.T @ cost @ (a - b @ gain)
        if np.max(np.abs(new - cost)) <= tol * max(1.0, np.max(np.abs(new))):
            return gain, new
        cost = new
    raise RuntimeError("the Riccati iteration did not converge")


@dataclass
class LQR:
    """Saturated LQR at upright, ``tau = clip(-K (x - x*), -1, 1)`` N m (angles of ``x - x*``
    wrapped), designed on the env's discrete model of ``p`` (the report's acrobot, or an
    identified one)."""

    q: tuple[float, ...] = (10.0, 10.0, 1.0, 1.0)
    r: float = 1.0
    p: AcrobotParams = REPORT
    gain: np.ndarray = field(init=False)
    #: The Riccati solution: the infinite-horizon cost-to-go ``x' S x`` of the error.
    cost: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        a, b = discrete_model(p=self.p)
        self.gain, self.cost = dlqr(a, b, np.diag(self.q), np.array([[self.r]]))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        limit = self.p.max_torque
        return np.clip(-(state_error(x) @ self.gain.T)[..., 0], -limit, limit)


def balances(
    controller: Callable[[np.ndarray], np.ndarray],
    starts: np.ndarray,
    seconds: float = 20.0,
    tolerance: float = 1e-3,
) -> np.ndarray:
    """For each start ``(n, 4)``: does ``controller`` bring it within ``tolerance`` of upright
    (all four coordinates, angles wrapped) and keep it there at the end?"""
    x = np.array(starts, dtype=float)
    for _ in range(round(seconds / REPORT.dt)):
        x = integrators.step_states(x, controller(x))
    return np.all(np.abs(state_error(x)) < tolerance, axis=1)


def q1_basin(
    controller: Callable[[np.ndarray], np.ndarray], upper: float = 0.5, resolution: float = 1e-4
) -> tuple[float, float]:
    """The largest pure q1 offsets (below and above upright, at rest) from which ``controller``
    balances, by bisection (assuming the basin along q1 is an interval)."""
    limits = []
    for sign in (-1.0, 1.0):
        good, bad = 0.0, upper
        while bad - good > resolution:
            mid = (good + bad) / 2
            start = UPRIGHT + np.array([sign * mid, 0.0, 0.0, 0.0])
            good, bad = (mid, bad) if balances(controller, start[None])[0] else (good, mid)
        limits.append(sign * good)
    return limits[0], limits[1]


def unstable_mode_bound(p: AcrobotParams = REPORT) -> dict[str, float]:
    """The largest pure q1 offset from upright that any controller with ``|tau| <= max_torque``
    recovers from, in the linearisation: each unstable mode ``z = w x`` (``w`` a left
    eigenvector, eigenvalue ``lambda > 0``) obeys ``dz/dt = lambda z + (w B) tau``, so past
    ``|z| = |w B| max_torque / lambda`` no torque stops it; for ``x = (d, 0, 0, 0)`` that caps
    ``|d|`` at ``min_i |w_i B| max_torque / (lambda_i |w_i1|)``. Keyed by the eigenvalue."""
    a, b = dynamics.linearize(UPRIGHT[:2], UPRIGHT[2:], 0.0, p)
    values, left = np.linalg.eig(a.T)
    bounds = {}
    for k in np.flatnonzero(values.real > 1e-9):
        w = left[:, k].real
        bounds[f"{values[k].real:.4f}"] = (
            abs(w @ b[:, 0]) * p.max_torque / (values[k].real * abs(w[0]))
        )
    return bounds


def controllability_rank(a: np.ndarray, b: np.ndarray) -> int:
    """Rank of ``[B, AB, A^2 B, A^3 B]``."""
    blocks = [b]
    for _ in range(a.shape[0] - 1):
        blocks.append(a @ blocks[-1])
    return int(np.linalg.matrix_rank(np.hstack(blocks)))


class SwingUpController:
    """``u_k = clip(u*_k - K_k (x - x*_k), -1, 1)`` N m along ``trajectory`` (angles of the error
    wrapped), then the saturated LQR at upright, both on the trajectory's model
    (``trajectory.params``). ``q`` and ``r`` weight the state error and the torque in both."""

    def __init__(
        self,
        trajectory: Trajectory,
        q: tuple[float, ...] = (10.0, 10.0, 1.0, 1.0),
        r: float = 1.0,
    ) -> None:
        self.trajectory, p = trajectory, trajectory.params
        self.lqr = LQR(q, r, p)
        weights, cost, riccati = np.diag(q), np.array([[r]]), self.lqr.cost
        self.gains = np.zeros((trajectory.steps, 4))
        for k in reversed(range(trajectory.steps)):
            x, u = trajectory.states[k], trajectory.torques[k]
            a, b = step_jacobians(x, u, trajectory.method, p)
            gain = np.linalg.solve(cost + b.T @ riccati @ b, b.T @ riccati @ a)
            riccati = weights + a.T @ riccati @ (a - b @ gain)
            self.gains[k] = gain[0]

    def __call__(self, k: int, x: np.ndarray) -> float:
        """The torque [N m] at physics step ``k`` (0 at the start) in state ``x``."""
        if k >= self.trajectory.steps:
            return float(self.lqr(x))
        error = state_error(x, self.trajectory.states[k])
        u = self.trajectory.torques[k] - self.gains[k] @ error
        limit = self.trajectory.params.max_torque
        return float(np.clip(u, -limit, limit))


class SigmaDelta:
    """First-order sigma-delta modulation: torques in {-1, 0, +1} N m whose running sum follows
    that of a continuous torque, the quantisation error carried to the next step."""

    def __init__(self) -> None:
        self.carried = 0.0

    def __call__(self, u: float) -> int:
        """The ``Discrete(3)`` action (0, 1, 2) for the continuous torque ``u`` [N m]."""
        wanted = u + self.carried
        level = int(np.clip(np.rint(wanted), -1, 1))
        self.carried = wanted - level
        return level + 1
