"""The one episode loop (:func:`run_episode`) that training, evaluation, videos, replays and
fixed policies run their episodes through, and the :class:`Actor` that chooses the actions.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, cast

import gymnasium as gym
import numpy as np

from acrobot_mj.stops import SafePoints, check_stop

if TYPE_CHECKING:  # not at run time: MuJoCo loads with the env
    from acrobot_mj.envs.acrobot import AcrobotEnv

#: A policy maps an observation ``(q1, q2, dq1, dq2)`` to an action of the env's space.
Policy = Callable[[np.ndarray], Any]


class Actor(Protocol):
    """What chooses the actions of an episode (a learner learns in ``observe``)."""

    def begin(self, obs: np.ndarray) -> Any:
        """The first action, from the reset observation."""

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        """See one step's outcome; the next action (unused once the episode is over)."""


class PolicyActor:
    """A fixed policy as an actor, asked only for actions that will be taken."""

    def __init__(self, policy: Policy) -> None:
        self.begin = self._policy = policy

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        return None if terminated or truncated else self._policy(obs)


class SequenceActor(PolicyActor):
    """Plays a fixed sequence of actions (cut longer episodes with ``max_steps``)."""

    def __init__(self, actions: Sequence[Any]) -> None:
        self._actions = iter(actions)
        super().__init__(lambda obs: next(self._actions))


def acrobot_of(env: gym.Env) -> AcrobotEnv:
    """``env.unwrapped``: the :class:`~acrobot_mj.envs.acrobot.AcrobotEnv` under ``env``'s
    wrappers, typed as one for type checkers (nothing is checked at run time)."""
    return cast("AcrobotEnv", env.unwrapped)


@dataclass
class Episode:
    """What one episode did: decisions, return (before shaping: ``info["unshaped_reward"]``
    where given), success (``info["is_success"]``), the env's truncation and the last ``info``."""

    length: int = 0
    episode_return: float = 0.0
    success: bool = False
    truncated: bool = False
    info: dict[str, Any] = field(default_factory=dict)


ResetHook = Callable[[np.ndarray, dict[str, Any]], None]
#: ``on_step(action, obs, reward, terminated, truncated, info)``, after each step.
StepHook = Callable[[Any, np.ndarray, float, bool, bool, dict[str, Any]], None]


@dataclass(frozen=True)
class Hooks:
    """What watches an episode: ``on_reset(obs, info)`` after the reset, ``on_step(action, obs,
    reward, terminated, truncated, info)`` after each step (None: nothing), and ``stops``, whose
    held stop signals are acted on after each step the actor has seen (a stop raised there
    cuts the episode short)."""

    on_reset: ResetHook | None = None
    on_step: StepHook | None = None
    stops: SafePoints | None = None


#: An episode nothing watches.
UNWATCHED = Hooks()


def run_episode(
    env: gym.Env,
    actor: Actor,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    *,
    max_steps: int | None = None,
    hooks: Hooks = UNWATCHED,
) -> Episode:
    """Run one episode of ``actor`` on ``env`` from ``env.reset(seed, options)`` until it ends
    or has taken ``max_steps`` actions (the actor sees a truncation; the Episode the env's
    flag); ``hooks`` see the reset and each step, and act on held stops after it."""
    check_stop()  # a stop that numba's loader dropped: taken between episodes
    obs, info = env.reset(seed=seed, options=options)
    if hooks.on_reset is not None:
        hooks.on_reset(obs, info)
    action = actor.begin(obs)
    # Training's hot loop: locals only. Rewards are floats here (Gymnasium: any SupportsFloat).
    step = cast("Callable[[Any], tuple[Any, float, bool, bool, dict[str, Any]]]", env.step)
    observe, on_step = actor.observe, hooks.on_step
    limit = sys.maxsize if max_steps is None else max_steps
    stops = hooks.stops
    held = () if stops is None else stops.held  # checked each step: a list, empty until a stop
    length, total = 0, 0.0
    while True:
        obs, reward, terminated, env_truncated, info = step(action)
        length += 1
        if on_step is not None:
            on_step(action, obs, reward, terminated, env_truncated, info)
        total += info.get("unshaped_reward", reward)
        truncated = env_truncated or length >= limit
        action = observe(reward, obs, terminated, truncated)
        if held:
            stops.check()  # type: ignore[union-attr]  # held is () without stops
        if terminated or truncated:
            success = bool(info.get("is_success", terminated))
            return Episode(length, float(total), success, bool(env_truncated), info)


#: The reset options of an episode from rest: the task's start, without start noise.
FROM_REST = {"start_noise": 0.0}


def run_from_rest(env: gym.Env, actor: Actor, seed: int | None = None, **hooks: Any) -> Episode:
    """:func:`run_episode` of ``actor`` on ``env`` from rest (:data:`FROM_REST`): the greedy
    episode a run records, assesses and evaluates from rest."""
    return run_episode(env, actor, seed, dict(FROM_REST), **hooks)
