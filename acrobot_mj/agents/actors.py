"""Agents as actors of the episode loop (:func:`acrobot_mj.envs.episode.run_episode`): learning
(every step updates the agent) or greedy (the agent's greedy policy, nothing learned)."""

from __future__ import annotations

from typing import Any

from acrobot_mj.agents.protocol import Agent
from acrobot_mj.agents.random_stream import RandomStream


class Learning:
    """The agent learning as it acts: ``begin_episode``, then ``learn`` after every step.

    The bound methods are the actor's (no call in between: this is training's hot loop)."""

    def __init__(self, agent: Agent) -> None:
        self.begin = agent.begin_episode
        self.observe = agent.learn


class Greedy:
    """The agent's greedy policy, ties broken by ``stream`` (the agent's own stream and values
    stay untouched)."""

    def __init__(self, agent: Agent, stream: RandomStream) -> None:
        self._agent, self._stream = agent, stream

    def begin(self, obs: Any) -> int:
        return self._agent.greedy_action(obs, self._stream)

    def observe(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        if terminated or truncated:
            return None
        return self._agent.greedy_action(obs, self._stream)
