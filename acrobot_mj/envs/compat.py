"""Gymnasium's own ``Acrobot-v1`` in this package's observation convention.

``Acrobot-v1`` observes ``(cos theta1, sin theta1, cos theta2, sin theta2, dtheta1, dtheta2)``
with ``theta1`` measured from hanging; :class:`ReportObservation` turns that into the report's
``(q1, q2, dq1, dq2)`` with ``q1 = theta1 - pi/2`` wrapped to [-pi, pi), so the same agents
and training loops run on both (for example to compare speed side by side).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from acrobot_mj.envs.spaces import observation_space
from acrobot_mj.physics.angles import wrap_angle


class ReportObservation(gym.ObservationWrapper):
    """Map Acrobot-v1 observations to ``(q1, q2, dq1, dq2)`` [rad, rad/s]."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        if getattr(env.observation_space, "shape", None) != (6,):
            raise ValueError(
                f"expected Acrobot-v1's (6,) observations, got {env.observation_space}"
            )
        self.observation_space = observation_space()

    def observation(self, observation: np.ndarray) -> np.ndarray:
        c1, s1, c2, s2, dq1, dq2 = observation.tolist()
        q1 = wrap_angle(math.atan2(s1, c1) - math.pi / 2)
        return np.array((q1, math.atan2(s2, c2), dq1, dq2))


def make_gymnasium_acrobot(**kwargs) -> gym.Env:
    """``gymnasium.make("Acrobot-v1", **kwargs)`` observed in the report's convention."""
    return ReportObservation(gym.make("Acrobot-v1", **kwargs))
