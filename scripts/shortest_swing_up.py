"""The shortest swing-up from hanging at rest to upright at rest that the control package's
minimum-time search from rest finds on a model, at its full torque, on steps of ``--dt`` [s]
by the model's integrator (an upper bound on the minimum: the search is local):

    python scripts/shortest_swing_up.py ai_olympics --dt 0.01 --horizons 50:201:10

The report's is shipped: ``min_time``, 345 steps of 0.05 s (17.25 s), from the search's
energy-pumping warm starts (from rest it finds 368, 18.4 s: docs/guide/balance.md). Prints
the length [s] and the wall time of the search.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

from acrobot_mj.control.trajopt import WarmStarts, min_time
from acrobot_mj.physics import integrators
from acrobot_mj.physics.models import resolve


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("--dt", type=float, required=True, help="the plan's step [s]")
    parser.add_argument("--horizons", required=True, help="START:STOP:STEP, in steps")
    parser.add_argument("--jobs", type=int, default=1)
    arguments = parser.parse_args()
    model = resolve(arguments.model)
    p = replace(model.analytic, dt=arguments.dt)
    try:
        start, stop, step = (int(v) for v in arguments.horizons.split(":"))
    except ValueError:
        parser.error(f"--horizons must be START:STOP:STEP, got {arguments.horizons!r}")
    method = integrators.ENV_INTEGRATORS[model.integrator]
    began = time.perf_counter()
    warm = WarmStarts(horizons=range(start, stop, step))
    plan = min_time(p.max_torque, method, warm=warm, p=p, jobs=arguments.jobs)
    seconds = time.perf_counter() - began
    print(f"{arguments.model}: {plan.seconds:g} s at {p.max_torque:g} N m ({seconds:.0f} s)")


if __name__ == "__main__":
    main()
