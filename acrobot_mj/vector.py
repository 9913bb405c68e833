"""Many acrobots stepped together in MuJoCo's C batch API (``mujoco.batch``).

:class:`AcrobotVectorEnv` is a ``gymnasium.vector.VectorEnv`` whose sub-environments have
exactly :class:`~acrobot_mj.env.AcrobotEnv`'s semantics (reward, goal, velocity clipping after
every physics step, angle wrapping, ``frame_skip``, integrator, start noise, truncation), with the
physics of all of them advanced by one ``Batch.step`` call per physics step across threads.
``gymnasium.make_vec("acrobot_mj/Acrobot-v0", num_envs=N)`` returns it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from mujoco.batch import Batch

from acrobot_mj.env import (
    MAX_VEL1,
    MAX_VEL2,
    RESET_OPTIONS,
    TORQUES,
    AcrobotEnv,
    _check_float,
    _check_int,
)

_LIMITS = np.array([MAX_VEL1, MAX_VEL2])
_TORQUES = np.array(TORQUES)
_HUGE = 1e10  # MuJoCo's mjMAXVAL, as in the single env


class AcrobotVectorEnv(VectorEnv):
    """``num_envs`` acrobots with the single env's task, stepped in one ``mujoco.batch.Batch``.

    Arguments: ``num_envs``; ``max_episode_steps`` (1000: the truncation the single env gets from
    ``gymnasium.make``); ``autoreset_mode`` (``"next_step"``, Gymnasium's default, or
    ``"disabled"``); ``nthread`` (threads of the batch, 0 for all CPUs); and the single env's
    ``frame_skip``, ``integrator``, ``step_reward``, ``goal_reward``, ``goal_height``,
    ``start_noise``, ``continuous`` and ``model_path`` (validated by the single env's rules).

    Autoreset (``AutoresetMode.NEXT_STEP``): when a sub-env terminates or truncates, the next
    ``step`` ignores its action, resets it and returns the reset observation with reward 0 and
    both flags False. With ``"disabled"``, a finished sub-env is reset only by
    ``reset(options={"reset_mask": mask})``, as in Gymnasium.

    Seeding follows Gymnasium's vector envs: ``reset(seed=s)`` seeds sub-env ``i`` with
    ``s + i`` (or takes a list of seeds); each sub-env owns its generator for start noise, so
    sub-env ``i`` behaves bit for bit like a single env reset with the same seed.

    ``info`` holds ``tip_height`` and ``is_success`` arrays (with Gymnasium's ``_`` masks).
    ``unwrapped.model`` is the shared ``MjModel``.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int = 1000,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        nthread: int = 0,
        render_mode: str | None = None,
        **env_kwargs: Any,
    ) -> None:
        self.num_envs = _check_int("num_envs", num_envs, 1)
        self.max_episode_steps = _check_int("max_episode_steps", max_episode_steps, 1)
        names = {"next_step": AutoresetMode.NEXT_STEP, "disabled": AutoresetMode.DISABLED}
        mode = (
            names.get(autoreset_mode, autoreset_mode)
            if isinstance(autoreset_mode, (str, AutoresetMode))
            else None
        )
        if mode not in names.values():
            raise ValueError(
                f"autoreset_mode must be 'next_step' or 'disabled', got {autoreset_mode!r}"
            )
        if render_mode is not None:
            raise ValueError("AcrobotVectorEnv does not render; use AcrobotEnv for frames")
        # One single env validates the options and builds the model (integrator, no autoreset).
        self._template = AcrobotEnv(**env_kwargs)
        self.model = self._template.model
        self.metadata = {
            **self.metadata,
            "autoreset_mode": mode,
            "render_fps": self._template.metadata["render_fps"],
        }
        self.render_mode = None
        self._frame_skip = self._template.frame_skip
        self._continuous = self._template.continuous
        self.batch = Batch(self.model, self.num_envs, nthread=_check_int("nthread", nthread, 0))
        self._qpos, self._qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self._ctrl = self.batch.bind("ctrl")
        self._hanging = self._template.model.key("hanging").qpos.copy()
        self._l1, self._l2 = self._template._l1, self._template._l2

        self.single_action_space = self._template.action_space
        self.single_observation_space = self._template.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._pending = np.zeros(self.num_envs, dtype=bool)  # reset at the next step
        self._rngs = [seeding.np_random()[0] for _ in range(self.num_envs)]
        self._reset_envs(np.ones(self.num_envs, dtype=bool), self._template.start_noise)

    # -- resets ----------------------------------------------------------------------------

    def _reset_envs(self, mask: np.ndarray, noise: float) -> None:
        """Put the masked sub-envs at rest, hanging, plus their own start noise."""
        ids = np.flatnonzero(mask)
        self._qpos[ids] = self._hanging
        self._qvel[ids] = 0.0
        self._ctrl[ids] = 0.0
        if noise > 0.0:
            for i in ids:  # the single env's draws, in its order: qpos, then qvel
                self._qpos[i] += self._rngs[i].uniform(-noise, noise, 2)
                self._qvel[i] += self._rngs[i].uniform(-noise, noise, 2)
        self._elapsed[ids] = 0
        self._pending[ids] = False

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        if options is not None and not isinstance(options, dict):
            raise TypeError(f"reset options must be a dict, got {options!r}")
        options = dict(options or {})
        mask = np.asarray(options.pop("reset_mask", np.ones(self.num_envs, dtype=bool)))
        if mask.shape != (self.num_envs,) or mask.dtype != bool:
            raise ValueError(f"reset_mask must be a bool array of shape ({self.num_envs},)")
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ValueError(
                f"unknown reset options {unknown}; known: {['reset_mask', *RESET_OPTIONS]}"
            )
        noise = self._template.start_noise
        if "start_noise" in options:
            noise = _check_float("start_noise", options["start_noise"], 0.0, 1.0)
        if seed is not None:
            if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
                seeds = [int(seed) + i for i in range(self.num_envs)]
            elif isinstance(seed, (list, tuple, np.ndarray)):
                seeds = [None if s is None else int(s) for s in seed]
            else:
                raise TypeError(f"seed must be an integer or one seed per sub-env, got {seed!r}")
            if len(seeds) != self.num_envs:
                raise ValueError(f"give one seed per sub-env ({self.num_envs}), got {len(seeds)}")
            for i in np.flatnonzero(mask):
                if seeds[i] is not None:
                    self._rngs[i] = seeding.np_random(seeds[i])[0]
        self._reset_envs(mask, noise)
        obs, tip, _ = self._observe()
        return obs, self._info(tip, np.zeros(self.num_envs, dtype=bool))

    # -- stepping --------------------------------------------------------------------------

    def _torques(self, actions: Any) -> np.ndarray:
        """Per-sub-env torques [N m]; anything outside the action space raises."""
        a = np.asarray(actions)
        if self._continuous:
            if a.dtype.kind not in "fiu" or a.shape != (self.num_envs, 1):
                raise ValueError(
                    f"actions must be a float array of shape ({self.num_envs}, 1), "
                    f"got {a.dtype} {a.shape}"
                )
            a = a[:, 0].astype(np.float64)
            if not np.all((a >= -1.0) & (a <= 1.0)):  # also refuses NaN
                raise ValueError(
                    f"torques outside [-1, 1] N m at sub-envs "
                    f"{np.flatnonzero(~((a >= -1.0) & (a <= 1.0))).tolist()}"
                )
            return a
        if a.dtype.kind not in "iu" or a.shape != (self.num_envs,):
            raise ValueError(
                f"actions must be integers of shape ({self.num_envs},), got {a.dtype} {a.shape}"
            )
        bad = (a < 0) | (a > 2)
        if bad.any():
            raise ValueError(
                f"actions outside Discrete(3) at sub-envs "
                f"{np.flatnonzero(bad).tolist()}: {a[bad].tolist()}"
            )
        return _TORQUES[a]

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        torques = self._torques(actions)
        resetting = self._pending.copy()
        self._ctrl[:, 0] = torques
        for _ in range(self._frame_skip):
            self.batch.step()
            # Velocity limits of the task, after every physics step.
            np.clip(self._qvel, -_LIMITS, _LIMITS, out=self._qvel)
        self._elapsed += 1
        if resetting.any():
            self._reset_envs(resetting, self._template.start_noise)
        obs, tip, finite = self._observe()
        if not finite.all():
            raise RuntimeError(
                f"sub-envs {np.flatnonzero(~finite).tolist()} reached a "
                "non-finite or huge state; reset them before stepping again"
            )
        terminated = (tip > self._template.goal_height) & ~resetting
        # As gymnasium's TimeLimit: truncated at the limit even on the step that terminates.
        truncated = (self._elapsed >= self.max_episode_steps) & ~resetting
        reward = np.where(terminated, self._template.goal_reward, self._template.step_reward)
        reward[resetting] = 0.0
        if self.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP:
            self._pending = terminated | truncated
        return obs, reward, terminated, truncated, self._info(tip, terminated)

    def _observe(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, v = self._qpos, self._qvel
        obs = np.empty((self.num_envs, 4))
        obs[:, :2] = q
        obs[:, 2:] = v
        # As the single env: angles in [-pi, pi) as they are, the others wrapped.
        outside = (q < -math.pi) | (q >= math.pi)
        if outside.any():
            wrapped = (q[outside] + math.pi) % (2 * math.pi) - math.pi
            wrapped[wrapped >= math.pi] -= 2 * math.pi
            obs[:, :2][outside] = wrapped
        tip = self._l1 * np.sin(q[:, 0]) + self._l2 * np.sin(q[:, 0] + q[:, 1])
        finite = np.ones(self.num_envs, dtype=bool)
        if not (np.abs(q).max() < _HUGE and np.abs(v).max() < _HUGE):  # NaN fails too
            finite = np.abs(q).sum(1) + np.abs(v).sum(1) < _HUGE
        return obs, tip, finite

    def _info(self, tip: np.ndarray, success: np.ndarray) -> dict[str, Any]:
        every = np.ones(self.num_envs, dtype=bool)
        return {
            "tip_height": tip,
            "_tip_height": every,
            "is_success": success,
            "_is_success": every,
        }

    def close_extras(self, **kwargs: Any) -> None:
        self._template.close()
