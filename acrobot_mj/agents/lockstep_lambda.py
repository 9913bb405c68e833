"""K compiled Sarsa(lambda) learners in lockstep: one weight row each, one kernel call a step.

Learner ``k`` is exactly :class:`~acrobot_mj.agents.sarsa_lambda_jit.CompiledSarsaLambda` (and
so the numpy :class:`~acrobot_mj.agents.sarsa_lambda.SarsaLambda`) with seed ``seeds[k]``: its
own :class:`~acrobot_mj.agents.random_stream.RandomStream`, the same kernels on its rows of the
group's arrays, and the same order of work, so on the same observations it takes the same
actions and learns the same weights bit for bit. The usual decision (epsilon 0, one best
action) of every learner is one kernel call (:func:`.kernels.lockstep_greedy`); ties,
exploration and the goal's terminal update are finished in Python, learner by learner, as the
single agent does.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from acrobot_mj.agents import kernels
from acrobot_mj.agents.features import TileCoder
from acrobot_mj.agents.protocol import DivergenceError
from acrobot_mj.agents.random_stream import RandomStream, checked_values

#: The kernels' undo log, not kept: a group's checkpoints copy each learner's weights.
_NO_UNDO = kernels.undo_log(0)


class LockstepSarsaLambda:
    """``len(seeds)`` Sarsa(lambda) learners of config ``c`` over one :class:`TileCoder`.

    Memory per learner: its weights (8 bytes each), one trace position per weight (4 bytes)
    and room for its live traces (16 bytes each, grown as needed). Methods take ``ids``, the
    learners concerned (a sorted int array without repeats), and their rows of observations,
    rewards and flags.
    """

    def __init__(self, features: TileCoder, c: Any, seeds: Sequence[int], n_actions: int = 3):
        if not isinstance(features, TileCoder) or features.num_active > kernels.PAIRWISE_BLOCK:
            raise ValueError("lockstep Sarsa(lambda) needs tile codes of at most 128 tilings")
        # c: a training config (validated there), read as SarsaLambda's arguments.
        k = len(seeds)
        self.n_actions, self.num_features = n_actions, features.num_features
        self.alpha, self.gamma, self.epsilon = c.alpha, c.gamma, c.epsilon
        self.replacing, self.cutoff = c.traces == "replacing", c.trace_cutoff
        self.factor = c.gamma * c.lam
        self.streams = [RandomStream(int(seed)) for seed in seeds]
        n_w, n_active = n_actions * features.num_features, features.num_active
        self.w = np.zeros((k, n_w))
        self.position = np.full((k, n_w), -1, dtype=np.int32)
        room = min(n_w, 64 * n_active)  # as the single learner: grown as needed
        self.pairs, self.values = np.zeros((k, room), dtype=np.int64), np.zeros((k, room))
        self.count = np.zeros(k, dtype=np.int64)
        self.active = np.zeros((k, n_active), dtype=np.int64)
        self.next = np.zeros((k, n_active), dtype=np.int64)
        self.a = np.full(k, -1, dtype=np.int64)
        self.tiles = features.tables()
        self.sizes = (self.num_features, self.n_actions, self.replacing)
        self.rates = (self.alpha, self.gamma, self.factor, self.cutoff)
        self._gathered, self._q = np.zeros((k, n_active)), np.zeros((k, n_actions))

    # -- the episode protocol, K at a time -------------------------------------------------

    def begin_episodes(self, ids: np.ndarray, obs: np.ndarray) -> np.ndarray:
        for j, i in enumerate(ids.tolist()):
            kernels.clear(self.pairs[i], self.position[i], self.count[i])
            self.count[i] = 0
            self.a[i] = self._policy(i, self._values_at(i, obs[j], self.active[i]))
        return self.a[ids]

    def learn(
        self,
        ids: np.ndarray,
        rewards: np.ndarray,
        obs: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
    ) -> np.ndarray:
        """One Sarsa(lambda) step of each learner in ``ids``; their next actions (-1 for those
        whose episode ended)."""
        if (self.a[ids] < 0).any():
            raise RuntimeError("learn() needs an episode in progress: call begin_episodes()")
        if self.count[ids].max() + self.active.shape[1] > self.pairs.shape[1]:
            self._grow()
        rewards = np.asarray(rewards, dtype=np.float64)
        obs = np.ascontiguousarray(obs, dtype=np.float64)
        out = np.full(ids.size, -1, dtype=np.int64)
        compiled = ~terminated if self.epsilon == 0.0 else np.zeros(ids.size, dtype=bool)
        if compiled.any():
            rows = np.flatnonzero(compiled)
            chosen = np.empty(rows.size, dtype=np.int64)
            kernels.lockstep_greedy(
                ids[rows], self.w, self.a, self.active, self.next, obs[rows], self.tiles,
                self.sizes, (self.pairs, self.values, self.position), self.count,
                rewards[rows], truncated[rows], self.rates, self._gathered, self._q, chosen,
                _NO_UNDO,
            )  # fmt: skip
            out[rows] = chosen
            for j in np.flatnonzero(chosen < 0).tolist():  # a tie, or a value not a number
                r, delta, q_next = rows[j], float(self._gathered[j, 0]), self._q[j].tolist()
                out[r] = self._finish(int(ids[r]), delta, q_next, bool(truncated[r]))
            ended = rows[truncated[rows] & (chosen >= 0)]
            self.a[ids[ended]], out[ended] = -1, -1
        for r in np.flatnonzero(~compiled).tolist():
            out[r] = self._step(int(ids[r]), float(rewards[r]), obs[r], terminated[r],
                                bool(truncated[r]))  # fmt: skip
        return out

    def _step(
        self, i: int, reward: float, obs: np.ndarray, terminated: bool, truncated: bool
    ) -> int:
        """A decision in Python around the kernels (CompiledSarsaLambda.learn's other path)."""
        q, self.count[i] = kernels.mark(
            self.w[i], self.a[i], self.active[i], self.num_features, self.pairs[i],
            self.values[i], self.position[i], self.count[i], self.replacing, self._gathered[0],
            _NO_UNDO,
        )  # fmt: skip
        if terminated:
            self._apply(i, reward - q)
            self.a[i] = -1
            return -1
        q_next = self._values_at(i, obs, self.next[i])
        return self._finish(i, reward - q, q_next, truncated)

    def _finish(self, i: int, delta: float, q_next: list[float], truncated: bool) -> int:
        """a' from learner ``i``'s policy, the update with the bootstrapped TD error, the
        decay, and the move to (s', a') (or the end at truncation)."""
        a2 = self._policy(i, q_next)
        self._apply(i, delta + self.gamma * q_next[a2])
        if truncated:
            self.a[i] = -1
            return -1
        self.count[i] = kernels.decay(self.pairs[i], self.values[i], self.position[i],
                                      self.count[i], self.factor, self.cutoff)  # fmt: skip
        self.active[i], self.a[i] = self.next[i], a2
        return a2

    def _values_at(self, i: int, obs: np.ndarray, out: np.ndarray) -> list[float]:
        """Learner ``i``'s action values at ``obs``, its active tiles written to ``out``."""
        kernels.tile_active(np.asarray(obs, dtype=float), *self.tiles, out)
        kernels.q_values(self.w[i], out, self.num_features, self.n_actions, self._gathered[0],
                         self._q[0])  # fmt: skip
        return self._q[0].tolist()

    def _policy(self, i: int, q: list[float]) -> int:
        stream = self.streams[i]
        if self.epsilon > 0.0 and stream.random() < self.epsilon:
            return stream.below(self.n_actions)
        return stream.argmax(q)

    def _apply(self, i: int, delta: float) -> None:
        if not -np.inf < delta < np.inf:  # NaN and infinities fail too
            error = DivergenceError(f"the TD error is {delta} (alpha {self.alpha:g})")
            error.learner = i  # which of the group: the trainer names its seed
            raise error
        kernels.update(self.w[i], self.pairs[i], self.values[i], self.count[i],
                       self.alpha * delta)  # fmt: skip

    def _grow(self) -> None:
        """Twice the room for every learner's traces (at most one per weight), live ones kept."""
        room = self.pairs.shape[1]
        need = int(self.count.max()) + self.active.shape[1]
        bigger = min(self.w.shape[1], max(2 * room, need))
        for name in ("pairs", "values"):
            old = getattr(self, name)
            new = np.zeros((len(old), bigger), dtype=old.dtype)
            new[:, :room] = old
            setattr(self, name, new)

    # -- checkpoints, in the single learner's format ---------------------------------------

    def state_dict(self, k: int) -> dict[str, np.ndarray]:
        w = self.w[k].reshape(self.n_actions, self.num_features).copy()
        return {"w": w, **self.streams[k].state_dict(prefix="stream.")}

    def load_state(self, k: int, state: dict[str, np.ndarray]) -> None:
        w = checked_values(state, "w", (self.n_actions, self.num_features))
        self.streams[k].load_state_dict(state, prefix="stream.")
        self.w[k] = w.ravel()
        kernels.clear(self.pairs[k], self.position[k], self.count[k])
        self.count[k], self.a[k] = 0, -1
