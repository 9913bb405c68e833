"""Training a run, and loading what a run directory holds, whatever the learner."""

from __future__ import annotations

from contextlib import nullcontext
from pathlib import Path
from typing import Any

import gymnasium as gym

from acrobot_mj.train.balance_preset import PlanConfig, PlanLearner
from acrobot_mj.train.black_box import BlackBoxConfig, BlackBoxLearner
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.feedback_run import FeedbackConfig, FeedbackLearner
from acrobot_mj.train.learners import AgentLearner, Learner
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.model_based import ModelBasedLearner
from acrobot_mj.train.monitor import run_total, watching
from acrobot_mj.train.records import (
    CURVE_FILE,
    EVAL_FILE,
    RUN_FILE,
    SUMMARY_FILE,
    check_fresh,
    read_record,
)
from acrobot_mj.train.run import PLAIN, Run, RunOptions

#: The learners that are not trained by episodes, by their config's type and ``run.json`` kind.
BUILT: dict[type, type[Learner]] = {
    PlanConfig: PlanLearner,
    FeedbackConfig: FeedbackLearner,
    BlackBoxConfig: BlackBoxLearner,
}
KINDS: dict[str | None, type[Learner]] = {cls.kind: cls for cls in BUILT.values()}
Config = TrainConfig | PlanConfig | FeedbackConfig | BlackBoxConfig


def learner_for(config: Config, seed: int, env: gym.Env | None = None) -> Learner:
    """The learner of ``config``: the balance preset's planner, the state-feedback controller,
    the black-box learner (which takes any env with a Box action), or the config's agent."""
    if isinstance(config, BlackBoxConfig):
        return BlackBoxLearner(config, seed, env)
    if type(config) in BUILT:
        if env is not None:
            raise ValueError(
                "the balance preset and the state-feedback controller run on the "
                "package's own env; give no env"
            )
        return BUILT[type(config)](config, seed)
    if not isinstance(config, TrainConfig):
        raise TypeError(
            f"config must be a TrainConfig, PlanConfig, FeedbackConfig or "
            f"BlackBoxConfig, got "
            f"{config!r}"
        )
    kind = ModelBasedLearner if config.identify_decisions > 0 else AgentLearner
    return kind(config, seed, env)


def train(
    config: Config,
    seed: int,
    out_dir: str | Path | None = None,
    options: RunOptions = PLAIN,
    *,
    env: gym.Env | None = None,
) -> dict[str, Any]:
    """Train ``config``'s learner with ``seed``; the run record. ``out_dir``: the run directory
    (one holding another run is refused unless ``options.overwrite``; ``options.resume``
    continues from its checkpoints exactly). ``env``: any env with ``Discrete(3)`` actions and
    ``(q1, q2, dq1, dq2)`` observations (default: the config's). ``options``: the
    :class:`~acrobot_mj.train.run.RunOptions` of one run (no ``jobs`` or ``lockstep``)."""
    options.only("one run", "resume", "overwrite", "progress", "tensorboard", "on_episode")
    learner = learner_for(config, seed, env)
    if type(config) in BUILT and options.resume:
        raise ValueError(
            "the balance preset and the state-feedback controller have nothing to resume"
        )
    out = None if out_dir is None else Path(out_dir)
    resume = options.resume
    with RunLock(out, "train", create=not resume) if out is not None else nullcontext():
        if out is not None and not resume and not options.overwrite:
            check_fresh(out)
        if out is not None:  # they evaluated or summarised what training is about to change
            (out / EVAL_FILE).unlink(missing_ok=True)
            if out.name.startswith("seed_") and (out.parent / SUMMARY_FILE).exists():
                for name in (SUMMARY_FILE, CURVE_FILE):  # of the --seeds run this seed is of
                    (out.parent / name).unlink(missing_ok=True)
        if not isinstance(config, TrainConfig):
            return learner.learn(Run(out, progress=bool(options.progress)))
        label = f"{config.algorithm} seed {seed}"
        total = run_total(config)
        with watching(options.progress, total, label, options.tensorboard) as monitor:
            return learner.learn(Run(out, resume, monitor, options.on_episode))


def load_learner(run_dir: str | Path) -> Learner:
    """The trained learner of a run directory, whatever it is."""
    run_dir = Path(run_dir)
    try:
        kind = read_record(run_dir / RUN_FILE).get("kind")
    except ValueError:
        kind = None  # an agent's run: its checkpoint says what is wrong
    return KINDS.get(kind, AgentLearner).load(run_dir)
