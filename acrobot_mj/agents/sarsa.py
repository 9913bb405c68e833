"""Tabular SARSA exactly as the report's pseudocode (Sutton and Barto, section 6.4).

    Initialise Q(s, a) = 0
    Repeat for each episode:
        s = initial state; choose a from s, epsilon-greedy in Q
        Repeat for each step:
            take a, observe r, s'
            choose a' from s', epsilon-greedy in Q
            Q(s, a) += alpha [r + gamma Q(s', a') - Q(s, a)]
            s, a = s', a'
        until s is terminal

Details the report leaves open, fixed here: epsilon-greedy picks a uniformly random action (any
of the three) with probability epsilon (one draw per decision when epsilon > 0), else a greedy
one with ties broken at random; at the goal (a terminal state, whose values are 0) the target is
the reward alone, with no bootstrap; at a truncation (the 1000-step limit, not a terminal state)
the update still bootstraps from ``Q(s', a')``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from acrobot_mj.agents.features import StateGrid
from acrobot_mj.agents.lockstep_sarsa import LockstepSarsa
from acrobot_mj.agents.protocol import AgentSpec
from acrobot_mj.agents.random_stream import RandomStream, checked_values


class Sarsa:
    """One-step tabular SARSA over a :class:`~acrobot_mj.agents.features.StateGrid`.

    alpha: step size; gamma: discount; epsilon: exploration probability; seed: of the agent's own
    random stream (exploration and tie-breaking).
    """

    def __init__(
        self,
        grid: StateGrid,
        n_actions: int = 3,
        alpha: float = 0.5,
        gamma: float = 1.0,
        epsilon: float = 0.001,
        seed: int | np.random.SeedSequence | None = None,
    ) -> None:
        if not 0.0 < alpha <= 1.0:
            raise ValueError(f"alpha must be in (0, 1], got {alpha}")
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"gamma must be in [0, 1], got {gamma}")
        if not 0.0 <= epsilon <= 1.0:
            raise ValueError(f"epsilon must be in [0, 1], got {epsilon}")
        self.grid, self.n_actions = grid, n_actions
        self.alpha, self.gamma, self.epsilon = alpha, gamma, epsilon
        self.stream = RandomStream(seed)
        # A list of rows: element access is several times faster than numpy's on this hot path.
        self._q = [[0.0] * n_actions for _ in range(grid.num_features)]
        self._s = self._a = -1

    @property
    def q(self) -> np.ndarray:
        """The action values, shape ``(num_states, n_actions)`` (a copy)."""
        return np.array(self._q)

    def _policy(self, s: int) -> int:
        """Epsilon-greedy in Q(s, .) with the agent's own stream."""
        stream = self.stream
        if self.epsilon > 0.0 and stream.random() < self.epsilon:
            return stream.below(self.n_actions)
        return stream.argmax(self._q[s])

    def begin_episode(self, obs: Any) -> int:
        self._s = self.grid.index(obs)
        self._a = self._policy(self._s)
        return self._a

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        """Update Q(s, a) from ``(r, s')``; return a' (``None`` once the episode is over)."""
        if self._s < 0:
            raise RuntimeError("learn() needs an episode in progress: call begin_episode()")
        row = self._q[self._s]
        if terminated:
            target = reward  # the terminal state's values are zero: no bootstrap
            s2 = a2 = -1
        else:
            s2 = self.grid.index(obs)
            a2 = self._policy(s2)
            target = reward + self.gamma * self._q[s2][a2]
        # TD error, then the step toward the target.
        row[self._a] += self.alpha * (target - row[self._a])
        if terminated or truncated:
            self._s = self._a = -1
            return None
        self._s, self._a = s2, a2
        return a2

    def greedy_action(self, obs: Any, stream: RandomStream) -> int:
        """argmax_a Q(s, a), ties broken by ``stream`` (so evaluation leaves ours untouched)."""
        return stream.argmax(self._q[self.grid.index(obs)])

    def state_dict(self) -> dict[str, np.ndarray]:
        return {"q": self.q, **self.stream.state_dict(prefix="stream.")}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        q = checked_values(state, "q", (self.grid.num_features, self.n_actions))
        self.stream.load_state_dict(state, prefix="stream.")
        self._q = q.tolist()


SPEC = AgentSpec(
    name="sarsa",
    doc="one-step tabular SARSA (the report), with lockstep training of many seeds",
    uses=("alpha", "gamma", "epsilon"),
    features=("grid",),
    build=lambda grid, c, seed, n: Sarsa(grid, n, c.alpha, c.gamma, c.epsilon, seed=seed),
    lockstep=lambda grid, c, seeds: LockstepSarsa(grid, seeds, 3, c.alpha, c.gamma, c.epsilon),
)
