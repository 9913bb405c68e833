"""Potential-based reward shaping with the acrobot's mechanical energy.

Ng, Harada and Russell (1999): adding ``F = gamma phi(s') - phi(s)`` to every reward leaves the
optimal policies unchanged (the shaping terms of an episode telescope to ``-phi(s0)``, the same
for every policy from ``s0``), while it changes what a learner tries first. Here

    phi(s) = scale * (E(s) - E_hanging) / (E_upright - E_hanging)

with ``E`` the mechanical energy [J] (``dynamics.total_energy``): 0 hanging at rest, ``scale``
balanced upright at rest, ``scale / 2`` at rest with both links horizontal. Swinging up means
pumping energy in, so the shaping rewards every step that adds energy and charges every step that
takes it out. The terminal state has ``phi = 0`` (Grzes, 2017: otherwise the telescoping breaks
and so does the policy invariance).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.physics.dynamics import DEFAULT_PARAMS, potential_energy, state_energy
from acrobot_mj.physics.params import AcrobotParams


@functools.cache
def _rest_energies(params: AcrobotParams) -> tuple[float, float]:
    """Energies [J] hanging and upright at rest (computed once per parameter set)."""
    hanging = float(potential_energy(np.array([-math.pi / 2, 0.0]), params))
    upright = float(potential_energy(np.array([math.pi / 2, 0.0]), params))
    return hanging, upright


def energy_potential(obs: Any, params: AcrobotParams = DEFAULT_PARAMS) -> float:
    """The normalised energy of ``obs = (q1, q2, dq1, dq2)``: 0 hanging at rest, 1 upright
    (``dynamics.state_energy``: ``total_energy``'s numbers on Python floats)."""
    q1, q2, dq1, dq2 = np.asarray(obs, dtype=np.float64).tolist()
    return _normalised(state_energy(q1, q2, dq1, dq2, params), _rest_energies(params))


def _normalised(energy: float, rest: tuple[float, float]) -> float:
    """``energy`` [J] on the scale 0 hanging at rest, 1 upright at rest (``rest``)."""
    hanging, upright = rest
    return (energy - hanging) / (upright - hanging)


class EnergyShaping(gym.Wrapper):
    """Adds ``scale * (gamma phi(s') - phi(s))`` to each reward (``phi``: normalised energy).

    ``info["unshaped_reward"]`` keeps the env's own reward, so returns can be reported on the
    task's scale. Observations must be ``(q1, q2, dq1, dq2)`` (this package's env, or
    Acrobot-v1 through ``acrobot_mj.envs.compat``).
    """

    def __init__(
        self,
        env: gym.Env,
        scale: float,
        gamma: float = 1.0,
        params: AcrobotParams = DEFAULT_PARAMS,
    ) -> None:
        super().__init__(env)
        if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
            raise ValueError(f"energy shaping scale must be a finite number > 0, got {scale!r}")
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"energy shaping gamma must be in [0, 1], got {gamma!r}")
        self.scale, self.gamma, self.params = float(scale), float(gamma), params
        self._phi: float | None = None
        self._rest, self._rest_of = _rest_energies(params), params

    def potential(self, obs: Any) -> float:
        """``scale`` times :func:`energy_potential` of ``obs`` (the same number: its steps
        without the per-call conversions and cache lookup, which cost as much as the energy)."""
        fast = isinstance(obs, np.ndarray) and obs.dtype == np.float64
        q1, q2, dq1, dq2 = (obs if fast else np.asarray(obs, dtype=np.float64)).tolist()
        if self._rest_of is not self.params:  # params replaced since: their rest energies
            self._rest, self._rest_of = _rest_energies(self.params), self.params
        energy = state_energy(q1, q2, dq1, dq2, self.params)
        return self.scale * _normalised(energy, self._rest)

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
