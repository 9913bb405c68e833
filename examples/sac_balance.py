"""SAC (Stable-Baselines3) on the balance task, acrobot_mj/AcrobotBalance-v0 with continuous
torques in [-1, 1] N m at 0.2 s decisions: a model-free baseline for the ``balance`` preset
(docs/guide/balance.md), evaluated from the same held-out starts.

    python examples/sac_balance.py [--steps 20000] [--seed 0] [--out DIR] [--episodes 100]

Hyperparameters: SB3's SAC defaults, as examples/sac_acrobot.py. Training starts: rest plus
U(-0.05, 0.05), from the env's own np_random. Evaluation: the deterministic policy from rest and
from the held-out starts of the balance results (rest plus U(-0.01, 0.01), the held-out seed
branch), each for the task's 100 s (500 decisions). An episode counts as balanced if both angles
stay within the task's 0.05 rad of upright for its last 60 s (the report's objective); the record
also gives each episode's return (at most 1 per physics step) and its longest time balanced.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from heldout_sb3 import CosSin, HeldOut, parse_args, report, set_up_torch
from sac_acrobot import HYPERPARAMETERS

from acrobot_mj.envs.tasks import Balance
from acrobot_mj.train.balance_preset import PlanLearner
from acrobot_mj.train.records import spread

FRAME_SKIP = 4
#: Decisions in the last 60 s of an episode (0.2 s each).
LAST_60_S = 300


def make_env(start_noise: float) -> gym.Env:
    env = gym.make(
        Balance.env_id,
        continuous=True,
        frame_skip=FRAME_SKIP,
        start_noise=start_noise,
        max_episode_steps=500,
    )
    return CosSin(env)


def episode(env: gym.Env, act, start: np.ndarray) -> dict:
    """One deterministic episode from the exact ``start``."""
    obs, _ = env.reset(options={"state": start})
    actions, balanced, total, truncated = [], [], 0.0, False
    while not truncated:
        action = np.asarray(act(obs), dtype=np.float32).reshape(1)
        obs, reward, _, truncated, info = env.step(action)
        actions.append(float(action[0]))
        balanced.append(bool(info["is_balanced"]))
        total += float(reward)
    runs = np.diff(np.flatnonzero(np.diff([0, *balanced, 0])))[::2]  # lengths of balanced runs
    return {
        "start_state": [float(v) for v in start],
        "length": len(actions),
        "actions": actions,
        "return": total,
        "balanced": all(balanced[-LAST_60_S:]),
        "longest_balanced_seconds": float(runs.max() * 0.2) if runs.size else 0.0,
    }


def evaluate(act, protocol: HeldOut) -> dict:
    env = make_env(0.0)
    rest = episode(env, act, np.array([-np.pi / 2, 0.0, 0.0, 0.0]))
    starts = protocol.starts(np.array(rest["start_state"]))
    episodes = [episode(env, act, s) for s in starts]
    env.close()
    return {
        "protocol": protocol.to_dict(),
        "env": {"id": Balance.env_id, "frame_skip": FRAME_SKIP, "continuous": True},
        "summary": {
            "balanced": sum(e["balanced"] for e in episodes),
            "episodes": len(episodes),
            "return": spread([e["return"] for e in episodes]),
            "longest_balanced_seconds": spread([e["longest_balanced_seconds"] for e in episodes]),
            "successes": sum(e["balanced"] for e in episodes),
            "decisions": spread([len(e["actions"]) for e in episodes]),
        },
        "rest": rest,
        "start_states": starts.tolist(),
        "actions": [e["actions"] for e in episodes],
        "episode_lengths": [len(e["actions"]) for e in episodes],
        "episode_returns": [e["return"] for e in episodes],
        "episode_successes": [e["balanced"] for e in episodes],
    }


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(__doc__.splitlines()[0], 20_000, argv)
    started = time.perf_counter()
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    set_up_torch()
    from stable_baselines3 import SAC
    from stable_baselines3.common.monitor import Monitor

    hp = dict(HYPERPARAMETERS)
    model = SAC(hp.pop("policy"), Monitor(make_env(0.05)), seed=args.seed, device="cpu", **hp)
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.steps)
    train_seconds = time.perf_counter() - t0

    def act(obs):
        return model.predict(obs, deterministic=True)[0]

    protocol = HeldOut(episodes=args.episodes, start_noise=PlanLearner.protocol.start_noise)
    record = evaluate(act, protocol)
    if args.out is not None:
        model.save(Path(args.out) / "model.zip")
    record = report(
        "SAC (balance)", args, record, HYPERPARAMETERS, train_seconds, started, model.num_timesteps
    )
    summary = record["summary"]
    print(
        f"balanced for the last 60 s: {summary['balanced']}/{summary['episodes']} held-out starts; "
        f"return median {summary['return']['median']:.1f}; longest balanced median "
        f"{summary['longest_balanced_seconds']['median']:g} s"
    )
    return record


if __name__ == "__main__":
    main()
