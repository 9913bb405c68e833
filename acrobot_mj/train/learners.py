"""The :class:`Learner` interface of everything trained or planned, and :class:`AgentLearner`:
one agent, or a population with the best kept, trained by interaction. Every random choice comes
from the run's seed, so a resumed run is identical to an uninterrupted one."""

from __future__ import annotations

import shutil
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from acrobot_mj.agents import Agent, DivergenceError
from acrobot_mj.agents.base import Greedy, Learning, RandomStream, Rewinding
from acrobot_mj.checks import check_int, check_memory
from acrobot_mj.envs.disturbances import Disturbances
from acrobot_mj.envs.rollout import Actor, Episode, Hooks, run_episode, run_from_rest
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.envs.wrappers import EnergyShaping
from acrobot_mj.files import versions, write_json
from acrobot_mj.settings import setting
from acrobot_mj.stops import SafePoints
from acrobot_mj.train.bookkeeping import Books
from acrobot_mj.train.checkpoint import (
    RESUME_MAY_DIFFER,
    Checkpoints,
    check_record_agrees,
    check_same_run,
    checkpoint_meta,
    load_checkpoint,
    load_into,
    read_checkpoint,
    read_for_resume,
    save_checkpoint,
)
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episode_log import RunLog
from acrobot_mj.train.monitor import run_total, watching
from acrobot_mj.train.records import (
    CHECKPOINT_FILE,
    EPISODE_LOG,
    RECENT,
    RUN_FILE,
    SUMMARY_FILE,
    History,
    Outcome,
    learner_dir,
    read_kind,
    recent_median,
    run_record,
    write_run,
)
from acrobot_mj.train.run import Run

#: Scores a trained learner ``k`` of a population (instead of its last training episodes).
Judge = Callable[[Agent, int], float]


#: The spawn key of every evaluation draw (training draws have none).
HELDOUT_BRANCH = 0xE7A1


@dataclass(frozen=True)
class HeldOut(Disturbances):
    """The held-out evaluation protocol: ``episodes`` starts from a stream no training seed
    gives, either rest plus ``U(-start_noise, start_noise)`` on each state variable
    (``starts_from="noise"``) or both angles uniform on the circle at rest (``"uniform"``), each
    episode ``seconds`` long (None: the env's own limit), under the
    :class:`~acrobot_mj.envs.disturbances.Disturbances` it adds these to: all drawn from
    ``seed``."""

    what: ClassVar[str] = "evaluation"

    episodes: int = setting(100, "held-out episodes", low=1, metavar="N")
    start_noise: float = setting(
        0.05,
        "half-width of the start noise (a balance-preset run's own: 0.01)",
        "rad, rad/s",
        low=0.0,
        high=1.0,
        metavar="S",
    )
    seed: int = setting(0, "seed of the held-out starts, pushes and perturbations", low=0)
    starts_from: str = setting(
        "noise",
        "noise: rest plus U(-S, S); uniform: both angles uniform on the circle, at rest",
        choices=("noise", "uniform"),
        flag="starts",
    )
    seconds: float | None = setting(
        None,
        "simulated seconds per episode (none: the run's own)",
        "s",
        low=0.0,
        low_open=True,
        high=86_400.0,
        metavar="T",
    )

    def disturbances(self) -> Disturbances:
        return Disturbances(**{f.name: getattr(self, f.name) for f in fields(Disturbances)})

    def stream(self, *purpose: int) -> np.random.Generator:
        """The generator of one ``purpose`` of the evaluation's draws (no purpose: the starts)."""
        key = (HELDOUT_BRANCH, *purpose)
        return np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=key))

    def starts(self, rest: np.ndarray) -> np.ndarray:
        """The held-out start states, shape ``(episodes, 4)``."""
        check_memory(f"{self.episodes:,} held-out starts", 64.0 * self.episodes)  # draws, sum
        rest = np.asarray(rest, dtype=np.float64)
        if rest.shape != (4,):
            raise ValueError(f"rest must be a state (q1, q2, dq1, dq2), got shape {rest.shape}")
        if self.starts_from == "uniform":
            angles = self.stream(UNIFORM).uniform(-np.pi, np.pi, size=(self.episodes, 2))
            return np.concatenate([angles, np.zeros((self.episodes, 2))], axis=1)
        rng = self.stream()
        return rest + rng.uniform(-self.start_noise, self.start_noise, size=(self.episodes, 4))

    def to_dict(self) -> dict[str, Any]:
        """Its settings; those added in 0.5.0 only where they differ from their defaults, so an
        older record's protocol reads the same."""
        default = asdict(DEFAULT)
        return {k: v for k, v in asdict(self).items() if k in BASIC or v != default[k]}


