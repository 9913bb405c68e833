"""What an evaluation does to the acrobot that its controller does not know: pushes (random
velocity kicks every few seconds), a perturbed model (masses and inertias scaled), the AI
Olympics protocol's sensor (velocity noise, delay: :class:`~acrobot_mj.envs.sensor.Sensor`) and
motor (torque noise and response: :class:`~acrobot_mj.envs.motor.Motor`); how a run recovers
from them; and the replay of an episode's torques and pushes in MuJoCo. A
:class:`Perturbation` is what the robustness table of ``acrobot-mj balance`` changes.

A push is added to the joint velocities just before physics step ``k`` (counted from 0), at the
first decision boundary at or after each multiple of ``push_every`` seconds: the controller
chose that decision's action before the push, as a kick that lands between sensing and acting.
So ``push_every`` is at least one decision, and at most an episode less one decision (a push
must land within the episode): other periods are refused, not rounded. The record holds each
push as drawn; one that would pass a velocity limit is clipped there, as every physics step is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from acrobot_mj.envs.links import LINK_PARAMETERS, acrobot_under, set_model_parameters
from acrobot_mj.envs.motor import MAX_RESPONSE
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.physics.integrators import limit_velocities, steps_in
from acrobot_mj.settings import Settings, setting

#: Within the tolerance this long [s] on end (or to the end of the episode) counts as balanced:
#: a swing through upright leaves 0.05 rad within a second (the unstable modes grow e-fold in
#: 0.35 s and 0.53 s).
SETTLE = 2.0
#: Past this error [rad] after a catch, the acrobot has fallen: no ``|tau| <= 1`` N m brings back
#: even a q1 offset at rest past 0.015 rad (the unstable modes' linearised bound). A smaller
#: excursion that comes back is a wobble, not a fall.
FALL = 0.5


@dataclass(frozen=True)
class Disturbances(Settings):
    """Pushes of ``U(-push_size, push_size)`` [rad/s] on each joint velocity every
    ``push_every`` [s] (None: no pushes), and each link's mass and inertia scaled by
    ``U(1 - perturb, 1 + perturb)``, drawn per episode; Gaussian noise of ``velocity_noise``
    [rad/s] on each measured velocity and a measurement ``delay`` [s] of the whole state
    (the protocol's ``"posvel"``); Gaussian noise of ``torque_noise`` [N m] on the applied
    torque and the motor's ``torque_response`` (wrappers of the env:
    :func:`acrobot_mj.train.evaluate.disturbed`). The one declaration of these settings:
    :class:`~acrobot_mj.train.learners.HeldOut` adds the starts to them."""

    what: ClassVar[str] = "disturbance"

    push_every: float | None = setting(
        None,
        "push every P seconds (none: no pushes)",
        "s",
        low=0.0,
        low_open=True,
        high=86_400.0,
        metavar="P",
    )
    push_size: float = setting(
        0.0,
        "each push adds U(-V, V) to each joint velocity",
        "rad/s",
        low=0.0,
        high=MAX_VEL1,
        metavar="V",
    )
    perturb: float = setting(
        0.0,
        "scale each link's mass and inertia by U(1-F, 1+F) per episode; the controller keeps "
        "its model",
        low=0.0,
        high=0.9,
        metavar="F",
    )
    velocity_noise: float = setting(
        0.0,
        "Gaussian noise on each observed joint velocity",
        "rad/s",
        low=0.0,
        high=MAX_VEL2,
        metavar="S",
    )
    delay: float = setting(
        0.0, "observe the state int(D/dt) decisions old", "s", low=0.0, high=86_400.0, metavar="D"
    )
    torque_noise: float = setting(
        0.0, "Gaussian noise on the applied elbow torque", "N m", low=0.0, high=1e3, metavar="S"
    )
    torque_response: float = setting(
        1.0,
        "the applied torque moves this fraction of the way to the command each decision",
        low=0.0,
        low_open=True,
        high=MAX_RESPONSE,
        metavar="K",
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        if (self.push_every is None) != (self.push_size == 0.0):
            raise ValueError("pushes need both push_every > 0 s and push_size > 0 rad/s")

    @property
    def sensed(self) -> bool:
        """Whether the observations are noisy or late."""
        return bool(self.velocity_noise or self.delay)

    @property
    def motored(self) -> bool:
        """Whether the applied torque differs from the commanded one."""
        return bool(self.torque_noise or self.torque_response != 1.0)

    def push_steps(self, physics_steps: int, frame_skip: int, dt: float) -> list[int]:
        """The physics steps [0, ``physics_steps``) before which a push lands, one per multiple
        of ``push_every``; refused where ``push_every`` is shorter than a decision
        (``frame_skip`` steps of ``dt`` [s]) or no push lands within ``physics_steps``."""
        if self.push_every is None:
            return []
        decision = dt * frame_skip
        episode = physics_steps * dt
        if self.push_every < decision * (1.0 - 1e-9):  # steps_in's tolerance: one push a decision
            raise ValueError(
                f"push_every must be at least one decision ({decision:g} s), got "
                f"{self.push_every:g} s: a decision takes one push at most"
            )
        if steps_in(self.push_every, decision) * frame_skip >= physics_steps:
            raise ValueError(
                f"push_every {self.push_every:g} s lands no push within an episode of "
                f"{episode:g} s: give a shorter period or longer episodes"
            )
        steps, n = [], 1
        while (k := steps_in(n * self.push_every, decision) * frame_skip) < physics_steps:
            steps.append(k)
            n += 1
        return steps

    def perturbed(self, nominal: dict[str, float], rng: np.random.Generator) -> dict[str, float]:
        """``nominal`` masses [kg] and inertias [kg m^2] (``LINK_PARAMETERS``), each scaled."""
        if self.perturb == 0.0:
            return dict(nominal)
        scale = rng.uniform(1.0 - self.perturb, 1.0 + self.perturb, size=len(LINK_PARAMETERS))
        return {name: nominal[name] * s for name, s in zip(LINK_PARAMETERS, scale, strict=True)}


@dataclass(frozen=True)
class Perturbation(Settings):
    """What the controller does not know: a start offset [rad, rad/s], link masses and inertias
    scaled in MuJoCo's model (:func:`~acrobot_mj.envs.links.scale_links`), and Gaussian torque noise
    on the elbow [N m] drawn from ``seed``."""

    what: ClassVar[str] = "perturbation"

    start_offset: tuple[float, float, float, float] = setting(
        (0.0, 0.0, 0.0, 0.0), "added to the start state", "rad, rad/s", low=-1.0, high=1.0
    )
    mass_scale: float = setting(
        1.0, "each link's mass times this", low=0.0, low_open=True, high=10.0
    )
    inertia_scale: float = setting(
        1.0, "each link's inertia times this", low=0.0, low_open=True, high=10.0
    )
    torque_noise: float = setting(
        0.0, "Gaussian noise on the elbow torque, drawn from seed", "N m", low=0.0, high=1e3
    )
    seed: int = setting(0, "seed of the torque noise", low=0)


class Pushed(gym.Wrapper):
    """Adds the pushes of :meth:`Disturbances.push_steps` to the velocities of the env below
    (the env's own velocity limits still apply) and records them in ``pushes`` as
    ``[k, d_dq1, d_dq2]``. :meth:`begin` gives each episode its steps and generator."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        acrobot = acrobot_under(env, "Pushed")
        limit = env.spec.max_episode_steps if env.spec else None
        if limit is None:
            raise ValueError("pushes need an env with a time limit (gymnasium.make gives one)")
        self.frame_skip = int(acrobot.frame_skip)
        #: Physics steps [s] and how many an episode has at most.
        self.physics_dt = float(acrobot.model.opt.timestep)
        self.physics_steps = limit * self.frame_skip
        self.pushes: list[list[float]] = []
        self._steps: list[int] = []
        self._rng: np.random.Generator | None = None
        self._size, self._physics_step = 0.0, 0

    def begin(self, steps: list[int], size: float, rng: np.random.Generator) -> None:
        """The next episode's push steps, push size [rad/s] and generator."""
        self._steps, self._size, self._rng = list(steps), size, rng

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        self.pushes, self._physics_step = [], 0
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        if self._steps and self._steps[0] == self._physics_step:
            self._steps.pop(0)
            assert self._rng is not None
            self.pushes.append([self._physics_step, *push(self.env, self._rng, self._size)])
        self._physics_step += self.frame_skip
        return self.env.step(action)


def push(env: gym.Env, rng: np.random.Generator, size: float) -> list[float]:
    """Add ``U(-size, size)`` [rad/s] to each joint velocity; what was drawn."""
    kick = rng.uniform(-size, size, size=2)
    add_velocity(env, kick)
    return kick.tolist()


def add_velocity(env: gym.Env, kick: Any) -> None:
    """Add ``kick`` [rad/s] to ``env``'s joint velocities, clipped to the velocity limits as
    every physics step is."""
    qvel = env.unwrapped.data.qvel  # type: ignore[attr-defined]
    qvel[:] = limit_velocities(*(qvel + np.asarray(kick, dtype=np.float64)), (MAX_VEL1, MAX_VEL2))


def recoveries(
    error: np.ndarray,
    tolerance: float,
    dt: float,
    pushes: list[int],
    settle: float = SETTLE,
    fall: float = FALL,
) -> dict[str, Any]:
    """How an episode of upright errors ``error[j]`` [rad] (decisions ``dt`` [s] apart;
    ``pushes``: the decisions before which a push landed) caught and kept its balance. A catch
    is ``settle`` [s] within ``tolerance`` (or to the end); a fall is an error past ``fall``
    after a catch, before the next. ``first_balance_seconds`` (None: never), ``falls``,
    ``balanced_at_end``, and per push ``recovered_seconds`` (0: it never left the tolerance;
    None: no catch before the next push or the end), ``fell`` (None: it was not balanced when
    pushed) and ``balanced_seconds`` (within the tolerance until the next push or the end)."""
    error = np.asarray(error, dtype=float)
    balanced = error < tolerance
    n, need = len(balanced), max(1, steps_in(settle, dt))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], balanced.astype(np.int8), [0]])))
    stretches = [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    catches = [(a, b) for a, b in stretches if b - a >= need or b == n]

    def falls_between(start: int) -> bool:  # past ``fall`` before the next catch from start
        nxt = [a for a, _ in catches if a > start]
        return bool(np.any(error[start : nxt[0] if nxt else n] > fall))

    after = []
    for j, k in enumerate(pushes):
        end = pushes[j + 1] if j + 1 < len(pushes) else n
        held = [b for a, b in catches if a <= k < b]
        fell = None if not held else falls_between(k)
        later = [a for a, _ in catches if k < a < end]
        recovered = 0.0 if held and held[0] >= end else (later[0] - k) * dt if later else None
        after.append(
            {
                "recovered_seconds": recovered,
                "fell": fell,
                "balanced_seconds": float(balanced[k:end].sum() * dt),
            }
        )
    return {
        "first_balance_seconds": catches[0][0] * dt if catches else None,
        "falls": sum(falls_between(b) for _, b in catches if b < n),
        "balanced_at_end": bool(catches and catches[-1][1] == n),
        "after_pushes": after,
    }


def replay(
    env: gym.Env,
    start: list[float],
    torques: list[float],
    pushes: list[list[float]],
    parameters: dict[str, float] | None = None,
) -> np.ndarray:
    """The state after ``torques`` (one per physics step) and ``pushes`` from ``start`` on
    ``env`` (continuous torques, one physics step a decision, no time limit shorter than the
    torques), with its model's ``parameters`` set first."""
    acrobot = env.unwrapped
    if acrobot.frame_skip != 1 or not acrobot.continuous:  # type: ignore[attr-defined]
        raise ValueError("replay needs an env of continuous torques and frame_skip=1")
    if parameters is not None:
        set_model_parameters(env, parameters)
    env.reset(options={"state": np.asarray(start, dtype=np.float64)})
    kicks = {int(k): (d1, d2) for k, d1, d2 in pushes}
    for k, torque in enumerate(torques):
        if k in kicks:
            add_velocity(env, kicks[k])
        env.step(np.array([torque], dtype=np.float32))
    return acrobot.state  # type: ignore[attr-defined]
