"""Steps per second of acrobot_mj/Acrobot-v0 against Gymnasium's Acrobot-v1, side by side.

Both envs go through ``gymnasium.make`` and take the same cyclic actions; the two are timed in
alternating rounds (so load on a shared machine hits both alike) and the median round is kept.
The foundation issue keeps ``env.step`` lean; the scale issue holds the ratio to >= 8x.

    python benchmarks/env_step.py [--steps N] [--rounds R]
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
from common import interleaved, print_ratios

import acrobot_mj


def steps_per_second(env: gym.Env, steps: int) -> float:
    env.reset(seed=0)
    start = time.perf_counter()
    for i in range(steps):
        _, _, terminated, truncated, _ = env.step(i % 3)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=50_000)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    envs = {
        "gymnasium Acrobot-v1": gym.make("Acrobot-v1"),
        "acrobot_mj/Acrobot-v0": gym.make(acrobot_mj.ENV_ID),
        "acrobot_mj/Acrobot-v0 (unwrapped)": gym.make(acrobot_mj.ENV_ID).unwrapped,
    }
    rates = interleaved(
        {
            name: (lambda k, env=env: steps_per_second(env, args.steps))
            for name, env in envs.items()
        },
        args.rounds,
    )
    print_ratios(rates, "gymnasium Acrobot-v1")


if __name__ == "__main__":
    main()
