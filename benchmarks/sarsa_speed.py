"""Report-preset tabular SARSA training: steps per second on acrobot_mj/Acrobot-v0 against the
same SARSA on Gymnasium's Acrobot-v1, measured side by side.

Both go through ``gymnasium.make`` and ``acrobot_mj.training.learn_episode`` with the same agent
(the report's 5x5x3x3 grid, alpha 0.5, epsilon 0.001, gamma 1). Acrobot-v1 observes cos/sin of
the angles, so it runs under ``acrobot_mj.compat.ReportObservation`` (two atan2 per step), the
cheapest way to give it the same observations. Rounds alternate between the two, so load on a
shared machine hits both alike; the median round is kept. Target (learning issue): >= 5x.

    python benchmarks/sarsa_speed.py [--episodes N] [--rounds R]
"""

from __future__ import annotations

import argparse
import time

from common import interleaved, print_ratios

import acrobot_mj  # noqa: F401  (registers the env)
from acrobot_mj.compat import make_gymnasium_acrobot
from acrobot_mj.config import PRESETS
from acrobot_mj.training import learn_episode, make_env


def steps_per_second(env, episodes: int, seed: int) -> float:
    agent = PRESETS["report"].make_agent(seed=seed)
    steps, start = 0, time.perf_counter()
    for episode in range(episodes):
        steps += learn_episode(env, agent, seed=episode)[0]
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20, help="1000-step episodes per round")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    envs = {
        "SARSA on Gymnasium Acrobot-v1": make_gymnasium_acrobot(max_episode_steps=1000),
        "SARSA on acrobot_mj/Acrobot-v0": make_env(PRESETS["report"]),
    }
    rates = interleaved(
        {
            name: (lambda k, env=env: steps_per_second(env, args.episodes, seed=k))
            for name, env in envs.items()
        },
        args.rounds,
    )
    print_ratios(rates, "SARSA on Gymnasium Acrobot-v1")


if __name__ == "__main__":
    main()
