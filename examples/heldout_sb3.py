"""Shared pieces of the Stable-Baselines3 examples: the env, the command line, and the package's
held-out evaluation of a deterministic SB3 policy (one definition for every example).

Not part of the package (the package never imports ``examples``). The evaluation follows
``acrobot_mj.train.evaluate``: an episode from rest (reported apart), then one episode from each
of ``HeldOut().starts(rest)`` (100 starts: rest plus U(-0.05, 0.05) on each of q1, q2, dq1, dq2,
drawn from the held-out seed branch that no training draw uses), each started exactly with
``env.reset(options={"state": s})``. The record (``eval.json``) holds ``start_states``,
``actions``, ``episode_lengths`` and ``episode_successes``, so every episode can be replayed.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import acrobot_mj  # registers acrobot_mj/Acrobot-v0
from acrobot_mj.envs.wrappers import CosSinObservation
from acrobot_mj.files import write_json
from acrobot_mj.train.evaluate import compare, stored_minima
from acrobot_mj.train.learners import DEFAULT, HeldOut
from acrobot_mj.train.records import spread

ENV_ID = acrobot_mj.ENV_ID
#: 0.2 s decisions, as the package's ``book`` preset.
FRAME_SKIP = 4
#: Training starts: rest plus U(-0.05, 0.05) on each angle and velocity, drawn by the env's own
#: np_random (seeded by SB3 from the training seed; never the held-out branch). From exact rest
#: a greedy policy that picks zero torque never moves (rest is an equilibrium).
TRAIN_START_NOISE = 0.05


def CosSin(env: gym.Env) -> gym.Env:
    """Observe (cos q1, sin q1, cos q2, sin q2, dq1, dq2), as Gymnasium's Acrobot-v1 does, in
    float64 (the examples' measurements were made so). The wrapped env's state and reset
    options are kept."""
    return CosSinObservation(env, dtype=np.float64)


def env_kwargs(continuous: bool = False, start_noise: float = TRAIN_START_NOISE) -> dict:
    return {"frame_skip": FRAME_SKIP, "continuous": continuous, "start_noise": start_noise}


def make_env(continuous: bool = False, start_noise: float = TRAIN_START_NOISE) -> gym.Env:
    """One env as the examples train and evaluate on (CosSin observations)."""
    return CosSin(gym.make(ENV_ID, **env_kwargs(continuous, start_noise)))


def parse_args(
    description: str, default_steps: int, argv: list[str] | None = None
) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--steps", type=int, default=default_steps, help="training decisions")
    parser.add_argument("--seed", type=int, default=0, help="training seed")
    parser.add_argument("--out", type=Path, default=None, help="directory for eval.json, model")
    parser.add_argument(
        "--episodes", type=int, default=DEFAULT.episodes, help="held-out starts (default 100)"
    )
    return parser.parse_args(argv)


def set_up_torch() -> None:
    import torch

    torch.set_num_threads(1)


def evaluate_heldout(
    act: Callable[[np.ndarray], Any],
    continuous: bool = False,
    protocol: HeldOut = DEFAULT,
) -> dict[str, Any]:
    """``act`` (observation -> action, deterministic) from rest and from every held-out start of
    ``protocol``: per-episode start states, actions, lengths (decisions; 1000 = goal not
    reached) and successes, their spread, and learned / minimum against the stored per-start
    minima (63 decisions from every start of the default protocol)."""
    env = make_env(continuous, start_noise=0.0)
    rest = episode(env, act, {"start_noise": 0.0}, continuous)
    starts = protocol.starts(np.array(rest["start_state"]))
    episodes = [episode(env, act, {"state": s}, continuous) for s in starts]
    lengths = [e["length"] for e in episodes]
    successes = [e["success"] for e in episodes]
    record = {
        "protocol": protocol.to_dict(),
        "env": {"id": ENV_ID, **env_kwargs(continuous, 0.0), "observation": "CosSin"},
        "summary": {
            "decisions": spread(lengths),
            "successes": sum(successes),
            "episodes": len(episodes),
        },
        "rest": rest,
        "start_states": starts.tolist(),
        "actions": [e["actions"] for e in episodes],
        "episode_lengths": lengths,
        "episode_returns": [e["return"] for e in episodes],
        "episode_successes": successes,
    }
    minima = stored_minima(env, protocol)
    if minima is not None:
        record["minima"] = compare(lengths, minima)
    env.close()
    return record


def episode(env: gym.Env, act, options: dict[str, Any], continuous: bool) -> dict[str, Any]:
    """One deterministic episode from ``env.reset(options=options)``."""
    obs, info = env.reset(options=options)
    start = env.unwrapped.state.tolist()
    actions, total, terminated, truncated = [], 0.0, False, False
    while not (terminated or truncated):
        action = act(obs)
        action = np.asarray(action, dtype=np.float32).reshape(1) if continuous else int(action)
        obs, reward, terminated, truncated, info = env.step(action)
        actions.append(float(action[0]) if continuous else action)
        total += float(reward)
    return {
        "start_state": start,
        "length": len(actions),
        "return": total,
        "success": bool(info.get("is_success", False)),
        "actions": actions,
    }


def report(
    learner: str,
    args: argparse.Namespace,
    record: dict[str, Any],
    hyperparameters: dict[str, Any],
    train_seconds: float,
    started: float,
    decisions: int,
) -> dict[str, Any]:
    """Add the run's settings to ``record``, write ``eval.json`` under ``--out`` and print one
    summary line. ``decisions``: the training decisions SB3 took (``model.num_timesteps``; PPO
    rounds ``--steps`` up to whole rollouts)."""
    record = {
        "learner": learner,
        "seed": args.seed,
        "steps_asked": args.steps,
        "training_decisions": decisions,
        "train_start_noise": TRAIN_START_NOISE,
        "hyperparameters": hyperparameters,
        "train_seconds": round(train_seconds, 1),
        "wall_seconds": round(time.perf_counter() - started, 1),
        **record,
    }
    if args.out is not None:
        write_json(Path(args.out) / "eval.json", record)
    median = record["summary"]["decisions"]["median"]
    ratio = record.get("minima", {}).get("ratio", {}).get("median")
    print(
        f"{learner} seed {args.seed}: {decisions} decisions, held-out median {median:g}"
        + (f" ({ratio:.2f} x minimum)" if ratio is not None else "")
        + f", successes {record['summary']['successes']}/{record['summary']['episodes']}"
        f", rest {record['rest']['length']}, train {train_seconds:.0f} s"
        f", wall {record['wall_seconds']:.0f} s"
    )
    return record
