"""Training one run: a single learner (:mod:`.learner`) or a population of them
(:mod:`.population`), into a run directory that holds no other run.

A run directory (:mod:`.rundir`) gets ``run.json``, ``checkpoint.npz`` (every
``checkpoint_every`` episodes, at the end and on Ctrl-C) and ``learning_curve.png``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym

from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.learner import OnEpisode
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.model_based import train_in_model
from acrobot_mj.train.population import train_learners
from acrobot_mj.train.progress import Monitor, run_total, watching
from acrobot_mj.train.rundir import check_fresh


def train(
    config: TrainConfig,
    seed: int,
    out_dir: str | Path | None = None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool | Monitor = False,
    on_episode: OnEpisode | None = None,
    overwrite: bool = False,
    tensorboard: str | Path | None = None,
    lockstep: bool | None = None,
) -> dict[str, Any]:
    """Train ``config``'s agent with ``seed`` for ``config.episodes`` episodes.

    With ``out_dir`` it writes the run record, checkpoints (every ``checkpoint_every`` episodes,
    at the end and on Ctrl-C) and the learning curve there; with ``resume`` it continues from
    the checkpoint in ``out_dir`` and ends exactly as an uninterrupted run would. ``env`` may be
    any env with ``Discrete(3)`` actions and ``(q1, q2, dq1, dq2)`` observations (default: the
    config's acrobot env). Returns the run record. With ``config.population > 1`` it trains
    that many learners and keeps one (:mod:`acrobot_mj.train.population`; ``lockstep``: its
    learners together on one vector env, or not, or None: the faster way for the algorithm).

    ``progress`` shows one bar over all the run's learners on stderr (or is the
    :class:`~acrobot_mj.train.progress.Monitor` of a bigger run); ``tensorboard`` writes each
    episode's length, return and success there (:mod:`acrobot_mj.train.tensorboard`). Every
    episode is also logged to ``out_dir/episodes.jsonl`` as it ends
    (:mod:`acrobot_mj.train.episode_log`).
    """
    check_seed(seed)
    if out_dir is None:
        return _train(config, seed, None, env, resume, progress, on_episode, tensorboard, lockstep)
    out = Path(out_dir)
    with RunLock(out, "train", create=not resume):  # resume: the directory must be there
        if not resume and not overwrite:
            check_fresh(out)
        return _train(config, seed, out, env, resume, progress, on_episode, tensorboard, lockstep)


def _train(config, seed, out, env, resume, progress, on_episode, board, lockstep) -> dict:
    learners = f" x{config.population}" if config.population > 1 else ""
    label = f"{config.algorithm}{learners} seed {seed}"
    if lockstep and config.identify_decisions > 0:
        raise ValueError("a model-based run's learners train one by one in the model: no lockstep")
    with watching(progress, run_total(config), label, board) as monitor:
        if config.identify_decisions > 0:
            return train_in_model(config, seed, out, env, resume, monitor, on_episode)
        return train_learners(config, seed, out, env, resume, monitor, on_episode, None, lockstep)[
            0
        ]


def check_seed(seed: Any) -> int:
    """A run's seed: an integer >= 0 (numpy's seeding takes no other)."""
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"a run's seed must be an integer >= 0, got {seed!r}")
    return seed
