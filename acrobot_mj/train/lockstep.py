"""Many seeds of one config trained together, in lockstep on one vector env.

Learner ``k`` sees exactly what ``train(config, seeds[k])`` would show it: its sub-env is reset
with the same per-episode seed and start noise, and the algorithm's lockstep form (for SARSA
:class:`~acrobot_mj.agents.lockstep_sarsa.LockstepSarsa`, for compiled Sarsa(lambda)
:class:`~acrobot_mj.agents.lockstep_lambda.LockstepSarsaLambda`) draws and computes as the
single agent does; so the records and checkpoints are identical to the single-env trainer's, up to
``wall_seconds`` (the training time shared out).
"""

from __future__ import annotations

import contextlib
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.agents.protocol import Agent, DivergenceError
from acrobot_mj.agents.registry import AGENTS, agent_spec, make_agent, make_features
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episodes import episode_seed, greedy_from_rest, make_env
from acrobot_mj.train.learner import check_finite_return, diverged
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.progress import Monitor, watching
from acrobot_mj.train.records import History, run_record
from acrobot_mj.train.rundir import (
    CHECKPOINT_FILE,
    Checkpoints,
    load_into,
    read_for_resume,
    seed_dir,
    write_run,
)


def train_lockstep(
    config: TrainConfig,
    seeds: list[int],
    out_dir: str | Path | None = None,
    progress: bool | Monitor = False,
    greedy: bool = True,
    resume: bool = False,
    run_dirs: list[Path] | None = None,
    tensorboard: str | Path | None = None,
) -> list[dict[str, Any]]:
    """Train one learner per seed together, on one :class:`AcrobotVectorEnv`.

    Writes ``out_dir/seed_S/`` (or ``run_dirs[k]`` for learner ``k``) like
    :func:`~acrobot_mj.train.trainer.train`, with each learner's checkpoint every
    ``checkpoint_every`` of its episodes, at the end and on Ctrl-C; ``resume`` continues from
    them; ``greedy=False`` skips the final greedy runs from rest. ``progress``: one bar over
    every learner's episodes (or the monitor of a bigger run), ``tensorboard``: a directory for
    their scalars. Returns the run records, one per seed.
    """
    check_lockstep(config)
    if run_dirs is None and out_dir is not None:
        run_dirs = [seed_dir(Path(out_dir), s) for s in seeds]
    if run_dirs is not None and len(run_dirs) != len(seeds):
        raise ValueError(f"give one run directory per seed ({len(seeds)}), got {len(run_dirs)}")
    if resume and run_dirs is None:
        raise ValueError("resume needs the run directories (out_dir or run_dirs)")
    with RunLock(out_dir) if out_dir is not None else contextlib.nullcontext():
        run, elapsed = _run(config, seeds, run_dirs, progress, resume, tensorboard)
        return run.records(elapsed, greedy)[0]


def train_together(
    config: TrainConfig,
    seeds: list[int],
    run_dirs: list[Path] | None,
    progress: bool | Monitor = False,
    resume: bool = False,
) -> tuple[list[dict[str, Any]], list[Agent]]:
    """:func:`train_lockstep` for a population's learners (its caller holds the run's lock):
    no greedy runs and no learning curves; the records and the trained agents."""
    check_lockstep(config)
    run, elapsed = _run(config, seeds, run_dirs, progress, resume, None)
    return run.records(elapsed, greedy=False, curves=False)


def _run(config, seeds, run_dirs, progress, resume, tensorboard) -> tuple[_Lockstep, float]:
    """The lockstep run of ``seeds``, trained (restored first with ``resume``); its seconds."""
    run = _Lockstep(config, seeds, run_dirs)
    if resume:
        run.restore()
    label = f"lockstep {config.algorithm} x{len(seeds)}"
    total = (config.episodes * len(seeds), "episodes")
    with watching(progress, total, label, tensorboard) as monitor:
        started = time.perf_counter()
        run.train(monitor)
    return run, time.perf_counter() - started


def check_lockstep(config: TrainConfig) -> None:
    """Refuse a config whose seeds cannot train in lockstep, saying what would allow it."""
    if not config.lockstep:
        able = [f"{s.name} ({s.doc})" for s in AGENTS.values() if s.lockstep is not None]
        raise ValueError(
            f"lockstep training needs an algorithm with a lockstep form: {', '.join(able)}, "
            f"one learner per run, no energy shaping and no decision cap; got "
            f"{config.algorithm} (kernel {config.kernel}, population {config.population}, "
            f"energy_shaping {config.energy_shaping}, max_decisions {config.max_decisions}): "
            "train it with one process per seed"
        )


