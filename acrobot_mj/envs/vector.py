"""Many acrobots stepped together in MuJoCo's C batch API (``mujoco.batch``).

:class:`AcrobotVectorEnv` is a ``gymnasium.vector.VectorEnv`` whose sub-environments have
exactly :class:`~acrobot_mj.envs.env.AcrobotEnv`'s semantics (the task's reward, termination
and info through the same :meth:`~acrobot_mj.envs.tasks.Task.outcome`, vectorised; velocity
clipping after every physics step, angle wrapping, ``frame_skip``, integrator, start noise,
truncation), with the physics of all of them advanced by one ``Batch.step`` call per physics
step across threads. ``gymnasium.make_vec("acrobot_mj/Acrobot-v0", num_envs=N)`` returns it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from mujoco.batch import Batch

from acrobot_mj.checks import check_int
from acrobot_mj.envs.env import HUGE, MAX_ANGLE, AcrobotEnv
from acrobot_mj.envs.resets import reset_noise
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2, action_torques
from acrobot_mj.envs.tasks import ARRAY
from acrobot_mj.physics.angles import wrap_angle

_LIMITS = np.array([MAX_VEL1, MAX_VEL2])


class AcrobotVectorEnv(VectorEnv):
    """``num_envs`` acrobots with the single env's task, stepped in one ``mujoco.batch.Batch``.

    Arguments: ``num_envs``; ``max_episode_steps`` (default: the task's, 1000 for the height
    goal: the truncation the single env gets from ``gymnasium.make``); ``autoreset_mode``
    (``"next_step"``, Gymnasium's default, or ``"disabled"``); ``nthread`` (threads of the batch,
    0 for all CPUs); and the single env's ``frame_skip``, ``integrator``, ``task``,
    ``continuous``, ``model_path`` and task options (validated by the single env's rules).

    Autoreset (``AutoresetMode.NEXT_STEP``): when a sub-env terminates or truncates, the next
    ``step`` ignores its action, resets it and returns the reset observation with reward 0 and
    both flags False. With ``"disabled"``, a finished sub-env is reset only by
    ``reset(options={"reset_mask": mask})``, as in Gymnasium.

    Seeding follows Gymnasium's vector envs: ``reset(seed=s)`` seeds sub-env ``i`` with
    ``s + i`` (or takes a list of seeds); each sub-env owns its generator for start noise, so
    sub-env ``i`` behaves bit for bit like a single env reset with the same seed.

    ``info`` holds the task's entries as arrays (for the height goal ``tip_height`` and
    ``is_success``), each with Gymnasium's ``_`` mask. ``unwrapped.model`` is the shared
    ``MjModel``, ``unwrapped.task`` the task.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        nthread: int = 0,
        render_mode: str | None = None,
        **env_kwargs: Any,
    ) -> None:
        self.num_envs = check_int("num_envs", num_envs, 1)
        mode = _autoreset_mode(autoreset_mode)
        if render_mode is not None:
            raise ValueError("AcrobotVectorEnv does not render; use AcrobotEnv for frames")
        # One single env validates the options and builds the model (integrator, no autoreset).
        self._template = AcrobotEnv(**env_kwargs)
        self.task = self._template.task
        if max_episode_steps is None:
            max_episode_steps = self.task.max_episode_steps
        self.max_episode_steps = check_int("max_episode_steps", max_episode_steps, 1)
        self.model = self._template.model
        self.metadata = {
            **self.metadata,
            "autoreset_mode": mode,
            "render_fps": self._template.metadata["render_fps"],
        }
        self.render_mode = None
        self._frame_skip = self._template.frame_skip
        self._continuous = self._template.continuous
        self.batch = Batch(self.model, self.num_envs, nthread=check_int("nthread", nthread, 0))
        self._qpos, self._qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self._ctrl = self.batch.bind("ctrl")
        start = self.model.key(self.task.start_keyframe)
        self._start_qpos, self._start_qvel = start.qpos.copy(), start.qvel.copy()
        self._outcome = self.task.outcome(ARRAY)

        self.single_action_space = self._template.action_space
        self.single_observation_space = self._template.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._pending = np.zeros(self.num_envs, dtype=bool)  # reset at the next step
        self._rngs = [seeding.np_random()[0] for _ in range(self.num_envs)]
        self._reset_envs(np.ones(self.num_envs, dtype=bool), self.task.start_noise)

    # -- resets ----------------------------------------------------------------------------

    def _reset_envs(self, mask: np.ndarray, noise: float) -> None:
        """Put the masked sub-envs at the task's start keyframe, plus their own start noise."""
        ids = np.flatnonzero(mask)
        self._qpos[ids] = self._start_qpos
        self._qvel[ids] = self._start_qvel
        self._ctrl[ids] = 0.0
        for i in ids:  # the single env's draws, from each sub-env's own generator
            offsets = self.task.start_offsets(self._rngs[i], noise)
            if offsets is not None:
                self._qpos[i] += offsets[0]
                self._qvel[i] += offsets[1]
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
        noise = reset_noise(options, self.task.start_noise, also_known=("reset_mask",))
        if seed is not None:
            for i, s in zip(np.flatnonzero(mask), self._seeds(seed)[mask], strict=True):
                if s is not None:
                    self._rngs[i] = seeding.np_random(s)[0]
        self._reset_envs(mask, noise)
        obs, _, _, info = self._observe()
        info["is_success"] = np.zeros(self.num_envs, dtype=bool)  # a reset is no success
        return obs, self._masked(info)

    def _seeds(self, seed: int | Sequence[int | None]) -> np.ndarray:
        """One seed (or None) per sub-env: ``seed + i``, or the given list."""
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        elif isinstance(seed, (list, tuple, np.ndarray)):
            seeds = [None if s is None else int(s) for s in seed]
        else:
            raise TypeError(f"seed must be an integer or one seed per sub-env, got {seed!r}")
        if len(seeds) != self.num_envs:
            raise ValueError(f"give one seed per sub-env ({self.num_envs}), got {len(seeds)}")
        return np.array(seeds, dtype=object)

    # -- stepping --------------------------------------------------------------------------

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        torques = action_torques(actions, self._continuous, self.num_envs)
        resetting = self._pending.copy()
        self._ctrl[:, 0] = torques
        for _ in range(self._frame_skip):
            self.batch.step()
            # Velocity limits of the task, after every physics step.
            np.clip(self._qvel, -_LIMITS, _LIMITS, out=self._qvel)
        self._elapsed += 1
        if resetting.any():
            self._reset_envs(resetting, self.task.start_noise)
        obs, reward, terminated, info = self._observe()
        # Sub-envs being reset report their reset state: reward 0, no flags, no success
        # (fresh arrays of one entry per sub-env, whatever the task returned).
        going = ~resetting
        reward = np.where(resetting, 0.0, reward)
        terminated = terminated & going
        # As gymnasium's TimeLimit: truncated at the limit even on the step that terminates.
        truncated = (self._elapsed >= self.max_episode_steps) & going
        info["is_success"] = info["is_success"] & going
        if self.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP:
            self._pending = terminated | truncated
        return obs, reward, terminated, truncated, self._masked(info)

    def _observe(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Observations and the task's outcome of every sub-env; raises on a bad state."""
        q, v = self._qpos, self._qvel
        # As the single env: NaN fails the test too; the row test names the bad sub-envs.
        if not (np.abs(q).max() < MAX_ANGLE and np.abs(v).max() < HUGE):
            bad = ~((np.abs(q) < MAX_ANGLE).all(1) & (np.abs(v) < HUGE).all(1))
            raise RuntimeError(
                f"sub-envs {np.flatnonzero(bad).tolist()} reached a non-finite state or angles "
                f"beyond +-{MAX_ANGLE:g} rad; reset them before stepping again"
            )
        obs = np.empty((self.num_envs, 4))
        obs[:, :2] = wrap_angle(q)  # as the single env: angles in [-pi, pi) as they are
        obs[:, 2:] = v
        reward, terminated, info = self._outcome(q[:, 0], q[:, 1], v[:, 0], v[:, 1])
        return obs, reward, terminated, info

    def _masked(self, info: dict[str, Any]) -> dict[str, Any]:
        """``info`` with Gymnasium's ``_name`` mask beside each entry (every sub-env has it)."""
        every = np.ones(self.num_envs, dtype=bool)
        out: dict[str, Any] = {}
        for key, value in info.items():
            out[key] = value
            out[f"_{key}"] = every
        return out

    def close_extras(self, **kwargs: Any) -> None:
        self._template.close()


def _autoreset_mode(autoreset_mode: Any) -> AutoresetMode:
    """``"next_step"``, ``"disabled"`` or an AutoresetMode of those two, as AutoresetMode."""
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
    return mode
