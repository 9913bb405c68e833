"""The AI Olympics protocol run on this project's MuJoCo model of an acrobot: each episode an
:class:`~acrobot_mj.envs.acrobot.AcrobotEnv` stepping every 0.002 s (continuous torques), under
the disturbance wrappers of :mod:`acrobot_mj.envs` (:class:`~acrobot_mj.envs.sensor.Sensor`,
:class:`~acrobot_mj.envs.motor.Motor`, :class:`~acrobot_mj.envs.model_error.ModelError`), its
controller any :class:`~acrobot_mj.control.controller.Controller` or a
:class:`~acrobot_mj.olympics.sources.Source` of one, built once per process; episodes shared
over a :class:`~acrobot_mj.pool.WorkerPool` or a :class:`~acrobot_mj.pool.RayPool`; scores
and record by :mod:`acrobot_mj.olympics.scores` and :mod:`acrobot_mj.olympics.report`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from acrobot_mj.bars import Steps
from acrobot_mj.checks import check_int
from acrobot_mj.control.controller import Controller
from acrobot_mj.envs.acrobot import AcrobotEnv
from acrobot_mj.envs.model_error import ModelError
from acrobot_mj.envs.motor import Motor
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.envs.sensor import Sensor
from acrobot_mj.olympics import protocol, sources
from acrobot_mj.olympics.globaltest import GlobalTester
from acrobot_mj.olympics.protocol import DT, GLOBAL, ROBUSTNESS, Category, GlobalPolicy, Robustness
from acrobot_mj.olympics.report import EpisodeRecord, Olympics
from acrobot_mj.olympics.scaling import Rules, protocol_for
from acrobot_mj.olympics.scores import Recording, final_success
from acrobot_mj.olympics.sources import Source
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.models import resolve
from acrobot_mj.pool import Ray, RayPool, WorkerPool

#: The parts of the protocol, in the order they run.
PARTS = ("performance", "robustness", "global")
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
    scored: Scored,
    model: str,
    conditions: Conditions,
    seed: int,
    disturbance: dict[str, Any],
    robustness: Robustness = ROBUSTNESS,
) -> EpisodeRecord:
    recording = episode(scored, model, robustness.t_final, conditions, seed, robustness.dt)
    success = final_success(recording.X[-1], robustness.epsilon)
    return EpisodeRecord.of(recording, success, disturbance)


def _calls(
    scored: Scored, model: str, category: Category, seed: int, robustness: Robustness = ROBUSTNESS
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
                calls.append((scored, model, conditions, episode_seed, disturbance, robustness))
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


def named(scored: Scored) -> str:
    """What the record calls the controller: its source's name, or its class's."""
    if isinstance(scored, str):
        return scored
    return scored.name if isinstance(scored, Source) else type(scored).__name__


@dataclass(frozen=True)
class OlympicsRun:
    """One run of the protocol: the controller ``scored`` (a
    :class:`~acrobot_mj.control.controller.Controller`, or a
    :class:`~acrobot_mj.olympics.sources.Source` of one) on ``model``, the ``parts`` of
    :data:`PARTS`, every draw from ``seed``, episodes on ``jobs`` processes (a controller
    object must then be picklable) or as tasks on a :class:`~acrobot_mj.pool.Ray` cluster
    (each gets the controller built here), a bar on stderr with ``progress``; ``protocol``
    (None: the original on ``ai_olympics``, else scaled to ``model``,
    :func:`~acrobot_mj.olympics.scaling.protocol_for`); ``global_seeds`` global episodes, of
    seeds ``seed``, ``seed + 1``, ... (their mean is the global score). Each episode's numbers
    come from its seed alone: the record is the same wherever the episodes run."""

    scored: Scored
    model: str = "ai_olympics"
    parts: tuple[str, ...] = PARTS
    seed: int = 0
    jobs: int | Ray = 1
    progress: bool = False
    protocol: Rules | None = None
    global_seeds: int = 1

    def __post_init__(self) -> None:
        check_int("global_seeds", self.global_seeds, 1, 10_000)
        if self.global_seeds > 1 and "global" not in self.parts:
            raise ValueError(f"global_seeds={self.global_seeds} needs the global score")
        if isinstance(self.jobs, Ray):
            self.jobs.check()
        else:
            check_int("jobs", self.jobs, 1)
        if isinstance(self.scored, str):
            object.__setattr__(self, "scored", Source(self.scored))
        if isinstance(self.scored, Source):
            sources.check_source(self.scored, self.model)
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
        scored = self.scored
        if isinstance(scored, Source):  # built here once (a learnt plan is planned, kept)
            built = sources.build(scored, self.model)
            # Ray's workers are no forks of this process: they get what was built here (no
            # plan made again, no file of this machine read there).
            scored = built if isinstance(self.jobs, Ray) else scored
        robustness = used.robustness
        categories = robustness.categories(model) if "robustness" in self.parts else ()
        episodes: list[tuple[str, Any, tuple]] = [
            ("robustness", _robust_episode, c)
            for category in categories
            for c in _calls(scored, self.model, category, self.seed, robustness)
        ]
        if "performance" in self.parts:
            run = used.performance
            call = (scored, self.model, run.t_final, Conditions(), self.seed, run.dt)
            episodes.insert(0, ("performance", episode, call))
        drawn = range(self.seed, self.seed + self.global_seeds) if "global" in self.parts else ()
        episodes += [
            ("global", global_episode, (scored, self.model, s, used.global_policy)) for s in drawn
        ]
        with Steps(len(episodes), "olympics", self.progress, "episodes") as bar:
            results = _played(self.jobs, episodes, bar)
        performance = results.pop(0) if "performance" in self.parts else None
        records, runs = results[: len(results) - len(drawn)], results[len(results) - len(drawn) :]
        p = model.params
        return Olympics(
            model={"name": self.model, "entry": named(self.scored)},
            lengths=(p.l1, p.l2),
            seeds={"seed": self.seed},
            performance=performance,
            categories=categories,
            episodes=_grouped(categories, records),
            global_episodes=tuple(recording for recording, _ in runs),
            global_seeds=tuple(drawn),
            global_draws=runs[0][1] if runs else {},
            protocol=used,
        )


def _played(jobs: int | Ray, episodes: list[tuple], bar: Steps) -> list:
    """Each ``(part, play, args)`` of ``episodes``, ``play(*args)``: here, one after the other
    (``jobs`` 1, or a single episode), else on a pool of ``jobs`` processes or on a Ray
    cluster; ``bar`` told of each ``part`` as it ends. The results in the order of
    ``episodes``."""
    if not isinstance(jobs, Ray) and (jobs == 1 or len(episodes) < 2):
        done = []
        for part, play, args in episodes:
            done.append(play(*args))
            bar.done(part)
        return done
    results: list[Any] = [None] * len(episodes)
    calls = [(play, *args) for _, play, args in episodes]
    with RayPool(jobs) if isinstance(jobs, Ray) else WorkerPool(jobs) as pool:
        for index, ok, value in pool.finished(_play, calls):
            if not ok:
                raise value
            results[index] = value
            bar.done(episodes[index][0])
    return results


def _play(play: Any, *args: Any) -> Any:
    """``play(*args)``: one call, whatever the episode's function, for a pool."""
    return play(*args)


def score(
    controller: Scored,
    *,
    model: str = "ai_olympics",
    scores: tuple[str, ...] = PARTS,
    seed: int = 0,
    jobs: int | Ray = 1,
    global_seeds: int = 1,
) -> dict[str, Any]:
    """The protocol's ``scores`` (some of :data:`PARTS`) of ``controller`` on ``model``: a
    :class:`~acrobot_mj.control.controller.Controller`, an object in ``double_pendulum``'s
    convention, a :class:`~acrobot_mj.olympics.sources.Source` or its name. The record
    :func:`~acrobot_mj.olympics.report.olympics_record` makes (every score, every episode),
    nothing written; ``jobs``: processes, or a :class:`~acrobot_mj.pool.Ray` cluster to run the
    episodes as tasks on; ``global_seeds``: the global score's mean over that many seeds from
    ``seed``, with its 95 % interval."""
    from acrobot_mj.olympics.foreign import DoublePendulumController, TheirConvention
    from acrobot_mj.olympics.report import olympics_record

    if isinstance(controller, DoublePendulumController) and not isinstance(controller, Controller):
        controller = TheirConvention(controller)
    run = OlympicsRun(controller, model, tuple(scores), seed, jobs, global_seeds=global_seeds)
    return olympics_record(run.run())
