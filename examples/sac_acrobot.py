"""SAC (Stable-Baselines3) on the continuous-torque acrobot_mj/Acrobot-v0 (``continuous=True``,
torque in [-1, 1] N m) at 0.2 s decisions, evaluated on the package's held-out starts.

    python examples/sac_acrobot.py [--steps 10000] [--seed 0] [--out DIR]

Hyperparameters: rl-zoo3 has no SAC entry for Acrobot (its Acrobot-v1 is discrete), so these are
SB3's SAC defaults (learning_rate 3e-4, buffer_size 1e6, learning_starts 100, batch_size 256,
tau 0.005, gamma 0.99, train_freq 1, gradient_steps 1, ent_coef "auto", net_arch [256, 256]),
one env. The default budget, 10,000 decisions, is what fits in about 5 minutes here (about
40 decisions per second on one shared CPU thread).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from heldout_sb3 import HeldOut, evaluate_heldout, make_env, parse_args, report, set_up_torch

HYPERPARAMETERS = {
    "learning_rate": 3e-4,
    "buffer_size": 1_000_000,
    "learning_starts": 100,
    "batch_size": 256,
    "tau": 0.005,
    "gamma": 0.99,
    "train_freq": 1,
    "gradient_steps": 1,
    "ent_coef": "auto",
    "policy": "MlpPolicy",
}


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(__doc__.splitlines()[0], 10_000, argv)
    started = time.perf_counter()
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    set_up_torch()
    from stable_baselines3 import SAC
    from stable_baselines3.common.monitor import Monitor

    hp = dict(HYPERPARAMETERS)
    env = Monitor(make_env(continuous=True))
    model = SAC(hp.pop("policy"), env, seed=args.seed, device="cpu", **hp)
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.steps)
    train_seconds = time.perf_counter() - t0

    def act(obs):
        return model.predict(obs, deterministic=True)[0]

    record = evaluate_heldout(act, continuous=True, protocol=HeldOut(episodes=args.episodes))
    if args.out is not None:
        model.save(Path(args.out) / "model.zip")
    return report("SAC", args, record, HYPERPARAMETERS, train_seconds, started, model.num_timesteps)


if __name__ == "__main__":
    main()
