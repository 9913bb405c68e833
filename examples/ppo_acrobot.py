"""PPO (Stable-Baselines3) on acrobot_mj/Acrobot-v0 at 0.2 s decisions, evaluated on the
package's held-out starts.

    python examples/ppo_acrobot.py [--steps 100000] [--seed 0] [--out DIR]

Hyperparameters: rl-zoo3's for Gymnasium's Acrobot-v1 (hyperparams/ppo.yml): normalize (obs
and reward, VecNormalize), n_envs 16, n_steps 256, gae_lambda 0.94, gamma 0.99, n_epochs 4,
ent_coef 0.0, MlpPolicy; the zoo trains 1e6 steps, this example 1e5 by default (SB3 rounds up to
whole rollouts of 16 x 256: 102,400 decisions).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from heldout_sb3 import (
    ENV_ID,
    CosSin,
    HeldOut,
    env_kwargs,
    evaluate_heldout,
    parse_args,
    report,
    set_up_torch,
)

HYPERPARAMETERS = {
    "normalize": True,
    "n_envs": 16,
    "n_steps": 256,
    "gae_lambda": 0.94,
    "gamma": 0.99,
    "n_epochs": 4,
    "ent_coef": 0.0,
    "policy": "MlpPolicy",
}


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(__doc__.splitlines()[0], 100_000, argv)
    started = time.perf_counter()
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    set_up_torch()
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    hp = dict(HYPERPARAMETERS)
    venv = make_vec_env(
        ENV_ID,
        n_envs=hp.pop("n_envs"),
        seed=args.seed,
        env_kwargs=env_kwargs(),
        wrapper_class=CosSin,
    )
    venv = VecNormalize(venv, norm_obs=hp.pop("normalize"), norm_reward=True, gamma=hp["gamma"])
    model = PPO(hp.pop("policy"), venv, seed=args.seed, device="cpu", verbose=0, **hp)
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.steps)
    train_seconds = time.perf_counter() - t0
    venv.training = False

    def act(obs):
        return model.predict(venv.normalize_obs(obs), deterministic=True)[0]

    record = evaluate_heldout(act, protocol=HeldOut(episodes=args.episodes))
    if args.out is not None:
        model.save(Path(args.out) / "model.zip")
        venv.save(str(Path(args.out) / "vecnormalize.pkl"))
    return report("PPO", args, record, HYPERPARAMETERS, train_seconds, started, model.num_timesteps)


if __name__ == "__main__":
    main()
