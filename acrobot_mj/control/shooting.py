"""Energy removal planned on the model's own steps (:class:`EnergyShooting`): random shooting,
receding horizon. Where the arm spins whole, the elbow's power ``tau dq2`` is near zero and
``tau = -clip(dq2)`` removes almost nothing; on the report's steps (semi-implicit Euler at
0.05 s) the arm even gains energy under it (``scripts/spin_energy.py``). Sequences of
torques planned on those same steps find the ones that lose it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acrobot_mj.checks import check_state
from acrobot_mj.control.controller import Controller
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import UPRIGHT, total_energy
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.settings import SettingError, Settings, setting


@dataclass(frozen=True)
class ShootingSettings(Settings):
    """The sequences the planner draws; where it acts. First guesses, untuned, tried first on
    seeds 11-16 (the ``backward`` entry's scaled global uptime 0.33 without the planner, 0.50
    with it), then on 52 held-out seeds (0.541)."""

    candidates: int = setting(128, "torque sequences drawn a decision", low=1)
    horizon: float = setting(2.0, "length of each sequence", "s", low=0.0, low_open=True)
    segment: float = setting(
        0.25, "time each torque of a sequence is held", "s", low=0.0, low_open=True
    )
    above: float = setting(5.0, "it acts above upright's energy by more than this", "J", low=0.0)
    seed: int = setting(0, "seed of the draws (re-drawn at each reset)", low=0)

    what = "shooting"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.segment > self.horizon:
            raise SettingError(
                f"config segment must be at most horizon ({self.horizon:g} s), got {self.segment:g}"
            )


class EnergyShooting(Controller):
    """``tau = pi(x)`` [N m] that drives the energy to upright's: of ``candidates`` piecewise
    constant sequences over the horizon (the last decision's best, shifted on, among them),
    the first torque of the one whose energy stays nearest upright's over the horizon's second
    half, on ``params``' steps by ``method`` with its velocity limits. It covers the states more
    than ``above`` over upright's energy (a link of
    :class:`~acrobot_mj.control.controller.Fallbacks`): about 2 ms a call on one core of a
    shared 2-core machine, real-time at the report's 0.05 s a step. Call it once a step of
    ``params.dt`` (the kept plan moves on a step a call), and :meth:`reset` before each
    episode."""

    def __init__(
        self, params: AcrobotParams, method: str, settings: ShootingSettings = ShootingSettings()
    ) -> None:
        self.params, self.settings = params, settings
        self.stepping = integrators.Stepping(params.dt, 1, params.max_vel, method)
        self.theta = np.array(params.lumped)
        self.upright = float(total_energy(UPRIGHT[:2], UPRIGHT[2:], params))
        self.steps = integrators.steps_in(settings.horizon, params.dt)
        self.hold = min(integrators.steps_in(settings.segment, params.dt), self.steps)
        self.levels = np.array([-1.0, 0.0, 1.0]) * params.max_torque
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """A new episode: the sequences re-drawn from ``seed`` (None: the settings' seed), no
        plan kept."""
        self.rng = np.random.default_rng(self.settings.seed if seed is None else seed)
        self.plan = np.zeros(self.steps)

    def energy(self, x: np.ndarray) -> np.ndarray:
        """The energy [J] over upright's of states ``x`` (..., 4)."""
        return total_energy(x[..., :2], x[..., 2:], self.params) - self.upright

    def covers(self, x: np.ndarray) -> bool:
        """Whether the energy of ``x`` (4,) is more than ``above`` over upright's; where it is
        not, the kept plan is dropped (the next one starts afresh)."""
        x = check_state("the state", x)
        if float(self.energy(x)) <= self.settings.above:
            self.plan[:] = 0.0
            return False
        return True

    def act(self, x: np.ndarray, t: float) -> float:
        """The torque [N m] in state ``x`` (4,), planned as if it covers ``x``."""
        x = check_state("the state", x)
        n, segments = self.settings.candidates, -(-self.steps // self.hold)
        drawn = self.rng.choice(self.levels, size=(n, segments))
        torques = np.repeat(drawn, self.hold, axis=1)[:, : self.steps]
        torques[0] = np.r_[self.plan[1:], 0.0]
        states, cost = np.repeat(x[None], n, 0), np.zeros(n)
        for k in range(self.steps):
            states = self.stepping.advance(self.theta, states, torques[:, k])
            if 2 * k >= self.steps:
                cost += np.abs(self.energy(states))
        self.plan = torques[int(np.argmin(cost))].copy()
        return float(self.plan[0])
