"""Run directories: their files, the check that a new run does not overwrite an old one, and
reading a run's checkpoint back (for resume, evaluation and videos), refusing any that does not
belong to the run asked for.

A run directory holds ``run.json`` (:mod:`.records`), ``checkpoint.npz`` (:mod:`.checkpoint`),
``episodes.jsonl`` (one line per training episode, written as it ends: the checkpoint says
how many lines are its own; :mod:`.episode_log`), ``learning_curve.png`` and, after evaluation,
``eval.json``; a run of several seeds holds ``summary.json`` and one ``seed_S/`` run directory
per seed; a population run holds ``learner_K/`` directories besides its own files.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.agents.protocol import Agent
from acrobot_mj.agents.registry import make_agent
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import write_json
from acrobot_mj.report.plots import learning_curve
from acrobot_mj.train.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episode_log import EpisodeLog, RunLog, read_rows
from acrobot_mj.train.records import HISTORY_KEYS, History, checkpoint_meta

#: An agent's arrays (its ``state_dict``).
StateNow = dict[str, np.ndarray]

RUN_FILE, EVAL_FILE, CHECKPOINT_FILE, CURVE_FILE, SUMMARY_FILE, EPISODE_LOG = (
    "run.json",
    "eval.json",
    "checkpoint.npz",
    "learning_curve.png",
    "summary.json",
    "episodes.jsonl",
)


def seed_dir(out: Path, seed: int) -> Path:
    """The run directory of ``seed`` in a run of several seeds."""
    return out / f"seed_{seed}"


def learner_dir(out: Path, k: int) -> Path:
    """The run directory of learner ``k`` in a population run."""
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


def read_checkpoint(path: Path) -> tuple[dict[str, Any], dict[str, np.ndarray], TrainConfig]:
    """A training checkpoint's meta (schema checked), arrays and config."""
    meta, arrays = load_checkpoint(path)
    kinds = {"config": dict, "seed": int, "episodes_done": int, "steps": int}
    wrong = [key for key, kind in kinds.items() if not isinstance(meta.get(key), kind)]
    if "history" in meta:  # written before the episode log: the episodes in the meta
        history = meta["history"]
        if not (
            isinstance(history, dict)
            and sorted(history) == sorted(HISTORY_KEYS)
            and all(len(v) == meta.get("episodes_done") for v in history.values())
        ):
            wrong.append("history")
    elif meta.get("episode_log") != EPISODE_LOG:
        wrong.append("episode_log")
    if wrong:
        raise CheckpointError(f"{path} is not a training checkpoint: bad or missing {wrong}")
    try:
        config = TrainConfig.from_dict(meta["config"])
    except (TypeError, ValueError) as error:
        raise CheckpointError(f"{path} holds an invalid config: {error}") from error
    return meta, arrays, config


def read_history(path: Path, meta: dict[str, Any]) -> History:
    """The episodes a checkpoint covers: from its meta (older checkpoints) or the first
    ``episodes_done`` lines of the episode log beside it."""
    if "history" in meta:
        return History(**meta["history"])
    log, count = path.parent / meta["episode_log"], meta["episodes_done"]
    history = History()
    try:
        for row in read_rows(log, count):  # a line cut short by a kill is not counted
            history.add(int(row["length"]), float(row["return"]), bool(row["success"]))
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise CheckpointError(f"{log} cannot give the episodes of {path}: {error!r}") from None
    if len(history) != count:
        raise CheckpointError(
            f"{log} holds {len(history)} episodes, but {path} was saved after {count}"
        )
    return history


def load_into(
    load: Callable[[dict[str, np.ndarray]], None], arrays: dict[str, np.ndarray], path: Path
) -> None:
    """Give an agent a checkpoint's arrays (``load``: its ``load_state_dict``), or say the
    checkpoint does not fit it."""
    try:
        load(arrays)
    except (KeyError, ValueError, TypeError, IndexError) as error:
        raise CheckpointError(f"{path} does not fit its agent: {error!r}") from error


#: Config fields a resumed run may change: they change nothing learned.
RESUME_MAY_DIFFER = ("checkpoint_every",)


def check_same_run(
    path: Path,
    meta: dict[str, Any],
    saved: TrainConfig,
    config: TrainConfig,
    seed: int,
    may_differ: tuple[str, ...] = (),
) -> None:
    """Refuse a checkpoint written with another config (but ``may_differ``) or seed."""
    differs = {k for k, v in saved.to_dict().items() if v != getattr(config, k)} - set(may_differ)
    if differs:
        raise CheckpointError(f"{path} was written with a different config ({sorted(differs)})")
    if meta["seed"] != seed:
        raise CheckpointError(f"{path} was written for seed {meta['seed']}, not {seed}")


def read_for_resume(
    path: Path, config: TrainConfig, seed: int
) -> tuple[History, dict[str, np.ndarray]]:
    """The history and agent arrays of a checkpoint that ``config`` and ``seed``
    may continue (more episodes than it holds are allowed, but no change of the schedule;
    another ``checkpoint_every`` too, which changes nothing learned)."""
    meta, arrays, saved = read_checkpoint(path)
    check_same_run(path, meta, saved, config, seed, may_differ=("episodes", *RESUME_MAY_DIFFER))
    history = read_history(path, meta)
    if config.episodes < meta["episodes_done"]:
        raise CheckpointError(
            f"{path} already holds {meta['episodes_done']} episodes; resume "
            f"needs episodes >= that, got {config.episodes}"
        )
    if config.noise_until and config.episodes != saved.episodes:
        raise CheckpointError(
            f"{path}: the start-noise schedule depends on episodes "
            f"({saved.episodes}), so resume cannot change it"
        )
    return history, arrays


