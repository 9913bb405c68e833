"""Feedback along a swing-up: time-varying LQR on the trajectory, then the saturated LQR at
upright, and sigma-delta modulation for the learning task's torques {-1, 0, +1} N m.

TVLQR: the discrete Riccati recursion backwards along the trajectory, on the exact Jacobians of
the env's physics step at each ``(x_k, u_k)`` (:func:`acrobot_mj.control.lqr.step_jacobians`:
the analytic continuous Jacobian through the integrator; no finite differences), starting from
the infinite-horizon LQR's cost at upright, so the two feedbacks join without a seam.
"""

from __future__ import annotations

import numpy as np

from acrobot_mj.control.lqr import LQR, state_error, step_jacobians
from acrobot_mj.control.trajectory import Trajectory


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
