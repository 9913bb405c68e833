"""The AI Olympics protocol run on this project's MuJoCo model of an acrobot: each episode an
:class:`~acrobot_mj.envs.acrobot.AcrobotEnv` stepping every 0.002 s (continuous torques), under
the disturbance wrappers of :mod:`acrobot_mj.envs` (:class:`~acrobot_mj.envs.sensor.Sensor`,
:class:`~acrobot_mj.envs.motor.Motor`, :class:`~acrobot_mj.envs.model_error.ModelError`), its
controller a named entry (:mod:`acrobot_mj.olympics.entries`) built once per process; episodes
shared over a :class:`~acrobot_mj.pool.WorkerPool`; scores and record by
:mod:`acrobot_mj.olympics.scores` and :mod:`acrobot_mj.olympics.report`."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from acrobot_mj.bars import Steps
from acrobot_mj.envs.acrobot import AcrobotEnv
from acrobot_mj.envs.model_error import ModelError
from acrobot_mj.envs.motor import Motor
from acrobot_mj.envs.sensor import Sensor
from acrobot_mj.olympics import protocol, trained
from acrobot_mj.olympics.globaltest import GlobalTester
from acrobot_mj.olympics.protocol import DT, GLOBAL, ROBUSTNESS, Category, GlobalPolicy, Robustness
from acrobot_mj.olympics.report import EpisodeRecord, Olympics
from acrobot_mj.olympics.scaling import Protocol, protocol_for
from acrobot_mj.olympics.scores import Recording, final_success
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.models import resolve
from acrobot_mj.pool import WorkerPool

#: The parts of the protocol, in the order they run.
PARTS = ("performance", "robustness", "global")


@dataclass(frozen=True)
class Conditions:
    """What one episode meets: the ``sensor``'s delay [s] and sigmas, the ``motor``'s
    response, sigma [N m] and pulse torques (2, steps), ``model_error`` values (the
    protocol's parameter names); empty: none."""

    sensor: dict[str, Any] = field(default_factory=dict)
    motor: dict[str, Any] = field(default_factory=dict)
    model_error: dict[str, float] = field(default_factory=dict)


def make_env(model: str, conditions: Conditions, seed: int) -> tuple[Any, Motor]:
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


def episode(
    entry: str, model: str, seconds: float, conditions: Conditions, seed: int, dt: float = DT
) -> Recording:
    """One episode of ``seconds`` [s] in steps of ``dt`` [s] from hanging at rest under
    ``entry``'s controller for ``model`` and ``conditions``: true states and the elbow torques
    applied."""
    controller = trained.build(entry, model)
    env, motor = make_env(model, conditions, seed)
    times = protocol.episode_times(seconds, dt)
    obs, _ = env.reset(options={"state": HANGING})
    controller.reset()
    acrobot = env.unwrapped
    states = [acrobot.state]
    for _ in range(len(times) - 1):
        obs = env.step(np.array([controller(obs)]))[0]
        states.append(acrobot.state)
    env.close()
    return Recording(times, np.array(states), motor.applied[:, motor.dof])


def global_run(
    controller: Any,
    model: str,
    targets: np.ndarray,
    reset_times: np.ndarray,
    policy: GlobalPolicy = GLOBAL,
    *,
    start: np.ndarray = HANGING,
) -> Recording:
    """``controller`` (``reset()``, ``controller(obs) -> elbow torque``) for ``policy``'s
    episode from ``start`` (the protocol's: hanging at rest) inside the protocol's testing
    controller (resets to ``targets`` at ``reset_times``), both joints driven within
    ``policy``'s limits (the shoulder through MuJoCo's ``qfrc_applied``: the env's motor drives
    the elbow only; a reset's elbow torque beyond the motor's limit acts there too)."""
    acrobot = resolve(model)
    tester = GlobalTester(controller, acrobot, targets, reset_times, policy)
    env = AcrobotEnv(model=model, continuous=True, task="balance")
    times = protocol.episode_times(policy.t_final, policy.dt)
    obs, _ = env.reset(options={"state": start})
    tester.reset()
    states, torques = [env.state], []
    limit = acrobot.params.max_torque
    for t in times[:-1]:
        shoulder, elbow = tester(float(t), obs, env.state)
        excess = elbow - float(np.clip(elbow, -limit, limit)) if tester.resetting else 0.0
        env.data.qfrc_applied[:] = (shoulder, excess)
        obs = env.step(np.array([elbow - excess]))[0]
        states.append(env.state)
        torques.append(elbow)
    env.close()
    return Recording(times, np.array(states), np.array(torques))


def global_episode(
    entry: str, model: str, seed: int, policy: GlobalPolicy = GLOBAL
) -> tuple[Recording, dict[str, Any]]:
    """The global-policy episode of ``seed``: ``entry`` (an entry or a trained run) in
    :func:`global_run` for ``policy``'s episode, random targets and reset times."""
    targets, reset_times = policy.draw(np.random.default_rng(seed))
    recording = global_run(trained.build(entry, model), model, targets, reset_times, policy)
    return recording, {"targets": targets.tolist(), "reset_times": reset_times.tolist()}


def _level_conditions(category: Category, parameter: str, value: float) -> Conditions:
    """The conditions of one level of ``category``."""
    key = category.key
    if key == "model":
        return Conditions(model_error={parameter: value})
    if key == "measurement_noise":
        return Conditions(sensor={"sigma": (0.0, 0.0, value, value)})
    if key == "u_noise":
        return Conditions(motor={"sigma": value})
    if key == "u_responsiveness":
        return Conditions(motor={"response": value})
    if key == "delay":
        return Conditions(sensor={"delay": value, "mode": "posvel"})
    raise ValueError(f"no conditions for the category {key!r}")


def _robust_episode(
    entry: str,
    model: str,
    conditions: Conditions,
    seed: int,
    disturbance: dict[str, Any],
    robustness: Robustness = ROBUSTNESS,
) -> EpisodeRecord:
    recording = episode(entry, model, robustness.t_final, conditions, seed, robustness.dt)
    success = final_success(recording.X[-1], robustness.epsilon)
    return EpisodeRecord.of(recording, success, disturbance)


def _calls(
    entry: str, model: str, category: Category, seed: int, robustness: Robustness = ROBUSTNESS
) -> list[tuple]:
    """The episodes of ``category`` as calls of :func:`_robust_episode`, in order."""
    calls = []
    base = protocol.CATEGORY_KEYS.index(category.key)
    for s, sweep in enumerate(category.sweeps):
        for level, value in enumerate(sweep.levels):
            for rep in range(category.repetitions):
                episode_seed = int(
                    np.random.SeedSequence([seed, base, s, level, rep]).generate_state(1)[0]
                )
                disturbance: dict[str, Any]
                if category.key == "perturbation":
                    pulses = robustness.perturbations.draw(
                        np.random.default_rng(episode_seed), robustness.t_final
                    )
                    torques = pulses.torques(robustness.t_final, robustness.dt)
                    conditions = Conditions(motor={"pulses": torques})
                    disturbance = pulses.to_dict()
                else:
                    conditions = _level_conditions(category, sweep.parameter, value)
                    disturbance = {sweep.parameter: value}
                calls.append((entry, model, conditions, episode_seed, disturbance, robustness))
    return calls


def _grouped(categories: tuple[Category, ...], records: list[EpisodeRecord]) -> dict[str, Any]:
    """The episode records in the order :func:`_calls` made them, by category key, sweep and
    level."""
    episodes, k = {}, 0
    for category in categories:
        grouped = []
        for sweep in category.sweeps:
            levels = []
            for _ in sweep.levels:
                levels.append(records[k : k + category.repetitions])
                k += category.repetitions
            grouped.append(levels)
        episodes[category.key] = grouped
    return episodes


@dataclass(frozen=True)
class OlympicsRun:
    """One run of the protocol: ``entry`` (a name in
    :data:`~acrobot_mj.olympics.entries.ENTRIES`) on ``model``,
    the ``parts`` of :data:`PARTS`, every draw from ``seed``, episodes on ``jobs`` processes,
    a bar on stderr with ``progress``; ``protocol`` (None: the original on ``ai_olympics``,
    else scaled to ``model``, :func:`~acrobot_mj.olympics.scaling.protocol_for`). ``entry``
    may be a trained run's folder (:mod:`~acrobot_mj.olympics.trained`)."""

    entry: str
    model: str = "ai_olympics"
    parts: tuple[str, ...] = PARTS
    seed: int = 0
    jobs: int = 1
    progress: bool = False
    protocol: Protocol | None = None

    def __post_init__(self) -> None:
        trained.check(self.entry, self.model)
        if self.protocol is None:
            object.__setattr__(self, "protocol", protocol_for(self.model))
        unknown = sorted(set(self.parts) - set(PARTS))
        if unknown or not self.parts:
            raise ValueError(f"scores must be some of {list(PARTS)}, got {list(self.parts)}")

    def run(self) -> Olympics:
        """Every episode of the parts asked for, for
        :class:`~acrobot_mj.olympics.report.Olympics` to score."""
        model, used = resolve(self.model), self.protocol
        assert used is not None
        robustness = used.robustness
        categories = robustness.categories(model) if "robustness" in self.parts else ()
        work = [
            c
            for category in categories
            for c in _calls(self.entry, self.model, category, self.seed, robustness)
        ]
        total = len(work) + ("performance" in self.parts) + ("global" in self.parts)
        pool = WorkerPool(self.jobs) if self.jobs > 1 and work else None
        with (
            pool or contextlib.nullcontext(),
            Steps(total, "olympics", self.progress, "episodes") as bar,
        ):
            performance = None
            if "performance" in self.parts:
                run = used.performance
                performance = episode(
                    self.entry, self.model, run.t_final, Conditions(), self.seed, run.dt
                )
                bar.done("performance")
            records = []
            each = (
                (_robust_episode(*c) for c in work)
                if pool is None
                else pool.map(_robust_episode, work)
            )
            for record in each:
                records.append(record)
                bar.done("robustness")
            global_run, draws = None, dict[str, Any]()
            if "global" in self.parts:
                global_run, draws = global_episode(
                    self.entry, self.model, self.seed, used.global_policy
                )
                bar.done("global")
        p = model.params
        return Olympics(
            model={"name": self.model, "entry": self.entry},
            lengths=(p.l1, p.l2),
            seeds={"seed": self.seed},
            performance=performance,
            categories=categories,
            episodes=_grouped(categories, records),
            global_episode=global_run,
            global_draws=draws,
            protocol=used,
        )
