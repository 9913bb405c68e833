"""Many seeds of one config trained together on one vector env: learner ``k`` sees exactly what
``train(config, seeds[k])`` would show it and the algorithm's lockstep form computes as the single
agent does, so the records and checkpoints are the single runs' (but ``wall_seconds``, shared)."""

from __future__ import annotations

import contextlib
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.agents import AGENTS, Agent, DivergenceError, agent_spec
from acrobot_mj.checks import check_open_files
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.stops import SafePoints
from acrobot_mj.train.bookkeeping import Books
from acrobot_mj.train.checkpoint import Checkpoints, load_into, read_for_resume
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.learners import episode_seed, greedy_from_rest, make_env
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.monitor import Monitor, watching
from acrobot_mj.train.records import (
    CHECKPOINT_FILE,
    History,
    Outcome,
    run_record,
    seed_dir,
    write_run,
)
from acrobot_mj.train.run import PLAIN, RunOptions

#: Seeds of one process from which they go in lockstep unless told otherwise: in smaller groups
#: one process per seed is faster (docs/guide/train.md).
LOCKSTEP_GROUP_FROM = 25


def can_lockstep(config: TrainConfig) -> bool:
    """Whether seeds of ``config`` can train together on one vector env."""
    return (
        agent_spec(config.algorithm).group is not None
        and config.energy_shaping == 0.0
        and config.population == 1
        and config.max_decisions == 0
        and config.identify_decisions == 0
    )


def lockstep_pays(config: TrainConfig, group: int) -> bool:
    """Whether ``group`` seeds of ``config`` in one process go in lockstep unless told otherwise."""
    return can_lockstep(config) and group >= LOCKSTEP_GROUP_FROM


def check_lockstep(config: TrainConfig) -> None:
    if not can_lockstep(config):
        able = [f"{s.name} ({s.doc})" for s in AGENTS.values() if s.group is not None]
        raise ValueError(
            f"lockstep training needs an algorithm with a lockstep form: {', '.join(able)}, "
            f"one learner per run, no energy shaping and no decision cap; got "
            f"{config.algorithm} (population {config.population}, energy_shaping "
            f"{config.energy_shaping}, max_decisions {config.max_decisions}): train it with "
            "one process per seed"
        )


def train_lockstep(
    config: TrainConfig,
    seeds: list[int],
    out_dir: str | Path | None = None,
    options: RunOptions = PLAIN,
    *,
    greedy: bool = True,
    run_dirs: list[Path] | None = None,
) -> list[dict[str, Any]]:
    """Train one learner per seed together; the run records. Writes ``out_dir/seed_S/`` (or
    ``run_dirs[k]``) as ``train`` does; ``greedy=False`` skips the greedy runs from rest;
    ``options``: ``resume``, one ``progress`` bar over every learner's episodes, and
    ``tensorboard``."""
    options.only("a lockstep run", "resume", "progress", "tensorboard")
    check_lockstep(config)
    if run_dirs is None and out_dir is not None:
        run_dirs = [seed_dir(Path(out_dir), s) for s in seeds]
    if run_dirs is not None and len(run_dirs) != len(seeds):
        raise ValueError(f"give one run directory per seed ({len(seeds)}), got {len(run_dirs)}")
    if options.resume and run_dirs is None:
        raise ValueError("resume needs the run directories (out_dir or run_dirs)")
    if run_dirs is not None:
        check_open_files(f"{len(seeds)} seeds in lockstep", 2 * len(seeds))  # lock, episode log
    with RunLock(out_dir) if out_dir is not None else contextlib.nullcontext():
        run = _Lockstep(config, seeds, run_dirs)
        if options.resume:
            run.restore()
        total = (config.episodes * len(seeds), "episodes")
        label = f"lockstep {config.algorithm} x{len(seeds)}"
        with watching(options.progress, total, label, options.tensorboard) as monitor:
            started = time.perf_counter()
            run.train(monitor)
        return run.records(time.perf_counter() - started, greedy)


