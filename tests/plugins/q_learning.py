"""A new algorithm, as a user would add one: tabular Q-learning (Watkins), one file plus one
registration: its typed config (alpha, gamma, epsilon, with its own defaults), the report's grid."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.agents.base import AgentSpec, RandomStream, checked_values, register_agent
from acrobot_mj.agents.features import StateGrid


@dataclass(frozen=True)
class QLearningConfig:
    """Q-learning's hyperparameters: step size, discount, exploration."""

    alpha: float = 0.5
    gamma: float = 1.0
    epsilon: float = 0.001


class QLearning:
    """Q(s, a) += alpha [r + gamma max_a' Q(s', a') - Q(s, a)], epsilon-greedy behaviour."""

    def __init__(
        self,
        grid: StateGrid,
        n_actions: int,
        alpha: float,
        gamma: float,
        epsilon: float,
        seed: Any = None,
    ) -> None:
        self.grid, self.n_actions = grid, n_actions
        self.alpha, self.gamma, self.epsilon = alpha, gamma, epsilon
        self.stream = RandomStream(seed)
        self.q = np.zeros((grid.num_features, n_actions))
        self._s = self._a = -1

    def _act(self, s: int) -> int:
        if self.epsilon > 0.0 and self.stream.random() < self.epsilon:
            return self.stream.below(self.n_actions)
        return self.stream.argmax(self.q[s].tolist())

    def begin_episode(self, obs: Any) -> int:
        self._s = self.grid.index(obs)
        self._a = self._act(self._s)
        return self._a

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        s2 = self.grid.index(obs)
        target = reward if terminated else reward + self.gamma * self.q[s2].max()
        self.q[self._s, self._a] += self.alpha * (target - self.q[self._s, self._a])
        if terminated or truncated:
            return None
        self._s, self._a = s2, self._act(s2)
        return self._a

    def greedy_action(self, obs: Any, stream: RandomStream) -> int:
        return stream.argmax(self.q[self.grid.index(obs)].tolist())

    def state_dict(self) -> dict[str, np.ndarray]:
        return {"q": self.q.copy(), **self.stream.state_dict(prefix="stream.")}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        q = checked_values(state, "q", self.q.shape)
        self.stream.load_state_dict(state, prefix="stream.")
        self.q = q.copy()


register_agent(
    AgentSpec(
        name="q_learning",
        doc="tabular Q-learning (a test plugin)",
        config=QLearningConfig,
        features=("grid",),
        build=lambda grid, c, seed, n: QLearning(grid, n, c.alpha, c.gamma, c.epsilon, seed),
    )
)
