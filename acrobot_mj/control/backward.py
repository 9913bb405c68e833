"""Swing-ups integrated backwards in time from upright (:func:`backward_library`): no optimiser,
and each plan ends at upright by construction. A plan leaves upright (``start_noise`` [rad] off)
backwards under torques that, run forwards, pump energy (``pump`` times ``reserve`` times the
sign of the elbow's velocity plus ``jitter`` times a torque within ``reserve`` held 1 to
``longest_hold`` steps), until the energy falls to a level drawn uniformly between hanging's
and upright's; it is then rolled out forwards from where it ended, on the model's own steps.
A :class:`~acrobot_mj.control.tracker.PlanTracker` enters them as it enters a grown
library."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT, accelerations, total_energy
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.settings import SettingError, Settings, setting

#: The one step rule the backward step inverts.
METHOD = "semi_implicit_euler"


@dataclass(frozen=True)
class BackwardSettings(Settings):
    """How the plans are drawn (:func:`backward_plan`); a plan that passes ``speed`` of a
    velocity limit, is shorter than ``shortest`` steps or whose forward rollout ends more than
    ``tolerance`` off upright is dropped."""

    count: int = setting(300, "plans drawn", low=1)
    seed: int = setting(12345, "seed of the draws", low=0)
    reserve: float = setting(
        0.8, "torque bound of the plans (TVLQR keeps the rest of the motor)", "N m", low=0.0,
        low_open=True,
    )  # fmt: skip
    pump: float = setting(0.7, "share of the reserve along the elbow's velocity", low=0.0, high=1.0)
    jitter: float = setting(0.3, "share of a random torque within the reserve", low=0.0, high=1.0)
    longest_hold: int = setting(10, "longest hold of a random torque", "steps", low=1)
    longest: int = setting(800, "longest plan", "steps", low=1)
    shortest: int = setting(20, "shortest plan kept", "steps", low=1)
    speed: float = setting(
        0.9, "share of a velocity limit a plan may reach", low=0.0, low_open=True, high=1.0
    )
    start_noise: float = setting(1e-3, "offset of each plan's end from upright", "rad", low=0.0)
    tolerance: float = setting(
        0.05, "largest end error of a plan's forward rollout", "rad, rad/s", low=0.0, low_open=True
    )

    what = "backward"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.longest < self.shortest:
            raise SettingError(
                f"config longest must be >= shortest ({self.shortest}), got {self.longest}"
            )


def back(x: np.ndarray, u: float, p: AcrobotParams) -> np.ndarray:
    """The state one semi-implicit Euler step of ``p.dt`` before ``x`` under torque ``u`` [N m]:
    ``q = q' - h v'``, then ``v = v' - h a(q, v, u)`` by fixed-point iteration (to rounding)."""
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


def backward_plan(
    rng: np.random.Generator, p: AcrobotParams, settings: BackwardSettings
) -> Trajectory | None:
    """One plan on ``p``, or None where it is dropped (:class:`BackwardSettings`)."""
    s = settings
    x = UPRIGHT.astype(float) + np.append(rng.normal(0.0, s.start_noise, 2), [0.0, 0.0])
    upright = float(total_energy(UPRIGHT[:2], UPRIGHT[2:], p))
    hanging = float(total_energy(HANGING[:2], HANGING[2:], p))
    level = rng.uniform(hanging, upright)
    torques: list[float] = []
    hold, noise = 0, 0.0
    while len(torques) < s.longest and total_energy(x[:2], x[2:], p) > level:
        if hold == 0:
            hold = int(rng.integers(1, s.longest_hold + 1))
            noise = rng.uniform(-s.reserve, s.reserve)
        hold -= 1
        u = s.pump * s.reserve * np.sign(x[3]) + s.jitter * noise
        torques.append(float(np.clip(u, -p.max_torque, p.max_torque)))
        x = back(x, torques[-1], p)
        if abs(x[2]) > s.speed * p.max_vel1 or abs(x[3]) > s.speed * p.max_vel2:
            return None
    if len(torques) < s.shortest:
        return None
    forward = np.array(torques[::-1])
    states = integrators.simulate(x, forward, METHOD, p)
    if np.abs(states[-1] - UPRIGHT).max() > s.tolerance:
        return None
    return Trajectory(states, forward, p.dt, METHOD, p.max_torque, p)


def backward_library(
    p: AcrobotParams, method: str, settings: BackwardSettings = BackwardSettings()
) -> list[Trajectory]:
    """``settings.count`` plans on ``p`` stepped by ``method`` (semi-implicit Euler, the one
    the backward step inverts; another is refused in one line), the same for the same seed."""
    if method != METHOD:
        raise ValueError(f"plans are integrated backwards by {METHOD} steps, not {method}")
    rng = np.random.default_rng(settings.seed)
    plans: list[Trajectory] = []
    while len(plans) < settings.count:
        found = backward_plan(rng, p, settings)
        if found is not None:
            plans.append(found)
    return plans