def load_agent(run_dir: str | Path) -> tuple[TrainConfig, int, Agent]:
    """The config, seed and trained agent of a run directory; refused if the checkpoint and the
    directory's ``run.json`` disagree on the config or the seed."""
    path = Path(run_dir) / CHECKPOINT_FILE
    if not path.exists() and (Path(run_dir) / SUMMARY_FILE).exists():
        raise FileNotFoundError(
            f"{run_dir} holds several seeds ({SUMMARY_FILE}): give one of its seed_S directories"
        )
    meta, arrays, config = read_checkpoint(path)
    _check_record_agrees(Path(run_dir) / RUN_FILE, config, meta["seed"], path)
    agent = make_agent(config, seed=meta["seed"])
    load_into(agent.load_state_dict, arrays, path)
    return config, meta["seed"], agent


def _check_record_agrees(run_file: Path, config: TrainConfig, seed: int, path: Path) -> None:
    """Refuse a checkpoint that is not the run ``run_file`` records (if there is one)."""
    if not run_file.exists():
        return
    try:
        record = json.loads(run_file.read_text())
        recorded = TrainConfig.from_dict(record["config"])
        recorded_seed = record["seed"]
    except (OSError, ValueError, TypeError, KeyError) as error:
        raise CheckpointError(f"{run_file} is not a readable run record: {error!r}") from None
    if recorded_seed != seed:
        raise CheckpointError(
            f"{path} is for seed {seed} but {run_file} records seed {recorded_seed}"
        )
    differs = sorted(k for k, v in recorded.to_dict().items() if v != getattr(config, k))
    if differs:
        both = ", ".join(
            f"{k}: {getattr(config, k)!r} vs {getattr(recorded, k)!r}" for k in differs
        )
        raise CheckpointError(f"{path} and {run_file} disagree on the config ({both})")


class Checkpoints:
    """A learner's checkpoint and episode log: the checkpoint holds the state after the
    learner's last completed episode (:meth:`snapshot`), so a run stopped in the middle of an
    episode resumes exactly (that episode is run again from its start). ``path`` None keeps
    nothing; ``learner`` is the learner's index in its log's lines (lockstep runs), ``tee``
    its population run's log, which gets each line too.

    A snapshot copies the agent's arrays, logs the episodes since the last one to
    ``episodes.jsonl`` (:class:`~acrobot_mj.train.episode_log.EpisodeLog`, flushed at once) and
    notes how long the history is; a save syncs the log, then writes the checkpoint, which
    counts its lines. So neither grows with the run: episode 10 costs what episode 10 million
    does, and a checkpoint stays the size of the agent."""

    def __init__(
        self,
        path: Path | None,
        config: TrainConfig,
        seed: int,
        learner: int | None = None,
        tee: RunLog | None = None,
    ) -> None:
        self.path, self.config, self.seed = path, config, seed
        self.log = None if path is None else EpisodeLog(path.parent / EPISODE_LOG, learner, tee)
        self._state: tuple[Any, int, int] | None = None
        self._logged = 0

    def start(self, history: History) -> None:
        """Begin at ``history``: the log keeps exactly its episodes (none for a new run; for a
        resumed one, those its checkpoint counted, and not the ones after)."""
        if self.log is not None:
            self.log.start(history)
            self._logged = len(history)

    def snapshot(
        self, state: Callable[[], StateNow | Callable[[], StateNow]], history: History
    ) -> None:
        """Log the episodes ``history`` gained, and remember the agent's arrays (``state()``,
        called only if there is a file to write, or the function it returns, called when the
        checkpoint is written: :class:`~acrobot_mj.agents.protocol.Rewinding`) and the
        progress, after a completed episode."""
        if self.log is None:
            return
        lists = history.episode_lengths, history.episode_returns, history.episode_successes
        for k in range(self._logged, len(history)):
            self.log.append(k, lists[0][k], lists[1][k], lists[2][k])
        self._logged = len(history)
        self._state = (state(), len(history), history.steps)

    def save(self) -> None:
        """Sync the log, then write the checkpoint (atomically) that counts its lines."""
        if self.log is None or self._state is None:
            return
        arrays, length, steps = self._state
        if callable(arrays):
            arrays = arrays()
        self.log.sync()
        meta = checkpoint_meta(self.config, self.seed, length, steps, EPISODE_LOG)
        save_checkpoint(self.path, arrays, meta)

    def close(self) -> None:
        """Close the log (after the last save)."""
        if self.log is not None:
            self.log.close()


def write_run(out: Path, record: dict[str, Any], label: str, curve: bool = True) -> None:
    """A finished run's ``run.json`` and (``curve``) learning curve (``label``: which run, for
    the title)."""
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / RUN_FILE, record)
    if curve:
        plot_learning_curves(
            out / CURVE_FILE, TrainConfig.from_dict(record["config"]), [record], label
        )


def plot_learning_curves(
    path: Path, config: TrainConfig, records: list[dict[str, Any]], label: str
) -> None:
    """The task's score per training episode: one run as a line, several as the median and
    the 25-75 % band (nothing is drawn for runs without episodes)."""
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
