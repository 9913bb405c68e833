"""Write ``acrobot_mj/train/heldout_minima.json``: the minimum-time search from each start of the
default held-out protocol on the default height-goal env (frame_skip 4, MuJoCo's Euler, goal 1 m).

    python scripts/heldout_minima.py        # about 6 minutes on one core
"""

from __future__ import annotations

import time

from acrobot_mj.files import write_json
from acrobot_mj.train.evaluate import STORED, compute_minima, env_settings
from acrobot_mj.train.learners import DEFAULT, make_env
from acrobot_mj.train.presets import PRESETS


def main() -> None:
    config = PRESETS["book"]
    env = make_env(config)
    env.reset(options={"start_noise": 0.0})
    rest = env.unwrapped.state
    starts = DEFAULT.starts(rest)
    began = time.perf_counter()
    found = compute_minima(env, starts, config.max_episode_steps)
    write_json(
        STORED,
        {
            "about": "beam search (acrobot_mj.control.search.min_time_search, width 20000) "
            "from each held-out start: an upper bound on the minimum decisions to the goal",
            "protocol": DEFAULT.to_dict(),
            "env": env_settings(env),
            "rest": rest.tolist(),
            "seconds": round(time.perf_counter() - began, 1),
            "starts": [{"state": s.tolist(), **f} for s, f in zip(starts, found, strict=True)],
        },
    )
    print(f"wrote {STORED}: {[f['decisions'] for f in found]}")


if __name__ == "__main__":
    main()
