"""Energy pumping: the swing-up through the elbow's power, ``dE/dt = tau dq2``."""

from __future__ import annotations

import numpy as np

from acrobot_mj.control.model import HANGING, UPRIGHT, P
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.params import AcrobotParams


def energy_pumping_torque(
    x: np.ndarray, target: float | None = None, gain: float = 50.0, p: AcrobotParams = P
) -> np.ndarray:
    """Energy pumping through the elbow's power, ``dE/dt = tau dq2`` (the energy-based swing-up
    idea of Spong, "The swing up control problem for the acrobot", IEEE Control Systems 1995,
    and Fantoni, Lozano and Spong 2000), in saturated form:

        tau = clip(gain (E* - E) dq2, -1, 1) N m,

    so while ``E < E*`` the torque always does non-negative work: the energy rises
    monotonically (in continuous time). ``E*`` defaults to the upright energy (19.6 J). From
    rest ``dq2 = 0``; the law then gives +1 N m to start the motion.
    """
    x = np.asarray(x, dtype=float)
    target = dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p) if target is None else target
    energy = dynamics.total_energy(x[..., :2], x[..., 2:], p)
    dq2 = x[..., 3]
    tau = np.clip(gain * (target - energy) * dq2, -p.max_torque, p.max_torque)
    return np.where(dq2 == 0.0, p.max_torque, tau)


def pumping_energies(dt: float = 1e-3, seconds: float = 20.0, p: AcrobotParams = P) -> np.ndarray:
    """Energy [J] under :func:`energy_pumping_torque` from rest, RK4 at ``dt`` with the torque
    held over each step, until it reaches the upright energy (the pumping phase)."""
    target = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p))
    x = HANGING.copy()
    energies = [float(dynamics.total_energy(x[:2], x[2:], p))]
    while energies[-1] < target and len(energies) <= seconds / dt:
        x = integrators.rk4_step(x, float(energy_pumping_torque(x, target, p=p)), dt, p)
        energies.append(float(dynamics.total_energy(x[:2], x[2:], p)))
    return np.array(energies)