class _Lockstep:
    """A lockstep run: the vector env, the learners, their histories, episodes and checkpoints."""

    def __init__(self, config: TrainConfig, seeds: list[int], dirs: list[Path] | None) -> None:
        self.config, self.seeds, self.dirs = config, list(seeds), dirs
        k = self.k = len(self.seeds)
        self.vec = AcrobotVectorEnv(
            num_envs=k, autoreset_mode="disabled", task=config.task, **config.env_kwargs()
        )
        features = config.encoding.build(self.vec.single_observation_space)
        group = agent_spec(config.algorithm).group
        if group is None:
            raise ValueError(f"{config.algorithm} cannot run in lockstep")
        self.learners = group(features, config.agent, self.seeds)
        self.histories = [History() for _ in range(k)]
        self.episode = np.zeros(k, dtype=np.int64)
        self.checkpoints = [
            Checkpoints(None if dirs is None else dirs[i] / CHECKPOINT_FILE, config, s, learner=i)
            for i, s in enumerate(self.seeds)
        ]
        self.books: list[Books] = []

    def restore(self) -> None:
        """Each learner from its checkpoint; one that never reached one starts afresh."""
        if self.dirs is None:
            raise ValueError("resume needs the run directories (out_dir or run_dirs)")
        for i, seed in enumerate(self.seeds):
            path = self.dirs[i] / CHECKPOINT_FILE
            if not path.exists():
                continue
            self.histories[i], arrays = read_for_resume(path, self.config, seed)
            load_into(partial(self.learners.load_state, i), arrays, path)
            self.episode[i] = len(self.histories[i])

    def _restart(self, mask: np.ndarray) -> np.ndarray:
        """Reset the masked sub-envs for their next episode as train() would; their actions."""
        config, k = self.config, self.k
        obs = np.zeros((k, 4))
        noise_of = np.array([config.start_noise_at(int(e)) for e in self.episode])
        for noise in sorted(set(noise_of[mask].tolist())):  # one reset per start-noise level
            group = mask & (noise_of == noise)
            seeds_now = [
                episode_seed(self.seeds[i], int(self.episode[i])) if group[i] else None
                for i in range(k)
            ]
            options = {"reset_mask": group, "start_noise": noise}
            reset_obs, _ = self.vec.reset(seed=seeds_now, options=options)
            obs[group] = reset_obs[group]
        ids = np.flatnonzero(mask)
        return self.learners.begin_episodes(ids, obs[ids])

    def train(self, monitor: Monitor) -> None:
        """Step every learner with episodes left until all are done."""
        config, k = self.config, self.k
        dirs = self.dirs if self.dirs is not None else [seed_dir(Path(), s) for s in self.seeds]
        self.books = [
            Books(c, partial(self.learners.state_dict, i), monitor.scoped(d.name), h)
            for i, (c, d, h) in enumerate(zip(self.checkpoints, dirs, self.histories, strict=True))
        ]
        for books in self.books:
            books.start()
        length, total = np.zeros(k, dtype=np.int64), np.zeros(k)
        active = self.episode < config.episodes
        actions = np.ones(k, dtype=np.int64)  # sub-envs of finished learners get no torque
        actions[active] = self._restart(active)
        try:
            with SafePoints() as stops:  # a stop lands between steps
                while active.any():
                    stops.check()
                    obs, reward, terminated, truncated, info = self.vec.step(actions)
                    ids = np.flatnonzero(active)
                    length[ids] += 1
                    total[ids] += reward[ids]
                    learned = self.learners.learn(
                        ids, reward[ids], obs[ids], terminated[ids], truncated[ids]
                    )
                    actions[ids] = np.where(learned >= 0, learned, 1)
                    done = np.zeros(k, dtype=bool)
                    done[ids] = terminated[ids] | truncated[ids]
                    self._finish_episodes(done, length, total, info["is_success"])
                    length[done], total[done] = 0, 0.0
                    active &= self.episode < config.episodes
                    again = done & active
                    if again.any():
                        actions[again] = self._restart(again)
        except (KeyboardInterrupt, DivergenceError) as stop:
            for checkpoint in self.checkpoints:  # each learner's last finite state
                checkpoint.save()
            if isinstance(stop, DivergenceError):
                raise
            raise type(stop)(
                "interrupted; each learner's checkpoint holds its last completed episode"
            ) from None
        for checkpoint in self.checkpoints:
            checkpoint.save()
            checkpoint.close()

    def _finish_episodes(
        self, done: np.ndarray, length: np.ndarray, total: np.ndarray, success: np.ndarray
    ) -> None:
        """Record the episodes that just ended (:meth:`.Books.end`)."""
        self.episode[done] += 1
        for i in np.flatnonzero(done):
            try:
                self.books[i].end(int(length[i]), float(total[i]), bool(success[i]))
            except DivergenceError as error:
                raise self.books[i].diverged(error) from None

    def records(self, elapsed: float, greedy: bool) -> list[dict[str, Any]]:
        """Each learner's run record and directory (``greedy``: with its greedy run from rest)."""
        config, records = self.config, []
        env = make_env(config) if greedy else None  # for the greedy runs alone
        for i, seed in enumerate(self.seeds):
            agent: Agent = config.make_agent(seed, self.vec.single_observation_space)
            agent.load_state_dict(self.learners.state_dict(i))
            rest = greedy_from_rest(env, agent, seed) if env is not None else None  # greedy
            outcome = Outcome(elapsed / self.k, greedy=rest)
            record = run_record(config, seed, self.histories[i], outcome, lockstep=self.k)
            if self.dirs is not None:
                write_run(self.dirs[i], record, f"seed {seed}")
            records.append(record)
        return records
