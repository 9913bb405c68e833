"""Tabular SARSA as the report's pseudocode (Sutton and Barto, section 6.4): one compiled decision
(:func:`sarsa_step`) serves one learner (:class:`Sarsa`) and K in lockstep (:class:`SarsaGroup`,
learner ``k`` exactly :class:`Sarsa` with seed ``seeds[k]``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.agents.base import BLOCK, RandomStream, checked_values, policy
from acrobot_mj.agents.features import StateGrid, grid_cell
from acrobot_mj.checks import check_memory
from acrobot_mj.compiled import compiled, jitable, without_dispatch
from acrobot_mj.settings import Settings, setting


def step_size(default: float) -> float:
    """The ``alpha`` setting of a learner (zero learns nothing)."""
    help = "step size; a fraction is allowed, e.g. 0.2/48"
    return setting(default, help, low=0.0, low_open=True, high=1.0)


def discount(default: float) -> float:
    """The ``gamma`` setting of a learner."""
    return setting(default, "discount factor", low=0.0, high=1.0)


def exploration(default: float) -> float:
    """The ``epsilon`` setting of a learner."""
    return setting(default, "exploration: the probability of a random action", low=0.0, high=1.0)


@dataclass(frozen=True)
class SarsaConfig(Settings):
    """Tabular SARSA's hyperparameters (the report's)."""

    alpha: float = step_size(0.5)
    gamma: float = discount(1.0)
    epsilon: float = exploration(0.001)


@jitable
def sarsa_step(q, s, a, reward, s2, terminated, config, block, position) -> tuple:
    """``Q(s, a)`` toward ``r + gamma Q(s', a')``: ``(a' (-1 at the goal), next position)``."""
    alpha, gamma, epsilon = config
    a2, target = -1, reward  # the goal is terminal: no bootstrap
    if not terminated:
        a2, position = policy(q[s2], epsilon, block, position)
        target = reward + gamma * q[s2, a2]
    q[s, a] += alpha * (target - q[s, a])
    return a2, position


@jitable
def sarsa_learn(q, s, a, reward, obs, terminated, grid, config, block, position) -> tuple:
    """:func:`sarsa_step` with the next state's cell taken from ``obs`` first (``grid``: the
    grid's constants): ``(s', a', next position)``, ``s'`` -1 at the goal."""
    s2 = -1 if terminated else grid_cell(obs[0], obs[1], obs[2], obs[3], grid)
    a2, position = sarsa_step(q, s, a, reward, s2, terminated, config, block, position)
    return s2, a2, position


@jitable
def group_step(q, ids, s, a, rewards, s2, terminated, config, blocks, positions) -> None:
    """:func:`sarsa_step` of learners ``ids``, the next actions into ``a``."""
    for j in range(ids.shape[0]):
        i = ids[j]
        a[i], positions[i] = sarsa_step(
            q[i], s[i], a[i], rewards[j], s2[j], terminated[j], config, blocks[i], positions[i]
        )
        s[i] = s2[j]


@jitable
def group_begin(q, ids, s, a, epsilon, blocks, positions) -> None:
    """The first actions of learners ``ids`` into ``a``."""
    for j in range(ids.shape[0]):
        i = ids[j]
        a[i], positions[i] = policy(q[i, s[i]], epsilon, blocks[i], positions[i])


class Sarsa:
    """One-step tabular SARSA over a grid (``index(obs)`` and ``num_features``; a
    :class:`~acrobot_mj.agents.features.StateGrid`'s cells are found in the compiled update)."""

    def __init__(
        self,
        grid: StateGrid,
        n_actions: int = 3,
        alpha: float = 0.5,
        gamma: float = 1.0,
        epsilon: float = 0.001,
        seed: int | np.random.SeedSequence | None = None,
    ) -> None:
        self.grid, self.n_actions = grid, n_actions
        self.config = SarsaConfig(alpha, gamma, epsilon)
        self.stream = RandomStream(seed)
        values = float(grid.num_features) * n_actions  # the table and a checkpoint's copy
        check_memory(f"a Q table of {values:,.0f} values", 16.0 * values)
        self._q = np.zeros((grid.num_features, n_actions))
        self._s = self._a = -1
        self._learn = self._first_learn  # then without numba's dispatch
        self._grid = isinstance(grid, StateGrid)
        self._rates = (float(alpha), float(gamma), float(epsilon))

    @property
    def q(self) -> np.ndarray:
        """The action values ``(num_states, n_actions)``, a copy."""
        return self._q.copy()

    def begin_episode(self, obs: Any) -> int:
        self._s = self.grid.index(obs)
        self.stream.reserve(2)
        self._a, self.stream.position = compiled(policy)(
            self._q[self._s], self._rates[2], self.stream.block, self.stream.position
        )
        return self._a

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        """Update Q(s, a) from ``(r, s')``; a' (None once the episode is over)."""
        if self._s < 0:
            raise RuntimeError("learn() needs an episode in progress: call begin_episode()")
        stream = self.stream
        if stream.block.size - stream.position < 2:
            stream.reserve(2)
        if self._grid:  # the next cell found in the same compiled call
            x = np.ascontiguousarray(obs, dtype=np.float64)
            if x.shape != (4,):
                raise ValueError(f"observations must be (q1, q2, dq1, dq2), got shape {x.shape}")
            s2, a2, stream.position = self._learn(
                self._q,
                self._s,
                self._a,
                float(reward),
                x,
                bool(terminated),
                self.grid.constants,
                self._rates,
                stream.block,
                stream.position,
            )
        else:
            s2 = -1 if terminated else self.grid.index(obs)
            a2, stream.position = compiled(sarsa_step)(
                self._q,
                self._s,
                self._a,
                float(reward),
                s2,
                bool(terminated),
                self._rates,
                stream.block,
                stream.position,
            )
        if terminated or truncated:
            self._s = self._a = -1
            return None
        self._s, self._a = s2, a2
        return a2

    def _first_learn(self, *args: Any) -> tuple:
        kernel = compiled(sarsa_learn)
        result = kernel(*args)
        self._learn = without_dispatch(kernel, args)  # every call's types are these
        return result

    def greedy_action(self, obs: Any, stream: RandomStream) -> int:
        """argmax_a Q(s, a), ties broken by ``stream``."""
        return stream.argmax(self._q[self.grid.index(obs)])

    def state_dict(self) -> dict[str, np.ndarray]:
        return {"q": self.q, **self.stream.state_dict(prefix="stream.")}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        q = checked_values(state, "q", self._q.shape)
        self.stream.load_state_dict(state, prefix="stream.")
        self._q = q


class SarsaGroup:
    """``len(seeds)`` tabular SARSA learners over one grid stepped together, learner ``k``
    :class:`Sarsa` with seed ``seeds[k]``; methods take ``ids`` (sorted, no repeats) and rows."""

    def __init__(self, grid: StateGrid, config: SarsaConfig, seeds: Sequence[int], n_actions=3):
        self.grid, self.config, k = grid, config, len(seeds)
        values = float(k) * grid.num_features * n_actions  # the tables and a checkpoint's copy
        check_memory(f"{k} Q tables of {values / k:,.0f} values", 16.0 * values)
        self.q = np.zeros((k, grid.num_features, n_actions))
        self.streams = [RandomStream(int(seed)) for seed in seeds]
        self.blocks = np.zeros((k, BLOCK + 2))
        self.lengths, self.positions = np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64)
        self.s, self.a = np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64)
        self._rates = (config.alpha, config.gamma, config.epsilon)

    def _reserve(self, ids: np.ndarray) -> None:
        for i in ids[self.lengths[ids] - self.positions[ids] < 2].tolist():
            stream = self._stream(i)
            stream.reserve(2)
            self._store(i, stream)

    def _stream(self, i: int) -> RandomStream:
        stream = self.streams[i]
        stream.block = self.blocks[i, : self.lengths[i]].copy()
        stream.position = int(self.positions[i])
        return stream

    def _store(self, i: int, stream: RandomStream) -> None:
        if len(stream.block) > self.blocks.shape[1]:
            raise ValueError("random state has a block longer than the stream's")
        self.blocks[i, : len(stream.block)] = stream.block
        self.lengths[i], self.positions[i] = len(stream.block), stream.position

    def begin_episodes(self, ids: np.ndarray, obs: np.ndarray) -> np.ndarray:
        self.s[ids] = self.grid.indices(obs)
        self._reserve(ids)
        compiled(group_begin)(
            self.q, ids, self.s, self.a, self.config.epsilon, self.blocks, self.positions
        )
        return self.a[ids]

    def learn(
        self,
        ids: np.ndarray,
        rewards: np.ndarray,
        obs: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
    ) -> np.ndarray:
        """One update per learner in ``ids``; their next actions (-1 where the episode ended)."""
        s2 = self.grid.indices(obs)
        s2[terminated] = -1
        self._reserve(ids)
        compiled(group_step)(
            self.q,
            ids,
            self.s,
            self.a,
            np.asarray(rewards, dtype=np.float64),
            s2,
            np.asarray(terminated, dtype=bool),
            self._rates,
            self.blocks,
            self.positions,
        )
        return np.where(terminated | truncated, -1, self.a[ids])

    def state_dict(self, k: int) -> dict[str, np.ndarray]:
        return {"q": self.q[k].copy(), **self._stream(k).state_dict(prefix="stream.")}

    def load_state(self, k: int, state: dict[str, np.ndarray]) -> None:
        q = checked_values(state, "q", self.q.shape[1:])
        stream = self.streams[k]
        stream.load_state_dict(state, prefix="stream.")
        self._store(k, stream)
        self.q[k] = q