#: What every protocol record holds; the later settings appear where they are not the default.
BASIC = ("episodes", "start_noise", "seed")
#: The purposes of an evaluation's draws besides the noise starts (spawn keys).
UNIFORM, PUSHES, PERTURB, SENSOR, MOTOR = 1, 2, 3, 4, 5
#: The protocol of the README's learning results: 100 starts of U(-0.05, 0.05), seed 0.
DEFAULT = HeldOut()


class Learner(ABC):
    """A trained thing: it learns into a run directory (``learn``), acts through ``env`` and
    ``actor``, and is loaded back from the directory (``load``)."""

    #: ``run.json``'s ``kind`` (absent for agents) and the run's name in errors.
    kind: ClassVar[str | None] = None
    kind_name: ClassVar[str] = "agent"
    #: What acts in its episodes, in a video's record.
    describes: ClassVar[str] = "greedy"
    protocol: ClassVar[HeldOut] = DEFAULT
    #: Physics steps its plan swings up in (None: none planned), for the task's assessment.
    swing_up: int | None = None

    def __init__(self, config: Any, seed: int) -> None:
        self.config, self.seed = config, check_int("a run's seed", seed, 0)

    @abstractmethod
    def learn(self, run: Run) -> dict[str, Any]:
        """Train into ``run``; the run record (also ``run.json`` where there is a directory)."""

    @abstractmethod
    def env(self, **kwargs: Any) -> gym.Env:
        """The env its episodes run on (``kwargs``: render settings, ``max_episode_steps``)."""

    @abstractmethod
    def actor(self, env: gym.Env, episode: int) -> Actor:
        """Its greedy policy for evaluation episode ``episode`` (0: from rest) in ``env``."""

    @classmethod
    @abstractmethod
    def load(cls, run_dir: Path) -> Learner:
        """The learner a run directory holds (refused, saying why, if it holds none)."""

    def save(self, out: Path) -> None:
        """Its own files beside ``run.json`` in ``out`` (a plan, a model), for :meth:`keep`."""
        raise NotImplementedError(f"{type(self).__name__} keeps no files of its own")

    def keep(self, run: Run, fields: dict[str, Any]) -> dict[str, Any]:
        """The run record of a learner of a ``kind``: the kind, config and seed, ``fields``,
        the versions; written with its own files (:meth:`save`) where ``run`` has a directory."""
        record = {
            "kind": self.kind,
            "config": self.config.to_dict(),
            "seed": self.seed,
            **fields,
            "versions": versions(),
        }
        if run.out is not None:
            self.save(run.out)
            write_json(run.out / RUN_FILE, record)
        return record

    @classmethod
    def read_run(cls, run_dir: Path) -> dict[str, Any]:
        """``run_dir``'s ``run.json``, refused unless it records a run of this kind."""
        if cls.kind is None:
            raise TypeError(f"{cls.__name__} keeps no run.json of a kind")
        return read_kind(run_dir, cls.kind, cls.kind_name)


def episode_seed(seed: int, episode: int) -> int:
    """The env's reset seed of training episode ``episode`` of run ``seed``."""
    return int(np.random.SeedSequence([seed, episode]).generate_state(1)[0])


def tie_stream(run_seed: int, episode: int = 0) -> RandomStream:
    """The stream that breaks the ties of greedy episode ``episode`` of run ``run_seed``."""
    return RandomStream(np.random.SeedSequence([run_seed, episode]))


