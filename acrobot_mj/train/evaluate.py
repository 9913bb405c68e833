"""Greedy episodes of a trained run: ``eval.json``, and videos of the greedy swing-up."""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path
from typing import Any

from acrobot_mj.agents.actors import Greedy
from acrobot_mj.envs.episode import run_episode
from acrobot_mj.files import write_json
from acrobot_mj.report.video import record_episode
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episodes import episode_seed, make_env, tie_stream
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.records import History
from acrobot_mj.train.rundir import EVAL_FILE, load_agent
from acrobot_mj.version import versions

#: Start noise of evaluation episodes after the first when the run's config sets none (it
#: trained with one evaluation episode).
DEFAULT_EVAL_NOISE = next(f for f in fields(TrainConfig) if f.name == "eval_noise").metadata[
    "default"
]


def evaluate(run_dir: str | Path, episodes: int | None = None, seed: int = 0) -> dict[str, Any]:
    """Greedy episodes of a trained run on its own env settings: episode 0 from rest (the same
    episode as the run's ``greedy_from_rest``), the others with ``config.eval_noise`` start
    noise drawn with ``seed``. Writes and returns ``eval.json``."""
    run_dir = Path(run_dir)
    with RunLock(run_dir, "evaluate", create=False):
        return _evaluate(run_dir, episodes, seed)


def _evaluate(run_dir: Path, episodes: int | None, seed: int) -> dict[str, Any]:
    config, run_seed, agent = load_agent(run_dir)
    episodes = config.eval_episodes if episodes is None else episodes
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    later = DEFAULT_EVAL_NOISE if config.eval_noise is None else config.eval_noise
    noises = [0.0 if k == 0 else later for k in range(episodes)]
    env = make_env(config)
    history = History()
    for k, noise in enumerate(noises):
        actor = Greedy(agent, tie_stream(run_seed, k))
        options = {"start_noise": noise}
        history.add_episode(run_episode(env, actor, episode_seed(seed, k), options))
    record = {
        "run": str(run_dir),
        "run_seed": run_seed,
        "eval_seed": seed,
        "config": config.to_dict(),
        "versions": versions(),
        "start_noise": noises,
        **history.to_dict(),
    }
    write_json(run_dir / EVAL_FILE, record)
    return record


def render_run(
    run_dir: str | Path,
    out: str | Path,
    seed: int = 0,
    width: int = 480,
    height: int = 480,
    camera: str = "side",
    max_steps: int | None = None,
    strip: str | Path | None = None,
    captions: bool = True,
) -> dict[str, Any]:
    """A video of a trained run's greedy policy from rest, on the run's own env settings (the
    video and its record must not replace a file of the run)."""
    with RunLock(run_dir, "render", create=False):
        config, run_seed, agent = load_agent(run_dir)
        env = make_env(config, render_mode="rgb_array", width=width, height=height, camera=camera)
    try:
        record = record_episode(
            env,
            # Ties broken as in the run's greedy_from_rest and evaluate's episode 0.
            Greedy(agent, tie_stream(run_seed)),
            out,
            seed=seed,
            max_steps=max_steps,
            reset_options={"start_noise": 0.0},
            captions=captions,
            strip=strip,
        )
    finally:
        env.close()
    record.update(run=str(run_dir), run_seed=run_seed, policy="greedy")
    write_json(Path(out).with_suffix(".json"), record)
    return record
