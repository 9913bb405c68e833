"""What an agent is to the package: the :class:`Agent` protocol, its random stream and
epsilon-greedy draws (one source for Python and compiled learners), the registry that builds it
from a config (:data:`AGENTS`), and the actors that run it in the episode loop."""

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
    """``(index of the largest of values, next position)``; a tie takes one draw from ``block``."""
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
    """Epsilon-greedy in ``values`` (one draw when ``epsilon > 0``, one more to explore)."""
    if epsilon > 0.0:
        position += 1
        if block[position - 1] < epsilon:
            return int(block[position] * values.shape[0]), position + 1
    return argmax(values, block, position)


class RandomStream:
    """Uniform draws in [0, 1) from ``numpy.random.default_rng(seed)``, fetched ``BLOCK`` at a
    time; :meth:`state_dict` holds the generator and the block, to go on where it stopped."""

    def __init__(self, seed: int | np.random.SeedSequence | None = None) -> None:
        self.generator = np.random.default_rng(seed)
        self.block, self.position = np.zeros(0), 0

    def reserve(self, count: int = 2) -> None:
        """At least ``count`` unread draws in ``block``, for a compiled learner to read."""
        if len(self.block) - self.position < count:
            self.block = np.concatenate([self.block[self.position :], self.generator.random(BLOCK)])
            self.position = 0

    def random(self) -> float:
        self.reserve(1)
        self.position += 1
        return float(self.block[self.position - 1])

    def below(self, n: int) -> int:
        return int(self.random() * n)

    def argmax(self, values: Any) -> int:
        """Index of the largest value, ties broken at random."""
        self.reserve(1)
        index, self.position = argmax(np.asarray(values, dtype=float), self.block, self.position)
        return index

    def position_now(self) -> tuple[Any, ...]:
        """Where the stream is now, cheaply, for :meth:`state_dict` later."""
        return self.generator.bit_generator.state, self.block, self.position

    def state_dict(self, prefix: str = "", at: tuple[Any, ...] | None = None) -> dict:
        """The state now (or ``at`` a :meth:`position_now`) as arrays named ``prefix...``."""
        bit_state, block, position = self.position_now() if at is None else at
        return {
            f"{prefix}bit_generator": np.array(json.dumps(bit_state)),
            f"{prefix}block": np.array(block, dtype=np.float64),
            f"{prefix}next": np.array(position),
        }

    def load_state_dict(self, state: dict[str, Any], prefix: str = "") -> None:
        state = {k.removeprefix(prefix): v for k, v in state.items() if k.startswith(prefix)}
        try:
            bit_state = json.loads(str(state["bit_generator"]))
            kind = bit_state.get("bit_generator")
        except (ValueError, AttributeError) as error:
            raise ValueError(f"random state is not a generator's state ({error})") from None
        if kind != type(self.generator.bit_generator).__name__:
            raise ValueError(
                f"random state is for {kind!r}, not {type(self.generator.bit_generator).__name__}"
            )
        block, position = np.asarray(state["block"], dtype=np.float64), int(state["next"])
        if block.ndim != 1 or not 0 <= position <= len(block):
            raise ValueError("random state has an inconsistent block position")
        self.generator.bit_generator.state = bit_state
        self.block, self.position = block.copy(), position


def checked_values(state: dict[str, Any], name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``state[name]``; ValueError unless it is float64 (as saved: anything else was edited, and
    a cast would change the numbers), has ``shape`` and is finite."""
    values = np.asarray(state[name])
    if values.dtype != np.float64:
        raise ValueError(f"{name} holds {values.dtype} values, this agent saves float64")
    if values.shape != shape:
        raise ValueError(f"{name} has shape {values.shape}, this agent needs {shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{name} holds non-finite values")
    return values


class DivergenceError(ArithmeticError):
    """A learner's values stopped being finite (``rewards``: the rewards overflowed)."""

    def __init__(self, message: str, rewards: bool = False) -> None:
        super().__init__(message)
        self.rewards = rewards


@runtime_checkable
class Agent(Protocol):
    """A learner with its own random stream: ``action = agent.begin_episode(obs)``, then after
    each step ``action = agent.learn(reward, obs, terminated, truncated)`` (None once over)."""

    n_actions: int
    stream: RandomStream

    def begin_episode(self, obs: Any) -> int: ...

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None: ...

    def greedy_action(self, obs: Any, stream: RandomStream) -> int: ...

    def state_dict(self) -> dict[str, np.ndarray]: ...

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None: ...  # KeyError, ValueError


@runtime_checkable
class Rewinding(Protocol):
    """An agent that can give its state after its last episode even during the next one."""

    def checkpoint_state(self) -> Callable[[], dict[str, np.ndarray]]: ...


@dataclass(frozen=True)
class AgentSpec:
    """An algorithm: its typed config, the features it takes, how to build one learner
    ``(features, config, seed, n_actions)`` and K in lockstep ``(features, config, seeds)`` (like
    :class:`~acrobot_mj.agents.sarsa.SarsaGroup`)."""

    name: str
    doc: str
    config: type
    features: tuple[str, ...]
    build: Callable[[Any, Any, Any, int], Agent]
    group: Callable[[Any, Any, Sequence[int]], Any] | None = None


#: The registered algorithms by name (:func:`register_agent` adds one).
AGENTS: dict[str, AgentSpec] = {}


def register_agent(spec: AgentSpec) -> AgentSpec:
    """Add an algorithm to :data:`AGENTS`."""
    if AGENTS.get(spec.name, spec) is not spec:
        raise ValueError(f"algorithm {spec.name!r} is already registered")
    if unknown := sorted(set(spec.features) - set(FEATURES)):
        raise ValueError(f"algorithm {spec.name!r} names unknown features {unknown}")
    AGENTS[spec.name] = spec
    return spec


def agent_spec(name: str) -> AgentSpec:
    if name not in AGENTS:
        raise ValueError(f"unknown algorithm {name!r}; known: {sorted(AGENTS)}")
    return AGENTS[name]


class Learning:
    """The agent learning as it acts, an actor of :func:`acrobot_mj.envs.rollout.run_episode`."""

    def __init__(self, agent: Agent) -> None:
        self.begin, self.observe = agent.begin_episode, agent.learn


class Greedy:
    """The agent's greedy policy as an actor, ties broken by ``stream``."""

    def __init__(self, agent: Agent, stream: RandomStream) -> None:
        self._agent, self._stream = agent, stream

    def begin(self, obs: Any) -> int:
        return self._agent.greedy_action(obs, self._stream)

    def observe(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        return None if terminated or truncated else self._agent.greedy_action(obs, self._stream)
