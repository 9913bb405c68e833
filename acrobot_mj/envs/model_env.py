"""An env over an identified model: the same task, spaces and resets as :class:`AcrobotEnv`, with
the dynamics of :func:`acrobot_mj.control.identification.lumped_step` instead of MuJoCo.

What a model-based learner plans in (Dyna-style: simulated experience, no env decisions). The
task object is the real env's (its rewards, goal and start noise: what is asked, not how the
acrobot moves); only the step differs.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.identification import BOOK_STEP, StepStructure, lumped_step
from acrobot_mj.control.model import HANGING
from acrobot_mj.envs.env import MAX_ANGLE
from acrobot_mj.envs.resets import RESET_OPTIONS, reset_noise, reset_state
from acrobot_mj.envs.spaces import action_space, action_torque, observation_space
from acrobot_mj.envs.tasks import SCALAR, Task
from acrobot_mj.physics.angles import wrap_angle


class ModelEnv(gym.Env[np.ndarray, Any]):
    """``Discrete(3)`` torques on the lumped model ``theta`` (see the identification module)
    with ``task`` (a Task object, e.g. ``real_env.unwrapped.task``); truncation after
    ``max_episode_steps`` decisions. ``reset`` takes the single env's options (``start_noise``,
    ``state``) and draws its start offsets from the task, as the single env does."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        theta: Sequence[float],
        task: Task,
        structure: StepStructure = BOOK_STEP,
        max_episode_steps: int = 1000,
        compiled: bool = False,
    ) -> None:
        theta = np.asarray(theta, dtype=np.float64)
        if theta.shape != (5,) or not np.all(np.isfinite(theta)):
            raise ValueError(f"theta must be 5 finite lumped parameters, got {theta!r}")
        self.theta, self.task, self.structure = tuple(theta.tolist()), task, structure
        self.max_episode_steps = max_episode_steps
        self.observation_space, self.action_space = observation_space(), action_space(False)
        self._outcome = task.outcome(SCALAR)
        self._x, self._t = tuple(HANGING.tolist()), 0
        self._step = lumped_step
        if compiled:  # the same function, compiled (acrobot_mj.envs.model_step_jit)
            from acrobot_mj.envs.model_step_jit import lumped_step_jit as _step

            self._step = _step
        s = structure
        self._constants = (*self.theta, s.dt, s.max_vel1, s.max_vel2, s.frame_skip)

    @property
    def state(self) -> np.ndarray:
        """The unwrapped state ``(q1, q2, dq1, dq2)`` [rad, rad/s], a copy."""
        return np.array(self._x)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        start = reset_state(options)
        noise = reset_noise(options, self.task.start_noise, known=RESET_OPTIONS)
        x = HANGING.copy() if start is None else start
        offsets = None if start is not None else self.task.start_offsets(self.np_random, noise)
        if offsets is not None:
            x[:2] += offsets[0]
            x[2:] += offsets[1]
        self._x, self._t = tuple(x.tolist()), 0
        _, _, info = self._outcome(*self._x)
        return self._observe(), {**info, "is_success": False}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._x = self._step(*self._x, action_torque(action, False), *self._constants)
        self._t += 1
        reward, terminated, info = self._outcome(*self._x)
        truncated = not terminated and self._t >= self.max_episode_steps
        return self._observe(), float(reward), bool(terminated), truncated, info

    def _observe(self) -> np.ndarray:
        q1, q2, v1, v2 = self._x
        # As the MuJoCo env: NaN (kept by the step's limits), infinities or runaway angles stop
        # the episode with an error instead of reaching the learner.
        if not (
            -MAX_ANGLE < q1 < MAX_ANGLE and -MAX_ANGLE < q2 < MAX_ANGLE and v1 == v1 and v2 == v2
        ):
            raise RuntimeError(
                f"the model reached a non-finite state or angles beyond +-{MAX_ANGLE:g} rad: "
                f"{list(self._x)}; call reset() before stepping again"
            )
        return np.array((wrap_angle(q1), wrap_angle(q2), v1, v2))
