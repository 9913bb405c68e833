"""Wrappers: reward shaping with the acrobot's energy, cos/sin observations, and Acrobot-v1 in
the report's convention.

Potential-based shaping (Ng, Harada and Russell, 1999) leaves the optimal policies unchanged; a
terminal state needs ``phi = 0`` for that (Grzes, 2017).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.envs.spaces import cos_sin, observation_space
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT, energies
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.physics.xp import wrap


class EnergyShaping(gym.Wrapper):
    """Adds ``gamma phi(s') - phi(s)`` to each reward, ``phi`` the energy of ``params`` (default
    the env's ``params``, else the report's) scaled to 0 hanging and ``scale`` upright at rest
    (pumping energy in pays); ``info["unshaped_reward"]`` keeps the env's. Observations must be
    ``(q1, q2, dq1, dq2)``."""

    def __init__(
        self, env: gym.Env, scale: float, gamma: float = 1.0, params: AcrobotParams | None = None
    ) -> None:
        super().__init__(env)
        if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
            raise ValueError(f"energy shaping scale must be a finite number > 0, got {scale!r}")
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"energy shaping gamma must be in [0, 1], got {gamma!r}")
        if params is None:
            params = getattr(env.unwrapped, "params", REPORT)
        self.scale, self.gamma, self.params = float(scale), float(gamma), params
        self._phi: float | None = None
        self._of: AcrobotParams | None = None  # whose constants are cached (params may change)

    def potential(self, obs: Any) -> float:
        """``scale`` times the normalised energy of ``obs = (q1, q2, dq1, dq2)``."""
        if self._of is not self.params:
            self._of, self._theta = self.params, self.params.lumped
            self._rest = [sum(energies(*x.tolist(), self._theta)) for x in (HANGING, UPRIGHT)]
        kinetic, potential = energies(*np.asarray(obs, dtype=np.float64).tolist(), self._theta)
        hanging, upright = self._rest
        return self.scale * ((kinetic + potential - hanging) / (upright - hanging))

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._phi = self.potential(obs)
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self._phi is None:
            raise RuntimeError("EnergyShaping.step() before reset()")
        obs, reward, terminated, truncated, info = self.env.step(action)
        phi = 0.0 if terminated else self.potential(obs)
        shaped = float(reward) + self.gamma * phi - self._phi
        self._phi = None if (terminated or truncated) else phi
        return obs, shaped, terminated, truncated, {**info, "unshaped_reward": float(reward)}


class CosSinObservation(gym.ObservationWrapper):
    """``(q1, q2, dq1, dq2)`` observed as ``(cos q1, sin q1, cos q2, sin q2, dq1, dq2)``, as
    Gymnasium's ``Acrobot-v1`` (no jump where a wrapped angle crosses pi), in ``dtype``
    (float32 as the RL-ready ids; float64 keeps every digit). The env's state and reset options
    are the wrapped env's. The registered ``...RL-v0`` ids observe this way without a wrapper."""

    def __init__(self, env: gym.Env, dtype: type = np.float32) -> None:
        super().__init__(env)
        space = env.observation_space
        if not isinstance(space, gym.spaces.Box) or space.shape != (4,):
            raise ValueError(f"expected (q1, q2, dq1, dq2) observations, got {space}")
        self.dtype = np.dtype(dtype)
        if self.dtype.kind != "f":
            raise TypeError(f"dtype must be a float type, got {dtype!r}")
        speeds = space.high[2:]  # the env's velocity limits (inf: none)
        high = np.array([1.0, 1.0, 1.0, 1.0, *speeds], dtype=self.dtype)
        self.observation_space = gym.spaces.Box(-high, high, dtype=self.dtype)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        if self.dtype == np.float32:
            return cos_sin(observation)
        q1, q2, dq1, dq2 = np.asarray(observation, dtype=np.float64)
        return np.array([np.cos(q1), np.sin(q1), np.cos(q2), np.sin(q2), dq1, dq2], self.dtype)


class ReportObservation(gym.ObservationWrapper):
    """Gymnasium's ``Acrobot-v1`` observed as ``(q1, q2, dq1, dq2)``, ``q1 = theta1 - pi/2``
    wrapped."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        if getattr(env.observation_space, "shape", None) != (6,):
            raise ValueError(
                f"expected Acrobot-v1's (6,) observations, got {env.observation_space}"
            )
        self.observation_space = observation_space()

    def observation(self, observation: np.ndarray) -> np.ndarray:
        c1, s1, c2, s2, dq1, dq2 = observation.tolist()
        return np.array((wrap(math.atan2(s1, c1) - math.pi / 2), math.atan2(s2, c2), dq1, dq2))


def make_gymnasium_acrobot(**kwargs: Any) -> gym.Env:
    """``gymnasium.make("Acrobot-v1", **kwargs)`` observed in the report's convention."""
    return ReportObservation(gym.make("Acrobot-v1", **kwargs))
