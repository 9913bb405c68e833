"""One law in two shapes, scored by the AI Olympics protocol: ``theirs``, a controller in
``double_pendulum``'s convention (``get_control_output(x, t)`` with ``theta1`` from hanging,
``[u1, u2]`` out, ``init()``), as its leaderboard's entries are written, and ``ours``, the same
law against acrobot_mj's :class:`~acrobot_mj.control.controller.Controller`. The law: Spong's
energy pumping to upright's energy, and the LQR within a level set of its cost at upright.
From this folder (each is a factory taking the model):

    acrobot-mj olympics double_pendulum_style:theirs --scores performance,global --out runs/theirs
    acrobot-mj olympics double_pendulum_style:ours --scores performance,global --out runs/ours

The two give the same torques to the bit, so the same scores.
"""

from __future__ import annotations

import math

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.control.lqr import LQR
from acrobot_mj.control.policies import energy_pumping_torque
from acrobot_mj.physics.models import AcrobotModel
from acrobot_mj.physics.xp import wrap_angle

#: The LQR acts within this level of its cost at upright (the funnel entry's level at 500 Hz).
LEVEL = 30_000.0
#: Energy pumping's gain [N m / (J rad/s)].
GAIN = 5.0


def law(theta: np.ndarray, lqr: LQR) -> float:
    """The elbow torque [N m] at ``theta`` (4,) in double_pendulum's convention: ``theta1``
    from hanging, ``theta2`` relative (upright is ``(pi, 0)``), velocities [rad/s]."""
    error = np.array(theta, dtype=float) - (math.pi, 0.0, 0.0, 0.0)
    error[:2] = wrap_angle(error[:2])
    if error @ lqr.cost @ error < LEVEL:
        return float(np.clip(-lqr.gain[0] @ error, -lqr.p.max_torque, lqr.p.max_torque))
    ours = np.array([theta[0] - math.pi / 2, theta[1], theta[2], theta[3]])
    return float(energy_pumping_torque(ours, gain=GAIN, p=lqr.p))


class Theirs:
    """The law in double_pendulum's shape (its ``AbstractController``'s methods, without the
    package): shoulder torque 0, the elbow's from :func:`law`."""

    def __init__(self, model: AcrobotModel) -> None:
        self.lqr = LQR(p=model.analytic)
        self.calls = 0

    def init(self) -> None:
        self.calls = 0

    def get_control_output(self, x: np.ndarray, t: float | None = None) -> list[float]:
        self.calls += 1
        return [0.0, law(x, self.lqr)]


class Ours(Controller):
    """The law as this package's controller: our state converted to their convention."""

    def __init__(self, model: AcrobotModel) -> None:
        self.lqr = LQR(p=model.analytic)

    def act(self, x: np.ndarray, t: float) -> float:
        theta = np.array([x[0] + math.pi / 2, x[1], x[2], x[3]])
        return law(theta, self.lqr)


def theirs(model: AcrobotModel) -> Theirs:
    """The factory ``acrobot-mj olympics double_pendulum_style:theirs`` calls."""
    return Theirs(model)


def ours(model: AcrobotModel) -> Ours:
    """The factory ``acrobot-mj olympics double_pendulum_style:ours`` calls."""
    return Ours(model)
