"""A state estimator for noisy measurements: the model predicts the state from the last estimate
and the last torque, the measured angles correct the angles, and their innovation (over one
step) corrects the velocities; the measured velocities enter with a small weight only. With
angles measured well (encoders) and velocities noisy (differentiated), as on the AI Olympics
robot, the velocities come from the angles and the model, not from the noisy measurement."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from acrobot_mj.checks import check_float
from acrobot_mj.control.controller import Controller
from acrobot_mj.physics import integrators
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.physics.xp import wrap


@dataclass
class Observer:
    """Estimates ``(q1, q2, dq1, dq2)`` [rad, rad/s] from measurements ``y`` of the same form:
    ``x- = step(x, u)`` on ``params`` by ``method`` (or by a learnt model's ``step``, a step of
    ``params.dt``), then ``q = q- + r`` with the angle innovation ``r = wrap(y_q - q-)`` and
    ``dq = dq- + angle_gain r / dt + velocity_gain (y_dq - dq-)`` (``angle_gain`` per step,
    ``velocity_gain`` dimensionless, both in [0, 1]); an innovation past ``jump`` [rad] (the
    arm moved by something else) restarts it from ``y``."""

    params: AcrobotParams
    method: str = "rk4"
    angle_gain: float = 0.5
    velocity_gain: float = 0.05
    #: An angle innovation [rad] past which the estimate restarts from the measurement.
    jump: float = 0.1
    step: Callable[[np.ndarray, float], np.ndarray] | None = None
    estimate: np.ndarray | None = field(default=None, init=False)
    torque: float = field(default=0.0, init=False)

    def __post_init__(self) -> None:
        check_float("angle_gain", self.angle_gain, 0.0, 1.0)
        check_float("velocity_gain", self.velocity_gain, 0.0, 1.0)
        if self.step is None:
            integrators.method_code(self.method)  # a known method

    def _one_step(self) -> integrators.OneStep:
        """The compiled step of one state on ``params`` by ``method``, kept while they stay."""
        kept = self.__dict__.get("_kept")
        if kept is None or kept.p is not self.params or kept.method is not self.method:
            kept = self._kept = integrators.OneStep(self.params, self.method)
        return kept

    def reset(self) -> None:
        """Forget the estimate: the next measurement is taken as it is."""
        self.estimate, self.torque = None, 0.0

    def __call__(self, y: Any) -> np.ndarray:
        """The estimate after measurement ``y`` (4,), a copy."""
        y = np.asarray(y, dtype=float)
        if self.estimate is None:
            x = y.copy()
        else:  # on floats: a call every 0.002 s, where numpy's small arrays cost most
            p = self.params
            if self.step is None:  # step_states' compiled step of one state, called directly
                q1, q2, v1, v2 = self._one_step()(*self.estimate.tolist(), self.torque)
            else:
                predicted = np.asarray(self.step(self.estimate, self.torque), dtype=float)
                q1, q2, v1, v2 = predicted.tolist()
            y0, y1, y2, y3 = y.tolist()
            r1, r2 = wrap(y0 - q1), wrap(y1 - q2)
            if abs(r1) > self.jump or abs(r2) > self.jump:  # not this model's motion: restart
                self.estimate = None
                return self(y)
            a, weight = self.angle_gain, self.velocity_gain
            x = np.array(
                [
                    q1 + r1,
                    q2 + r2,
                    v1 + a * r1 / p.dt + weight * (y2 - v1),
                    v2 + a * r2 / p.dt + weight * (y3 - v2),
                ]
            )
        self.estimate = x
        return x.copy()

    def applied(self, torque: float) -> None:
        """The torque [N m] commanded for the step after the last measurement."""
        self.torque = float(torque)


class Estimated(Controller):
    """``controller`` acting on an :class:`Observer`'s estimate instead of the measurement; the
    observer predicts with the torque ``controller`` gave."""

    def __init__(self, controller: Controller, observer: Observer) -> None:
        self.controller, self.observer = controller, observer

    def reset(self, seed: int | None = None) -> None:
        """A new episode for both."""
        self.observer.reset()
        self.controller.reset(seed)

    def act(self, x: np.ndarray, t: float) -> float:
        torque = float(self.controller.act(self.observer(x), t))
        self.observer.applied(torque)
        return torque

    def applied(self, torque: float) -> None:
        self.controller.applied(torque)
