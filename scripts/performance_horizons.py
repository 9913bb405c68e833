"""The performance score of planned swing-ups against their length: for each number of
decisions (torques held 0.01 s), the swing-up that the performance planner finds on the
ai_olympics acrobot, scored as an episode that stays at upright at rest with no torque after it
(the funnel entry's own episode scores the same: 0.6882 for the shipped 200):

    python scripts/performance_horizons.py 150 200 250

Prints each plan's criteria, its v2 score and the planning time.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from acrobot_mj.olympics.protocol import PERFORMANCE, episode_times
from acrobot_mj.olympics.scores import Recording, performance
from acrobot_mj.olympics.swing_ups import performance_swing_up
from acrobot_mj.physics.dynamics import UPRIGHT
from acrobot_mj.physics.models import MODELS


def held_after(states: np.ndarray, torques: np.ndarray) -> Recording:
    """The protocol's episode of ``PERFORMANCE.t_final`` that follows the plan, then stays at
    upright at rest with no torque."""
    times = episode_times(PERFORMANCE.t_final)
    steps = len(times) - 1
    X, U = np.tile(UPRIGHT, (steps + 1, 1)), np.zeros(steps)
    X[: len(states)], U[: len(torques)] = states, torques
    return Recording(times, X, U)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("decisions", type=int, nargs="+", help="torques held 0.01 s")
    model = MODELS["ai_olympics"]
    for decisions in parser.parse_args().decisions:
        start = time.process_time()
        plan = performance_swing_up(model, decisions=decisions, hold=5)
        lengths = model.params.l1, model.params.l2
        scores = performance(held_after(plan.states, plan.torques), *lengths)
        shown = {k: round(v, 4) if isinstance(v, float) else v for k, v in scores.items()}
        print(decisions, shown, f"{time.process_time() - start:.0f} s CPU", flush=True)


if __name__ == "__main__":
    main()
