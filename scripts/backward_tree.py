"""A global policy for the report's acrobot from swing-ups integrated backwards from upright: no
optimiser, and every plan ends at upright by construction. Each plan leaves upright (1e-3 rad
off) backwards in time under torques that, run forwards, pump energy (0.7 of ``RESERVE`` times
the sign of the elbow's velocity plus 0.3 of a random torque held 1 to 10 steps), until the
energy falls to a level drawn uniformly between hanging's and upright's; it is then rolled out
forwards from where it ended. The plans are entered as the ``tree`` entry enters its library
(TVLQR cost below the funnel's entry level), with energy pumping elsewhere, and scored by the
scaled protocol's global test:

    python scripts/backward_tree.py 300 0,1,2
    python scripts/backward_tree.py 3000 0

Prints the plans' lengths, each seed's uptime and how many times a plan was entered.
"""

from __future__ import annotations

import argparse

import numpy as np

from acrobot_mj.control.estimator import Estimated
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.control.tree import TreeController, TreeSettings
from acrobot_mj.olympics import entries
from acrobot_mj.olympics.controllers import shipped_swing_up
from acrobot_mj.olympics.run import global_run
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.olympics.scores import uptime
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import UPRIGHT, accelerations, total_energy
from acrobot_mj.physics.params import AcrobotParams

#: The plans' torque bound [N m] (the shipped plan's reserve: TVLQR keeps 0.2 N m).
RESERVE = 0.8
#: The longest plan [steps of 0.05 s].
LONGEST = 800
#: A reset is an angle jump past this [rad] between calls: at 0.05 s a step, the arm moving at
#: 9 pi rad/s turns 1.4 rad (the tree's 0.1 rad is for 0.002 s steps).
JUMP = 2.0


def back(x: np.ndarray, u: float, p: AcrobotParams) -> np.ndarray:
    """The state one semi-implicit Euler step before ``x`` under torque ``u``: ``q = q' - h
    v'``, then ``v = v' - h a(q, v, u)`` by fixed-point iteration (to rounding)."""
    h, theta = p.dt, p.lumped
    q1, q2 = x[0] - h * x[2], x[1] - h * x[3]
    w1, w2 = x[2], x[3]
    for _ in range(50):
        a1, a2 = accelerations(q1, q2, w1, w2, u, theta)
        n1, n2 = x[2] - h * a1, x[3] - h * a2
        done = abs(n1 - w1) + abs(n2 - w2) < 1e-15
        w1, w2 = n1, n2
        if done:
            break
    return np.array([q1, q2, w1, w2])


def backward_plan(rng: np.random.Generator, plan: Trajectory) -> Trajectory | None:
    """One plan on ``plan``'s model, or None where it passed 0.9 of a velocity limit, is
    shorter than 20 steps or its forward rollout ends more than 0.05 off upright."""
    p = plan.params
    x = UPRIGHT.astype(float) + np.append(rng.normal(0.0, 1e-3, 2), [0.0, 0.0])
    upright = float(total_energy(UPRIGHT[:2], UPRIGHT[2:], p))
    floor = rng.uniform(-upright, upright)
    torques: list[float] = []
    hold, noise = 0, 0.0
    while len(torques) < LONGEST and float(total_energy(x[:2], x[2:], p)) > floor:
        if hold == 0:
            hold, noise = int(rng.integers(1, 11)), rng.uniform(-RESERVE, RESERVE)
        hold -= 1
        torques.append(float(np.clip(0.7 * RESERVE * np.sign(x[3]) + 0.3 * noise, -1, 1)))
        x = back(x, torques[-1], p)
        if abs(x[2]) > 0.9 * p.max_vel1 or abs(x[3]) > 0.9 * p.max_vel2:
            return None
    if len(torques) < 20:
        return None
    forward = np.array(torques[::-1])
    states = integrators.simulate(x, forward, plan.method, p)
    if np.abs(states[-1] - UPRIGHT).max() > 0.05:
        return None
    return Trajectory(states, forward, p.dt, plan.method, p.max_torque, p)


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
    swing_up = shipped_swing_up("report")
    p, rng, plans = swing_up.params, np.random.default_rng(12345), []
    while len(plans) < arguments.plans:
        found = backward_plan(rng, swing_up)
        if found is not None:
            plans.append(found)
    lengths = np.percentile([q.steps for q in plans], [0, 50, 100]) * p.dt
    print(f"{len(plans)} plans; lengths [s]: min, median, max {lengths.round(2).tolist()}")
    funnel = entries.build("funnel", "report")  # the entry: its funnel and its estimator
    tree = TreeController(funnel.controller, plans, TreeSettings(jump=JUMP))
    policy = protocol_for("report").global_policy
    for seed in (int(s) for s in arguments.seeds.split(",")):
        targets, times = policy.draw(np.random.default_rng(seed))
        counted = Entries(tree.fresh())
        run = global_run(Estimated(counted, funnel.observer), "report", targets, times, policy)
        score = uptime(run, p.l1, p.l2, policy.t_final, policy.height)["score"]
        print(f"seed {seed}: uptime {score:.3f}, plans entered {counted.entered}", flush=True)


if __name__ == "__main__":
    main()
