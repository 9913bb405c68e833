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
import math
import time
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.agents import AGENTS, Agent, DivergenceError, agent_spec
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.learners import diverged, episode_seed, greedy_from_rest, make_env
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.progress import Monitor, watching
from acrobot_mj.train.records import (
    CHECKPOINT_FILE,
    Checkpoints,
    History,
    load_into,
    read_for_resume,
    run_record,
    seed_dir,
    write_run,
)

#: Learners of one process from which tabular SARSA's seeds go in lockstep unless told
#: otherwise: in smaller groups the learners that finish an episode wait for the group's
#: slowest, and one process per seed is faster (measured: docs/learning.md).
LOCKSTEP_GROUP_FROM = 25


def can_lockstep(config: TrainConfig) -> bool:
    """Whether seeds of ``config`` can train together on one vector env: an algorithm with a
    lockstep form, one learner per run, no shaping, no decision cap, in the env."""
    return (agent_spec(config.algorithm).group is not None and config.energy_shaping == 0.0
            and config.population == 1 and config.max_decisions == 0
            and config.identify_decisions == 0)  # fmt: skip


def lockstep_pays(config: TrainConfig, group: int) -> bool:
    """Whether ``group`` seeds of ``config`` in one process go in lockstep unless told
    otherwise: they can, and there are at least :data:`LOCKSTEP_GROUP_FROM` of them."""
    return can_lockstep(config) and group >= LOCKSTEP_GROUP_FROM


def check_lockstep(config: TrainConfig) -> None:
    """Refuse a config whose seeds cannot train in lockstep, saying what would allow it."""
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
    *,
    progress: bool | Monitor = False,
    greedy: bool = True,
    resume: bool = False,
    run_dirs: list[Path] | None = None,
    tensorboard: str | Path | None = None,
) -> list[dict[str, Any]]:
    """Train one learner per seed together, on one :class:`AcrobotVectorEnv`: learner ``k``
    sees exactly what ``train(config, seeds[k])`` would show it (its sub-env reset with the same
    seed and start noise, the algorithm's lockstep form drawing and computing as the single
    agent), so the records and checkpoints are the single runs', up to ``wall_seconds`` (the
    training time shared out).

    Writes ``out_dir/seed_S/`` (or ``run_dirs[k]``) like ``train``, each learner's checkpoint
    every ``checkpoint_every`` of its episodes, at the end and on Ctrl-C; ``resume`` continues
    from them; ``greedy=False`` skips the final greedy runs. ``progress``: one bar over every
    learner's episodes (or a bigger run's monitor). Returns the run records, one per seed."""
    check_lockstep(config)
    if run_dirs is None and out_dir is not None:
        run_dirs = [seed_dir(Path(out_dir), s) for s in seeds]
    if run_dirs is not None and len(run_dirs) != len(seeds):
        raise ValueError(f"give one run directory per seed ({len(seeds)}), got {len(run_dirs)}")
    if resume and run_dirs is None:
        raise ValueError("resume needs the run directories (out_dir or run_dirs)")
    with RunLock(out_dir) if out_dir is not None else contextlib.nullcontext():
        run = _Lockstep(config, seeds, run_dirs)
        if resume:
            run.restore()
        total = (config.episodes * len(seeds), "episodes")
        label = f"lockstep {config.algorithm} x{len(seeds)}"
        with watching(progress, total, label, tensorboard) as monitor:
            started = time.perf_counter()
            run.train(monitor)
        return run.records(time.perf_counter() - started, greedy)


class _Lockstep:
    """The state of a lockstep run: the vector env, the learners, and per learner its history,
    episode count and checkpoint."""

    def __init__(self, config: TrainConfig, seeds: list[int], dirs: list[Path] | None) -> None:
        self.config, self.seeds, self.dirs = config, list(seeds), dirs
        k = self.k = len(self.seeds)
        self.vec = AcrobotVectorEnv(
            num_envs=k, autoreset_mode="disabled", task=config.task, **config.env_kwargs()
        )
        features = config.encoding.build(self.vec.single_observation_space)
        self.learners = agent_spec(config.algorithm).group(features, config.agent, self.seeds)
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
        except DivergenceError:
            for checkpoint in self.checkpoints:  # each learner's last finite state
                checkpoint.save()
            raise
        for checkpoint in self.checkpoints:
            checkpoint.save()
            checkpoint.close()

    def _finish_episodes(
        self, done: np.ndarray, length: np.ndarray, total: np.ndarray, success: np.ndarray
    ) -> None:
        """Record the episodes that just ended, and checkpoint where one is due."""
        self.episode[done] += 1
        for i in np.flatnonzero(done):
            if not math.isfinite(total[i]):
                error = DivergenceError(f"the episode's return is {total[i]}", rewards=True)
                episode, kept = int(self.episode[i]) - 1, len(self.histories[i])
                raise diverged(self.config, self.seeds[i], episode, kept, error)
            self.histories[i].add(int(length[i]), float(total[i]), bool(success[i]))
            self._snapshot(i)
            self.monitors[i].episode(
                int(self.episode[i]) - 1, int(length[i]), float(total[i]), bool(success[i])
            )
            if self.episode[i] % self.config.checkpoint_every == 0:
                self.checkpoints[i].save()

    def records(self, elapsed: float, greedy: bool) -> list[dict[str, Any]]:
        """Each learner's run record (and run directory, with its learning curve), with its
        greedy episode from rest if ``greedy``."""
        config, records = self.config, []
        env = make_env(config) if greedy else None  # for the greedy runs alone
        for i, seed in enumerate(self.seeds):
            agent: Agent = config.make_agent(seed, self.vec.single_observation_space)
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
                write_run(self.dirs[i], record, f"seed {seed}")
            records.append(record)
        return records
