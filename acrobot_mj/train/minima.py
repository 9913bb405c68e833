"""Per-start references for held-out evaluation: the minimum-time swing-up from each start.

For each held-out start the beam search of :func:`acrobot_mj.control.search.min_time_search`
finds a torque sequence that reaches the height goal; its length is an upper bound on the true
minimum (the search may miss a shorter sequence), so learned / minimum read against it is, if
anything, flattering to the learner. From rest it finds 63 decisions at frame_skip 4.

The default protocol's references on the default height-goal env (frame_skip 4, MuJoCo's Euler,
goal 1 m) are stored in ``heldout_minima.json`` beside this module (about 6 minutes to compute:
``python scripts/heldout_minima.py``); other protocols and envs compute theirs on request
(``acrobot-mj evaluate --minima``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.search import min_time_search
from acrobot_mj.train.heldout import Protocol
from acrobot_mj.train.stats import spread

STORED = Path(__file__).with_name("heldout_minima.json")
#: The analytic model's integrator for each of the env's.
METHODS = {"euler": "semi_implicit_euler", "rk4": "rk4"}


def env_settings(env: gym.Env) -> dict[str, Any] | None:
    """What the minimum-time search depends on in ``env`` (None: not a height-goal task)."""
    acrobot = env.unwrapped
    if acrobot.task.name != "height_goal":
        return None
    return {
        "frame_skip": acrobot.frame_skip,
        "integrator": acrobot.integrator,
        "goal_height": acrobot.task.goal_height,
    }


def compute_minima(
    env: gym.Env, starts: np.ndarray, max_decisions: int, width: int = 20_000
) -> list[dict[str, Any]]:
    """The beam search from each start on ``env``'s settings: decisions (None if the goal was
    not reached within ``max_decisions``) and actions."""
    settings = env_settings(env)
    if settings is None:
        raise ValueError(
            f"per-start minima exist for the height goal only, not {env.unwrapped.task.name!r}"
        )
    found = []
    for start in np.asarray(starts, dtype=np.float64):
        result = min_time_search(
            frame_skip=settings["frame_skip"],
            width=width,
            method=METHODS[settings["integrator"]],
            max_decisions=max_decisions,
            goal_height=settings["goal_height"],
            start=start,
        )
        found.append({"decisions": result.decisions, "actions": result.actions})
    return found


def stored_minima(env: gym.Env, protocol: Protocol) -> list[int] | None:
    """The stored per-start minima if they are for ``protocol`` and ``env``'s settings, else
    None."""
    stored = json.loads(STORED.read_text())
    if stored["protocol"] != protocol.to_dict() or stored["env"] != env_settings(env):
        return None
    return [entry["decisions"] for entry in stored["starts"]]


def compare(lengths: list[int], minima: list[int | None]) -> dict[str, Any]:
    """Learned / minimum per start (starts without a reference are left out, and counted)."""
    if len(lengths) != len(minima):
        raise ValueError(f"{len(lengths)} episodes but {len(minima)} per-start minima")
    pairs = [(n, m) for n, m in zip(lengths, minima, strict=True) if m]
    return {
        "per_start": minima,
        "minimum": spread([m for _, m in pairs]),
        "ratio": spread([n / m for n, m in pairs]),
        "without_reference": len(lengths) - len(pairs),
    }
