"""Greedy episodes of a trained run: ``eval.json``, and videos of the greedy swing-up."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.agents.actors import Greedy
from acrobot_mj.agents.protocol import Agent
from acrobot_mj.envs.episode import run_episode
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import write_json
from acrobot_mj.report.video import record_episode
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episodes import make_env, tie_stream
from acrobot_mj.train.heldout import DEFAULT, Protocol
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.minima import compare, compute_minima, env_settings, stored_minima
from acrobot_mj.train.records import History
from acrobot_mj.train.rundir import EVAL_FILE, load_agent
from acrobot_mj.train.stats import spread
from acrobot_mj.version import versions

#: What ``evaluate`` compares with: stored per-start minima, computed ones, or none.
MINIMA = ("stored", "compute", "none")


def evaluate(run_dir: str | Path, protocol: Protocol = DEFAULT, minima: str = "stored") -> dict:
    """Greedy episodes of a trained run on its own env settings, from the held-out starts of
    ``protocol`` and, apart, from rest (the run's ``greedy_from_rest``). Writes and returns
    ``eval.json`` (see :func:`evaluate_agent`); the run directory is locked meanwhile."""
    with RunLock(Path(run_dir), "evaluate", create=False):
        return evaluate_run(run_dir, protocol, minima)


def evaluate_run(run_dir: str | Path, protocol: Protocol = DEFAULT, minima: str = "stored") -> dict:
    """:func:`evaluate` for a caller that holds the lock (of the run or of a directory above)."""
    run_dir = Path(run_dir)
    config, run_seed, agent = load_agent(run_dir)
    record = {
        "run": str(run_dir),
        "run_seed": run_seed,
        "config": config.to_dict(),
        "versions": versions(),
        **evaluate_agent(config, agent, run_seed, protocol, minima),
    }
    write_json(run_dir / EVAL_FILE, record)
    return record


def evaluate_agent(
    config: TrainConfig,
    agent: Agent,
    run_seed: int,
    protocol: Protocol = DEFAULT,
    minima: str = "stored",
) -> dict[str, Any]:
    """The held-out evaluation of ``agent``: per episode its ``start_states`` [rad, rad/s],
    ``actions`` and results, a summary by the task's score, the episode from rest apart, and
    learned / minimum per start against the references of :mod:`acrobot_mj.train.minima`
    (``minima``: ``"stored"`` where stored ones apply, ``"compute"`` them otherwise, or
    ``"none"``). Ties are broken by :func:`tie_stream` (``run_seed``, episode 0 for rest)."""
    if minima not in MINIMA:
        raise ValueError(f"minima must be one of {MINIMA}, got {minima!r}")
    env = make_env(config)
    rest = greedy_episode(env, agent, tie_stream(run_seed), {"start_noise": 0.0}, run_seed)
    starts = protocol.starts(np.array(rest["start_state"]))
    history, actions = History(), []
    for k, start in enumerate(starts):
        episode = greedy_episode(env, agent, tie_stream(run_seed, k + 1), {"state": start})
        actions.append(episode["actions"])
        history.add(episode["length"], episode["return"], episode["success"])
    record = {
        "protocol": protocol.to_dict(),
        "summary": summarise(history, config),
        "rest": rest,
        "start_states": starts.tolist(),
        "actions": actions,
        **history.to_dict(),
    }
    references = references_for(env, protocol, starts, config, minima)
    env.close()
    if references is not None:
        record["minima"] = compare(history.episode_lengths, references)
    return record


def references_for(env, protocol, starts, config, minima) -> list[int | None] | None:
    """The per-start minima ``evaluate_agent`` compares with (None: none apply or asked)."""
    if minima == "none" or env_settings(env) is None:
        return None
    stored = stored_minima(env, protocol)
    if stored is not None or minima == "stored":
        return stored
    return [m["decisions"] for m in compute_minima(env, starts, config.max_episode_steps)]


def greedy_episode(
    env: gym.Env, agent: Agent, ties: Any, options: dict[str, Any], seed: int | None = None
) -> dict[str, Any]:
    """One greedy episode from ``env.reset(seed, options)``: its start state, actions and
    result."""
    actions: list[int] = []
    starts: list[np.ndarray] = []
    episode = run_episode(
        env,
        Greedy(agent, ties),
        seed,
        options,
        on_reset=lambda obs, info: starts.append(env.unwrapped.state),
        on_step=lambda action, *_: actions.append(int(action)),
    )
    return {
        "start_state": starts[0].tolist(),
        "length": episode.length,
        "return": episode.episode_return,
        "success": episode.success,
        "actions": actions,
    }


def summarise(history: History, config: TrainConfig) -> dict[str, Any]:
    """The held-out episodes by the task's score: spread of the scores and the successes."""
    score = get_task(config.task).score
    return {
        score.quantity: spread(score.values(history.to_dict())),
        "successes": sum(history.episode_successes),
        "episodes": len(history),
    }


def distinct_outcomes(evaluations: list[dict[str, Any]]) -> dict[str, int]:
    """How many distinct greedy behaviours several runs' evaluations show: runs whose greedy
    policies take the same actions from rest (``from_rest``), or from every held-out start
    (``held_out``), count once. Seeds that collapse onto a few policies are few outcomes."""
    return {
        "from_rest": len({tuple(e["rest"]["actions"]) for e in evaluations}),
        "held_out": len({tuple(map(tuple, e["actions"])) for e in evaluations}),
    }


def render_run(
    run_dir: str | Path,
    out: str | Path,
    seed: int = 0,
    width: int = 480,
    height: int = 480,
    camera: str = "side",
    max_steps: int | None = None,
    strip: str | Path | None = None,
    captions: bool = True,
    progress: bool = False,
) -> dict[str, Any]:
    """A video of a trained run's greedy policy from rest, on the run's own env settings (the
    video and its record must not replace a file of the run; ``progress``: a bar of the
    frames on stderr)."""
    with RunLock(run_dir, "render", create=False):
        config, run_seed, agent = load_agent(run_dir)
        env = make_env(config, render_mode="rgb_array", width=width, height=height, camera=camera)
    try:
        record = record_episode(
            env,
            # Ties broken as in the run's greedy_from_rest and evaluate's episode 0.
            Greedy(agent, tie_stream(run_seed)),
            out,
            seed=seed,
            max_steps=max_steps,
            reset_options={"start_noise": 0.0},
            captions=captions,
            strip=strip,
            progress=progress,
        )
    finally:
        env.close()
    record.update(run=str(run_dir), run_seed=run_seed, policy="greedy")
    write_json(Path(out).with_suffix(".json"), record)
    return record
