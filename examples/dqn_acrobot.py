"""DQN (Stable-Baselines3) on acrobot_mj/Acrobot-v0 at 0.2 s decisions, evaluated on the
package's held-out starts.

    python examples/dqn_acrobot.py [--steps 100000] [--seed 0] [--out DIR]

Hyperparameters: rl-zoo3's for Gymnasium's Acrobot-v1 (hyperparams/dqn.yml): n_timesteps 1e5,
learning_rate 6.3e-4, batch_size 128, buffer_size 50000, learning_starts 0, gamma 0.99,
target_update_interval 250, train_freq 4, gradient_steps -1, exploration_fraction 0.12,
exploration_final_eps 0.1, net_arch [256, 256], MlpPolicy, one env.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from heldout_sb3 import HeldOut, evaluate_heldout, make_env, parse_args, report, set_up_torch

HYPERPARAMETERS = {
    "learning_rate": 6.3e-4,
    "batch_size": 128,
    "buffer_size": 50_000,
    "learning_starts": 0,
    "gamma": 0.99,
    "target_update_interval": 250,
    "train_freq": 4,
    "gradient_steps": -1,
    "exploration_fraction": 0.12,
    "exploration_final_eps": 0.1,
    "policy_kwargs": {"net_arch": [256, 256]},
    "policy": "MlpPolicy",
}


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(__doc__.splitlines()[0], 100_000, argv)
    started = time.perf_counter()
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    set_up_torch()
    from stable_baselines3 import DQN
    from stable_baselines3.common.monitor import Monitor

    hp = dict(HYPERPARAMETERS)
    # The env's np_random is seeded by SB3 from --seed (training starts: rest + U(-0.05, 0.05)).
    model = DQN(hp.pop("policy"), Monitor(make_env()), seed=args.seed, device="cpu", **hp)
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.steps)
    train_seconds = time.perf_counter() - t0

    def act(obs):
        return model.predict(obs, deterministic=True)[0]

    record = evaluate_heldout(act, protocol=HeldOut(episodes=args.episodes))
    if args.out is not None:
        model.save(Path(args.out) / "model.zip")
    return report("DQN", args, record, HYPERPARAMETERS, train_seconds, started, model.num_timesteps)


if __name__ == "__main__":
    main()
