"""Many acrobots stepped together: a ``VectorEnv`` whose sub-envs have
:class:`~acrobot_mj.envs.acrobot.AcrobotEnv`'s semantics, ``gymnasium.make_vec``'s for our ids.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any, cast

import gymnasium as gym
import numpy as np
from gymnasium.error import ResetNeeded
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from acrobot_mj.checks import check_int, check_memory
from acrobot_mj.envs.acrobot import AcrobotEnv, EnvOptions, check_copy, drawn_start
from acrobot_mj.envs.batch import AnalyticPhysics, BatchPhysics
from acrobot_mj.envs.spaces import REPORT_TORQUES, TorqueLimit, cos_sin, reset_noise, write_torques

if sys.version_info >= (3, 11):
    from typing import Unpack
else:
    from typing_extensions import Unpack

PHYSICS_BACKENDS: dict[str, type[BatchPhysics | AnalyticPhysics]] = {
    "mujoco": BatchPhysics,
    "analytic": AnalyticPhysics,
}
#: Sub-env attributes with one value per sub-env (get_attr), and those set_attr sets.
PER_ENV = ("state", "np_random", "np_random_seed")
#: The sub-env attributes set_attr sets.
SETTABLE = ("np_random",)
#: Sub-env attributes the batch shares (get_attr repeats the one value; set_attr refuses them).
SHARED = (
    "frame_skip",
    "integrator",
    "continuous",
    "observation",
    "start_noise",
    "dt",
    "task",
    "model",
    "params",
    "metadata",
    "render_mode",
    "width",
    "height",
    "camera",
    "action_space",
    "observation_space",
)
#: The sub-env methods call runs on every sub-env.
SUB_ENV_METHODS = ("set_state", "render")


class AcrobotVectorEnv(VectorEnv):
    """``num_envs`` acrobots with the single env's arguments, stepped together; sub-env ``i``
    reset with seed ``s + i`` behaves bit for bit as a single env with that seed.

    ``nthread``: None for one thread below :data:`~acrobot_mj.envs.batch.THREADED_FROM`
    sub-envs and all CPUs from there, 0 for all (the numbers do not depend on it). ``backend``:
    ``"mujoco"`` (``mujoco.batch``, the reference) or ``"analytic"`` (the lumped model compiled,
    matching MuJoCo to rounding). ``render()`` gives a tuple of every sub-env's frame, as
    ``SyncVectorEnv``'s (so ``gymnasium.wrappers.vector.RecordVideo`` records them), or with
    ``render_envs=k`` the first ``k`` frames in one image (a grid; 1: sub-env 0's frame).
    ``get_attr``, ``set_attr`` and ``call`` work as ``SyncVectorEnv``'s. ``batch`` is the
    ``mujoco.batch.Batch`` (or None).
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": ["rgb_array"]}

    def __init__(
        self,
        num_envs: int = 1,
        *,
        max_episode_steps: int | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        nthread: int | None = None,
        render_mode: str | None = None,
        render_envs: int | None = None,
        backend: str = "mujoco",
        **env_kwargs: Unpack[EnvOptions],
    ) -> None:
        if not isinstance(backend, str) or backend not in PHYSICS_BACKENDS:
            raise ValueError(f"backend must be one of {list(PHYSICS_BACKENDS)}, got {backend!r}")
        self.backend = backend
        self.num_envs = check_int("num_envs", num_envs, 1)
        # Each sub-env's MuJoCo state and rows (about 8 KB; mujoco.batch said std::bad_alloc).
        check_memory(f"num_envs={self.num_envs}", 8192 * self.num_envs)
        mode = _autoreset_mode(autoreset_mode)
        self.render_envs = (
            None if render_envs is None else check_int("render_envs", render_envs, 1, self.num_envs)
        )
        modes = self.metadata["render_modes"]
        if render_mode is not None and render_mode not in modes:  # no window, no depth video
            raise ValueError(f"render_mode must be None or one of {modes}, got {render_mode!r}")
        # One single env validates the options, builds the model and renders each sub-env.
        self._template = AcrobotEnv(render_mode=render_mode, **env_kwargs)
        self.task = self._template.task
        steps = self.task.max_episode_steps if max_episode_steps is None else max_episode_steps
        self.max_episode_steps = check_int("max_episode_steps", steps, 1)
        self.model = self._template.model
        fps = self._template.metadata["render_fps"]
        self.metadata = {**self.metadata, "autoreset_mode": mode, "render_fps": fps}
        self.render_mode = render_mode
        self._frame_skip = self._template.frame_skip
        self._continuous = self._template.continuous
        self._torques = TorqueLimit(self._template.params.max_torque)
        self._cos_sin = self._template.observation == "cos_sin"
        self._nthread = None if nthread is None else check_int("nthread", nthread, 0)
        self._build_batch()
        start = self.model.key(self.task.start_keyframe)
        self._rest = np.concatenate((start.qpos, start.qvel))  # the task's start, at rest
        self.single_action_space = self._template.action_space
        self.single_observation_space = self._template.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        # Steps so far, and the step each episode began at: cheaper than counting per sub-env.
        self._steps, self._began = 0, np.zeros(self.num_envs, dtype=np.int64)
        self._every, self._none = np.ones(self.num_envs, dtype=bool), np.zeros(self.num_envs, bool)
        self._mask_names: dict[str, str] = {}  # info key -> its mask's key
        self._next_step = mode == AutoresetMode.NEXT_STEP
        self._same_step = mode == AutoresetMode.SAME_STEP
        self._pending = np.zeros(self.num_envs, dtype=bool)  # reset at the next step
        # step refuses to run before every sub-env's first reset, as a single env's does.
        self._never_reset, self._was_reset = np.ones(self.num_envs, dtype=bool), False
        self._rngs, self._rng_seeds = map(
            list, zip(*(seeding.np_random() for _ in range(self.num_envs)), strict=True)
        )
        self._reset_envs(np.ones(self.num_envs, dtype=bool), self.task.start_noise)

    def _build_batch(self) -> None:  # also on unpickling
        #: The backend's physics stepping the sub-envs.
        self.physics = physics = PHYSICS_BACKENDS[self.backend](
            self.model, self.num_envs, self._nthread, self._template.params.max_vel
        )
        self.batch = physics.batch if isinstance(physics, BatchPhysics) else None
        self._qpos, self._qvel, self._ctrl = physics.qpos, physics.qvel, physics.ctrl

    def __getstate__(self) -> dict[str, Any]:
        views = ("physics", "batch", "_qpos", "_qvel", "_ctrl")
        state = {key: value for key, value in self.__dict__.items() if key not in views}
        return {**state, "batch_state": self.physics.snapshot()}

    def __setstate__(self, state: dict[str, Any]) -> None:
        check_copy("AcrobotVectorEnv", state, ("backend", "_same_step", "_cos_sin"))
        state = dict(state)
        rows = state.pop("batch_state")
        state.setdefault("_was_reset", True)  # pickled by 0.4.0, whose step checked no reset
        state.setdefault("_never_reset", np.zeros(state["num_envs"], dtype=bool))
        state.setdefault("_torques", REPORT_TORQUES)  # 0.4.0's: the report's
        self.__dict__.update(state)
        self._build_batch()
        self.physics.restore(rows)

    def _reset_envs(self, mask: np.ndarray, noise: float) -> None:
        ids = np.flatnonzero(mask)
        self._ctrl[ids] = 0.0
        for i in ids:  # the single env's draws
            start = drawn_start(self.task, self._rest, self._rngs[i], noise)
            self._qpos[i], self._qvel[i] = start[:2], start[2:]
        self._began[ids] = self._steps
        self._first = int(self._began.min())  # the oldest episode's start
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
        noise = reset_noise(options, self.task.start_noise, known=("reset_mask", "start_noise"))
        if seed is not None:
            for i, s in zip(np.flatnonzero(mask), self._seeds(seed)[mask], strict=True):
                if s is not None:
                    self._rngs[i], self._rng_seeds[i] = seeding.np_random(s)
        self._reset_envs(mask, noise)
        self._never_reset &= ~mask
        self._was_reset = not self._never_reset.any()
        obs = self._observe()  # raises on a bad state
        _, _, info = self.task.outcomes(*self.physics.columns)
        info["is_success"] = np.zeros(self.num_envs, dtype=bool)  # a reset is no success
        return obs, self._masked(info)

    def _seeds(self, seed: int | Sequence[int | None]) -> np.ndarray:
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds: list[int | None] = [int(seed) + i for i in range(self.num_envs)]
        elif isinstance(seed, (list, tuple, np.ndarray)):
            seeds = [None if s is None else int(s) for s in seed]
        else:
            raise TypeError(f"seed must be an integer or one seed per sub-env, got {seed!r}")
        if len(seeds) != self.num_envs:
            raise ValueError(f"give one seed per sub-env ({self.num_envs}), got {len(seeds)}")
        return np.array(seeds, dtype=object)

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._was_reset:
            never = np.flatnonzero(self._never_reset).tolist()
            raise ResetNeeded(
                f"Cannot call env.step() before calling env.reset() (sub-envs {never} never were)"
            )
        physics = self.physics
        # raises, writing nothing
        write_torques(actions, self._continuous, self._ctrl, self._torques)
        physics.step(self._frame_skip)
        self._steps += 1
        # count_nonzero: a fraction of any()'s cost on small batches
        resetting = self._pending.copy() if np.count_nonzero(self._pending) else None
        if resetting is not None:
            self._reset_envs(resetting, self.task.start_noise)
        obs = self._observe()
        reward, terminated, info = self.task.outcomes(*physics.columns)
        # As TimeLimit: truncated at the limit even when terminating; none before the oldest.
        limit = self._steps - self.max_episode_steps
        truncated = self._began <= limit if limit >= self._first else self._none.copy()
        if resetting is not None:  # these report their reset state
            going = ~resetting
            reward[resetting] = 0.0
            terminated &= going
            truncated &= going
            info["is_success"] &= going
        if self._next_step:
            self._pending = terminated | truncated
        elif self._same_step:
            ended = terminated | truncated
            if np.count_nonzero(ended):
                return obs, reward, terminated, truncated, self._reset_ended(ended, obs, info)
        return obs, reward, terminated, truncated, self._masked(info)

    def _reset_ended(self, ended: np.ndarray, obs: np.ndarray, info: dict) -> dict[str, Any]:
        """SAME_STEP: reset the sub-envs that ended in this step, in it; ``obs`` becomes their
        reset observations, and the info theirs, with the ended step's observation and info
        under ``final_obs`` (an object array: None elsewhere) and ``final_info`` (zeros elsewhere),
        as ``SyncVectorEnv``'s."""
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(ended):
            final_obs[i] = obs[i].copy()
        final_info: dict[str, Any] = {}
        for key, value in info.items():
            final_info[key] = np.where(ended, value, np.zeros_like(value))
            final_info[f"_{key}"] = ended.copy()
        self._reset_envs(ended, self.task.start_noise)
        obs[ended] = self._observe()[ended]
        _, _, fresh = self.task.outcomes(*self.physics.columns)
        fresh["is_success"] = np.zeros(self.num_envs, dtype=bool)  # a reset is no success
        info = self._masked(
            {key: np.where(ended, fresh[key], value) for key, value in info.items()}
        )
        return {
            **info,
            "final_obs": final_obs,
            "_final_obs": ended.copy(),
            "final_info": final_info,
            "_final_info": ended.copy(),
        }

    def _observe(self) -> np.ndarray:
        obs = self.physics.observe()
        return cos_sin(obs) if self._cos_sin else obs

    @property
    def nthread(self) -> int:
        """Threads the batch steps on (at most one per sub-env)."""
        return self.physics.nthread

    @property
    def _elapsed(self) -> np.ndarray:
        return self._steps - self._began

    def _masked(self, info: dict[str, Any]) -> dict[str, Any]:
        """``info`` with Gymnasium's (all True) ``_name`` mask beside each entry."""
        every, names = self._every.copy(), self._mask_names
        out: dict[str, Any] = {}
        for key, value in info.items():
            out[key] = value
            name = names.get(key)
            if name is None:
                name = names[key] = f"_{key}"
            out[name] = every
        return out

    # One generator and seed per sub-env, as SyncVectorEnv's get_attr gives them: not
    # VectorEnv's one (read-only here: set_attr("np_random", ...) sets them).
    @property  # type: ignore[misc]
    def np_random(self) -> tuple[np.random.Generator, ...]:  # type: ignore[override]
        """Each sub-env's generator."""
        return tuple(self._rngs)

    @property
    def np_random_seed(self) -> tuple[int, ...]:  # type: ignore[override]
        """Each sub-env's seed, -1 where its generator was set directly."""
        return tuple(self._rng_seeds)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """One value of attribute ``name`` per sub-env."""
        if name == "state":
            return tuple(np.concatenate([self._qpos, self._qvel], axis=1))  # copies
        if name in PER_ENV:
            return getattr(self, name)
        if name in SHARED:
            return (getattr(self._template, name),) * self.num_envs
        raise AttributeError(
            f"AcrobotVectorEnv's sub-envs have no attribute {name!r}; per sub-env: "
            f"{list(PER_ENV)}, shared by all: {list(SHARED)}, "
            f"methods (call): {list(SUB_ENV_METHODS)}"
        )

    def set_attr(self, name: str, values: Any) -> None:
        """Set :data:`SETTABLE` ``name`` on every sub-env: one value per sub-env, or one for
        all."""
        if name in SHARED:
            raise AttributeError(
                f"{name!r} is shared by all {self.num_envs} sub-envs of the batch and fixed when "
                f"it is built: it cannot be set per sub-env; make a new env with it instead"
            )
        if name not in SETTABLE:
            why = "is read-only" if name in PER_ENV else "is no attribute of the sub-envs"
            hint = "; call('set_state', q, dq) sets the state" if name == "state" else ""
            raise AttributeError(f"{name!r} {why}; settable: {list(SETTABLE)}{hint}")
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(
                "Values must be a list or tuple with length equal to the number of environments. "
                f"Got `{len(values)}` values for {self.num_envs} environments."
            )
        bad = [v for v in values if not isinstance(v, np.random.Generator)]
        if bad:
            raise TypeError(f"np_random must be numpy Generators, got {bad[0]!r}")
        self._rngs, self._rng_seeds = list(values), [-1] * self.num_envs

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Run :data:`SUB_ENV_METHODS` ``name`` on every sub-env, or return attribute ``name``."""
        if name == "set_state":
            self._template.set_state(*args, **kwargs)  # validates
            self._qpos[...] = self._template.data.qpos
            self._qvel[...] = self._template.data.qvel
            return (None,) * self.num_envs
        if name == "render":
            if self.render_mode is None:
                return (self.render(),) * self.num_envs  # warns, as each single env would
            return tuple(self._frame(i) for i in range(self.num_envs))
        return self.get_attr(name)

    # render_envs=k gives one image (VectorEnv's render gives a tuple of frames).
    def render(self) -> np.ndarray | tuple[np.ndarray, ...] | None:  # type: ignore[override]
        """Every frame (``render_envs`` None), or the first ``render_envs`` in a grid."""
        if self.render_mode is None:
            gym.logger.warn("render() called with render_mode=None: nothing is rendered")
            return None
        if self.render_envs is None:
            return self.call("render")
        frames = [self._frame(i) for i in range(self.render_envs)]
        if len(frames) == 1:
            return frames[0]
        cols = math.ceil(math.sqrt(len(frames)))
        frames += [np.zeros_like(frames[0])] * (-len(frames) % cols)  # black where none
        return np.vstack([np.hstack(frames[r : r + cols]) for r in range(0, len(frames), cols)])

    def _frame(self, i: int) -> np.ndarray:
        self.physics.get_data(i, self._template.data)
        return cast(np.ndarray, self._template.render())  # rgb_array: never None

    def close_extras(self, **kwargs: Any) -> None:
        self._template.close()


def _autoreset_mode(mode: Any) -> AutoresetMode:
    names: dict[Any, object] = {
        "next_step": AutoresetMode.NEXT_STEP,
        "same_step": AutoresetMode.SAME_STEP,
        "disabled": AutoresetMode.DISABLED,
    }
    found = names.get(mode, mode) if isinstance(mode, (str, AutoresetMode)) else None
    if not isinstance(found, AutoresetMode) or found not in names.values():
        raise ValueError(f"autoreset_mode must be one of {list(names)}, got {mode!r}")
    return found
