"""Several independent learners sharing one run's episode budget; the best one is kept.

With epsilon 0 in a deterministic task a Sarsa(lambda) learner settles on one swing-up after a
few dozen episodes, and which one depends on its first episodes (the README's results). Random
restarts turn that lottery into a choice: ``population`` learners of ``episodes`` episodes each
(own seeds, own start noise), and the run keeps the learner whose last 20 training episodes had
the best median score by the run's task (for the height goal: the fewest decisions). The choice
uses training episodes only, from the learners' own training starts; no greedy runs are made
for it (the learners make none), so the run's decisions are its learning episodes' and the
kept learner's one greedy run from rest.

A run directory holds ``learner_K/`` (each a run of its own: record, episode log, and its
checkpoints while the population trains, so an interrupted run resumes; no learning curve, which
costs about half a tuned learner's training: ``acrobot-mj curves`` draws one) and, at the top, the
usual ``run.json``, ``checkpoint.npz`` (the kept learner's agent) and learning curve, so
``evaluate`` and ``render`` work on it unchanged. Once the top-level checkpoint is written the
learners' checkpoints are deleted (ten of them would take ten times the disk); resuming a
finished run trains the learners again and gets the same result. The top-level per-episode
lists are every learner's episodes in order (the whole budget spent); ``population`` in
``run.json`` says which learner was kept and why. The top-level ``episodes.jsonl`` gets each
learner's lines as they are logged (numbered through the run, with the learner's index); a
resumed run rebuilds it from the learners' own logs first.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.agents.protocol import Agent
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.train.checkpoint import load_checkpoint, save_checkpoint
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episode_log import RunLog, concatenate
from acrobot_mj.train.episodes import greedy_from_rest, training_env
from acrobot_mj.train.learner import OnEpisode, train_agent
from acrobot_mj.train.lockstep import check_lockstep, train_together
from acrobot_mj.train.progress import Monitor, run_total, watching
from acrobot_mj.train.records import History, checkpoint_meta, run_record
from acrobot_mj.train.rundir import (
    CHECKPOINT_FILE,
    EPISODE_LOG,
    RESUME_MAY_DIFFER,
    check_same_run,
    learner_dir,
    read_checkpoint,
    write_run,
)
from acrobot_mj.train.stats import RECENT, recent_median

LAST = "training episodes"
#: Scores a trained learner ``k`` (instead of its last training episodes); its ``rule``
#: attribute, if any, says how in the run record.
Judge = Callable[[Agent, int], float]


def learner_seed(seed: int, k: int) -> int:
    """The seed of learner ``k`` of run ``seed``."""
    return int(np.random.SeedSequence([seed, 0x9E37, k]).generate_state(1)[0])


def _check_population_resume(out: Path | None, config: TrainConfig, seed: int) -> None:
    """Refuse to resume into a directory whose run has another config or seed."""
    if out is None:
        raise ValueError("resume needs the run directory (out_dir)")
    path = out / CHECKPOINT_FILE
    if path.exists():  # else unfinished: each learner checks its own checkpoint
        meta, _, saved = read_checkpoint(path)
        check_same_run(path, meta, saved, config, seed, RESUME_MAY_DIFFER)


def train_population(
    config: TrainConfig,
    seed: int,
    out: Path | None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool | Monitor = False,
    on_episode: OnEpisode | None = None,
    judge: Judge | None = None,
    lockstep: bool | None = None,
) -> tuple[dict[str, Any], Agent]:
    """Train ``config.population`` learners and keep the best (see the module docstring): the
    run record and the kept learner. ``judge`` replaces the rule: it scores learner ``k`` from
    the learner itself, by the task's score (a model-based run's greedy runs in its model).
    ``progress``: one bar over all the learners, or the run's monitor. ``lockstep``: the
    learners together on one vector env (True) or one after another (False or None: faster for
    a population's size, measured: ten tabular SARSA learners of the report took 12.9-14.4 s
    one by one and 25.6-27.5 s in lockstep); the same run either way."""
    together = _together(config, env, on_episode, judge, lockstep)
    if resume:
        _check_population_resume(out, config, seed)
    elif out is not None:
        for old in sorted(out.glob("learner_*")):  # an overwritten run's learners
            if old.is_dir():
                shutil.rmtree(old)
    label = f"{config.algorithm} x{config.population} seed {seed}"
    with watching(progress, run_total(config), label) as monitor:
        if together and _all_or_none_saved(out, config.population, resume):
            records, scores, best, agent = _train_together(config, seed, out, resume, monitor)
        else:
            records, scores, best, agent = _train_each(
                config, seed, out, env, resume, monitor, on_episode, judge
            )
    history = History()
    for r in records:
        history.extend(r)
    score = get_task(config.task).score
    greedy = greedy_from_rest(training_env(config, env), agent, seed)
    record = run_record(
        config,
        seed,
        history,
        sum(r["wall_seconds"] for r in records),
        interrupted=records[best]["interrupted"],
        env=records[best].get("env"),
        greedy=greedy,
        population={
            "learners": config.population,
            "seeds": [r["seed"] for r in records],
            "scores": scores,
            "kept": best,
            "rule": getattr(
                judge, "rule", f"{score.best_word} median of the last {RECENT} training episodes"
            ),
        },
    )
    if out is not None:
        meta = checkpoint_meta(config, seed, len(history), history.steps, EPISODE_LOG)
        save_checkpoint(out / CHECKPOINT_FILE, agent.state_dict(), meta)
        write_run(out, record, f"{config.population} learners, seed {seed}")
        for k in range(config.population):
            (learner_dir(out, k) / CHECKPOINT_FILE).unlink(missing_ok=True)
    return record, agent


def _single(config: TrainConfig) -> TrainConfig:
    """The config of each of ``config``'s learners: one learner, its share of the cap."""
    return config.replace(population=1, max_decisions=config.learner_decisions)


