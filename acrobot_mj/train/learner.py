"""Training one learner over any Gymnasium env with the acrobot's spaces, with its run record,
checkpoints and exact resume (the run directory's files: :mod:`.rundir`)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.agents.protocol import Agent, DivergenceError, Rewinding
from acrobot_mj.agents.registry import make_agent, make_features
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episode_log import RunLog
from acrobot_mj.train.episodes import (
    episode_seed,
    greedy_from_rest,
    learn_episode,
    noise_options,
    training_env,
)
from acrobot_mj.train.progress import Monitor, run_total, watching
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


def check_finite_return(total: float) -> None:
    """Raise :class:`DivergenceError` for an episode return that is not a finite number."""
    if not math.isfinite(total):
        raise DivergenceError(f"the episode's return is {total}", rewards=True)


def diverged(
    config: TrainConfig, seed: int, episode: int, kept: int, error: DivergenceError
) -> DivergenceError:
    """The error a run stops with when its learner diverges: where, and the likely cause."""
    n = make_features(config).num_active
    if error.rewards:
        cause = (
            f"the rewards (step_reward {config.step_reward}, goal_reward "
            f"{config.goal_reward}) overflow a float"
        )
    else:
        cause = (
            f"the step size: alpha={config.alpha:g} is per weight, and {n} features are active "
            f"in each state (Sutton and Barto use 0.2/{n} with tile coding)"
        )
    return DivergenceError(
        f"{config.algorithm} diverged in episode {episode + 1} of seed {seed} ({error}); "
        f"the likely cause is {cause}; the checkpoint keeps the state after episode {kept}"
    )


def checkpoint_state(agent: Agent) -> Callable[[], Any]:
    """What a checkpoint snapshot calls: the agent's own rewinding state if it has one (no copy
    after every episode), else its ``state_dict``."""
    return agent.checkpoint_state if isinstance(agent, Rewinding) else agent.state_dict


def budget_left(config: TrainConfig, history: History) -> int | None:
    """Decisions a learner may still take under ``config.max_decisions`` (None: no cap)."""
    cap = config.learner_decisions
    return None if cap == 0 else max(cap - history.steps, 0)


def train_agent(
    config: TrainConfig,
    seed: int,
    out: Path | None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool | Monitor = False,
    on_episode: OnEpisode | None = None,
    greedy: bool = True,
    tee: RunLog | None = None,
    curve: bool = True,
) -> tuple[dict[str, Any], Agent]:
    """:func:`train` for one learner (no freshness check); returns the record and the agent.
    ``greedy=False`` skips the greedy episode from rest after training (a population's
    learners: nothing uses theirs, and it would cost the env decisions). ``progress``: show a
    bar, or the :class:`~acrobot_mj.train.progress.Monitor` of the run this learner is in;
    ``tee``: the population's log, which gets each episode's line too; ``curve=False``: no
    ``learning_curve.png`` (a population's learners: ``acrobot-mj curves`` draws one)."""
    env_name = "acrobot_mj (make_env)" if env is None else str(env)
    env = training_env(config, env)
    agent = make_agent(config, seed=seed)
    history = History()
    path = None if out is None else out / CHECKPOINT_FILE
    checkpoints = Checkpoints(path, config, seed, tee=tee)
    if resume:
        if out is None:
            raise ValueError("resume needs the run directory (out_dir)")
        history, arrays = read_for_resume(out / CHECKPOINT_FILE, config, seed)
        load_into(agent.load_state_dict, arrays, out / CHECKPOINT_FILE)
    checkpoints.start(history)
    checkpoints.snapshot(checkpoint_state(agent), history)
    with watching(progress, run_total(config), f"{config.algorithm} seed {seed}") as monitor:
        monitor.restored(history)
        started = time.perf_counter()
        stop = _learn(config, seed, env, agent, history, checkpoints, monitor, on_episode)
    elapsed = time.perf_counter() - started
    checkpoints.save()
    checkpoints.close()
    # The greedy policy from rest, on the training env (ties broken by a fixed stream).
    rest = None if stop or not greedy else greedy_from_rest(env, agent, seed)
    record = run_record(
        config, seed, history, elapsed, interrupted=bool(stop), env=env_name, greedy=rest
    )
    if out is not None:
        write_run(out, record, f"seed {seed}", curve)
    if stop:
        raise type(stop)(f"interrupted after {len(history)} episodes; checkpoint saved")
    return record, agent


def _learn(config, seed, env, agent, history, checkpoints, monitor, on_episode):
    """The learning episodes left (checkpoints as they go); the Ctrl-C that stopped them."""
    try:
        for episode in range(len(history), config.episodes):
            left = budget_left(config, history)
            if left == 0:
                break
            noise = noise_options(config.start_noise_at(episode))
            try:
                with np.errstate(over="ignore", invalid="ignore"):  # checked here, by value
                    result = learn_episode(env, agent, episode_seed(seed, episode), noise, left)
                check_finite_return(result.episode_return)
            except DivergenceError as error:
                checkpoints.save()  # the state after the last finite episode
                checkpoints.close()
                raise diverged(config, seed, episode, len(history), error) from None
            history.add_episode(result)
            checkpoints.snapshot(checkpoint_state(agent), history)
            monitor.episode(episode, result.length, result.episode_return, result.success)
            if (episode + 1) % config.checkpoint_every == 0:
                checkpoints.save()
            if on_episode is not None:
                on_episode(episode, history)
    except KeyboardInterrupt as interrupt:
        return interrupt
    return None
