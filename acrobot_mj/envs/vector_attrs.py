"""The sub-env attributes of :class:`~acrobot_mj.envs.vector.AcrobotVectorEnv`, as
``SyncVectorEnv``'s: ``get_attr``, ``set_attr``, ``call`` and the per-sub-env generators.

:class:`SubEnvAttributes` is a mixin: its host holds ``num_envs``, the single env
``_template`` (shared attributes, ``set_state``'s checks), the generators ``_rngs`` and their
seeds ``_rng_seeds``, the state views ``_qpos`` and ``_qvel``, and ``render`` and ``_frame(i)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Sub-env attributes with one value per sub-env (get_attr), and those of them set_attr sets.
PER_ENV = ("state", "np_random", "np_random_seed")
SETTABLE = ("np_random",)
#: Sub-env attributes every sub-env of a batch shares (get_attr repeats the one value); fixed
#: when the env is built, so set_attr refuses them.
SHARED = (
    "frame_skip",
    "integrator",
    "continuous",
    "start_noise",
    "dt",
    "task",
    "model",
    "metadata",
    "render_mode",
    "width",
    "height",
    "camera",
    "action_space",
    "observation_space",
)
#: Sub-env methods call() runs (with the same arguments for every sub-env).
METHODS = ("set_state", "render")


class SubEnvAttributes:
    """``get_attr``, ``set_attr`` and ``call`` over the host's sub-envs (see the module)."""

    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:
        """Each sub-env's generator (as ``SyncVectorEnv.np_random``)."""
        return tuple(self._rngs)

    @property
    def np_random_seed(self) -> tuple[int, ...]:
        """Each sub-env's seed, -1 where its generator was set directly."""
        return tuple(self._rng_seeds)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """One value of attribute ``name`` per sub-env (see AcrobotVectorEnv's docstring)."""
        if name == "state":
            return tuple(np.concatenate([self._qpos, self._qvel], axis=1))  # copies
        if name in PER_ENV:
            return getattr(self, name)
        if name in SHARED:
            return (getattr(self._template, name),) * self.num_envs
        raise AttributeError(
            f"AcrobotVectorEnv's sub-envs have no attribute {name!r}; per sub-env: "
            f"{list(PER_ENV)}, shared by all: {list(SHARED)}, methods (call): {list(METHODS)}"
        )

    def set_attr(self, name: str, values: Any) -> None:
        """Set ``name`` on every sub-env: a list or tuple of one value per sub-env, or one value
        for all (as ``SyncVectorEnv.set_attr``). Only :data:`SETTABLE` names can be set."""
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
        """Run method ``name`` of every sub-env with the same arguments (``set_state``,
        ``render``), or return attribute ``name`` (as ``SyncVectorEnv.call``)."""
        if name == "set_state":
            self._template.set_state(*args, **kwargs)  # the single env's checks
            self._qpos[...] = self._template.data.qpos
            self._qvel[...] = self._template.data.qvel
            return (None,) * self.num_envs
        if name == "render":
            if self.render_mode is None:
                return (self.render(),) * self.num_envs  # warns, as each single env would
            return tuple(self._frame(i) for i in range(self.num_envs))
        return self.get_attr(name)
