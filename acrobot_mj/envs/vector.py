"""Many acrobots stepped together in MuJoCo's C batch API (``mujoco.batch``).

:class:`AcrobotVectorEnv` is a ``gymnasium.vector.VectorEnv`` whose sub-environments have
exactly :class:`~acrobot_mj.envs.env.AcrobotEnv`'s semantics (the task's reward, termination
and info through the same :meth:`~acrobot_mj.envs.tasks.Task.outcome`, vectorised; velocity
clipping after every physics step, angle wrapping, ``frame_skip``, integrator, start noise,
truncation), with the physics of all of them advanced by one ``Batch.step`` call per physics
step (:class:`~acrobot_mj.envs.batch_physics.BatchPhysics`: one thread for small batches, all
CPUs for large ones). ``gymnasium.make_vec("acrobot_mj/Acrobot-v0", num_envs=N)`` returns it.
With ``backend="analytic"`` the same task is stepped by the lumped Lagrangian model compiled
with numba instead (:class:`~acrobot_mj.envs.analytic_physics.AnalyticPhysics`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from acrobot_mj.checks import check_int
from acrobot_mj.envs.analytic_physics import AnalyticPhysics
from acrobot_mj.envs.batch_physics import BatchPhysics
from acrobot_mj.envs.env import AcrobotEnv
from acrobot_mj.envs.resets import reset_noise
from acrobot_mj.envs.spaces import TORQUE_ARRAY, action_torques
from acrobot_mj.envs.vector_attrs import METHODS, PER_ENV, SETTABLE, SHARED, SubEnvAttributes

_FLOAT, _BOOL, _INT = np.dtype(np.float64), np.dtype(bool), np.dtype(np.int64)
#: The physics a vector env can step on: MuJoCo's batch (the default and the reference), or the
#: lumped analytic model compiled with numba.
BACKENDS = {"mujoco": BatchPhysics, "analytic": AnalyticPhysics}
__all__ = ["METHODS", "PER_ENV", "SETTABLE", "SHARED", "AcrobotVectorEnv"]


class AcrobotVectorEnv(SubEnvAttributes, VectorEnv):
    """``num_envs`` acrobots with the single env's task, stepped in one ``mujoco.batch.Batch``.

    Arguments: ``num_envs``; ``max_episode_steps`` (default: the task's, 1000 for the height
    goal: the truncation the single env gets from ``gymnasium.make``); ``autoreset_mode``
    (``"next_step"``, Gymnasium's default, or ``"disabled"``); ``nthread`` (threads of the batch:
    by default one below :data:`~acrobot_mj.envs.batch_physics.THREADED_FROM` sub-envs and all
    CPUs from there; 0 for all CPUs, or a number, always honoured; the numbers are the same
    whichever); ``backend`` (below); ``render_envs`` (below); and the single env's ``frame_skip``,
    ``integrator``, ``task``, ``continuous``, ``model_path``, ``render_mode``, ``width``,
    ``height``, ``camera`` and task options (validated by the single env's rules).

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

    Sub-env attributes (``get_attr``, ``set_attr``, ``call``, as ``SyncVectorEnv``'s, tuples of
    one value per sub-env): :data:`PER_ENV` ones differ per sub-env (``state``, ``np_random``,
    ``np_random_seed``; only ``np_random`` can be set, one Generator per sub-env or one for
    all); :data:`SHARED` ones (``frame_skip``, ``task``, ``model``, the single spaces, ...) are
    one value for the whole batch, repeated, and ``set_attr`` refuses them (build a new env).
    ``call`` runs :data:`METHODS` (``set_state(q, dq)`` on every sub-env, ``render`` for every
    sub-env's frame) or returns an attribute. Unknown names raise ``AttributeError``.

    Rendering (``render_mode="rgb_array"``, the single env's ``width``, ``height``, ``camera``):
    ``render()`` returns one frame, sub-env 0's, identical to a single env's in the same state;
    with ``render_envs=k`` the first ``k`` sub-envs' frames tiled row by row in a grid of
    ``ceil(sqrt(k))`` columns (black where the grid has no sub-env); with ``render_envs=None``
    a tuple of every sub-env's frame, as ``SyncVectorEnv.render`` (Gymnasium's vector
    ``RecordVideo`` and ``HumanRendering`` wrappers need that form).

    Pickling (and ``copy.deepcopy``) rebuilds the batch and restores every sub-env's full
    MuJoCo state (the analytic backend: its states and controls), elapsed steps, pending
    autoresets and generators: the copy steps identically.

    Backends (``backend``): ``"mujoco"`` (the default and the reference) steps ``mujoco.batch``;
    ``"analytic"`` steps the lumped manipulator model (parameters derived from the loaded model)
    in a numba kernel (the ``fast`` extra), on one thread below
    :data:`~acrobot_mj.envs.analytic_physics.THREADED_FROM` sub-envs and numba's threads from
    there (``nthread`` as above). Everything else (task, resets, seeding, info, pickling,
    rendering) is the same code. It refuses what the lumped model cannot represent (``rk4``,
    damping, armature, a model whose dynamics differ); its trajectories match MuJoCo's to
    rounding, which the acrobot's chaos amplifies over long episodes (``tests/test_analytic.py``).
    ``batch`` is the ``mujoco.batch.Batch`` with the MuJoCo backend, None with the analytic one.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": ["rgb_array"]}

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        nthread: int | None = None,
        render_mode: str | None = None,
        render_envs: int | None = 1,
        backend: str = "mujoco",
        **env_kwargs: Any,
    ) -> None:
        if not isinstance(backend, str) or backend not in BACKENDS:
            raise ValueError(f"backend must be one of {list(BACKENDS)}, got {backend!r}")
        self.backend = backend
        self.num_envs = check_int("num_envs", num_envs, 1)
        mode = _autoreset_mode(autoreset_mode)
        self.render_envs = (
            None if render_envs is None else check_int("render_envs", render_envs, 1, self.num_envs)
        )
        # One single env validates the options and builds the model (integrator, no autoreset);
        # it also renders, one sub-env's state at a time.
        self._template = AcrobotEnv(render_mode=render_mode, **env_kwargs)
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
        self.render_mode = render_mode
        self._frame_skip = self._template.frame_skip
        self._continuous = self._template.continuous
        self._nthread = None if nthread is None else check_int("nthread", nthread, 0)
        self._build_batch()
        start = self.model.key(self.task.start_keyframe)
        self._start_qpos, self._start_qvel = start.qpos.copy(), start.qvel.copy()

        self.single_action_space = self._template.action_space
        self.single_observation_space = self._template.observation_space
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        # Steps of the env so far, and the step each sub-env's episode began at (cheaper than
        # counting every sub-env's steps at every step): see _elapsed.
        self._steps, self._began = 0, np.zeros(self.num_envs, dtype=np.int64)
        self._every, self._none = np.ones(self.num_envs, dtype=bool), np.zeros(self.num_envs, bool)
        self._mask_names: dict[str, str] = {}  # info key -> its mask's key
        self._next_step = mode == AutoresetMode.NEXT_STEP
        self._pending = np.zeros(self.num_envs, dtype=bool)  # reset at the next step
        self._rngs, self._rng_seeds = map(
            list, zip(*(seeding.np_random() for _ in range(self.num_envs)), strict=True)
        )
        self._reset_envs(np.ones(self.num_envs, dtype=bool), self.task.start_noise)

    def _build_batch(self) -> None:
        """The batch of ``num_envs`` simulations and the views into it (redone by unpickling)."""
        physics = BACKENDS[self.backend](self.model, self.num_envs, self._nthread)
        self._physics = physics
        self.batch = physics.batch if isinstance(physics, BatchPhysics) else None
        self._qpos, self._qvel = physics.qpos, physics.qvel
        self._ctrl = physics.ctrl
        # The task's compiled rule where the physics has compiled kernels: the same numbers,
        # in new arrays of its own (``_fresh``: handed on without copies).
        self._outcome, self._fresh = self.task.rows_outcome(physics.kernels is not None)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for key in ("_physics", "batch", "_qpos", "_qvel", "_ctrl", "_outcome", "_fresh"):
            state.pop(key)
        # Every simulation's whole state row (MuJoCo's: time, qpos, qvel, ctrl, warm start, ...).
        state["batch_state"] = self._physics.snapshot()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        state = dict(state)
        rows = state.pop("batch_state")
        state.setdefault("backend", "mujoco")  # pickled before there were backends
        self.__dict__.update(state)
        self._build_batch()
        self._physics.restore(rows)

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
        noise = reset_noise(options, self.task.start_noise, also_known=("reset_mask",))
        if seed is not None:
            for i, s in zip(np.flatnonzero(mask), self._seeds(seed)[mask], strict=True):
                if s is not None:
                    self._rngs[i], self._rng_seeds[i] = seeding.np_random(s)
        self._reset_envs(mask, noise)
        obs = self._physics.observe()  # raises on a bad state
        _, _, info = self._outcome(*self._physics.columns)
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
        # The hot path (profiled at N = 1 to 4096): one call per part, numpy's cheapest calls
        # or the physics' compiled passes.
        physics = self._physics
        self._act(actions, physics.kernels)
        physics.step(self._frame_skip)  # with the task's velocity limits after each
        self._steps += 1
        # count_nonzero: a fraction of any()'s cost on small batches
        resetting = self._pending.copy() if np.count_nonzero(self._pending) else None
        if resetting is not None:
            self._reset_envs(resetting, self.task.start_noise)
        obs = physics.observe()
        reward, terminated, info = self._outcome(*physics.columns)
        reward, terminated, truncated = self._flags(reward, terminated, info, resetting)
        if self._next_step:
            self._pending = terminated | truncated
        return obs, reward, terminated, truncated, self._masked(info)

    def _act(self, actions: Any, kernels: Any) -> None:
        """Write the actions' torques into the controls; anything outside the action space
        raises (:func:`~acrobot_mj.envs.spaces.action_torques`), writing nothing. Integer
        actions of the usual dtype and shape take one compiled pass where ``kernels`` are."""
        if (
            kernels is not None
            and actions.__class__ is np.ndarray
            and actions.dtype == _INT
            and actions.shape == self.action_space.shape
            and not self._continuous
            and kernels.discrete_torques(actions, TORQUE_ARRAY, self._ctrl) < 0
        ):
            return  # written
        self._ctrl[:, 0] = action_torques(actions, self._continuous, self.num_envs)

    def _flags(
        self, reward: Any, terminated: Any, info: dict[str, Any], resetting: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Reward, terminated and truncated (and ``info["is_success"]``) as fresh arrays of one
        entry per sub-env, whatever the task returned; sub-envs being reset (``resetting``)
        report their reset state: reward 0, no flags, no success."""
        # As gymnasium's TimeLimit: truncated at the limit even on the step that terminates;
        # none can be before the oldest episode reaches it.
        limit = self._steps - self.max_episode_steps
        truncated = self._began <= limit if limit >= self._first else self._none.copy()
        if resetting is None and self._fresh:  # the task's compiled rule: new arrays already
            return reward, terminated, truncated
        success, rows = info["is_success"], (self.num_envs,)
        if terminated is False:  # a task that never terminates (the balance task)
            terminated = self._none
        if (
            resetting is None
            and reward.__class__ is terminated.__class__ is success.__class__ is np.ndarray
            and reward.shape == terminated.shape == success.shape == rows
            and reward.dtype == _FLOAT
            and terminated.dtype == success.dtype == _BOOL
        ):  # the usual case: copies are the same numbers
            info["is_success"] = success.copy()
            return reward.copy(), terminated.copy(), truncated
        going = self._every if resetting is None else ~resetting
        reward = np.where(going, reward, 0.0)
        info["is_success"] = success & going
        return reward, terminated & going, truncated & going

    @property
    def physics(self) -> BatchPhysics | AnalyticPhysics:
        """The physics stepping the sub-envs (the backend's), for measurements and tests."""
        return self._physics

    @property
    def nthread(self) -> int:
        """Threads the batch steps on (at most one per sub-env)."""
        return self._physics.nthread

    @property
    def _elapsed(self) -> np.ndarray:
        """Steps of each sub-env's episode so far."""
        return self._steps - self._began

    def _masked(self, info: dict[str, Any]) -> dict[str, Any]:
        """``info`` with Gymnasium's ``_name`` mask beside each entry (every sub-env has it)."""
        every, names = self._every.copy(), self._mask_names
        out: dict[str, Any] = {}
        for key, value in info.items():
            out[key] = value
            name = names.get(key)
            if name is None:
                name = names[key] = f"_{key}"
            out[name] = every
        return out

    # -- rendering -------------------------------------------------------------------------

    def render(self) -> np.ndarray | tuple[np.ndarray, ...] | None:
        """Sub-env 0's frame, the first ``render_envs`` sub-envs' frames in a grid, or (with
        ``render_envs=None``) every sub-env's frame."""
        if self.render_mode is None:
            gym.logger.warn("render() called with render_mode=None: nothing is rendered")
            return None
        if self.render_envs is None:
            return self.call("render")
        frames = [self._frame(i) for i in range(self.render_envs)]
        if len(frames) == 1:
            return frames[0]
        h, w, c = frames[0].shape
        cols = math.ceil(math.sqrt(len(frames)))
        rows = math.ceil(len(frames) / cols)
        grid = np.zeros((rows * h, cols * w, c), dtype=frames[0].dtype)
        for k, frame in enumerate(frames):
            r, col = divmod(k, cols)
            grid[r * h : (r + 1) * h, col * w : (col + 1) * w] = frame
        return grid

    def _frame(self, i: int) -> np.ndarray:
        """Sub-env ``i``'s frame, rendered by the single env put in its state."""
        self._physics.get_data(i, self._template.data)
        return self._template.render()

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
