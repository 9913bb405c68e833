"""What an agent is to the rest of the package: its protocol, its own random stream (and the
draws of an epsilon-greedy policy, written once for Python and compiled learners alike), the
registry that builds one from a config, and the actors that run it in the episode loop.

An :class:`Agent` has ``begin_episode(obs)``, ``learn(reward, obs, terminated, truncated)``
(the next action, or None once the episode is over), ``greedy_action(obs, stream)`` (ties broken
by a stream that is not its own), ``state_dict()`` / ``load_state_dict()`` (plain numpy arrays)
and its own ``stream``. The registry keeps one :class:`AgentSpec` per algorithm: its typed
config (with its defaults), the features it takes and how to build one learner (and, for
tabular SARSA, many in lockstep). Adding an algorithm is one module with a spec and one
:func:`register_agent` call.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from acrobot_mj.agents.features import FEATURES
from acrobot_mj.compiled import jitable

BLOCK = 1024


@jitable
def argmax(values, block, position) -> tuple:
    """The index of the largest of ``values``, ties broken by one draw from ``block`` at
    ``position`` (only when there is a tie): ``(index, next position)``."""
    best, first, count = values[0], 0, 1
    for i in range(1, values.shape[0]):
        if values[i] > best:
            best, first, count = values[i], i, 1
        elif values[i] == best:
            count += 1
    if count == 1:
        return first, position
    pick = int(block[position] * count)
    for i in range(first, values.shape[0]):
        if values[i] == best:
            if pick == 0:
                return i, position + 1
            pick -= 1
    return first, position + 1  # not reached


@jitable
def policy(values, epsilon, block, position) -> tuple:
    """Epsilon-greedy in ``values``: with probability ``epsilon`` (one draw, when ``epsilon >
    0``) a uniformly random action (one more draw), else :func:`argmax`."""
    if epsilon > 0.0:
        position += 1
        if block[position - 1] < epsilon:
            return int(block[position] * values.shape[0]), position + 1
    return argmax(values, block, position)


class RandomStream:
    """Uniform draws in [0, 1) from ``numpy.random.default_rng(seed)``, fetched ``BLOCK`` at a
    time (one Generator call per draw costs more than an agent's whole update). The same seed
    gives the same draws; :meth:`state_dict` captures the generator and the unread part of the
    block, so a restored stream goes on exactly where it stopped."""

    def __init__(self, seed: int | np.random.SeedSequence | None = None) -> None:
        self.generator = np.random.default_rng(seed)
        self.block, self.position = np.zeros(0), 0

    def reserve(self, count: int = 2) -> None:
        """At least ``count`` unread draws in :attr:`block` (the next block appended where
        fewer are left: the same draws in the same order), for a compiled learner to read."""
        if len(self.block) - self.position < count:
            rest = self.block[self.position :]
            self.block = np.concatenate([rest, self.generator.random(BLOCK)])
            self.position = 0

    def random(self) -> float:
        """One uniform draw in [0, 1)."""
        self.reserve(1)
        self.position += 1
        return float(self.block[self.position - 1])

    def below(self, n: int) -> int:
        """A uniform integer in ``[0, n)``."""
        return int(self.random() * n)

    def argmax(self, values: Any) -> int:
        """Index of the largest value, ties broken uniformly at random (:func:`argmax`)."""
        self.reserve(1)
        index, self.position = argmax(np.asarray(values, dtype=float), self.block, self.position)
        return index

    def position_now(self) -> tuple[Any, ...]:
        """Where the stream is now, cheaply (a block is replaced, never changed): give it to
        :meth:`state_dict` later for the state as it is now."""
        return self.generator.bit_generator.state, self.block, self.position

    def state_dict(self, prefix: str = "", at: tuple[Any, ...] | None = None) -> dict:
        """The stream's state (or, ``at``, the state at that :meth:`position_now`) as arrays,
        their names starting with ``prefix``."""
        bit_state, block, position = self.position_now() if at is None else at
        return {
            f"{prefix}bit_generator": np.array(json.dumps(bit_state)),
            f"{prefix}block": np.array(block, dtype=np.float64),
            f"{prefix}next": np.array(position),
        }

    def load_state_dict(self, state: dict[str, Any], prefix: str = "") -> None:
        """Restore what :meth:`state_dict` returned (with the same ``prefix``)."""
        state = {k.removeprefix(prefix): v for k, v in state.items() if k.startswith(prefix)}
        try:
            bit_state = json.loads(str(state["bit_generator"]))
            kind = bit_state.get("bit_generator")
        except (ValueError, AttributeError) as error:
            raise ValueError(f"random state is not a generator's state ({error})") from None
        if kind != type(self.generator.bit_generator).__name__:
            raise ValueError(f"random state is for {kind!r}, not "
                             f"{type(self.generator.bit_generator).__name__}")  # fmt: skip
        block = np.asarray(state["block"], dtype=np.float64)
        position = int(state["next"])
        if block.ndim != 1 or not 0 <= position <= len(block):
            raise ValueError("random state has an inconsistent block position")
        self.generator.bit_generator.state = bit_state
        self.block, self.position = block.copy(), position


def checked_values(state: dict[str, Any], name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``state[name]`` as float64, refused unless it has ``shape`` and only finite values."""
    values = np.asarray(state[name], dtype=np.float64)
    if values.shape != shape:
        raise ValueError(f"{name} has shape {values.shape}, this agent needs {shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{name} holds non-finite values")
    return values


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
