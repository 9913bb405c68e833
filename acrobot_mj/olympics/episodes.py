"""One episode of the AI Olympics protocol on this project's MuJoCo model of an acrobot: an
:class:`~acrobot_mj.envs.acrobot.AcrobotEnv` stepping every 0.002 s (continuous torques) under
the disturbance wrappers of :mod:`acrobot_mj.envs` (:class:`~acrobot_mj.envs.sensor.Sensor`,
:class:`~acrobot_mj.envs.motor.Motor`, :class:`~acrobot_mj.envs.model_error.ModelError`), or
inside the global test's resets; its controller any
:class:`~acrobot_mj.control.controller.Controller` or a
:class:`~acrobot_mj.olympics.sources.Source` of one, through the one episode loop."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.envs.acrobot import AcrobotEnv
from acrobot_mj.envs.model_error import ModelError
from acrobot_mj.envs.motor import Motor
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.envs.sensor import Sensor
from acrobot_mj.olympics import protocol, sources
from acrobot_mj.olympics.globaltest import GlobalTester
from acrobot_mj.olympics.protocol import DT, GLOBAL, GlobalPolicy
from acrobot_mj.olympics.scores import Recording
from acrobot_mj.olympics.sources import Source
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.models import resolve

#: What the protocol scores: a controller, or where to build one (a name: its Source).
Scored = Controller | Source | str


@dataclass(frozen=True)
class Conditions:
    """What one episode meets: the ``sensor``'s delay [s] and sigmas, the ``motor``'s
    response, sigma [N m] and pulse torques (2, steps), ``model_error`` values (the
    protocol's parameter names); empty: none."""

    sensor: dict[str, Any] = field(default_factory=dict)
    motor: dict[str, Any] = field(default_factory=dict)
    model_error: dict[str, float] = field(default_factory=dict)


def protocol_env(model: str, conditions: Conditions, seed: int) -> tuple[Any, Motor]:
    """The env of one episode: ``model``'s acrobot, continuous torques, no episode end, under
    ``conditions`` (noise streams from ``seed``); and its motor, which records the torques."""
    env: Any = AcrobotEnv(model=model, continuous=True, task="balance")
    if conditions.model_error:
        env = ModelError(env, conditions.model_error)
    motor = Motor(
        env, rng=np.random.SeedSequence([seed, 1]).generate_state(1)[0].item(), **conditions.motor
    )
    sensor_seed = np.random.SeedSequence([seed, 2]).generate_state(1)[0].item()
    return Sensor(motor, rng=sensor_seed, **conditions.sensor), motor


class ProtocolActor:
    """A controller as an episode-loop actor on the protocol's env: it acts on what the env
    observes at the protocol's ``times`` [s], its torque clipped to ``limit`` [N m] as the
    protocol's plant clips it, and is told the clipped torque; ``states`` records the true
    state at each time."""

    def __init__(self, controller: Controller, env: Any, times: np.ndarray, limit: float) -> None:
        self.controller, self.limit = controller, limit
        self.acrobot = env.unwrapped
        self.times: list[float] = times.tolist()  # floats: a lookup every step
        #: The true states, each ``(q1, q2, dq1, dq2)`` as floats (``acrobot.state``'s numbers).
        self.states: list[tuple[float, ...]] = []

    def _state(self) -> tuple[float, ...]:
        data = self.acrobot.data
        return (*data.qpos.tolist(), *data.qvel.tolist())

    def begin(self, obs: np.ndarray) -> Any:
        self.controller.reset()
        self.states = [self._state()]
        return self._act(obs)

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        self.states.append(self._state())
        return None if terminated or truncated else self._act(obs)

    def _act(self, obs: np.ndarray) -> np.ndarray:
        t = self.times[len(self.states) - 1]
        torque = min(max(self.controller.act(obs, t), -self.limit), self.limit)
        self.controller.applied(torque)
        return np.array([torque])


class GlobalActor(ProtocolActor):
    """The protocol's testing controller (:class:`~acrobot_mj.olympics.globaltest.GlobalTester`)
    as an actor: it acts on the true state; its shoulder torque, and a reset's elbow torque
    beyond the motor's limit, drive the joints through MuJoCo's ``qfrc_applied`` (the env's
    motor drives the elbow only); ``torques`` records the elbow's whole torque."""

    def __init__(self, tester: GlobalTester, env: Any, times: np.ndarray, limit: float) -> None:
        super().__init__(tester, env, times, limit)
        self.tester, self.torques = tester, list[float]()

    def _act(self, obs: np.ndarray) -> np.ndarray:
        t = self.times[len(self.states) - 1]
        elbow = self.tester.act(self.acrobot.state, t)
        clipped = float(np.clip(elbow, -self.limit, self.limit))
        excess = elbow - clipped if self.tester.resetting else 0.0
        self.acrobot.data.qfrc_applied[:] = (self.tester.shoulder, excess)
        self.torques.append(elbow)
        return np.array([elbow - excess])


def episode(
    scored: Scored, model: str, seconds: float, conditions: Conditions, seed: int, dt: float = DT
) -> Recording:
    """One episode of ``seconds`` [s] in steps of ``dt`` [s] from hanging at rest under the
    controller ``scored`` for ``model`` and ``conditions`` (:class:`ProtocolActor`, through
    the one episode loop): true states and the elbow torques applied."""
    env, motor = protocol_env(model, conditions, seed)
    times = protocol.episode_times(seconds, dt)
    limit = resolve(model).params.max_torque
    actor = ProtocolActor(sources.build(scored, model), env, times, limit)
    run_episode(env, actor, options={"state": HANGING}, max_steps=len(times) - 1)
    env.close()
    return Recording(times, np.array(actor.states), motor.applied[:, motor.dof])


def global_run(
    controller: Controller,
    model: str,
    targets: np.ndarray,
    reset_times: np.ndarray,
    policy: GlobalPolicy = GLOBAL,
    *,
    start: np.ndarray = HANGING,
) -> Recording:
    """``controller`` for ``policy``'s episode from ``start`` (the protocol's: hanging at rest)
    inside the protocol's testing controller (resets to ``targets`` at ``reset_times``), both
    joints driven within ``policy``'s limits (:class:`GlobalActor`)."""
    acrobot = resolve(model)
    tester = GlobalTester(controller, acrobot, targets, reset_times, policy)
    env = AcrobotEnv(model=model, continuous=True, task="balance")
    times = protocol.episode_times(policy.t_final, policy.dt)
    actor = GlobalActor(tester, env, times, acrobot.params.max_torque)
    run_episode(env, actor, options={"state": start}, max_steps=len(times) - 1)
    env.close()
    return Recording(times, np.array(actor.states), np.array(actor.torques))


def global_episode(
    scored: Scored, model: str, seed: int, policy: GlobalPolicy = GLOBAL
) -> tuple[Recording, dict[str, Any]]:
    """The global-policy episode of ``seed``: the controller ``scored`` in :func:`global_run`
    for ``policy``'s episode, random targets and reset times."""
    targets, reset_times = policy.draw(seed)
    recording = global_run(sources.build(scored, model), model, targets, reset_times, policy)
    return recording, {"targets": targets.tolist(), "reset_times": reset_times.tolist()}
