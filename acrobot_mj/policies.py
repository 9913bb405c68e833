"""Fixed baseline policies and a one-episode rollout, for demos and smoke tests.

These are not learners (see ``agents/``) nor the model-based controllers of ``control.py``: they are
simple reference behaviours that need no training.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

#: A policy maps an observation ``(q1, q2, dq1, dq2)`` to a ``Discrete(3)`` action.
Policy = Callable[[np.ndarray], int]


def zero_policy(obs: np.ndarray) -> int:
    """No torque: the acrobot stays hanging at rest."""
    return 1


def pump_policy(obs: np.ndarray) -> int:
    """Bang-bang energy pumping, ``tau = -sign(dq1)`` [N m].

    A demo heuristic found by trying the four sign laws on ``dq1`` and ``dq2``: from rest it
    reaches the goal in 300 steps at frame_skip 1 and 96 decisions at frame_skip 4.
    """
    return 0 if obs[2] > 0 else 2


def random_policy(seed: int | None = None) -> Policy:
    """Uniformly random actions from its own generator (seeded)."""
    rng = np.random.default_rng(seed)
    return lambda obs: int(rng.integers(3))


def make_policy(name: str, seed: int | None = None) -> Policy:
    """The policy called ``name``: one of :data:`POLICY_NAMES`."""
    if name == "zero":
        return zero_policy
    if name == "pump":
        return pump_policy
    if name == "random":
        return random_policy(seed)
    raise ValueError(f"unknown policy {name!r}; choose one of {POLICY_NAMES}")


POLICY_NAMES = ("pump", "zero", "random")


@dataclass
class Episode:
    """One episode: ``states`` has one row per observation, the reset one first."""

    length: int
    episode_return: float
    success: bool
    truncated: bool
    states: list[list[float]] = field(default_factory=list)
    tip_heights: list[float] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_episode(
    env: gym.Env, policy: Policy, seed: int | None = None, max_steps: int | None = None
) -> Episode:
    """Run ``policy`` for one episode (until termination, truncation or ``max_steps``)."""
    obs, info = env.reset(seed=seed)
    episode = Episode(0, 0.0, False, False, [obs.tolist()], [info["tip_height"]])
    while max_steps is None or episode.length < max_steps:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        episode.length += 1
        episode.episode_return += float(reward)
        episode.states.append(obs.tolist())
        episode.tip_heights.append(info["tip_height"])
        if terminated or truncated:
            episode.success, episode.truncated = bool(info["is_success"]), bool(truncated)
            break
    return episode
