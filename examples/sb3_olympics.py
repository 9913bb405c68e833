"""SAC (Stable-Baselines3) trained on the AI Olympics acrobot, then scored by the protocol as
any controller is: the saved policy file goes to ``acrobot-mj olympics``.

    python examples/sb3_olympics.py [--steps 100000] [--seed 0] [--out DIR]
        [--scores performance,global] [--jobs 1]

Training: SB3's SAC defaults on ``acrobot_mj/AcrobotBalanceRLContinuous-v0`` with
``model="ai_olympics"`` (torques in [-6, 6] N m decided every 4 steps of 0.002 s, float32
cos/sin observations, starts at rest plus U(-0.1, 0.1), the balance task's reward in [0, 1] a
decision, 500 decisions an episode). The policy is ``DIR/policy.zip``; the protocol's record
``DIR/olympics/olympics.json``, written by ``acrobot-mj olympics DIR/policy.zip`` (the policy
file's env defaults to this id on ``--model``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import gymnasium as gym
from stable_baselines3 import SAC

sys.path.insert(0, str(Path(__file__).resolve().parent))

from heldout_sb3 import set_up_torch

import acrobot_mj  # noqa: F401  registers the ids
from acrobot_mj.cli import main as acrobot_mj_main
from acrobot_mj.olympics.sources import POLICY_ENV

MODEL = "ai_olympics"


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000, help="training decisions")
    parser.add_argument("--seed", type=int, default=0, help="training seed")
    parser.add_argument("--out", type=Path, default=Path("runs/sb3-olympics"))
    parser.add_argument("--scores", default="performance,global", help="the protocol's parts")
    parser.add_argument("--jobs", default="1", help="processes for the robustness episodes")
    args = parser.parse_args(argv)
    set_up_torch()
    started = time.perf_counter()
    with gym.make(POLICY_ENV, model=MODEL) as env:
        model = SAC("MlpPolicy", env, seed=args.seed, verbose=0)
        model.learn(args.steps)
    args.out.mkdir(parents=True, exist_ok=True)
    model.save(args.out / "policy.zip")
    trained = time.perf_counter() - started
    out = args.out / "olympics"
    argv = ["olympics", str(args.out / "policy.zip"), "--model", MODEL, "--scores", args.scores]
    acrobot_mj_main([*argv, "--jobs", args.jobs, "--out", str(out), "--force", "--no-progress"])
    record = json.loads((out / "olympics.json").read_text())
    print(f"SAC, {args.steps} decisions, seed {args.seed}: trained in {trained:.0f} s")
    return record


if __name__ == "__main__":
    main()
