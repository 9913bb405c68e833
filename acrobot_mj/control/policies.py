"""Policies that need no training: fixed baselines (``Discrete(3)`` actions: 0 is -1 N m, 1 is 0,
2 is +1 N m) and energy pumping (continuous torques)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT
from acrobot_mj.physics.params import REPORT, AcrobotParams

#: The fixed policies by name.
POLICY_NAMES = ("pump", "zero", "random")


def zero_policy(obs: np.ndarray) -> int:
    return 1


def pump_policy(obs: np.ndarray) -> int:
    """Bang-bang energy pumping, ``tau = -sign(dq1)`` [N m]: the goal in 300 steps from rest."""
    return 0 if obs[2] > 0 else 2


def make_policy(name: str, seed: int | None = None) -> Callable[[np.ndarray], int]:
    """The policy called ``name`` (one of :data:`POLICY_NAMES`; ``random`` is seeded)."""
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
    """Spong's energy pumping, ``tau = clip(gain (E* - E) dq2, -1, 1)`` N m (+1 at ``dq2 = 0``),
    ``E*`` [J] by default the upright energy."""
    x = np.asarray(x, dtype=float)
    goal = dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p) if target is None else target
    energy = dynamics.total_energy(x[..., :2], x[..., 2:], p)
    dq2 = x[..., 3]
    tau = np.clip(gain * (goal - energy) * dq2, -p.max_torque, p.max_torque)
    return np.where(dq2 == 0.0, p.max_torque, tau)


class EnergyPumping(Controller):
    """:func:`energy_pumping_torque` to upright's energy at ``gain`` [N m / (J rad/s)] on the
    model ``p``."""

    def __init__(self, p: AcrobotParams, gain: float = 50.0) -> None:
        self.p, self.gain = p, gain

    def act(self, x: np.ndarray, t: float) -> float:
        return float(energy_pumping_torque(x, gain=self.gain, p=self.p))


def pumping_energies(dt: float = 1e-3, seconds: float = 20.0, p: AcrobotParams = REPORT):
    """Energies [J] under :func:`energy_pumping_torque` from rest until the upright energy, by
    RK4 at ``dt`` [s]."""
    fine = replace(p, dt=dt)
    target = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p))
    x, energies = HANGING.copy(), [float(dynamics.total_energy(HANGING[:2], HANGING[2:], p))]
    while energies[-1] < target and len(energies) <= seconds / dt:
        tau = float(energy_pumping_torque(x, target, p=p))
        x = integrators.step_states(x, tau, fine, method="rk4", limits=False)
        energies.append(float(dynamics.total_energy(x[:2], x[2:], p)))
    return np.array(energies)
