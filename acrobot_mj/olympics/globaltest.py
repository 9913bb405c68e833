"""The global-policy leaderboard's testing controller (double_pendulum, controller/
global_policy_testing_controller.py, ``GlobalPolicyTestingControllerV2``, with
controller/pid/point_pid_controller.py): at each reset time a PID on both joints plus gravity
compensation drives the arm to the next random target for more than ``reset_length``; the
entry's controller acts in between. A wrapper of that controller."""

from __future__ import annotations

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.envs.acrobot import observation
from acrobot_mj.olympics.protocol import GLOBAL, GlobalPolicy, to_protocol
from acrobot_mj.physics.dynamics import terms
from acrobot_mj.physics.models import AcrobotModel


class GlobalTester(Controller):
    """``controller`` inside the protocol's resets to ``targets`` (protocol convention, (M, 4))
    at ``reset_times`` [s]. It acts on the true, unwrapped state (what the reset's PID sees);
    ``controller`` sees its observation, the angles wrapped. It gives the elbow's torque; the
    shoulder's, which only a reset drives, is ``shoulder`` after each call."""

    def __init__(
        self,
        controller: Controller,
        model: AcrobotModel,
        targets: np.ndarray,
        reset_times: np.ndarray,
        protocol: GlobalPolicy = GLOBAL,
    ) -> None:
        self.controller, self.model, self.protocol = controller, model, protocol
        self.targets = np.asarray(targets, dtype=float)
        self.reset_times = np.append(np.asarray(reset_times, dtype=float), np.inf)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """A new episode: no reset yet, the PID's error history empty."""
        self.controller.reset(seed)
        self.counter, self.resetting, self.timer, self.last_t = 0, False, 0.0, 0.0
        self.errors: list[np.ndarray] = []
        #: The shoulder's torque [N m] of the last call.
        self.shoulder = 0.0

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

    def act(self, x: np.ndarray, t: float) -> float:
        """The elbow torque [N m] at time ``t`` [s] in the true unwrapped state ``x`` (ours),
        both joints' torques clipped to the protocol's limits as the plant clips them."""
        state = x
        if t >= self.reset_times[self.counter] and not self.resetting:
            self.resetting, self.timer = True, 0.0
            self.counter += 1
        if self.resetting and self.timer > self.protocol.reset_length:
            self.resetting = False
        if self.resetting:
            u = self._pid(to_protocol(state)[:2]) + self.gravity(state)
            self.timer += t - self.last_t
        else:
            obs = observation(*(float(v) for v in state))
            assert obs is not None  # the env refuses a state it cannot observe
            u = np.array([0.0, float(self.controller.act(obs, t))])
        self.last_t = t
        limit = np.array(self.protocol.torque_limit)
        shoulder, elbow = np.clip(u, -limit, limit)
        self.shoulder = float(shoulder)
        return float(elbow)
