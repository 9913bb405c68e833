"""The tuned learner's rows of ``acrobot-mj bench``: its model-based learning cut to a short
budget, and ``train --preset tuned`` over seeds as the CLI runs it.

:func:`tuned_learner` returns a rate: round -> training decisions per wall second, as
``benchmarks/suite.py``'s ``learner`` does; :func:`learner_rows` names it for the suite.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from acrobot_mj.agents.base import Learning
from acrobot_mj.envs.identified import IdentifiedEnv
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.learners import episode_seed, make_env, shape_rewards
from acrobot_mj.train.model_based import identified_model
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.seeds import train_seeds

Rate = Callable[[int], float]  # round -> decisions per second


def tuned_config(decisions: int) -> TrainConfig:
    """The ``tuned`` preset as one learner of ``decisions`` simulated decisions (its model
    identified from the preset's 1,000 env decisions)."""
    return PRESETS["tuned"].replace(population=1, max_decisions=decisions)


def tuned_learner(decisions: int) -> Rate:
    """Simulated learning decisions per wall second of ``train --preset tuned``'s learner: Sarsa
    (lambda) on tiles with energy shaping, in the :class:`IdentifiedEnv` identified (once,
    untimed: about 1,000 MuJoCo decisions and a least-squares fit) from the real env. Each round
    runs a fresh learner for ``decisions`` decisions, episodes seeded and start-noised as
    training does; the population's judging and the greedy run are left out."""
    config = tuned_config(decisions)
    real = make_env(config)
    _, theta, _, told = identified_model(real, config.identify_decisions, 0, config.start_noise)
    model = IdentifiedEnv(theta, real.unwrapped.task, told, config.max_episode_steps)
    env = shape_rewards(model, config)

    def measure(k: int) -> float:
        agent = config.make_agent(k, env.observation_space)
        steps, episode, start = 0, 0, time.perf_counter()
        with np.errstate(over="ignore", invalid="ignore"):  # as training runs it
            while steps < decisions:
                noise = config.start_noise_at(episode)
                options = {"start_noise": noise} if noise > 0 else None
                seed = episode_seed(k, episode)
                steps += run_episode(
                    env, Learning(agent), seed, options, max_steps=decisions - steps
                ).length
                episode += 1
        return steps / (time.perf_counter() - start)

    return measure


def learner_rows(quick: bool) -> tuple[dict[str, Rate], dict[str, str]]:
    """The rows this module adds to the suite's rates, by name (compiled before any round), and
    the key of each row's ratio to Gymnasium's ``Acrobot-v1`` ``env.step``."""
    rate = tuned_learner(2_000 if quick else 5_000)
    tuned_learner(50)(0)  # compiled (or loaded from numba's cache) before timing
    name = "tuned learner (decisions)"
    return {name: rate}, {name: "tuned_vs_gymnasium_env_step"}


def tuned_seeds(seeds: int, jobs: int, config: TrainConfig) -> float:
    """Decisions per wall second of ``train --preset tuned --seeds S --jobs J`` as the CLI
    runs it (``train_seeds`` into a temporary directory): each seed's model identification
    (env decisions), its learners (simulated decisions), records, checkpoints, learning curve,
    greedy run and held-out evaluation. The decisions counted are the records' (simulated
    learning ``steps`` and the env's ``decisions_total``, as a model-based record keeps them);
    the evaluation's are not, though its time is."""
    if not config.identify_decisions:
        raise ValueError("tuned_seeds counts a model-based run's decisions: identify_decisions")
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        train_seeds(config, list(range(seeds)), Path(tmp) / "run", options=RunOptions(jobs=jobs))
        wall = time.perf_counter() - start
        records = [json.loads(path.read_text()) for path in Path(tmp).glob("run/seed_*/run.json")]
    if len(records) != seeds:
        raise RuntimeError(f"tuned over {seeds} seeds wrote {len(records)} run records")
    return sum(r["steps"] + r["decisions_total"] for r in records) / wall


def tuned_seeds_row(quick: bool, baseline: Rate) -> dict[str, float | int]:
    """The tuned preset over 20 seeds, ``--jobs 2`` (quick: 2 seeds of 2 short learners),
    measured once between two rounds of ``baseline`` (Gymnasium's ``env.step``: the ratio is
    to their mean). A minute or two on two cores."""
    config = PRESETS["tuned"]
    seeds, jobs = (2, 2) if quick else (20, 2)
    if quick:
        config = config.replace(population=2, max_decisions=20_000, identify_decisions=300)
    before = baseline(0)
    rate = tuned_seeds(seeds, jobs, config)
    base = (before + baseline(1)) / 2
    return {
        "seeds": seeds,
        "jobs": jobs,
        "decisions_per_second": rate,
        "gymnasium_env_step_per_second": base,
        "ratio": rate / base,
    }


def tuned_seeds_line(row: dict[str, float | int]) -> str:
    """The report's line for :func:`tuned_seeds_row`."""
    return (
        f"tuned over {row['seeds']} seeds, --jobs {row['jobs']}: "
        f"{row['decisions_per_second']:.0f} decisions/s, Acrobot-v1 env.step "
        f"{row['gymnasium_env_step_per_second']:.0f}/s around it"
    )
