"""Policies that need no training: the fixed baselines of demos and smoke tests (``Discrete(3)``
actions: 0 is -1 N m, 1 is 0, 2 is +1 N m) and energy pumping (continuous torques)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT
from acrobot_mj.physics.params import REPORT, AcrobotParams

POLICY_NAMES = ("pump", "zero", "random")


def zero_policy(obs: np.ndarray) -> int:
    """No torque: the acrobot stays hanging at rest."""
    return 1


def pump_policy(obs: np.ndarray) -> int:
    """Bang-bang energy pumping, ``tau = -sign(dq1)`` [N m]: from rest it reaches the goal in 300
    steps at frame_skip 1 and 96 decisions at frame_skip 4 (the best of the four sign laws on
    ``dq1`` and ``dq2``)."""
    return 0 if obs[2] > 0 else 2


def make_policy(name: str, seed: int | None = None) -> Callable[[np.ndarray], int]:
    """The policy called ``name`` (one of :data:`POLICY_NAMES`; ``random`` draws uniformly from
    its own generator, seeded)."""
    if name == "random":
        rng = np.random.default_rng(seed)
        return lambda obs: int(rng.integers(3))
    policies = {"zero": zero_policy, "pump": pump_policy}
    if name not in policies:
        raise ValueError(f"unknown policy {name!r}; choose one of {POLICY_NAMES}")
    return policies[name]


def energy_pumping_torque(
    x: np.ndarray, target: float | None = None, gain: float = 50.0, p: AcrobotParams = REPORT
) -> np.ndarray:
    """Energy pumping through the elbow's power ``dE/dt = tau dq2`` (Spong, "The swing up control
    problem for the acrobot", IEEE Control Systems 1995), saturated::

        tau = clip(gain (E* - E) dq2, -1, 1) N m

    so while ``E < E*`` the torque does no negative work and the energy rises (in continuous
    time). ``E*`` defaults to the upright energy (19.6 J); from rest (``dq2 = 0``) the law gives
    +1 N m to start the motion."""
    x = np.asarray(x, dtype=float)
    target = dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p) if target is None else target
    energy = dynamics.total_energy(x[..., :2], x[..., 2:], p)
    dq2 = x[..., 3]
    tau = np.clip(gain * (target - energy) * dq2, -p.max_torque, p.max_torque)
    return np.where(dq2 == 0.0, p.max_torque, tau)


def pumping_energies(dt: float = 1e-3, seconds: float = 20.0, p: AcrobotParams = REPORT):
    """Energies [J] under :func:`energy_pumping_torque` from rest, RK4 at ``dt`` with the torque
    held over each step, until the upright energy (the pumping phase)."""
    fine = replace(p, dt=dt)
    target = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p))
    x, energies = HANGING.copy(), [float(dynamics.total_energy(HANGING[:2], HANGING[2:], p))]
    while energies[-1] < target and len(energies) <= seconds / dt:
        tau = float(energy_pumping_torque(x, target, p=p))
        x = integrators.step_states(x, tau, fine, method="rk4", limits=False)
        energies.append(float(dynamics.total_energy(x[:2], x[2:], p)))
    return np.array(energies)
