"""The ``tree`` entry's shortened plan set: each plan of the grown set (``scripts/grow_plans.py``)
re-solved from its start to its own upright end, warm-started from its torques, with an
objective that counts the time the tip spends below the AI Olympics' height
(:class:`~acrobot_mj.control.replan.TimeBelow`); the new plan replaces the old where it spends
less time below. CasADi: the ``control`` extra. Run

    python scripts/shorten_plans.py [JOBS [PATH]]

to write the shipped shortened set (or the set at ``PATH``); prints each plan's time below,
before and after."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from acrobot_mj.control.plans import PlanSet
from acrobot_mj.control.replan import Planner, TimeBelow, upright_targets
from acrobot_mj.olympics.entries import PLAN_SETS
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.models import resolve
from acrobot_mj.pool import WorkerPool

#: IPOPT's iterations for each re-solve: offline, so many more than online.
ITERATIONS = 300
PARAMS = resolve("ai_olympics").params


def time_below(states: np.ndarray, below: TimeBelow) -> float:
    """The time [s] the tip spends at or below ``below.height`` of the reach over ``states``
    (T + 1, 4), past the start."""
    reach = PARAMS.l1 + PARAMS.l2
    return float(
        (dynamics.tip_height(states[1:], PARAMS) <= below.height * reach).sum() * PARAMS.dt
    )


def shorten(start: np.ndarray, held: np.ndarray, hold: int) -> tuple[np.ndarray, float, float]:
    """The held torques of the plan from ``start`` holding ``held`` re-solved (or ``held``
    where the new plan is not found or not lower), its time below before and after [s]."""
    below = TimeBelow()
    old = integrators.simulate(start, np.repeat(held, hold), "rk4", PARAMS)
    target = upright_targets(old[-1], 1)[0]  # its own end, upright at rest
    planner = Planner(
        PARAMS, "rk4", decisions=len(held), hold=hold, below=below, iterations=ITERATIONS
    )
    found, before = planner.solve(start, target, warm=held), time_below(old, below)
    if found is None or time_below(found[0].states, below) >= before:
        return held, before, before
    return found[0].torques[::hold], before, time_below(found[0].states, below)


def main(jobs: int = 2, path: Path = PLAN_SETS["shortened"]) -> None:
    grown = PlanSet.load(PLAN_SETS["grown"])
    calls = [(s, h, grown.hold) for s, h in zip(grown.starts, grown.held, strict=True)]
    held = grown.held.copy()
    with WorkerPool(jobs, terminate=True) as pool:
        for i, (new, before, after) in enumerate(pool.map(shorten, calls)):
            held[i] = new
            print(f"plan {i}: {before:.3f} s below, now {after:.3f} s", flush=True)
    PlanSet(grown.starts, held, grown.hold).save(path)
    print(f"wrote {path}")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    main(
        int(arguments[0]) if arguments else 2,
        Path(arguments[1]) if arguments[1:] else PLAN_SETS["shortened"],
    )
