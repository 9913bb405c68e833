"""The one episode loop: training, greedy evaluation, videos, validation replays and the fixed
policies all run their episodes through :func:`run_episode`.

What acts is an :class:`Actor`: ``begin(obs)`` gives the first action, ``observe(reward, obs,
terminated, truncated)`` sees each step's result and gives the next action (ignored once the
episode is over). A learning agent learns in ``observe`` (``acrobot_mj.agents.base``); a fixed
policy just maps observations to actions (:class:`PolicyActor`). Hooks see the reset and every
step, for frames or per-step records.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

#: A policy maps an observation ``(q1, q2, dq1, dq2)`` to an action of the env's space.
Policy = Callable[[np.ndarray], Any]


class Actor(Protocol):
    """What chooses the actions of an episode."""

    def begin(self, obs: np.ndarray) -> Any:
        """The first action, from the reset observation."""

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        """See one step's outcome; return the next action (unused once the episode is over)."""


class PolicyActor:
    """A fixed policy as an actor: it is asked only for actions that will be taken."""

    def __init__(self, policy: Policy) -> None:
        self.begin = policy
        self._policy = policy

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        return None if terminated or truncated else self._policy(obs)


class SequenceActor(PolicyActor):
    """Plays a fixed sequence of actions (episodes longer than it must be cut by max_steps)."""

    def __init__(self, actions: Sequence[Any]) -> None:
        self._actions = iter(actions)
        super().__init__(lambda obs: next(self._actions))


@dataclass
class Episode:
    """What one episode did: decisions taken, return (the task's reward, before any shaping:
    ``info["unshaped_reward"]`` where a shaping wrapper provides it), whether it succeeded
    (``info["is_success"]``), whether the env truncated it, and the last step's ``info``."""

    length: int = 0
    episode_return: float = 0.0
    success: bool = False
    truncated: bool = False
    info: dict[str, Any] = field(default_factory=dict)


ResetHook = Callable[[np.ndarray, dict[str, Any]], None]
#: ``on_step(action, obs, reward, terminated, truncated, info)``, after each step.
StepHook = Callable[[Any, np.ndarray, float, bool, bool, dict[str, Any]], None]


class _HookedStep:
    """``env.step`` with the hooks of an episode: ``on_step`` after each step, and the episode
    cut after ``max_steps`` actions (reported to the actor as a truncation; ``env_truncated``
    keeps the env's own flag for the record)."""

    def __init__(self, step: Callable, on_step: StepHook | None, max_steps: int | None) -> None:
        self._step, self._on_step = step, on_step
        self._limit = sys.maxsize if max_steps is None else max_steps
        self.steps, self.env_truncated = 0, False

    def __call__(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self._step(action)
        self.steps += 1
        self.env_truncated = truncated
        if self._on_step is not None:
            self._on_step(action, obs, reward, terminated, truncated, info)
        return obs, reward, terminated, truncated or self.steps >= self._limit, info


def run_episode(
    env: gym.Env,
    actor: Actor,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    *,
    max_steps: int | None = None,
    on_reset: ResetHook | None = None,
    on_step: StepHook | None = None,
) -> Episode:
    """Run one episode of ``actor`` on ``env``: from ``env.reset(seed, options)`` until it
    terminates, truncates or has taken ``max_steps`` actions (then the actor sees it as
    truncated, and the Episode records the env's own flag)."""
    obs, info = env.reset(seed=seed, options=options)
    if on_reset is not None:
        on_reset(obs, info)
    action = actor.begin(obs)
    hooked = (
        None if on_step is None and max_steps is None else _HookedStep(env.step, on_step, max_steps)
    )
    step = env.step if hooked is None else hooked
    observe = actor.observe  # the hot loop of training: locals only, nothing more per step
    length, total = 0, 0.0
    while True:
        obs, reward, terminated, truncated, info = step(action)
        length += 1
        total += info.get("unshaped_reward", reward)
        action = observe(reward, obs, terminated, truncated)
        if terminated or truncated:
            success = bool(info.get("is_success", terminated))
            env_truncated = truncated if hooked is None else hooked.env_truncated
            return Episode(length, float(total), success, bool(env_truncated), info)
