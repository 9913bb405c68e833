"""A run of the AI Olympics protocol: its episodes (:mod:`acrobot_mj.olympics.episodes`), the
controller any :class:`~acrobot_mj.control.controller.Controller` or a
:class:`~acrobot_mj.olympics.sources.Source` of one, built once per process; episodes shared
over a :class:`~acrobot_mj.pool.WorkerPool` or a :class:`~acrobot_mj.pool.RayPool`; scores
and record by :mod:`acrobot_mj.olympics.scores` and :mod:`acrobot_mj.olympics.report`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.bars import Steps
from acrobot_mj.checks import check_int
from acrobot_mj.control.controller import Controller
from acrobot_mj.olympics import protocol, sources
from acrobot_mj.olympics.bound import check_model, uptime_bound
from acrobot_mj.olympics.episodes import Conditions, Scored, episode, global_episode
from acrobot_mj.olympics.protocol import ROBUSTNESS, Category, Robustness
from acrobot_mj.olympics.report import EpisodeRecord, Olympics
from acrobot_mj.olympics.scaling import Rules, protocol_for
from acrobot_mj.olympics.scores import final_success
from acrobot_mj.olympics.sources import Source
from acrobot_mj.physics.models import resolve
from acrobot_mj.physics.xp import symbolic
from acrobot_mj.pool import Ray, RayPool, WorkerPool

#: The parts of the protocol, in the order they run.
PARTS = ("performance", "robustness", "global")


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


def described(model: str, scored: Scored) -> dict[str, Any]:
    """The record's ``model``: the acrobot's name, the controller's (:func:`named`) and an
    entry's options where it was given any."""
    given = scored.options if isinstance(scored, Source) else {}
    return {"name": model, "entry": named(scored)} | ({"options": dict(given)} if given else {})


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
    come from its seed alone: the record is the same wherever the episodes run. ``bound``:
    each global episode's bound (:mod:`~acrobot_mj.olympics.bound`) beside its score."""

    scored: Scored
    model: str = "ai_olympics"
    parts: tuple[str, ...] = PARTS
    seed: int = 0
    jobs: int | Ray = 1
    progress: bool = False
    protocol: Rules | None = None
    global_seeds: int = 1
    bound: bool = False

    def __post_init__(self) -> None:
        check_int("global_seeds", self.global_seeds, 1, 10_000)
        if self.global_seeds > 1 and "global" not in self.parts:
            raise ValueError(f"global_seeds={self.global_seeds} needs the global score")
        if self.bound and "global" not in self.parts:
            raise ValueError("the bound is the global score's: it needs the global score")
        if self.bound:
            check_model(self.model)
            symbolic()  # the control extra, refused at once where missing
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
        if self.bound:
            episodes += [
                ("bound", uptime_bound, (self.model, s, used.global_policy)) for s in drawn
            ]
        with Steps(len(episodes), "olympics", self.progress, "episodes") as bar:
            results = _played(self.jobs, episodes, bar)
        performance = results.pop(0) if "performance" in self.parts else None
        found = [results.pop() for _ in drawn if self.bound][::-1]
        records, runs = results[: len(results) - len(drawn)], results[len(results) - len(drawn) :]
        p = model.params
        return Olympics(
            model=described(self.model, self.scored),
            lengths=(p.l1, p.l2),
            seeds={"seed": self.seed},
            performance=performance,
            categories=categories,
            episodes=_grouped(categories, records),
            global_episodes=tuple(recording for recording, _ in runs),
            global_seeds=tuple(drawn),
            global_draws=runs[0][1] if runs else {},
            global_bounds=tuple(found),
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
    **options: Any,
) -> dict[str, Any]:
    """The protocol's ``scores`` (some of :data:`PARTS`) of ``controller`` on ``model``: a
    :class:`~acrobot_mj.control.controller.Controller`, an object in ``double_pendulum``'s
    convention, a :class:`~acrobot_mj.olympics.sources.Source` or its name. The record
    :func:`~acrobot_mj.olympics.report.olympics_record` makes (every score, every episode),
    nothing written. ``options``: the rest of :class:`OlympicsRun`'s fields (``seed``,
    ``jobs``: processes or a :class:`~acrobot_mj.pool.Ray` cluster, ``global_seeds``: the
    global score's mean over that many seeds from ``seed`` with its 95 % interval, ``bound``,
    ``progress``, ``protocol``)."""
    from acrobot_mj.olympics.foreign import DoublePendulumController, TheirConvention
    from acrobot_mj.olympics.report import olympics_record

    if isinstance(controller, DoublePendulumController) and not isinstance(controller, Controller):
        controller = TheirConvention(controller)
    run = OlympicsRun(controller, model, tuple(scores), **options)
    return olympics_record(run.run())
