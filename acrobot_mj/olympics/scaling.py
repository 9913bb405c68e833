"""The AI Olympics protocol carried to another acrobot by physical scales.

The protocol's constants (:mod:`~acrobot_mj.olympics.protocol`) are set for its robot,
``ai_olympics`` (reach 0.5 m, 1.15 kg, 6 N m at the elbow, a swing-up of about 2 s).
:class:`Scales` holds the ratios, target over source, of the quantities that carry them to
another acrobot; :class:`Scaling` maps each constant by its unit
(``dataclasses.replace``); :func:`protocol_for` builds the three parts for a model. On
``ai_olympics`` every ratio is exactly 1 and every constant is unchanged.

Three kinds of time enter: the pendulum's own time ``sqrt(l / g)`` (:attr:`Scales.time`:
pulse widths, delays, velocities, the PID's reset), the task's time, the ratio of the planned
swing-ups' lengths (``Scales.task``: episode lengths, pulse spacing, reset spacing), and
the physics step (``Scales.step``). Two kinds of torque enter: what the motor can give
(``Scales.motor``, the ratio of torque limits: every disturbance the controller must
overcome) and what gravity asks (``Scales.weight``, the ratio of gravity's torques on the
arms held out straight, ``(m1 lc1 + m2 l1 + m2 lc2) g``: the reset's PID, which must move the
arm against gravity, and a swing-up's work, twice that torque in joules).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from acrobot_mj.control.planned import planned_swing_up
from acrobot_mj.olympics.protocol import (
    GLOBAL,
    PERFORMANCE,
    ROBUSTNESS,
    GlobalPolicy,
    Performance,
    Robustness,
)
from acrobot_mj.physics.models import MODELS, AcrobotModel, resolve
from acrobot_mj.physics.params import AcrobotParams

#: The model the protocol's constants are set for.
SOURCE = "ai_olympics"


@dataclass(frozen=True)
class Scales:
    """Ratios, target over source (dimensionless), of the arm's ``length`` (the reach
    ``l1 + l2``), its ``mass`` (``m1 + m2``), ``gravity``, the ``motor``'s torque limit, the
    ``task``'s time (the planned swing-ups' lengths), the physics ``step`` and gravity's
    torque on the arm held out straight (``weight``, ``(m1 lc1 + m2 l1 + m2 lc2) g`` [N m]:
    half the potential energy a swing-up gains, the torque the reset's PID works against)."""

    length: float = 1.0
    mass: float = 1.0
    gravity: float = 1.0
    motor: float = 1.0
    task: float = 1.0
    step: float = 1.0
    weight: float = 1.0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"the scale {name} must be a finite number > 0, got {value!r}")

    @property
    def time(self) -> float:
        """The pendulum's time ``sqrt(length / gravity)``."""
        return math.sqrt(self.length / self.gravity)

    @property
    def inertia(self) -> float:
        """A moment of inertia, ``mass length^2``."""
        return self.mass * self.length**2

    def to_dict(self) -> dict[str, float]:
        """The ratios and the derived ones, as JSON."""
        derived = {"time": self.time, "inertia": self.inertia}
        return {**asdict(self), **derived}


@dataclass(frozen=True)
class Rules:
    """The three parts of the protocol one run uses, its ``name`` (``"ai_olympics"``: the
    original, ``"scaled"``) and the ``scales`` that made it."""

    name: str = SOURCE
    scales: Scales = Scales()
    performance: Performance = PERFORMANCE
    robustness: Robustness = ROBUSTNESS
    global_policy: GlobalPolicy = GLOBAL

    def to_dict(self) -> dict[str, Any]:
        """What the record keeps: the name, the scales and each part's constants."""
        parts = {
            "performance": asdict(self.performance),
            "robustness": asdict(self.robustness),
            "global": asdict(self.global_policy),
        }
        return {"name": self.name, "scales": self.scales.to_dict(), "constants": parts}


#: The protocol as its leaderboards define it.
ORIGINAL = Rules()


