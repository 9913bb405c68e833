"""How long swing-ups from random rest poses take on a model: for each pose (both angles uniform
in ``[-pi, pi)``, at rest, drawn from a seed), the shortest swing-up to upright at rest that a
search of trajectory optimisation finds (horizons from 5 s, 2.5 s apart, up to ``longest``;
the three nearest upright states; IPOPT from tiny torques, the end nearest the target first,
then exact, as the control package's swing-up search):

    python scripts/swing_up_times.py report 5 10

The search is local, so each time is an upper bound on the least one. Prints each pose's
time, its CPU time and the mean over the poses that found one.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from acrobot_mj.control.replan import upright_targets
from acrobot_mj.control.trajopt import Optimiser
from acrobot_mj.olympics.controllers import shipped_swing_up
from acrobot_mj.physics import integrators


def shortest(model: str, x0: np.ndarray, longest: float = 40.0) -> float | None:
    """The length [s] of the shortest swing-up the search finds from ``x0``, or None."""
    plan = shipped_swing_up(model)
    p = plan.params
    optimiser = Optimiser(u_max=p.max_torque, method=plan.method, p=p, start=tuple(x0))
    for seconds in np.arange(5.0, longest + 1e-9, 2.5):
        horizon = integrators.steps_in(seconds, p.dt)
        for target in upright_targets(x0, 3):
            if optimiser.approach(target, optimiser.tiny_torques(horizon))[1] is not None:
                return float(seconds)
    return None


def main(model: str, seed: int, count: int) -> None:
    rng = np.random.default_rng(seed)
    found = []
    for _ in range(count):
        x0 = np.zeros(4)
        x0[:2] = rng.uniform(-np.pi, np.pi, 2)
        started = time.process_time()
        seconds = shortest(model, x0)
        if seconds is not None:
            found.append(seconds)
        cpu = time.process_time() - started
        print(f"from {np.round(x0, 2).tolist()} at rest: {seconds} s (cpu {cpu:.0f} s)", flush=True)
    print(f"{len(found)} of {count} found; mean {np.mean(found):.1f} s")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]))
