"""The ``backward`` entry (:func:`acrobot_mj.olympics.entries.backward`: swing-ups integrated
backwards from upright, :mod:`acrobot_mj.control.backward`) with a set of ``PLANS`` swing-ups,
in the scaled protocol's global test on the report's acrobot; how often it enters a plan:

    python scripts/backward_tree.py 300 0,1,2
    python scripts/backward_tree.py 3000 3,4,5,6,7,8,9,10

Prints the plans' lengths, each seed's uptime and how many times a plan was entered.
"""

from __future__ import annotations

import argparse

import numpy as np

from acrobot_mj.control.backward import BackwardSettings, backward_library
from acrobot_mj.control.controller import Controller
from acrobot_mj.control.planned import planned_swing_up
from acrobot_mj.control.tracker import PlanTracker
from acrobot_mj.olympics.entries import backward
from acrobot_mj.olympics.episodes import global_run
from acrobot_mj.olympics.plants import equations
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.olympics.scores import uptime


class Entries(Controller):
    """``tracker`` counting the times it enters a plan."""

    def __init__(self, tracker: PlanTracker) -> None:
        self.tracker, self.entered = tracker, 0

    def reset(self, seed: int | None = None) -> None:
        self.tracker.reset(seed)

    def act(self, x: np.ndarray, t: float) -> float:
        before = self.tracker.following
        torque = self.tracker.act(x, t)
        self.entered += before is None and self.tracker.following is not None
        return torque


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("plans", type=int)
    parser.add_argument("seeds", help="global episodes' seeds, comma-separated")
    arguments = parser.parse_args()
    swing_up = planned_swing_up("report")
    p = swing_up.params
    plans = backward_library(p, swing_up.method, BackwardSettings(count=arguments.plans))
    lengths = np.percentile([q.steps for q in plans], [0, 50, 100]) * p.dt
    print(f"{len(plans)} plans; lengths [s]: min, median, max {lengths.round(2).tolist()}")
    policy = protocol_for("report").global_policy
    for seed in (int(s) for s in arguments.seeds.split(",")):
        targets, times = policy.draw(seed)
        plant = equations("report")
        counted = Entries(backward(plant, plans))
        run = global_run(plant.estimated(counted), "report", targets, times, policy)
        score = uptime(run, p.l1, p.l2, policy.t_final, policy.height)["score"]
        print(f"seed {seed}: uptime {score:.3f}, plans entered {counted.entered}", flush=True)


if __name__ == "__main__":
    main()
