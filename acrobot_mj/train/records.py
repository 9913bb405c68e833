"""The run record: one definition of what ``run.json`` and a checkpoint's meta document hold.

A run record has the config, the seed, package versions, progress (episodes, decisions, wall
time, whether it was interrupted, ``decisions_total`` with its greedy episodes), the per-episode
``episode_lengths``, ``episode_returns`` and ``episode_successes``, and the greedy episode from
rest; population and lockstep runs add their own entries.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from acrobot_mj.envs.episode import Episode
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.stats import recent_median
from acrobot_mj.version import versions

HISTORY_KEYS = ("episode_lengths", "episode_returns", "episode_successes")


@dataclass
class History:
    """Per-episode results so far."""

    episode_lengths: list[int] = field(default_factory=list)
    episode_returns: list[float] = field(default_factory=list)
    episode_successes: list[bool] = field(default_factory=list)
    #: Decisions taken in all episodes: a running total, so reading it costs nothing per episode.
    steps: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        self.steps = int(sum(self.episode_lengths))

    def add(self, length: int, total: float, success: bool) -> None:
        self.episode_lengths.append(length)
        self.steps += int(length)
        self.episode_returns.append(total)
        self.episode_successes.append(success)

    def add_episode(self, episode: Episode) -> None:
        self.add(episode.length, episode.episode_return, episode.success)

    def extend(self, record: dict[str, Any]) -> None:
        """Append a run record's episodes."""
        for row in zip(*(record[key] for key in HISTORY_KEYS), strict=True):
            self.add(*row)

    def __len__(self) -> int:
        return len(self.episode_lengths)

    def to_dict(self) -> dict[str, list]:
        return {key: getattr(self, key) for key in HISTORY_KEYS}


def greedy_result(episode: Episode) -> dict[str, Any]:
    """A greedy episode as a record's ``greedy_from_rest`` entry."""
    return {"length": episode.length, "return": episode.episode_return, "success": episode.success}


def run_record(
    config: TrainConfig,
    seed: int,
    history: History,
    wall_seconds: float,
    *,
    interrupted: bool = False,
    env: str | None = None,
    greedy: Episode | None = None,
    **extra: Any,
) -> dict[str, Any]:
    """The ``run.json`` of one run (``extra``: the entries of population or lockstep runs).

    ``steps`` counts the decisions of learning episodes; ``decisions_total`` adds the run's
    greedy episode from rest (``greedy``): all the experience the run cost the env."""
    record: dict[str, Any] = {
        "config": config.to_dict(),
        "seed": seed,
        "versions": versions(),
        "episodes_done": len(history),
        "steps": history.steps,
        "interrupted": interrupted,
    }
    if env is not None:
        record["env"] = env
    record["wall_seconds"] = wall_seconds
    record.update(history.to_dict())
    record["decisions_total"] = history.steps + (0 if greedy is None else greedy.length)
    if greedy is not None:
        record["greedy_from_rest"] = greedy_result(greedy)
    record.update(extra)
    return record


def checkpoint_meta(
    config: TrainConfig, seed: int, episodes_done: int, steps: int, episode_log: str
) -> dict[str, Any]:
    """The JSON document of a training checkpoint: with the agent's arrays and the first
    ``episodes_done`` lines of the run's episode log, enough to resume exactly."""
    return {
        "config": config.to_dict(),
        "seed": seed,
        "episodes_done": episodes_done,
        "steps": steps,
        "episode_log": episode_log,
        "agent": config.algorithm,
    }


def recent_score(record: dict[str, Any]) -> float:
    """Median score of the last 20 training episodes of the learner a run keeps (in a
    population run: the kept learner's, not the last learner's), by the run's task."""
    pop = record.get("population")
    if pop is not None:
        return float(pop["scores"][pop["kept"]])
    score = get_task(TrainConfig.from_dict(record["config"]).task).score
    return recent_median(score.values(record))