def learner_seed(seed: int, k: int) -> int:
    """The seed of learner ``k`` of a population run ``seed``."""
    return int(np.random.SeedSequence([seed, 0x9E37, k]).generate_state(1)[0])


def make_env(config: TrainConfig, **kwargs: Any) -> gym.Env:
    """The config's env (``gymnasium.make``, so with its TimeLimit) with its reward shaping."""
    return shape_rewards(gym.make(config.env_id, **{**config.env_kwargs(), **kwargs}), config)


def shape_rewards(env: gym.Env, config: TrainConfig) -> gym.Env:
    """``env`` with ``config``'s energy shaping (records report unshaped returns)."""
    if config.energy_shaping == 0.0:
        return env
    return EnergyShaping(env, config.energy_shaping, 1.0 if config.gamma is None else config.gamma)


def check_spaces(env: gym.Env) -> None:
    if not (isinstance(env.action_space, gym.spaces.Discrete) and env.action_space.n == 3):
        raise ValueError(f"the agents need a Discrete(3) action space, got {env.action_space}")
    if not isinstance(env.observation_space, gym.spaces.Box) or env.observation_space.shape != (4,):
        raise ValueError(
            "the agents need observations (q1, q2, dq1, dq2) in a Box of shape "
            f"(4,), got {env.observation_space}"
        )


def greedy_from_rest(env: gym.Env, agent: Agent, run_seed: int) -> Episode:
    """The greedy episode from rest that a run records."""
    return run_from_rest(env, Greedy(agent, tie_stream(run_seed)), run_seed)


class AgentLearner(Learner):
    """The config's agent (or the best of a ``population``) trained by interaction in ``env``."""

    def __init__(self, config: TrainConfig, seed: int, env: gym.Env | None = None) -> None:
        super().__init__(config, seed)
        if env is not None:
            check_spaces(env)
        self.given_env = env
        self.agent: Agent | None = None  # learn() or load() sets it

    def learn(self, run: Run) -> dict[str, Any]:
        learners = f" x{self.config.population}" if self.config.population > 1 else ""
        label = f"{self.config.algorithm}{learners} seed {self.seed}"
        with watching(run.monitor or False, run_total(self.config), label) as monitor:
            record, self.agent = self.train(replace(run, monitor=monitor))
        return record

    def train(self, run: Run) -> tuple[dict[str, Any], Agent]:
        """The run record and the kept agent."""
        return train_learners(self.config, self.seed, run, self.given_env)

    def env(self, **kwargs: Any) -> gym.Env:
        return make_env(self.config, **kwargs)

    def actor(self, env: gym.Env, episode: int) -> Actor:
        if self.agent is None:
            raise ValueError("this learner has no agent yet: learn() or load() one first")
        return Greedy(self.agent, tie_stream(self.seed, episode))

    @classmethod
    def load(cls, run_dir: Path) -> AgentLearner:
        path = Path(run_dir) / CHECKPOINT_FILE
        if not path.exists() and (Path(run_dir) / SUMMARY_FILE).exists():
            raise FileNotFoundError(
                f"{run_dir} holds several seeds ({SUMMARY_FILE}): give one "
                "of its seed_S directories"
            )
        meta, arrays, config = read_checkpoint(path)
        check_record_agrees(Path(run_dir), config, meta["seed"])
        learner = cls(config, meta["seed"])
        agent = learner.agent = config.make_agent(meta["seed"], learner.env().observation_space)
        load_into(agent.load_state_dict, arrays, path)
        return learner


def train_learners(
    config: TrainConfig, seed: int, run: Run, env: gym.Env | None = None, judge: Judge | None = None
) -> tuple[dict[str, Any], Agent]:
    """One learner, or ``config.population`` of them with the best kept: record and agent."""
    if config.population > 1:
        return train_population(config, seed, run, env, judge)
    return train_one(config, seed, run, env)


