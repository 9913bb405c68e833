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
import statistics
import time

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
    rates: dict[str, list[float]] = {name: [] for name in envs}
    for k in range(args.rounds):
        for name, env in envs.items():
            rates[name].append(steps_per_second(env, args.episodes, seed=k))
    base = statistics.median(rates["SARSA on Gymnasium Acrobot-v1"])
    print(f"{'training loop':<34} {'steps/s':>10} {'us/step':>8} {'ratio':>6}")
    for name, values in rates.items():
        rate = statistics.median(values)
        print(f"{name:<34} {rate:10.0f} {1e6 / rate:8.2f} {rate / base:6.2f}")


if __name__ == "__main__":
    main()
