"""Several independent learners sharing one run's episode budget; the best one is kept.

With epsilon 0 in a deterministic task a Sarsa(lambda) learner settles on one swing-up after a
few dozen episodes, and which one depends on its first episodes (the README's results). Random
restarts turn that lottery into a choice: ``population`` learners of ``episodes`` episodes each
(own seeds, own start noise), and the run keeps the learner whose last 20 training episodes had
the shortest median length (``training.recent_median``). The choice uses training episodes
only; no extra evaluation.

A run directory holds ``learner_K/`` (each a run of its own: record, learning curve, and its
checkpoints while the population trains, so an interrupted run resumes) and, at the top, the
usual ``run.json``, ``checkpoint.npz`` (the kept learner's agent) and learning curve, so
``evaluate`` and ``render`` work on it unchanged. Once the top-level checkpoint is written the
learners' checkpoints are deleted (ten of them would take ten times the disk); resuming a
finished run trains the learners again and gets the same result. The top-level per-episode
lists are every learner's episodes in order (the whole budget spent); ``population`` in
``run.json`` says which learner was kept and why.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.checkpoint import save_checkpoint
from acrobot_mj.config import TrainConfig
from acrobot_mj.plots import learning_curve
from acrobot_mj.training import (
    CHECKPOINT_FILE,
    CURVE_FILE,
    RUN_FILE,
    History,
    _meta,
    _read_run,
    _reference,
    check_same_run,
    greedy_episode,
    recent_median,
    tie_stream,
    train_agent,
    training_env,
)


def learner_seed(seed: int, k: int) -> int:
    """The seed of learner ``k`` of run ``seed``."""
    return int(np.random.SeedSequence([seed, 0x9E37, k]).generate_state(1)[0])


def _check_population_resume(out: Path | None, config: TrainConfig, seed: int) -> None:
    """Refuse to resume into a directory whose run has another config or seed."""
    if out is None:
        raise ValueError("resume needs the run directory (out_dir)")
    path = out / CHECKPOINT_FILE
    if path.exists():  # else unfinished: each learner checks its own checkpoint
        meta, _, saved = _read_run(path)
        check_same_run(path, meta, saved, config, seed)


def train_population(
    config: TrainConfig,
    seed: int,
    out: Path | None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool = False,
    on_episode: Callable[[int, History], None] | None = None,
) -> dict[str, Any]:
    """Train ``config.population`` learners and keep the best; see the module docstring."""
    if resume:
        _check_population_resume(out, config, seed)
    elif out is not None:
        for old in sorted(out.glob("learner_*")):  # an overwritten run's learners
            if old.is_dir():
                shutil.rmtree(old)
    single = config.replace(population=1)
    records, scores = [], []
    best, agent = 0, None
    for k in range(config.population):
        sub = out / f"learner_{k}" if out is not None else None
        again = resume and sub is not None and (sub / CHECKPOINT_FILE).exists()
        try:
            record, learner = train_agent(
                single, learner_seed(seed, k), sub, env, again, progress, on_episode
            )
        except KeyboardInterrupt as error:
            raise KeyboardInterrupt(
                f"interrupted in learner {k} of {config.population} ({error}); resume to continue"
            ) from error
        records.append(record)
        scores.append(recent_median(record["episode_lengths"]))
        if agent is None or scores[k] < scores[best]:  # ties: the first
            best, agent = k, learner  # only the best so far stays in memory

    history = History()
    for r in records:
        lists = (r["episode_lengths"], r["episode_returns"], r["episode_successes"])
        for row in zip(*lists, strict=True):
            history.add(*row)
    steps = sum(r["steps"] for r in records)
    length, total, success = greedy_episode(
        training_env(config, env), agent, tie_stream(seed), seed=seed, options={"start_noise": 0.0}
    )
    record: dict[str, Any] = {
        **records[best],
        "config": config.to_dict(),
        "seed": seed,
        "episodes_done": len(history),
        "steps": steps,
        "wall_seconds": sum(r["wall_seconds"] for r in records),
        **history.to_dict(),
        "greedy_from_rest": {"length": length, "return": total, "success": success},
        "population": {
            "learners": config.population,
            "seeds": [r["seed"] for r in records],
            "scores": scores,
            "kept": best,
            "rule": "shortest median of the last 20 training episodes",
            "greedy_from_rest_lengths": [r["greedy_from_rest"]["length"] for r in records],
        },
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        save_checkpoint(
            out / CHECKPOINT_FILE, agent.state_dict(), _meta(config, seed, history, steps)
        )
        (out / RUN_FILE).write_text(json.dumps(record, indent=1))
        learning_curve(
            out / CURVE_FILE,
            [history.episode_lengths],
            f"{config.algorithm} ({config.features}), {config.population} learners, seed {seed}",
            _reference(config),
        )
        for k in range(config.population):
            (out / f"learner_{k}" / CHECKPOINT_FILE).unlink(missing_ok=True)
    return record
