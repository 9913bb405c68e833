"""What an agent is to the rest of the package: the :class:`Agent` protocol, and the specs the
registry (:mod:`acrobot_mj.agents.registry`) keeps of each algorithm and each kind of features.

A spec says which fields of the flat training config (``acrobot_mj.train.config.TrainConfig``)
the algorithm or the features use, and how to build them from a config: the config's validity
per algorithm is read from here, and nothing outside ``agents/`` names an algorithm.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from acrobot_mj.agents.random_stream import RandomStream


class DivergenceError(ArithmeticError):
    """A learner's values stopped being finite numbers: a step size too large for its features,
    or (``rewards``) rewards too large for a float."""

    def __init__(self, message: str, rewards: bool = False) -> None:
        super().__init__(message)
        self.rewards = rewards
        #: In a lockstep group: the index of the learner that diverged.
        self.learner: int | None = None


@runtime_checkable
class Features(Protocol):
    """Observations ``(q1, q2, dq1, dq2)`` to the indices of their active binary features."""

    num_features: int
    num_active: int

    def active(self, obs: Any) -> np.ndarray:
        """Indices of the active features, int64 of shape ``(num_active,)``."""


@runtime_checkable
class Rewinding(Protocol):
    """An agent that can give, when asked, its :meth:`Agent.state_dict` as it was after its
    last completed episode, even in the middle of the next one (from a log of what that episode
    changed), so a checkpoint need not copy the agent's arrays after every episode."""

    def checkpoint_state(self) -> Callable[[], dict[str, np.ndarray]]:
        """Between episodes: a function that gives the state as it is now, if called before
        the episode after the next one begins (else it raises RuntimeError)."""


@runtime_checkable
class Agent(Protocol):
    """A learner with its own random stream. The episode protocol::

    action = agent.begin_episode(obs)
    while the episode goes on:
        obs, reward, terminated, truncated, info = env.step(action)
        action = agent.learn(reward, obs, terminated, truncated)  # None once it is over
    """

    n_actions: int
    stream: RandomStream

    def begin_episode(self, obs: Any) -> int:
        """Start an episode at ``obs``; the first action."""

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        """Learn from one step; the next action, or None once the episode is over."""

    def greedy_action(self, obs: Any, stream: RandomStream) -> int:
        """The greedy action at ``obs``, ties broken by ``stream`` (not the agent's own)."""

    def state_dict(self) -> dict[str, np.ndarray]:
        """Everything a checkpoint needs, as plain numpy arrays."""

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s arrays; raises ValueError/KeyError if they do not fit."""


class LockstepAgents(Protocol):
    """K learners of one algorithm trained together on a vector env, learner ``k`` exactly as
    the single agent with seed ``seeds[k]``. Methods take ``ids``, the learners concerned (a
    sorted int array), and their rows of observations, rewards and flags."""

    def begin_episodes(self, ids: np.ndarray, obs: np.ndarray) -> np.ndarray: ...

    def learn(
        self,
        ids: np.ndarray,
        rewards: np.ndarray,
        obs: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
    ) -> np.ndarray: ...

    def state_dict(self, k: int) -> dict[str, np.ndarray]: ...

    def load_state(self, k: int, state: dict[str, np.ndarray]) -> None: ...


@dataclass(frozen=True)
class FeatureSpec:
    """A kind of features: its name, the config fields it reads, how to build it."""

    name: str
    doc: str
    uses: tuple[str, ...]
    build: Callable[[Any], Features]  # config -> features


@dataclass(frozen=True)
class AgentSpec:
    """An algorithm: its name, the config fields it reads (its hyperparameters), the features it
    accepts, how to build one learner and, if it can, K learners in lockstep (for the configs
    ``lockstep_if`` accepts)."""

    name: str
    doc: str
    uses: tuple[str, ...]
    features: tuple[str, ...]
    build: Callable[[Features, Any, Any, int], Agent]  # features, config, seed, n_actions
    lockstep: Callable[[Features, Any, Sequence[int]], LockstepAgents] | None = None
    #: Which configs the lockstep form serves (None: all of them).
    lockstep_if: Callable[[Any], bool] | None = None
    #: Whether several seeds train in lockstep unless told otherwise (where it is the faster
    #: way; else one process per seed, and lockstep when asked for).
    lockstep_default: bool = True
