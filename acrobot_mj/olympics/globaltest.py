"""The global-policy leaderboard's testing controller (double_pendulum, controller/
global_policy_testing_controller.py, ``GlobalPolicyTestingControllerV2``, with
controller/pid/point_pid_controller.py): at each reset time a PID on both joints plus gravity
compensation drives the arm to the next random target for more than ``reset_length``; the
entry's controller acts in between."""

from __future__ import annotations

from typing import Any

import numpy as np

from acrobot_mj.olympics.protocol import GLOBAL, GlobalPolicy, to_protocol
from acrobot_mj.physics.dynamics import terms
from acrobot_mj.physics.models import AcrobotModel


class GlobalTester:
    """``controller`` (``reset()``, ``controller(obs) -> elbow torque``) inside the protocol's
    resets to ``targets`` (protocol convention, (M, 4)) at ``reset_times`` [s]."""

    def __init__(
        self,
        controller: Any,
        model: AcrobotModel,
        targets: np.ndarray,
        reset_times: np.ndarray,
        protocol: GlobalPolicy = GLOBAL,
    ) -> None:
        self.controller, self.model, self.protocol = controller, model, protocol
        self.targets = np.asarray(targets, dtype=float)
        self.reset_times = np.append(np.asarray(reset_times, dtype=float), np.inf)
        self.reset()

    def reset(self) -> None:
        """A new episode: no reset yet, the PID's error history empty."""
        self.controller.reset()
        self.counter, self.resetting, self.timer, self.last_t = 0, False, 0.0, 0.0
        self.errors: list[np.ndarray] = []

    def _pid(self, theta: np.ndarray) -> np.ndarray:
        """The PID's torques (2,) [N m] at protocol angles ``theta`` (not wrapped)."""
        g, step = self.protocol, self.protocol.pid_dt
        self.errors.append(self.targets[self.counter - 1, :2] - theta)
        derivative = (self.errors[-1] - self.errors[-2]) / step if len(self.errors) > 2 else 0.0
        u = g.kp * self.errors[-1] + g.ki * np.sum(self.errors, axis=0) * step + g.kd * derivative
        return np.clip(u, -np.array(g.torque_limit), np.array(g.torque_limit))

    def gravity(self, state: np.ndarray) -> np.ndarray:
        """The torques (2,) [N m] that hold the arm still against gravity at ``state`` (ours)."""
        q1, q2 = state[:2]
        return np.array(terms(q1, q2, 0.0, 0.0, self.model.params.lumped)[5:7])

    def __call__(self, t: float, obs: np.ndarray, state: np.ndarray) -> tuple[float, float]:
        """The shoulder and elbow torques [N m] at time ``t`` [s], measurement ``obs`` (what the
        entry sees) and true unwrapped ``state`` (ours; what the PID sees), each clipped to the
        protocol's limits as the plant clips them."""
        if t >= self.reset_times[self.counter] and not self.resetting:
            self.resetting, self.timer = True, 0.0
            self.counter += 1
        if self.resetting and self.timer > self.protocol.reset_length:
            self.resetting = False
        if self.resetting:
            u = self._pid(to_protocol(state)[:2]) + self.gravity(state)
            self.timer += t - self.last_t
        else:
            u = np.array([0.0, float(self.controller(obs))])
        self.last_t = t
        limit = np.array(self.protocol.torque_limit)
        shoulder, elbow = np.clip(u, -limit, limit)
        return float(shoulder), float(elbow)
