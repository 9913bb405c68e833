"""A run directory and its records: ``run.json`` (:func:`run_record`), ``episodes.jsonl``,
``learning_curve.png`` and ``eval.json``; ``summary.json`` and ``seed_S/`` for several seeds,
``learner_K/`` for a population (the checkpoint: :mod:`acrobot_mj.train.checkpoint`). Every file
is written atomically."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.envs.rollout import Episode
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import read_json, versions, write_json
from acrobot_mj.report.plots import learning_curve
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.lock import LOCK_FILE, RunLock

RUN_FILE, EVAL_FILE, CHECKPOINT_FILE = "run.json", "eval.json", "checkpoint.npz"
CURVE_FILE, SUMMARY_FILE, EPISODE_LOG = "learning_curve.png", "summary.json", "episodes.jsonl"
TRAJECTORY_FILE = "trajectory.json"  # a balance-preset run's plan
MODEL_FILE = "model.json"  # a black-box run's learnt model and plan
#: What a run directory holds of its own: no other command's output replaces it.
RUN_RECORDS = (
    RUN_FILE,
    EVAL_FILE,
    CHECKPOINT_FILE,
    CURVE_FILE,
    SUMMARY_FILE,
    EPISODE_LOG,
    TRAJECTORY_FILE,
    MODEL_FILE,
)


@contextlib.contextmanager
def output_into(path: str | Path, command: str) -> Iterator[None]:
    """While ``command`` writes ``path``: where its folder is a run directory, that run's lock
    (a running run refuses), and never one of the run's own records."""
    path = Path(path)
    folder = path.parent
    if not any((folder / name).exists() for name in (*RUN_RECORDS, LOCK_FILE)):
        yield
        return
    if path.name in RUN_RECORDS:
        raise FileExistsError(f"{path} is a record of the run in {folder}: choose another file")
    with RunLock(folder, command, create=False):
        yield


HISTORY_KEYS = ("episode_lengths", "episode_returns", "episode_successes")
#: Training episodes whose scores a run's recent performance is judged by.
RECENT = 20


def spread(values: Sequence[float]) -> dict[str, float | None]:
    """Mean, standard deviation, median, quartiles and range of ``values`` (None if empty)."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return dict.fromkeys(("mean", "std", "median", "q25", "q75", "min", "max"))
    q25, q50, q75 = np.percentile(v, [25, 50, 75])
    return {
        "mean": float(v.mean()),
        "std": float(v.std()),
        "median": float(q50),
        "q25": float(q25),
        "q75": float(q75),
        "min": float(v.min()),
        "max": float(v.max()),
    }


def recent_median(values: Sequence[float]) -> float:
    """Median of the last :data:`RECENT` values (of a run's per-episode scores)."""
    return float(np.median(values[-RECENT:]))


@dataclass
class History:
    """Per-episode results so far, and the decisions they took (a running total)."""

    episode_lengths: list[int] = field(default_factory=list)
    episode_returns: list[float] = field(default_factory=list)
    episode_successes: list[bool] = field(default_factory=list)
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


@dataclass(frozen=True)
class Outcome:
    """How a run's training ended: the ``wall_seconds`` [s] it took, whether it was
    ``interrupted``, and its ``greedy`` episode from rest (None: none was run)."""

    wall_seconds: float
    interrupted: bool = False
    greedy: Episode | None = None


def run_record(
    config: TrainConfig,
    seed: int,
    history: History,
    outcome: Outcome,
    *,
    env: str | None = None,
    **extra: Any,
) -> dict[str, Any]:
    """The ``run.json`` of one run: ``steps`` counts the learning decisions, ``decisions_total``
    adds the greedy episode from rest; ``env``: the name of a user's env; ``extra``: a
    population's or lockstep's."""
    interrupted, greedy = outcome.interrupted, outcome.greedy
    record: dict[str, Any] = {
        "config": config.to_dict(),
        "seed": seed,
        "versions": versions(),
        "episodes_done": len(history),
        "steps": history.steps,
        "interrupted": interrupted,
        **({} if env is None else {"env": env}),
        "wall_seconds": outcome.wall_seconds,
        **history.to_dict(),
        "decisions_total": history.steps + (0 if greedy is None else greedy.length),
    }
    if greedy is not None:
        record["greedy_from_rest"] = greedy_result(greedy)
    return record | extra


def recent_score(record: dict[str, Any]) -> float:
    """Median score of the last 20 training episodes of the learner a run keeps, by its task."""
    pop = record.get("population")
    if pop is not None:
        return float(pop["scores"][pop["kept"]])
    score = get_task(TrainConfig.from_dict(record["config"]).task).score
    return recent_median(score.values(record))


def seed_dir(out: Path, seed: int) -> Path:
    return out / f"seed_{seed}"


def resumable(run_dir: Path) -> bool:
    """Whether a run directory holds a checkpoint to resume: its own, or a population learner's."""
    return (run_dir / CHECKPOINT_FILE).exists() or any(run_dir.glob(f"learner_*/{CHECKPOINT_FILE}"))


def learner_dir(out: Path, k: int) -> Path:
    return out / f"learner_{k}"


def check_fresh(out: Path) -> None:
    """Refuse to write a new run over an existing one."""
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"{out} is a file, not a run directory")
    names = (RUN_FILE, CHECKPOINT_FILE, SUMMARY_FILE, learner_dir(Path(), 0).name)
    taken = [name for name in names if (out / name).exists()]
    if taken:
        raise FileExistsError(
            f"{out} already holds a run ({', '.join(taken)}): resume it, "
            "choose another directory, or overwrite it on purpose"
        )
    # Files a run writes, found where no run is: someone's own, which training would replace.
    others = [name for name in RUN_RECORDS if (out / name).exists()]
    if others:
        raise FileExistsError(
            f"{out} holds {', '.join(others)} but no run, which training "
            "would replace: choose another directory, or overwrite on "
            "purpose"
        )


def read_record(path: Path, what: str = "record") -> dict[str, Any]:
    """The JSON object at ``path``, or one line naming the file and what is wrong with it
    (``what``: what it should be)."""
    try:
        record = read_json(path)
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a readable {what}: {error}") from None
    if not isinstance(record, dict):
        raise ValueError(f"{path} is not a {what}: a JSON object was expected")
    return record


def read_kind(run_dir: Path, kind: str, what: str) -> dict[str, Any]:
    """``run_dir``'s ``run.json``, refused unless it records a run of ``kind`` (``what``: its
    name in the error)."""
    path = Path(run_dir) / RUN_FILE
    record = read_record(path, "run record")
    if record.get("kind") != kind:
        raise ValueError(f"{path} is not a {what} run (kind {kind!r})")
    return record


def write_run(out: Path, record: dict[str, Any], label: str, curve: bool = True) -> None:
    """A finished run's ``run.json`` and (``curve``) learning curve (``label``: which run)."""
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / RUN_FILE, record)
    if curve:
        config = TrainConfig.from_dict(record["config"])
        plot_learning_curves(out / CURVE_FILE, config, [record], label)


def plot_learning_curves(path: Path, config: TrainConfig, records: list[dict], label: str) -> None:
    """The task's score per training episode: one run's, or several runs' median and quartiles."""
    task = get_task(config.task)
    runs = [task.score.values(r) for r in records if r["episode_lengths"]]
    if not runs:
        return
    reference = task.reference(config.frame_skip)
    learning_curve(
        path,
        runs,
        f"{config.algorithm} ({config.features}), {label}",
        [reference] if reference else [],
        ylabel=task.score.label,
        log_y=task.score.log_scale,
    )