class _Lockstep:
    """The state of a lockstep run: the vector env, the learners, and per learner its history,
    episode count and checkpoint."""

    def __init__(self, config: TrainConfig, seeds: list[int], dirs: list[Path] | None) -> None:
        self.config, self.seeds, self.dirs = config, list(seeds), dirs
        k = self.k = len(self.seeds)
        self.vec = AcrobotVectorEnv(
            num_envs=k, autoreset_mode="disabled", task=config.task, **config.env_kwargs()
        )
        self.learners = agent_spec(config.algorithm).lockstep(
            make_features(config), config, self.seeds
        )
        self.histories = [History() for _ in range(k)]
        self.episode = np.zeros(k, dtype=np.int64)
        self.checkpoints = [
            Checkpoints(None if dirs is None else dirs[i] / CHECKPOINT_FILE, config, s, learner=i)
            for i, s in enumerate(self.seeds)
        ]
        self.monitors: list[Monitor] = []

    def restore(self) -> None:
        """Continue every learner from its checkpoint."""
        for i, seed in enumerate(self.seeds):
            path = self.dirs[i] / CHECKPOINT_FILE
            self.histories[i], arrays = read_for_resume(path, self.config, seed)
            load_into(partial(self.learners.load_state, i), arrays, path)
            self.episode[i] = len(self.histories[i])

    def _snapshot(self, i: int) -> None:
        """Learner ``i``'s state after its last completed episode (before its next one draws)."""
        history = self.histories[i]
        self.checkpoints[i].snapshot(lambda: self.learners.state_dict(i), history)

    def _restart(self, mask: np.ndarray) -> np.ndarray:
        """Reset the masked sub-envs for their next episode, as train() would; their actions."""
        config, k = self.config, self.k
        obs = np.zeros((k, 4))
        noise_of = np.array([config.start_noise_at(int(e)) for e in self.episode])
        for noise in sorted(set(noise_of[mask].tolist())):  # one reset per start-noise level
            group = mask & (noise_of == noise)
            seeds_now = [
                episode_seed(self.seeds[i], int(self.episode[i])) if group[i] else None
                for i in range(k)
            ]
            reset_obs, _ = self.vec.reset(
                seed=seeds_now, options={"reset_mask": group, "start_noise": noise}
            )
            obs[group] = reset_obs[group]
        ids = np.flatnonzero(mask)
        return self.learners.begin_episodes(ids, obs[ids])

    def train(self, monitor: Monitor) -> None:
        """Step every learner with episodes left until all are done; checkpoints as they go;
        each finished episode to ``monitor``."""
        config, k = self.config, self.k
        names = [seed_dir(Path(), s).name for s in self.seeds]
        if self.dirs is not None:
            names = [d.name for d in self.dirs]
        self.monitors = [monitor.scoped(name) for name in names]
        for i in range(k):
            self.checkpoints[i].start(self.histories[i])
            self._snapshot(i)
            self.monitors[i].restored(self.histories[i])
        length, total = np.zeros(k, dtype=np.int64), np.zeros(k)
        active = self.episode < config.episodes
        actions = np.ones(k, dtype=np.int64)  # sub-envs of finished learners get no torque
        actions[active] = self._restart(active)
        try:
            while active.any():
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
        except KeyboardInterrupt as stop:
            for checkpoint in self.checkpoints:
                checkpoint.save()
            raise type(stop)(
                "interrupted; each learner's checkpoint holds its last completed episode"
            ) from None
        except DivergenceError as error:
            for checkpoint in self.checkpoints:  # each learner's last finite state
                checkpoint.save()
            if error.learner is None:
                raise
            i = error.learner
            raise diverged(
                config, self.seeds[i], int(self.episode[i]), len(self.histories[i]), error
            ) from None
        for checkpoint in self.checkpoints:
            checkpoint.save()
            checkpoint.close()

    def _finish_episodes(
        self, done: np.ndarray, length: np.ndarray, total: np.ndarray, success: np.ndarray
    ) -> None:
        """Record the episodes that just ended, and checkpoint where one is due."""
        self.episode[done] += 1
        for i in np.flatnonzero(done):
            try:
                check_finite_return(float(total[i]))
            except DivergenceError as error:
                raise diverged(
                    self.config,
                    self.seeds[i],
                    int(self.episode[i]) - 1,
                    len(self.histories[i]),
                    error,
                ) from None
            self.histories[i].add(int(length[i]), float(total[i]), bool(success[i]))
            self._snapshot(i)
            self.monitors[i].episode(
                int(self.episode[i]) - 1, int(length[i]), float(total[i]), bool(success[i])
            )
            if self.episode[i] % self.config.checkpoint_every == 0:
                self.checkpoints[i].save()

    def records(
        self, elapsed: float, greedy: bool, curves: bool = True
    ) -> tuple[list[dict[str, Any]], list[Agent]]:
        """Each learner's run record (and run directory, with its learning curve if
        ``curves``), with its greedy episode from rest if ``greedy``; and the agents."""
        config, records, agents = self.config, [], []
        env = make_env(config) if greedy else None  # for the greedy runs alone
        for i, seed in enumerate(self.seeds):
            agent = make_agent(config, seed=seed)
            agent.load_state_dict(self.learners.state_dict(i))
            history = self.histories[i]
            record = run_record(
                config,
                seed,
                history,
                elapsed / self.k,
                lockstep=self.k,
                greedy=greedy_from_rest(env, agent, seed) if greedy else None,
            )
            if self.dirs is not None:
                write_run(self.dirs[i], record, f"seed {seed}", curves)
            records.append(record)
            agents.append(agent)
        return records, agents