def train_one(
    config: TrainConfig, seed: int, run: Run, env: gym.Env | None = None, greedy: bool = True
) -> tuple[dict[str, Any], Agent]:
    """Train one learner into ``run`` (checkpoints every ``checkpoint_every`` episodes, at the
    end and on Ctrl-C). ``greedy=False``: no greedy episode from rest and no learning curve."""
    env_name = "acrobot_mj (make_env)" if env is None else str(env)
    env = make_env(config) if env is None else shape_rewards(env, config)
    agent = config.make_agent(seed, env.observation_space)
    history = History()
    path = None if run.out is None else run.out / CHECKPOINT_FILE
    checkpoints = Checkpoints(path, config, seed, tee=run.tee)
    if run.resume:
        if path is None or run.out is None:  # both or neither
            raise ValueError("resume needs the run directory (out_dir)")
        history, arrays = read_for_resume(path, config, seed)
        load_into(agent.load_state_dict, arrays, path)
        if (run.out / RUN_FILE).exists() and len(history) < config.episodes:
            # The finished record no longer describes the run: until this one ends (or is
            # killed, or diverges), it is this config's, interrupted where it resumed.
            record = run_record(config, seed, history, Outcome(0.0, True), env=env_name)
            write_run(run.out, record, f"seed {seed}", curve=False)
    started, stop = time.perf_counter(), None
    state = agent.checkpoint_state if isinstance(agent, Rewinding) else agent.state_dict
    watched = watching(run.monitor or False, run_total(config), f"{config.algorithm} seed {seed}")
    try:
        with SafePoints() as stops, watched as monitor:  # stops land between steps
            books = Books(checkpoints, state, monitor, history, on_episode=run.on_episode)
            books.start()
            stop = _episodes(books, env, agent, stops)
            elapsed = time.perf_counter() - started
            checkpoints.save()
            checkpoints.close()
    except KeyboardInterrupt as interrupt:  # held while the checkpoint was saved
        stop = stop or interrupt
    try:  # not held: the greedy episode may be long, and nothing of it is saved
        rest = None if stop or not greedy else greedy_from_rest(env, agent, seed)
    except KeyboardInterrupt as interrupt:
        stop, rest = interrupt, None
    record = run_record(config, seed, history, Outcome(elapsed, bool(stop), rest), env=env_name)
    if run.out is not None:
        with SafePoints():  # the record written whole
            write_run(run.out, record, f"seed {seed}", curve=greedy)
    if stop:
        raise type(stop)(f"interrupted after {len(history)} episodes; checkpoint saved")
    return record, agent


def _episodes(books: Books, env: gym.Env, agent: Agent, stops: SafePoints) -> BaseException | None:
    """Train ``agent`` until its config's episodes or decisions are spent; the Ctrl-C that cut
    the run short, if one did. A divergence saves the checkpoint and stops the run."""
    config, seed, history = books.checkpoints.config, books.checkpoints.seed, books.history
    watch = Hooks(stops=stops)
    try:
        for episode in range(len(history), config.episodes):
            stops.check()
            cap = config.learner_decisions
            left = None if cap == 0 else max(cap - history.steps, 0)
            if left == 0:
                break
            noise = config.start_noise_at(episode)
            options = {"start_noise": noise} if noise > 0 else None
            try:
                with np.errstate(over="ignore", invalid="ignore"):  # checked, by value
                    seed_now = episode_seed(seed, episode)
                    result = run_episode(
                        env, Learning(agent), seed_now, options, max_steps=left, hooks=watch
                    )
                books.end(result.length, result.episode_return, result.success)
            except DivergenceError as error:
                books.checkpoints.save()  # the state after the last finite episode
                books.checkpoints.close()
                raise books.diverged(error) from None
    except KeyboardInterrupt as interrupt:
        return interrupt
    return None


