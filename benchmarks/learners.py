"""Learner rows of ``acrobot-mj bench`` beyond the book ones: the tuned preset's model-based
learning, cut to a short budget, and K compiled book learners in lockstep on one vector env.

Each function returns a rate: round -> training decisions per wall second, as
``benchmarks/suite.py``'s ``learner`` does; :func:`learner_rows` names them for the suite.
"""

from __future__ import annotations

import importlib.util
import json
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np

from acrobot_mj.agents.registry import make_agent, make_features
from acrobot_mj.envs.model_env import ModelEnv
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episodes import (
    episode_seed,
    learn_episode,
    make_env,
    noise_options,
    shape_rewards,
)
from acrobot_mj.train.lockstep import train_lockstep
from acrobot_mj.train.model_based import identified_model
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.seeds import train_seeds

Rate = Callable[[int], float]  # round -> decisions per second


def tuned_config(decisions: int, kernel: str | None) -> TrainConfig:
    """The ``tuned`` preset as one learner of ``decisions`` simulated decisions (its model
    identified from the preset's 1,000 env decisions), with ``kernel`` (``"numba"`` or None)."""
    return PRESETS["tuned"].replace(population=1, max_decisions=decisions, kernel=kernel)


def tuned_learner(decisions: int, kernel: str | None) -> Rate:
    """Simulated learning decisions per wall second of ``train --preset tuned``'s learner: Sarsa
    (lambda) on tiles with energy shaping, in the :class:`ModelEnv` identified (once, untimed:
    about 1,000 MuJoCo decisions and a least-squares fit) from the real env. Each round runs a
    fresh learner for ``decisions`` decisions, episodes seeded and start-noised as training
    does; the population's judging and the greedy run are left out."""
    config = tuned_config(decisions, kernel)
    real = make_env(config)
    _, theta, _, structure = identified_model(
        real, config.identify_decisions, 0, config.start_noise
    )
    compiled = kernel == "numba"
    model = ModelEnv(theta, real.unwrapped.task, structure, config.max_episode_steps, compiled)
    env = shape_rewards(model, config)

    def measure(k: int) -> float:
        agent = make_agent(config, seed=k)
        steps, episode, start = 0, 0, time.perf_counter()
        with np.errstate(over="ignore", invalid="ignore"):  # as training runs it
            while steps < decisions:
                noise = noise_options(config.start_noise_at(episode))
                seed = episode_seed(k, episode)
                steps += learn_episode(env, agent, seed, noise, decisions - steps).length
                episode += 1
        return steps / (time.perf_counter() - start)

    return measure


def learner_rows(quick: bool) -> tuple[dict[str, Rate], dict[str, str]]:
    """The rows this module adds to the suite's rates, by name (the compiled kernel when numba
    is installed, compiled before any round), and the key of each row's ratio to Gymnasium's
    ``Acrobot-v1`` ``env.step``."""
    numba = importlib.util.find_spec("numba") is not None
    kernel = "numba" if numba else None
    rate = tuned_learner(2_000 if quick else 5_000, kernel)
    if numba:
        tuned_learner(50, kernel)(0)  # compiled (or loaded from numba's cache) before timing
    name = f"tuned learner, {kernel or 'numpy'} (decisions)"
    rows, ratios = {name: rate}, {name: f"tuned_{kernel or 'numpy'}_vs_gymnasium_env_step"}
    if numba:
        k = 4 if quick else 20
        lockstep_book(2, 1)(0)  # compiled (or loaded from numba's cache) before timing
        name = f"lockstep book, numba, K={k} (decisions)"
        rows[name] = lockstep_book(k, 1 if quick else 3)
        ratios[name] = "lockstep_book_numba_vs_gymnasium_env_step"
    return rows, ratios


def lockstep_book(learners: int, episodes: int) -> Rate:
    """Learning decisions of all ``learners`` per wall second: the book preset compiled, its
    seeds in lockstep on one vector env (``train --preset book --kernel numba --seeds K``), one
    process, no greedy runs. Round ``r`` trains seeds ``r * learners`` onwards."""
    config = PRESETS["book"].replace(kernel="numba", episodes=episodes)

    def measure(r: int) -> float:
        seeds = list(range(r * learners, (r + 1) * learners))
        start = time.perf_counter()
        records = train_lockstep(config, seeds, greedy=False)
        return sum(record["steps"] for record in records) / (time.perf_counter() - start)

    return measure


def lockstep_memory_mb(learners: int) -> float:
    """Peak memory (tracemalloc, MB) per learner of a lockstep group of ``learners`` with the
    tuned preset's tile coding (1,260,900 weights), built and one episode begun."""
    from acrobot_mj.agents.lockstep_lambda import LockstepSarsaLambda

    config = PRESETS["tuned"].replace(kernel="numba")
    features = make_features(config)
    tracemalloc.start()
    try:
        group = LockstepSarsaLambda(features, config, list(range(learners)))
        ids = np.arange(learners)
        group.begin_episodes(ids, np.tile([-np.pi / 2, 0.0, 0.0, 0.0], (learners, 1)))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak / 1e6 / learners


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
        train_seeds(config, list(range(seeds)), Path(tmp) / "run", jobs=jobs)
        wall = time.perf_counter() - start
        records = [json.loads(path.read_text()) for path in Path(tmp).glob("run/seed_*/run.json")]
    if len(records) != seeds:
        raise RuntimeError(f"tuned over {seeds} seeds wrote {len(records)} run records")
    return sum(r["steps"] + r["decisions_total"] for r in records) / wall


def tuned_seeds_row(quick: bool, baseline: Rate) -> dict[str, float | int | str]:
    """The tuned preset over 20 seeds, ``--jobs 2`` (quick: 2 seeds of 2 short learners),
    compiled when numba is installed, measured once between two rounds of ``baseline``
    (Gymnasium's ``env.step``: the ratio is to their mean). A minute or two on two cores."""
    numba = importlib.util.find_spec("numba") is not None
    config = PRESETS["tuned"].replace(kernel="numba" if numba else None)
    seeds, jobs = (2, 2) if quick else (20, 2)
    if quick:
        config = config.replace(population=2, max_decisions=20_000, identify_decisions=300)
    before = baseline(0)
    rate = tuned_seeds(seeds, jobs, config)
    base = (before + baseline(1)) / 2
    return {
        "seeds": seeds,
        "jobs": jobs,
        "kernel": config.kernel or "numpy",
        "decisions_per_second": rate,
        "gymnasium_env_step_per_second": base,
        "ratio": rate / base,
    }


def tuned_seeds_line(row: dict[str, float | int | str]) -> str:
    """The report's line for :func:`tuned_seeds_row`."""
    return (
        f"tuned over {row['seeds']} seeds, --jobs {row['jobs']} ({row['kernel']}): "
        f"{row['decisions_per_second']:.0f} decisions/s, Acrobot-v1 env.step "
        f"{row['gymnasium_env_step_per_second']:.0f}/s around it"
    )


def lockstep_lambda_memory(quick: bool) -> dict[str, float]:
    """Peak memory per learner of lockstep Sarsa(lambda) with the tuned tiles (numba only)."""
    if importlib.util.find_spec("numba") is None:
        return {}
    per_learner = lockstep_memory_mb(2 if quick else 10)
    return {"lockstep_lambda_peak_memory_mb_per_tuned_learner": per_learner}
