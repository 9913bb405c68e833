"""The black box's two model forms on one acrobot: its exploration (seed 0), then the map and
the ODE each fitted to the first nine tenths and scored on the last (RMS error per state
variable [rad, rad/s]), as the learner chooses between them:

    python scripts/black_box_forms.py gymnasium 5000
    python scripts/black_box_forms.py ai_olympics 5000 --decision-period 0.01 --episode-decisions 20

Prints, per form, the library terms kept, the held-out RMS errors and the fit's CPU seconds.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from acrobot_mj.train.black_box import (
    BlackBoxConfig,
    black_box_env,
    explore,
    fit_model,
    fitted_share,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model", help="a shipped acrobot's name")
    parser.add_argument("decisions", type=int)
    parser.add_argument("--decision-period", type=float, default=0.05)
    parser.add_argument("--episode-decisions", type=int, default=100)
    args = parser.parse_args()
    settings = {
        "model": args.model,
        "decisions": args.decisions,
        "decision_period": args.decision_period,
        "episode_decisions": args.episode_decisions,
    }
    env = black_box_env(BlackBoxConfig(**settings))
    data = explore(env, BlackBoxConfig(**settings), 0)
    cut = fitted_share(len(data["actions"]))
    train, held = ({k: v[s] for k, v in data.items()} for s in (slice(cut), slice(cut, None)))
    fastest = np.abs(data["states"][:, 2:]).max(axis=0)
    print(f"{args.model}: {len(data['actions'])} decisions, fastest {fastest.round(1)} rad/s")
    fields = ("states", "actions", "next_states")
    for form in ("map", "ode"):
        clock = time.process_time()
        model = fit_model(train, held, BlackBoxConfig(**settings, form=form), env)
        rms = model.errors(*(held[k] for k in fields))["rms"]
        seconds = time.process_time() - clock
        print(f"{form}: {model.terms} terms, held-out RMS {np.round(rms, 7)}, {seconds:.0f} s")


if __name__ == "__main__":
    main()
