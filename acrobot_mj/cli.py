"""Command line: ``acrobot-mj demo | params``. A thin layer over the library."""

from __future__ import annotations

import argparse
import json
import platform
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

import acrobot_mj
from acrobot_mj.params import describe
from acrobot_mj.policies import POLICY_NAMES, make_policy, run_episode


def versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on."""
    return {
        "python": platform.python_version(),
        "acrobot_mj": acrobot_mj.__version__,
        "mujoco": mujoco.__version__,
        "gymnasium": gym.__version__,
        "numpy": np.__version__,
    }


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def demo(args: argparse.Namespace) -> dict[str, Any]:
    """Roll out a fixed policy from rest and print the state as it goes."""
    env = gym.make(acrobot_mj.ENV_ID, frame_skip=args.frame_skip, integrator=args.integrator)
    policy = make_policy(args.policy, args.seed)
    episode = run_episode(env, policy, seed=args.seed, max_steps=args.steps)
    dt = env.unwrapped.dt
    print(
        f"policy {args.policy}, frame_skip {args.frame_skip} ({dt:g} s per action), "
        f"integrator {args.integrator}"
    )
    print(f"{'step':>5} {'t [s]':>7} {'q1':>8} {'q2':>8} {'dq1':>8} {'dq2':>8} {'tip [m]':>8}")
    last = episode.length
    for k, (state, tip) in enumerate(zip(episode.states, episode.tip_heights, strict=True)):
        if k % args.every == 0 or k == last:
            print(f"{k:5d} {k * dt:7.2f} " + " ".join(f"{v:8.3f}" for v in state) + f" {tip:8.3f}")
    outcome = "reached the goal" if episode.success else "did not reach the goal"
    print(
        f"{outcome} after {episode.length} actions ({episode.length * dt:.2f} s), "
        f"return {episode.episode_return:g}"
    )
    record = {
        "command": "demo",
        "config": {k: v for k, v in vars(args).items() if k not in ("func", "json")},
        "seed": args.seed,
        "versions": versions(),
        "episode_lengths": [episode.length],
        "episode_returns": [episode.episode_return],
        "episode_successes": [episode.success],
        "episodes": [episode.to_dict()],
    }
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(record, indent=1))
        print(f"wrote {args.json}")
    return record


def params(args: argparse.Namespace) -> None:
    """Print the physical parameters with units and sources."""
    print(describe())


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="acrobot-mj", description=__doc__)
    parser.add_argument("--version", action="version", version=acrobot_mj.__version__)
    commands = parser.add_subparsers(dest="command", required=True)

    p = commands.add_parser("demo", help="roll out a fixed policy from rest, print the states")
    p.add_argument(
        "--policy",
        choices=POLICY_NAMES,
        default="pump",
        help="pump: tau = -sign(dq1); zero: no torque; random: uniform (seeded)",
    )
    p.add_argument("--steps", type=_positive_int, default=1000, help="most actions to take")
    p.add_argument("--seed", type=int, default=0, help="seed of the env and the random policy")
    p.add_argument("--frame-skip", type=_positive_int, default=1, help="physics steps per action")
    p.add_argument("--integrator", choices=("euler", "rk4"), default="euler")
    p.add_argument("--every", type=_positive_int, default=20, help="print every N-th state")
    p.add_argument("--json", metavar="FILE", help="also write the run record as JSON")
    p.set_defaults(func=demo)

    p = commands.add_parser("params", help="print the physical parameters, units and sources")
    p.set_defaults(func=params)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    args.func(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
