"""What an agent is to the rest of the package, and how a config becomes one.

An :class:`Agent` has ``begin_episode(obs)``, ``learn(reward, obs, terminated, truncated)``
(the next action, or None once the episode is over), ``greedy_action(obs, stream)`` (ties broken
by a stream that is not its own), ``state_dict()`` / ``load_state_dict()`` (plain numpy arrays)
and its own ``stream``. The registry keeps one :class:`AgentSpec` per algorithm: its typed
config (with its defaults), the features it takes and how to build one learner (and, for
tabular SARSA, many in lockstep). Adding an algorithm is one module with a spec and one
:func:`register_agent` call.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from acrobot_mj.agents.features import FEATURES
from acrobot_mj.agents.stream import RandomStream


class DivergenceError(ArithmeticError):
    """A learner's values stopped being finite: a step size too large for its features, or
    (``rewards``) rewards too large for a float."""

    def __init__(self, message: str, rewards: bool = False) -> None:
        super().__init__(message)
        self.rewards = rewards


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

    def begin_episode(self, obs: Any) -> int: ...

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None: ...

    def greedy_action(self, obs: Any, stream: RandomStream) -> int: ...

    def state_dict(self) -> dict[str, np.ndarray]: ...

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s arrays; ValueError or KeyError if they do not fit."""


@runtime_checkable
class Rewinding(Protocol):
    """An agent that can give its :meth:`Agent.state_dict` as it was after its last completed
    episode, even in the middle of the next one, so that a checkpoint need not copy the
    agent's arrays after every episode."""

    def checkpoint_state(self) -> Callable[[], dict[str, np.ndarray]]: ...


class Group(Protocol):
    """K learners of one algorithm stepped together (lockstep on a vector env), learner ``k``
    exactly the single agent with seed ``seeds[k]``; ``ids`` are the learners concerned."""

    def begin_episodes(self, ids: np.ndarray, obs: np.ndarray) -> np.ndarray: ...

    def learn(self, ids: np.ndarray, rewards: np.ndarray, obs: np.ndarray,
              terminated: np.ndarray, truncated: np.ndarray) -> np.ndarray: ...  # fmt: skip

    def state_dict(self, k: int) -> dict[str, np.ndarray]: ...

    def load_state(self, k: int, state: dict[str, np.ndarray]) -> None: ...


@dataclass(frozen=True)
class AgentSpec:
    """An algorithm: its name, its typed config (``config()`` holds its defaults), the features
    it takes, how to build one learner ``(features, config, seed, n_actions)`` and, if it has
    one, its lockstep form ``(features, config, seeds)``."""

    name: str
    doc: str
    config: type
    features: tuple[str, ...]
    build: Callable[[Any, Any, Any, int], Agent]
    group: Callable[[Any, Any, Sequence[int]], Group] | None = None


AGENTS: dict[str, AgentSpec] = {}


def register_agent(spec: AgentSpec) -> AgentSpec:
    """Add an algorithm to :data:`AGENTS` (its features must be known)."""
    known = AGENTS.get(spec.name)
    if known is not None and known is not spec:
        raise ValueError(f"algorithm {spec.name!r} is already registered")
    unknown = sorted(set(spec.features) - set(FEATURES))
    if unknown:
        raise ValueError(f"algorithm {spec.name!r} names unknown features {unknown}")
    AGENTS[spec.name] = spec
    return spec


def agent_spec(name: str) -> AgentSpec:
    """The spec of algorithm ``name``; the error lists the known ones."""
    if name not in AGENTS:
        raise ValueError(f"unknown algorithm {name!r}; known: {sorted(AGENTS)}")
    return AGENTS[name]


class Learning:
    """The agent learning as it acts, as an actor of the episode loop
    (:func:`acrobot_mj.envs.rollout.run_episode`): ``begin_episode``, then ``learn`` after every
    step (the bound methods themselves: training's hot loop)."""

    def __init__(self, agent: Agent) -> None:
        self.begin, self.observe = agent.begin_episode, agent.learn


class Greedy:
    """The agent's greedy policy as an actor, ties broken by ``stream`` (the agent's own stream
    and values stay untouched)."""

    def __init__(self, agent: Agent, stream: RandomStream) -> None:
        self._agent, self._stream = agent, stream

    def begin(self, obs: Any) -> int:
        return self._agent.greedy_action(obs, self._stream)

    def observe(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        if terminated or truncated:
            return None
        return self._agent.greedy_action(obs, self._stream)
