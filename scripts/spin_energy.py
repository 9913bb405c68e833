"""The energy [J above upright's] of the report's acrobot spinning fast under the funnel's
energy removal ``tau = -clip(dq2, -1, 1)`` N m, on the model's own steps (semi-implicit Euler,
0.05 s, velocity limits) and on fine continuous ones (RK4, 0.001 s, no limits), and under
removal planned on the model's steps (:class:`~acrobot_mj.control.shooting.EnergyShooting`,
``-clip(dq2)`` within 5 J of upright's energy), from the same state (the shoulder at
-8.5 rad/s), every 4 s for 28 s:

    python scripts/spin_energy.py

``-clip(dq2)`` lowers the continuous energy; on the model's steps the arm gains energy under
it until the shoulder spins at its velocity limit. The planned torques take it down.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from acrobot_mj.control.shooting import EnergyShooting
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import UPRIGHT
from acrobot_mj.physics.params import REPORT

#: The start (4,) [rad, rad/s]: the arm nearly straight, spinning.
START = np.array([0.0, 0.3, -8.5, 1.0])
SECONDS = 28.0


def energies(dt: float, method: str, limits: bool, planned: bool = False) -> list[float]:
    """The energies above upright's [J] every 4 s, stepping by ``method`` at ``dt`` [s], the
    torques planned (``planned``, on the model's steps) or ``-clip(dq2)``."""
    p = replace(REPORT, dt=dt)
    upright = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], REPORT))
    x, out = START.copy(), []
    law = EnergyShooting(p, method) if planned else None
    steps, every = integrators.steps_in(SECONDS, dt), integrators.steps_in(4.0, dt)
    for k in range(steps + 1):
        if k % every == 0:
            out.append(round(float(dynamics.total_energy(x[:2], x[2:], REPORT)) - upright, 1))
        u = None if law is None else law(x)
        u = float(np.clip(-x[3], -REPORT.max_torque, REPORT.max_torque)) if u is None else u
        x = integrators.step_states(x, u, p, method=method, limits=limits)
    return out


def main() -> None:
    model = energies(0.05, "semi_implicit_euler", True)
    print("model's steps (semi-implicit Euler, 0.05 s):", model)
    print("continuous (RK4, 0.001 s, no limits):", energies(0.001, "rk4", False))
    planned = energies(0.05, "semi_implicit_euler", True, planned=True)
    print("planned on the model's steps:", planned)


if __name__ == "__main__":
    main()
