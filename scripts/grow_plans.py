"""The ``tree`` entry's plan set (:class:`~acrobot_mj.control.plans.PlanSet`), grown offline
on the global policy's episodes of seeds the evaluation does not use (1000 and up): the
entry's tracker runs each episode, and wherever it can enter no plan within the energy window,
a swing-up is planned there (:class:`~acrobot_mj.control.replan.Planner`, CasADi: the
``control`` extra), warm-started from the nearest plan, and joins the set. Run

    python scripts/grow_plans.py SEED COUNT [MINUTES [PATH]]

to grow the shipped file (or the set at ``PATH``, a new one where there is none)."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.control.plans import PlanSet, warm_torques
from acrobot_mj.control.tracker import tracker_stats
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.olympics.entries import PLANS, TreeOptions, tree
from acrobot_mj.olympics.plants import equations
from acrobot_mj.physics.xp import wrap_angle


def empty(hold: int = 5, decisions: int = 150) -> PlanSet:
    """A set without plans."""
    return PlanSet(np.zeros((0, 4)), np.zeros((0, decisions)), hold)


def planner_for(first: Trajectory, planner: Any) -> Any:
    """The tracker's planner while growing: a plan from ``x`` warm-started from the torques of
    the nearest plan (but ``first``, the shipped swing-up from hanging) towards the upright
    state its own end is (shifted by whole turns as ``x`` is from its start), else
    ``planner``'s cold plans to the two nearest upright states."""

    def grow(x: np.ndarray, plan: Trajectory) -> Any:
        if plan is not first:
            turns = x[:2] - plan.states[0, :2] - wrap_angle(x[:2] - plan.states[0, :2])
            target = plan.states[-1].copy()
            target[:2] += turns
            target[2:] = 0.0
            warm = warm_torques(plan, planner.hold, planner.decisions)
            found = planner.solve(x, target, warm)
            if found is not None:
                return found[0]
        return planner.plan(x, 2)

    return grow


def grow(first: int, count: int, minutes: float = 60.0, path: Path = PLANS) -> PlanSet:
    """Grow the plan set at ``path`` (or an empty one) on the global episodes of seeds
    ``first`` to ``first + count - 1``, at most ``minutes`` of CPU in all, saving it after each
    episode; prints each episode's uptime score and the counts."""
    from acrobot_mj.control.replan import Planner  # CasADi: the control extra
    from acrobot_mj.olympics.episodes import global_run
    from acrobot_mj.olympics.protocol import GLOBAL
    from acrobot_mj.olympics.scores import uptime
    from acrobot_mj.physics.models import resolve

    library = PlanSet.load(path) if path.is_file() else empty()
    plant = equations("ai_olympics")
    swing_up = plant.swing_up
    planner = Planner(swing_up.params, swing_up.method, hold=library.hold)
    # Entered as when the set was grown: below the entry level, no rollout.
    grown = TreeOptions(candidates=0, pause=0, below=None)
    tracker = tree(plant, library, planner_for(swing_up, planner), grown)
    controller = plant.estimated(tracker)
    started = time.process_time()
    for seed in range(first, first + count):
        targets, reset_times = GLOBAL.draw(seed)
        before = dict(tracker_stats(tracker))
        recording = global_run(controller, "ai_olympics", targets, reset_times)
        for plan in tracker.planned[before["planned"] :]:
            library = library.with_plan(plan)
        library.save(path)
        p = resolve("ai_olympics").params
        score = uptime(recording, p.l1, p.l2, GLOBAL.t_final, GLOBAL.height)["score"]
        cpu = time.process_time() - started
        print(
            f"seed {seed}: score {score:.3f}, set of {len(library)} plans, "
            f"planned {len(tracker.planned) - before['planned']}, "
            f"failed {tracker.failed - before['failed']}, cpu {cpu:.0f} s",
            flush=True,
        )
        if cpu > 60.0 * minutes:
            break
    return library


if __name__ == "__main__":
    arguments = sys.argv[1:]
    minutes = float(arguments[2]) if arguments[2:] else 60.0
    path = Path(arguments[3]) if arguments[3:] else PLANS
    grow(int(arguments[0]), int(arguments[1]), minutes, path)