def train_population(
    config: TrainConfig, seed: int, run: Run, env: gym.Env | None = None, judge: Judge | None = None
) -> tuple[dict[str, Any], Agent]:
    """``config.population`` learners in ``learner_K/``, the one whose last 20 training episodes
    scored best (or the best by ``judge``) kept. A resumed finished run trains them again."""
    out = run.out
    if run.resume:
        if out is None:
            raise ValueError("resume needs the run directory (out_dir)")
        if (out / CHECKPOINT_FILE).exists():  # else unfinished: each learner checks its own
            meta, _, saved = read_checkpoint(out / CHECKPOINT_FILE)
            check_same_run(out / CHECKPOINT_FILE, meta, saved, config, seed, RESUME_MAY_DIFFER)
    elif out is not None:
        for old in sorted(out.glob("learner_*")):  # an overwritten run's learners
            if old.is_dir():
                shutil.rmtree(old)
    score = get_task(config.task).score
    records: list[dict[str, Any]] = []
    scores: list[float] = []
    best, kept = 0, None
    for k in range(config.population):
        record, learner = _train_learner(
            config, seed, k, run.learner(k, _tee(run, k, records)), env
        )
        records.append(record)
        scores.append(recent_median(score.values(record)) if judge is None else judge(learner, k))
        if k == 0 or score.is_better(scores[k], scores[best]):  # ties: the first
            best, kept = k, learner  # only the best so far stays in memory
    assert kept is not None  # population > 1: learner 0 at least was kept
    rule = f"{score.best_word} median of the last {RECENT} training episodes"
    chosen = {"scores": scores, "kept": best, "rule": getattr(judge, "rule", rule)}
    real = make_env(config) if env is None else shape_rewards(env, config)
    record = _population_record(config, seed, records, chosen, greedy_from_rest(real, kept, seed))
    if out is not None:
        meta = checkpoint_meta(config, seed, record["episodes_done"], record["steps"])
        save_checkpoint(out / CHECKPOINT_FILE, kept.state_dict(), meta)
        write_run(out, record, f"{config.population} learners, seed {seed}")
        for k in range(config.population):
            (learner_dir(out, k) / CHECKPOINT_FILE).unlink(missing_ok=True)
    return record, kept


def _tee(run: Run, k: int, records: list[dict[str, Any]]) -> RunLog | None:
    """The run's ``episodes.jsonl`` as learner ``k`` starts: the episodes of the learners
    before it and, resuming, its own (None: no run directory)."""
    if run.out is None:
        return None
    mine = learner_dir(run.out, k) / CHECKPOINT_FILE
    done = load_checkpoint(mine)[0]["episodes_done"] if run.resume and mine.exists() else 0
    logs = [learner_dir(run.out, j) / EPISODE_LOG for j in range(k + 1)]
    return RunLog(run.out / EPISODE_LOG, logs, [r["episodes_done"] for r in records] + [done])


def _train_learner(
    config: TrainConfig, seed: int, k: int, run: Run, env: gym.Env | None
) -> tuple[dict[str, Any], Agent]:
    """Learner ``k`` of ``config``'s population of run ``seed``, in ``run`` (whose ``tee`` is
    closed at its end); its errors name it."""
    single = config.replace(population=1, max_decisions=config.learner_decisions)
    try:
        return train_one(single, learner_seed(seed, k), run, env, greedy=False)
    except KeyboardInterrupt as error:  # the command says how to continue
        why = f" ({error})" if str(error) else ""
        raise type(error)(f"interrupted in learner {k} of {config.population}{why}") from error
    except DivergenceError as error:  # its seed is the learner's, drawn from the run's
        raise DivergenceError(
            f"learner {k} of {config.population} of run seed {seed}: {error}", error.rewards
        ) from None
    finally:
        if run.tee is not None:
            run.tee.close()


def _population_record(
    config: TrainConfig,
    seed: int,
    records: list[dict[str, Any]],
    chosen: dict[str, Any],
    greedy: Episode,
) -> dict[str, Any]:
    """The run record of a population: every learner's episodes, the kept one's greedy episode
    from rest, and how it was ``chosen`` (``scores``, ``kept``, ``rule``)."""
    history = History()
    for r in records:
        history.extend(r)
    best = records[chosen["kept"]]
    return run_record(
        config,
        seed,
        history,
        Outcome(sum(r["wall_seconds"] for r in records), best["interrupted"], greedy),
        env=best.get("env"),
        population={
            "learners": config.population,
            "seeds": [r["seed"] for r in records],
            "scores": chosen["scores"],
            "kept": chosen["kept"],
            "rule": chosen["rule"],
        },
    )
