"""The ``backward`` entry (:func:`acrobot_mj.olympics.entries.backward_tree`: swing-ups
integrated backwards from upright, :mod:`acrobot_mj.control.backward`) with a library of
``PLANS`` swing-ups, in the scaled protocol's global test on the report's acrobot; how often it
enters a plan:

    python scripts/backward_tree.py 300 0,1,2
    python scripts/backward_tree.py 3000 3,4,5,6,7,8,9,10

Prints the plans' lengths, each seed's uptime and how many times a plan was entered.
"""

from __future__ import annotations

import argparse

import numpy as np

from acrobot_mj.control.backward import BackwardSettings
from acrobot_mj.control.estimator import Estimated, Observer
from acrobot_mj.control.tree import TreeController
from acrobot_mj.olympics.entries import backward_tree
from acrobot_mj.olympics.run import global_run
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.olympics.scores import uptime


class Entries:
    """``tree`` counting the times it enters a plan."""

    def __init__(self, tree: TreeController) -> None:
        self.tree, self.entered = tree, 0

    def reset(self) -> None:
        self.tree.reset()

    def __call__(self, x: np.ndarray) -> float:
        before = self.tree.plan
        torque = self.tree(x)
        self.entered += before is None and self.tree.plan is not None
        return torque


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("plans", type=int)
    parser.add_argument("seeds", help="global episodes' seeds, comma-separated")
    arguments = parser.parse_args()
    tree = backward_tree("report", BackwardSettings(count=arguments.plans))
    p = tree.funnel.trajectory.params
    plans = tree.plans[1:]  # the first is the funnel's own swing-up
    lengths = np.percentile([q.steps for q in plans], [0, 50, 100]) * p.dt
    print(f"{len(plans)} plans; lengths [s]: min, median, max {lengths.round(2).tolist()}")
    policy = protocol_for("report").global_policy
    for seed in (int(s) for s in arguments.seeds.split(",")):
        targets, times = policy.draw(np.random.default_rng(seed))
        counted = Entries(tree.fresh())
        observer = Observer(p, tree.funnel.trajectory.method)
        run = global_run(Estimated(counted, observer), "report", targets, times, policy)
        score = uptime(run, p.l1, p.l2, policy.t_final, policy.height)["score"]
        print(f"seed {seed}: uptime {score:.3f}, plans entered {counted.entered}", flush=True)


if __name__ == "__main__":
    main()
