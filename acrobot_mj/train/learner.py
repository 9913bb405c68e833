"""Training one learner over any Gymnasium env with the acrobot's spaces, with its run record,
checkpoints and exact resume (the run directory's files: :mod:`.rundir`)."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym

from acrobot_mj.agents.protocol import Agent
from acrobot_mj.agents.registry import make_agent
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episodes import (
    episode_seed,
    greedy_from_rest,
    learn_episode,
    noise_options,
    training_env,
)
from acrobot_mj.train.progress import Progress
from acrobot_mj.train.records import History, run_record
from acrobot_mj.train.rundir import (
    CHECKPOINT_FILE,
    Checkpoints,
    load_into,
    read_for_resume,
    write_run,
)

#: Called after every training episode with its index and the history so far.
OnEpisode = Callable[[int, History], None]


def train_agent(
    config: TrainConfig,
    seed: int,
    out: Path | None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool = False,
    on_episode: OnEpisode | None = None,
) -> tuple[dict[str, Any], Agent]:
    """:func:`train` for one learner (no freshness check); returns the record and the agent."""
    env_name = "acrobot_mj (make_env)" if env is None else str(env)
    env = training_env(config, env)
    agent = make_agent(config, seed=seed)
    history, steps = History(), 0
    checkpoints = Checkpoints(None if out is None else out / CHECKPOINT_FILE, config, seed)
    if resume:
        if out is None:
            raise ValueError("resume needs the run directory (out_dir)")
        history, steps, arrays = read_for_resume(out / CHECKPOINT_FILE, config, seed)
        load_into(agent, arrays, out / CHECKPOINT_FILE)
    checkpoints.snapshot(agent.state_dict, history, steps)
    bar = Progress(config.episodes, f"{config.algorithm} seed {seed}", progress)
    started = time.perf_counter()
    interrupted = False
    try:
        for episode in range(len(history), config.episodes):
            noise = noise_options(config.start_noise_at(episode))
            result = learn_episode(env, agent, episode_seed(seed, episode), noise)
            history.add_episode(result)
            steps += result.length
            checkpoints.snapshot(agent.state_dict, history, steps)
            bar.update(len(history), history)
            if (episode + 1) % config.checkpoint_every == 0:
                checkpoints.save()
            if on_episode is not None:
                on_episode(episode, history)
    except KeyboardInterrupt:
        interrupted = True
    elapsed = time.perf_counter() - started
    checkpoints.save()
    # The greedy policy from rest, on the training env (ties broken by a fixed stream).
    greedy = None if interrupted else greedy_from_rest(env, agent, seed)
    record = run_record(
        config, seed, history, steps, elapsed, interrupted=interrupted, env=env_name, greedy=greedy
    )
    if out is not None:
        write_run(out, record, f"seed {seed}")
    if interrupted:
        raise KeyboardInterrupt(f"interrupted after {len(history)} episodes; checkpoint saved")
    return record, agent
