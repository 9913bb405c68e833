"""How long swing-ups take on a model from random starts: for each start, the shortest swing-up
to upright at rest that a search of trajectory optimisation finds (horizons from 5 s, 2.5 s
apart, up to ``LONGEST``; the three nearest upright states; IPOPT from tiny torques, the end
nearest the target first, then exact, as the control package's swing-up search). The starts
are poses at rest (both angles uniform in ``[-pi, pi)``, drawn from ``SEED``), or with
``--resets`` the states the global policy's first resets of episode ``SEED`` leave the arm in
(the protocol for the model, from upright at rest, where a balancing controller would be):

    python scripts/swing_up_times.py report 5 10
    python scripts/swing_up_times.py report 0 1 --resets --longest 35

The search is local, so each time is an upper bound on the shortest. Prints each start, its
time (None: none found) and CPU time, and the mean over the starts that found one.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.control.planned import planned_swing_up
from acrobot_mj.control.replan import upright_targets
from acrobot_mj.control.trajopt import Optimiser
from acrobot_mj.olympics.episodes import global_run
from acrobot_mj.olympics.protocol import from_protocol
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import UPRIGHT


class FirstCall(Controller):
    """A controller that never acts and keeps the first observation it is given."""

    def __init__(self) -> None:
        self.obs: np.ndarray | None = None

    def reset(self, seed: int | None = None) -> None:
        self.obs = None

    def act(self, x: np.ndarray, t: float) -> float:
        if self.obs is None:
            self.obs = np.array(x, dtype=float)
        return 0.0


def after_reset(model: str, target: np.ndarray) -> np.ndarray:
    """The state [rad, rad/s; angles wrapped] the protocol's reset to ``target`` (ours) leaves,
    from upright at rest: what the controller is first given after the reset."""
    policy = protocol_for(model).global_policy
    first = FirstCall()
    reset_only = replace(policy, t_final=policy.reset_length + 10 * policy.dt)
    global_run(first, model, target[None], np.array([0.0]), reset_only, start=UPRIGHT)
    assert first.obs is not None
    return first.obs


def shortest(model: str, x0: np.ndarray, longest: float) -> float | None:
    """The length [s] of the shortest swing-up the search finds from ``x0``, or None."""
    plan = planned_swing_up(model)
    p = plan.params
    optimiser = Optimiser(u_max=p.max_torque, method=plan.method, p=p, start=tuple(x0))
    for seconds in np.arange(5.0, longest + 1e-9, 2.5):
        horizon = integrators.steps_in(seconds, p.dt)
        for target in upright_targets(x0, 3):
            if optimiser.approach(target, optimiser.tiny_torques(horizon))[1] is not None:
                return float(seconds)
    return None


def starts(model: str, seed: int, count: int, resets: bool) -> list[np.ndarray]:
    """The starts (4,) [rad, rad/s]: rest poses, or the states after the first resets."""
    if resets:
        targets = from_protocol(protocol_for(model).global_policy.draw(seed)[0])
        return [after_reset(model, target) for target in targets[:count]]
    rng = np.random.default_rng(seed)
    return [np.append(rng.uniform(-np.pi, np.pi, 2), [0.0, 0.0]) for _ in range(count)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("seed", type=int)
    parser.add_argument("count", type=int)
    parser.add_argument("--resets", action="store_true", help="start where resets leave the arm")
    parser.add_argument("--longest", type=float, default=40.0, help="the longest horizon [s]")
    arguments = parser.parse_args()
    found = []
    for x0 in starts(arguments.model, arguments.seed, arguments.count, arguments.resets):
        started = time.process_time()
        seconds = shortest(arguments.model, x0, arguments.longest)
        if seconds is not None:
            found.append(seconds)
        cpu = time.process_time() - started
        print(f"from {np.round(x0, 2).tolist()}: {seconds} s (cpu {cpu:.0f} s)", flush=True)
    mean = f"{np.mean(found):.1f} s" if found else "-"
    print(f"{len(found)} of {arguments.count} found; mean {mean}")


if __name__ == "__main__":
    main()