@dataclass(frozen=True)
class Scaling:
    """Maps the protocol's constants by ``scales`` onto an acrobot stepping every ``dt`` [s]
    (None: the source's step times ``Scales.step``)."""

    scales: Scales
    dt: float | None = None

    def _dt(self, dt: float) -> float:
        return dt * self.scales.step if self.dt is None else self.dt

    def performance(self, p: Performance = PERFORMANCE) -> Performance:
        """The swing-up episode: its length by the task's time, the torque limit by the
        motor's; the criteria's normalisers: time by the task, energy [J] by gravity's torque
        (a swing-up's work, twice it, lifts the arm), torque cost [N^2 m^2 s] by motor^2 task,
        smoothness (a torque's change per step) by motor step / task, velocity cost [rad^2/s]
        by task / time^2."""
        s = self.scales
        norm = {
            "swingup_time": s.task,
            "energy": s.weight,
            "tau_cost": s.motor**2 * s.task,
            "tau_smoothness": s.motor * s.step / s.task,
            "velocity_cost": s.task / s.time**2,
        }
        criteria = tuple(replace(c, norm=c.norm * norm[c.name]) for c in p.criteria)
        return replace(
            p,
            t_final=p.t_final * s.task,
            dt=self._dt(p.dt),
            torque_limit=p.torque_limit * s.motor,
            criteria=criteria,
        )

    def robustness(self, r: Robustness = ROBUSTNESS) -> Robustness:
        """The robustness episodes: length and pulse spacing by the task's time; pulse widths
        and delays by the pendulum's; every torque the controller must overcome (noise, pulses,
        friction, damping [N m s/rad] times the pendulum's time) by the motor's; motor inertia
        by ``mass length^2``; velocity noise and the success box's velocities by 1 / time.
        Angles, relative levels and the torque response (a fraction per step) stay."""
        s = self.scales
        e = r.epsilon
        pulses = replace(
            r.perturbations,
            min_gap=r.perturbations.min_gap * s.task,
            sigma=(r.perturbations.sigma[0] * s.time, r.perturbations.sigma[1] * s.time),
            amplitude=(
                r.perturbations.amplitude[0] * s.motor,
                r.perturbations.amplitude[1] * s.motor,
            ),
        )
        return replace(
            r,
            t_final=r.t_final * s.task,
            dt=self._dt(r.dt),
            torque_limit=r.torque_limit * s.motor,
            epsilon=(e[0], e[1], e[2] / s.time, e[3] / s.time),
            perturbations=pulses,
            motor_inertia=r.motor_inertia * s.inertia,
            damping=r.damping * s.motor * s.time,
            friction=r.friction * s.motor,
            velocity_noise=r.velocity_noise / s.time,
            torque_noise=r.torque_noise * s.motor,
            delay=r.delay * s.time,
        )

    def global_policy(self, g: GlobalPolicy = GLOBAL) -> GlobalPolicy:
        """The global episode: its length and the resets' jitter by the task's time (the
        number of resets kept, so their spacing follows the swing-up's length); the reset's
        length by the pendulum's time; the reset PID's torque limit and gains by gravity's
        torque (``kp`` [N m/rad], ``ki`` over time, ``kd`` times time), so it moves the arm
        against gravity as it does on the source (a reset from upright leaves the arm with
        as large a share of a swing-up's energy to lose: tested); the PID's own step by the
        physics step (its ratio to the episode's step kept)."""
        s = self.scales
        return replace(
            g,
            t_final=g.t_final * s.task,
            dt=self._dt(g.dt),
            torque_limit=(g.torque_limit[0] * s.weight, g.torque_limit[1] * s.weight),
            jitter=g.jitter * s.task,
            reset_length=g.reset_length * s.time,
            kp=g.kp * s.weight,
            ki=g.ki * s.weight / s.time,
            kd=g.kd * s.weight * s.time,
            pid_dt=g.pid_dt * s.step,
        )

    def protocol(self, name: str = "scaled") -> Rules:
        """The three parts, scaled, as one :class:`Rules` called ``name``."""
        return Rules(name, self.scales, self.performance(), self.robustness(), self.global_policy())


def scales_between(
    source: AcrobotModel, target: AcrobotModel, source_swing_up: float, target_swing_up: float
) -> Scales:
    """The scales from ``source`` to ``target``, with their planned swing-ups' lengths [s]."""
    p, q = source.params, target.params
    if not (source_swing_up > 0 and target_swing_up > 0):
        raise ValueError("the swing-ups' lengths must be > 0 s")
    return Scales(
        length=(q.l1 + q.l2) / (p.l1 + p.l2),
        mass=(q.m1 + q.m2) / (p.m1 + p.m2),
        gravity=q.g / p.g,
        motor=q.max_torque / p.max_torque,
        task=target_swing_up / source_swing_up,
        step=q.dt / p.dt,
        weight=gravity_torque(q) / gravity_torque(p),
    )


def gravity_torque(p: AcrobotParams) -> float:
    """Gravity's torque [N m] about the shoulder on the arm held out straight and level,
    ``(m1 lc1 + m2 l1 + m2 lc2) g``: the lumped ``d + e``."""
    *_, d, e = p.lumped
    return d + e


def protocol_for(model: str) -> Rules:
    """The protocol a run on ``model`` (a name or a file with a swing-up,
    :func:`~acrobot_mj.olympics.swing_ups.check_plannable`) uses: the original on
    ``ai_olympics`` and its kin (the protocol's units are that robot's), else the original
    scaled (:func:`scales_between` with the plans' lengths), stepping at the model's own
    physics step."""
    from acrobot_mj.olympics.swing_ups import check_plannable, swing_up_for

    target = resolve(model)
    if check_plannable(model) == SOURCE:
        return ORIGINAL
    plan = swing_up_for(model)
    scales = scales_between(MODELS[SOURCE], target, planned_swing_up(SOURCE).seconds, plan.seconds)
    return Scaling(scales, target.params.dt).protocol()