def _together(config, env, on_episode, judge, lockstep: bool | None) -> bool:
    """Whether the population trains in lockstep (see :func:`train_population`); a lockstep
    that cannot be is refused, saying why."""
    if lockstep:
        check_lockstep(_single(config))
        if env is not None or on_episode is not None or judge is not None:
            raise ValueError(
                "a population in lockstep trains on its own vector env: it takes no env, "
                "on_episode or judge (train it with lockstep=False)"
            )
    return bool(lockstep)


def _all_or_none_saved(out: Path | None, population: int, resume: bool) -> bool:
    """Whether a lockstep group can take the learners up: resuming, every learner has its
    checkpoint or none has (else the learners go on one by one, to the same run)."""
    if not resume or out is None:
        return True
    saved = {(learner_dir(out, k) / CHECKPOINT_FILE).exists() for k in range(population)}
    return len(saved) == 1


def _train_together(config, seed, out, resume, monitor):
    """:func:`_train_each` in lockstep (one vector env, ``train.lockstep``), the same records;
    the run's ``episodes.jsonl`` is assembled from the learners' logs when they finish."""
    score, k = get_task(config.task).score, config.population
    dirs = None if out is None else [learner_dir(out, i) for i in range(k)]
    again = resume and dirs is not None and (dirs[0] / CHECKPOINT_FILE).exists()
    seeds = [learner_seed(seed, i) for i in range(k)]
    try:
        records, agents = train_together(_single(config), seeds, dirs, monitor, again)
    except KeyboardInterrupt as error:
        raise type(error)(
            f"interrupted while {k} learners trained in lockstep ({error}); resume to continue"
        ) from error
    if dirs is not None:
        counts = [r["episodes_done"] for r in records]
        concatenate(out / EPISODE_LOG, [d / EPISODE_LOG for d in dirs], counts)
    scores = [recent_median(score.values(record)) for record in records]
    best = _first_best(score, scores)
    return records, scores, best, agents[best]


def _first_best(score: Any, scores: list[float]) -> int:
    """The index of the best of ``scores`` by the task's ``score`` (ties: the first)."""
    best = 0
    for i in range(1, len(scores)):
        if score.is_better(scores[i], scores[best]):
            best = i
    return best


def _train_each(config, seed, out, env, resume, monitor, on_episode, judge):
    """Train the population's learners in turn: their records, scores, the best one's index
    and that learner (only the best so far stays in memory)."""
    score = get_task(config.task).score
    single = _single(config)
    records, scores = [], []
    best, agent = 0, None
    for k in range(config.population):
        sub = learner_dir(out, k) if out is not None else None
        again = resume and sub is not None and (sub / CHECKPOINT_FILE).exists()
        tee = None if out is None else _run_log(out, records, again)
        try:
            record, learner = train_agent(
                single,
                learner_seed(seed, k),
                sub,
                env,
                again,
                monitor.scoped(learner_dir(Path(), k).name),
                on_episode,
                greedy=False,
                tee=tee,
                curve=False,
            )
        except KeyboardInterrupt as error:
            raise type(error)(
                f"interrupted in learner {k} of {config.population} ({error}); resume to continue"
            ) from error
        finally:
            if tee is not None:
                tee.close()
        records.append(record)
        scores.append(recent_median(score.values(record)) if judge is None else judge(learner, k))
        if _first_best(score, scores) == k:  # only the best so far is kept in memory
            best, agent = k, learner
    return records, scores, best, agent


def _run_log(out: Path, records: list[dict[str, Any]], again: bool) -> RunLog:
    """The run's ``episodes.jsonl`` for the next learner: the learners' before it (``records``)
    and, resuming (``again``), the next one's episodes its checkpoint counts."""
    k = len(records)
    counts = [r["episodes_done"] for r in records]
    if again:
        counts.append(load_checkpoint(learner_dir(out, k) / CHECKPOINT_FILE)[0]["episodes_done"])
    else:
        counts.append(0)
    logs = [learner_dir(out, j) / EPISODE_LOG for j in range(k + 1)]
    return RunLog(out / EPISODE_LOG, logs, counts)


def train_learners(
    config: TrainConfig,
    seed: int,
    out: Path | None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool | Monitor = False,
    on_episode: OnEpisode | None = None,
    judge: Judge | None = None,
    lockstep: bool | None = None,
) -> tuple[dict[str, Any], Agent]:
    """One learner, or ``config.population`` of them with the best kept (``lockstep``: see
    :func:`train_population`): record and agent."""
    if config.population > 1:
        return train_population(
            config, seed, out, env, resume, progress, on_episode, judge, lockstep
        )
    if lockstep:
        raise ValueError("lockstep trains a population's learners together: population is 1")
    return train_agent(config, seed, out, env, resume, progress, on_episode)
