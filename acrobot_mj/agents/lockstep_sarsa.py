"""K tabular SARSA learners in lockstep: one Q table each, updates vectorised over learners.

Learner ``k`` is exactly :class:`~acrobot_mj.agents.sarsa.Sarsa` with seed ``seeds[k]``: its
random stream is the same generator read in the same blocks, each step draws the same numbers in
the same order (epsilon test, then the explored action or the tie-break), and the arithmetic is
the same IEEE operations, so run on the same observations it learns the same values bit for bit.
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from acrobot_mj.agents.features import StateGrid
from acrobot_mj.agents.random_stream import BLOCK, checked_values


class LockstepSarsa:
    """``len(seeds)`` independent tabular SARSA learners over one :class:`StateGrid`.

    Methods take ``ids``, the learners concerned (a sorted int array without repeats), and their
    rows of observations, rewards and flags.
    """

    def __init__(
        self,
        grid: StateGrid,
        seeds: Sequence[int],
        n_actions: int = 3,
        alpha: float = 0.5,
        gamma: float = 1.0,
        epsilon: float = 0.001,
    ) -> None:
        if not 0.0 < alpha <= 1.0 or not 0.0 <= gamma <= 1.0 or not 0.0 <= epsilon <= 1.0:
            raise ValueError(
                f"need 0 < alpha <= 1 and gamma, epsilon in [0, 1]; got {alpha}, {gamma}, {epsilon}"
            )
        self.grid, self.n_actions = grid, n_actions
        self.alpha, self.gamma, self.epsilon = alpha, gamma, epsilon
        self.seeds = list(seeds)
        k = len(self.seeds)
        self.q = np.zeros((k, grid.num_features, n_actions))
        self._generators = [np.random.default_rng(seed) for seed in self.seeds]
        self._block = np.zeros((k, BLOCK))
        self._next = np.full(k, BLOCK)  # empty: the first draw fetches a block, as RandomStream
        self._s = np.zeros(k, dtype=np.int64)
        self._a = np.zeros(k, dtype=np.int64)

    def _draw(self, ids: np.ndarray) -> np.ndarray:
        """One uniform draw for each learner in ``ids``, from its own stream."""
        for k in ids[self._next[ids] == BLOCK]:
            self._block[k] = self._generators[k].random(BLOCK)
            self._next[k] = 0
        u = self._block[ids, self._next[ids]]
        self._next[ids] += 1
        return u

    def _policy(self, ids: np.ndarray, states: np.ndarray) -> np.ndarray:
        """Epsilon-greedy actions, ties broken at random: Sarsa._policy for each learner."""
        actions = np.empty(ids.size, dtype=np.int64)
        if self.epsilon > 0.0:
            explore = self._draw(ids) < self.epsilon
        else:  # Sarsa draws nothing for the epsilon test then
            explore = np.zeros(ids.size, dtype=bool)
        if explore.any():
            actions[explore] = (self._draw(ids[explore]) * self.n_actions).astype(np.int64)
        greedy = ~explore
        rows = self.q[ids[greedy], states[greedy]]
        ties = rows == rows.max(axis=1, keepdims=True)
        count = ties.sum(axis=1)
        choice = rows.argmax(axis=1)
        several = count > 1
        if several.any():
            pick = (self._draw(ids[greedy][several]) * count[several]).astype(np.int64)
            choice[several] = (np.cumsum(ties[several], axis=1) <= pick[:, None]).sum(axis=1)
        actions[greedy] = choice
        return actions

    def begin_episodes(self, ids: np.ndarray, obs: np.ndarray) -> np.ndarray:
        self._s[ids] = self.grid.indices(obs)
        self._a[ids] = self._policy(ids, self._s[ids])
        return self._a[ids]

    def learn(
        self,
        ids: np.ndarray,
        rewards: np.ndarray,
        obs: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
    ) -> np.ndarray:
        """One SARSA update per learner in ``ids``; returns their next actions (-1 for those
        whose episode ended)."""
        s, a = self._s[ids], self._a[ids]
        target = np.asarray(rewards, dtype=np.float64).copy()
        going = ~terminated  # the goal is terminal: no bootstrap there
        s2 = self.grid.indices(obs[going])
        a2 = self._policy(ids[going], s2)
        target[going] += self.gamma * self.q[ids[going], s2, a2]
        # TD error, then the step toward the target.
        self.q[ids, s, a] += self.alpha * (target - self.q[ids, s, a])
        self._s[ids[going]], self._a[ids[going]] = s2, a2
        actions = np.full(ids.size, -1, dtype=np.int64)
        continuing = going & ~truncated
        actions[continuing] = a2[~truncated[going]]
        return actions

    def state_dict(self, k: int) -> dict[str, np.ndarray]:
        """Learner ``k``'s state in :class:`~acrobot_mj.agents.sarsa.Sarsa`'s format."""
        block = self._block[k, self._next[k] :] if self._next[k] < BLOCK else np.zeros(0)
        return {
            "q": self.q[k].copy(),
            "stream.bit_generator": np.array(json.dumps(self._generators[k].bit_generator.state)),
            # Sarsa keeps the whole block and a position; the unread rest is equivalent.
            "stream.block": block.copy(),
            "stream.next": np.array(0),
        }

    def load_state(self, k: int, state: dict[str, np.ndarray]) -> None:
        """Give learner ``k`` a state in Sarsa's format (from its checkpoint)."""
        q = checked_values(state, "q", self.q.shape[1:])
        bit_state = json.loads(str(state["stream.bit_generator"]))
        block = np.asarray(state["stream.block"], dtype=np.float64)
        rest = block[int(state["stream.next"]) :]  # the unread draws, read before a refill
        if rest.size > BLOCK:
            raise ValueError("random state has a block longer than the stream's")
        self._generators[k].bit_generator.state = bit_state
        self.q[k] = q
        self._block[k, BLOCK - rest.size :] = rest
        self._next[k] = BLOCK - rest.size
