"""The envs training runs on, and the two kinds of episode a run is made of: learning episodes
and greedy ones, both through the one episode loop (:func:`acrobot_mj.envs.episode.run_episode`).

Every random choice is fixed by the run's seed: each episode's reset seed
(:func:`episode_seed`) and each greedy episode's tie-breaking stream (:func:`tie_stream`), so a
resumed run resets exactly as an uninterrupted one and ``train``, ``evaluate`` and ``render``
report the same greedy swing-up.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.agents.actors import Greedy, Learning
from acrobot_mj.agents.protocol import Agent
from acrobot_mj.agents.random_stream import RandomStream
from acrobot_mj.envs.episode import Episode, run_episode
from acrobot_mj.envs.shaping import EnergyShaping
from acrobot_mj.train.config import TrainConfig


def make_env(config: TrainConfig, **overrides: Any) -> gym.Env:
    """The training env of ``config`` (through ``gymnasium.make``, so with its TimeLimit, and
    with its reward shaping if any)."""
    kwargs = {**config.env_kwargs(), **overrides}
    return shape_rewards(gym.make(config.env_id, **kwargs), config)


def training_env(config: TrainConfig, env: gym.Env | None = None) -> gym.Env:
    """``config``'s env, or the given ``env`` checked and with ``config``'s reward shaping."""
    if env is None:
        return make_env(config)
    check_spaces(env)
    return shape_rewards(env, config)


def shape_rewards(env: gym.Env, config: TrainConfig) -> gym.Env:
    """``env`` with ``config``'s energy shaping (unchanged without it). Records report the
    unshaped returns (``info["unshaped_reward"]``)."""
    if config.energy_shaping == 0.0:
        return env
    gamma = 1.0 if config.gamma is None else config.gamma
    return EnergyShaping(env, config.energy_shaping, gamma)


def check_spaces(env: gym.Env) -> None:
    """Refuse envs whose spaces the agents cannot use, naming what is wrong."""
    if not (isinstance(env.action_space, gym.spaces.Discrete) and env.action_space.n == 3):
        raise ValueError(f"the agents need a Discrete(3) action space, got {env.action_space}")
    shape = getattr(env.observation_space, "shape", None)
    if not isinstance(env.observation_space, gym.spaces.Box) or shape != (4,):
        raise ValueError(
            "the agents need observations (q1, q2, dq1, dq2) in a Box of shape "
            f"(4,), got {env.observation_space}"
        )


def episode_seed(seed: int, episode: int) -> int:
    """The env's reset seed for ``episode`` of run ``seed``: fixed per episode, so a resumed
    run resets exactly as an uninterrupted one."""
    return int(np.random.SeedSequence([seed, episode]).generate_state(1)[0])


def tie_stream(run_seed: int, episode: int = 0) -> RandomStream:
    """The stream that breaks ties of greedy episode ``episode`` of run ``run_seed``: the same
    for the greedy run from rest in ``train``, in ``evaluate`` (its episode 0) and in
    ``render``, so all three report the same swing-up."""
    return RandomStream(np.random.SeedSequence([run_seed, episode]))


def noise_options(noise: float) -> dict[str, float] | None:
    """Reset options for a training episode with start noise ``noise`` (None without)."""
    return {"start_noise": noise} if noise > 0 else None


def learn_episode(
    env: gym.Env,
    agent: Agent,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    max_steps: int | None = None,
) -> Episode:
    """One learning episode (cut after ``max_steps`` decisions: a truncation to the agent)."""
    return run_episode(env, Learning(agent), seed, options, max_steps)


def greedy_from_rest(env: gym.Env, agent: Agent, run_seed: int) -> Episode:
    """The greedy episode from rest that a run records (ties broken by :func:`tie_stream`)."""
    return run_episode(env, Greedy(agent, tie_stream(run_seed)), run_seed, {"start_noise": 0.0})
