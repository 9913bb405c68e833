"""An env over an identified model, where a model-based learner plans: the real env's task,
spaces and resets, stepped by the analytic model on the identified parameters instead of MuJoCo.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.compiled import compiled
from acrobot_mj.envs.acrobot import MAX_ANGLE, Diverged, observation, start_state
from acrobot_mj.envs.spaces import (
    action_space,
    action_torque,
    observation_space,
)
from acrobot_mj.envs.tasks import Task
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.integrators import Stepping, method_code, step_one


class IdentifiedEnv(gym.Env[np.ndarray, Any]):
    """``Discrete(3)`` torques on the lumped model ``theta`` with ``task`` (e.g.
    ``real_env.unwrapped.task``), stepped as ``stepping`` says; truncated after
    ``max_episode_steps`` decisions. Resets as the single env."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        theta: Sequence[float] | np.ndarray,
        task: Task,
        stepping: Stepping = Stepping(substeps=4),  # noqa: B008 (frozen)
        max_episode_steps: int = 1000,
    ) -> None:
        values = np.asarray(theta, dtype=np.float64)
        if values.shape != (5,) or not np.all(np.isfinite(values)):
            raise ValueError(f"theta must be 5 finite lumped parameters, got {values!r}")
        self.theta, self.task, self.stepping = tuple(values.tolist()), task, stepping
        self.max_episode_steps = max_episode_steps
        self.observation_space, self.action_space = observation_space(), action_space(False)
        self._rule, self._info = task.rule(), task.info()
        self._x, self._t = tuple(HANGING.tolist()), 0
        self._constants = (
            *stepping.constants(self.theta).tolist(),
            stepping.substeps,
            method_code(stepping.method),
        )
        self._step = compiled(step_one)

    @property
    def state(self) -> np.ndarray:
        """The unwrapped state ``(q1, q2, dq1, dq2)`` [rad, rad/s], a copy."""
        return np.array(self._x)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        x = start_state(self.task, HANGING, self.np_random, options)[0]
        self._x, self._t = tuple(x.tolist()), 0
        values = self._rule(*self._x)[3]
        return self._observe(), self._info(values, False)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._x = self._step(*self._x, action_torque(action, False), *self._constants)
        self._t += 1
        reward, terminated, success, values = self._rule(*self._x)
        truncated = not terminated and self._t >= self.max_episode_steps
        obs = self._observe()
        return obs, float(reward), bool(terminated), truncated, self._info(values, success)

    def _observe(self) -> np.ndarray:
        obs = observation(*self._x)
        if obs is None:  # as the MuJoCo env: a bad state raises instead of reaching the learner
            raise Diverged(
                f"the model reached a non-finite state or angles beyond +-{MAX_ANGLE:g} rad: "
                f"{list(self._x)}; call reset() before stepping again"
            )
        return obs
