"""A run directory and its records: ``run.json`` (:func:`run_record`), ``checkpoint.npz``
(``.npz``, no pickle, versioned, checksummed; a bad one raises :class:`CheckpointError`),
``episodes.jsonl``, ``learning_curve.png`` and ``eval.json``; ``summary.json`` and ``seed_S/``
for several seeds, ``learner_K/`` for a population. Every file is written atomically."""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import zipfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.envs.rollout import Episode
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import read_json, versions, write_atomic, write_json
from acrobot_mj.report.plots import learning_curve
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episode_log import EpisodeLog, RunLog, read_rows
from acrobot_mj.train.lock import LOCK_FILE, RunLock

RUN_FILE, EVAL_FILE, CHECKPOINT_FILE = "run.json", "eval.json", "checkpoint.npz"
CURVE_FILE, SUMMARY_FILE, EPISODE_LOG = "learning_curve.png", "summary.json", "episodes.jsonl"
TRAJECTORY_FILE = "trajectory.json"  # a balance-preset run's plan
MODEL_FILE = "model.json"  # a black-box run's learnt model and plan
#: What a run directory holds of its own: no other command's output replaces it.
RUN_RECORDS = (RUN_FILE, EVAL_FILE, CHECKPOINT_FILE, CURVE_FILE, SUMMARY_FILE, EPISODE_LOG,
               TRAJECTORY_FILE, MODEL_FILE)  # fmt: skip


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
#: Config fields a resumed run may change: they change nothing learned.
RESUME_MAY_DIFFER = ("checkpoint_every",)
#: An agent's arrays (its ``state_dict``).
StateNow = dict[str, np.ndarray]
FORMAT, VERSION = "acrobot_mj.checkpoint", 1
_RESERVED = ("format", "version", "meta", "sha256")


class CheckpointError(ValueError):
    """A checkpoint file that cannot be used, and why."""


def _digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 over every array's name, dtype, shape and bytes, in name order."""
    sha = hashlib.sha256()
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        sha.update(f"{name}|{array.dtype.str}|{array.shape}|".encode())
        sha.update(array.tobytes())
    return sha.hexdigest()


def save_checkpoint(path: str | Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> Path:
    """Write ``arrays`` and the JSON-serialisable ``meta`` to ``path`` atomically."""
    clash = sorted(set(arrays) & set(_RESERVED))
    if clash:
        raise ValueError(f"array names {clash} are reserved for the checkpoint format")
    payload: dict[str, Any] = {name: np.asarray(value) for name, value in arrays.items()}
    if any(value.dtype == object for value in payload.values()):
        raise ValueError("checkpoints hold plain numeric or string arrays only (no objects)")
    payload |= {"format": np.array(FORMAT), "version": np.array(VERSION),
                "meta": np.array(json.dumps(meta, sort_keys=True))}  # fmt: skip
    payload["sha256"] = np.array(_digest(payload))
    return write_atomic(path, lambda f: np.savez(f, **payload))


def _check_sizes(path: Path) -> None:
    """ValueError where an array of the file declares more bytes than the file holds for it
    (a hand-made header would have numpy allocate them before finding out)."""
    with zipfile.ZipFile(path) as archive:
        for member in archive.infolist():
            with archive.open(member) as f:
                version = np.lib.format.read_magic(f)
                read = {(1, 0): np.lib.format.read_array_header_1_0,
                        (2, 0): np.lib.format.read_array_header_2_0}.get(version)  # fmt: skip
                if read is None:
                    raise ValueError(f"{member.filename} is an .npy of version {version}")
                shape, _, dtype = read(f)
            declared = math.prod(shape) * dtype.itemsize
            if declared > member.file_size:
                raise ValueError(f"{member.filename} declares {declared:,} bytes of {dtype} "
                                 f"{shape}, the file holds {member.file_size:,}")  # fmt: skip


def load_checkpoint(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read and validate a checkpoint; return ``(meta, arrays)``."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint not found: {path}")
    try:
        _check_sizes(path)
        with np.load(path, allow_pickle=False) as npz:
            data = {name: npz[name] for name in npz.files}
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError, MemoryError) as error:
        why = (str(error).strip().splitlines() or [type(error).__name__])[0]  # numpy's run on
        raise CheckpointError(f"{path} is not a readable checkpoint (truncated or corrupt?): "
                              f"{why}") from error  # fmt: skip
    missing = [name for name in _RESERVED if name not in data]
    if missing:
        raise CheckpointError(f"{path} is not an acrobot_mj checkpoint: it lacks {missing}")
    if str(data["format"]) != FORMAT:
        raise CheckpointError(f"{path} has format {str(data['format'])!r}, expected {FORMAT!r}")
    version = data["version"]
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != VERSION:
        raise CheckpointError(f"{path} has format version {version.tolist()!r}; "
                              f"this acrobot_mj reads version {VERSION}")  # fmt: skip
    stored = str(data.pop("sha256"))
    if _digest(data) != stored:
        raise CheckpointError(f"{path} fails its checksum: the file was modified or damaged")
    try:
        meta = json.loads(str(data["meta"]))
    except json.JSONDecodeError as error:
        raise CheckpointError(f"{path} has an unreadable meta document: {error}") from error
    if not isinstance(meta, dict):
        raise CheckpointError(f"{path} has a meta document that is not a JSON object")
    return meta, {name: value for name, value in data.items() if name not in _RESERVED}


def spread(values: Sequence[float]) -> dict[str, float | None]:
    """Mean, standard deviation, median, quartiles and range of ``values`` (None if empty)."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return dict.fromkeys(("mean", "std", "median", "q25", "q75", "min", "max"))
    q25, q50, q75 = np.percentile(v, [25, 50, 75])
    return {"mean": float(v.mean()), "std": float(v.std()), "median": float(q50), "q25": float(q25),
            "q75": float(q75), "min": float(v.min()), "max": float(v.max())}  # fmt: skip


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


def run_record(config: TrainConfig, seed: int, history: History, wall_seconds: float, *,
               interrupted: bool = False, env: str | None = None, greedy: Episode | None = None,
               **extra: Any) -> dict[str, Any]:  # fmt: skip
    """The ``run.json`` of one run: ``steps`` counts the learning decisions, ``decisions_total``
    adds the greedy episode from rest (``greedy``); ``extra``: a population's or lockstep's."""
    record: dict[str, Any] = {
        "config": config.to_dict(), "seed": seed, "versions": versions(),
        "episodes_done": len(history), "steps": history.steps, "interrupted": interrupted,
        **({} if env is None else {"env": env}), "wall_seconds": wall_seconds, **history.to_dict(),
        "decisions_total": history.steps + (0 if greedy is None else greedy.length),
    }  # fmt: skip
    if greedy is not None:
        record["greedy_from_rest"] = greedy_result(greedy)
    return record | extra


def checkpoint_meta(config: TrainConfig, seed: int, episodes: int, steps: int) -> dict[str, Any]:
    """A checkpoint's JSON document: with the arrays and the episode log's first lines, a resume."""
    return {"config": config.to_dict(), "seed": seed, "episodes_done": episodes, "steps": steps,
            "episode_log": EPISODE_LOG, "agent": config.algorithm}  # fmt: skip


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
        raise FileExistsError(f"{out} already holds a run ({', '.join(taken)}): resume it, "
                              "choose another directory, or overwrite it on purpose")  # fmt: skip
    # Files a run writes, found where no run is: someone's own, which training would replace.
    others = [name for name in RUN_RECORDS if (out / name).exists()]
    if others:
        raise FileExistsError(f"{out} holds {', '.join(others)} but no run, which training "
                              "would replace: choose another directory, or overwrite on "
                              "purpose")  # fmt: skip


def read_checkpoint(path: Path) -> tuple[dict[str, Any], StateNow, TrainConfig]:
    """A training checkpoint's meta (schema checked), arrays and config."""
    meta, arrays = load_checkpoint(path)
    kinds = {"config": dict, "seed": int, "episodes_done": int, "steps": int}
    wrong = [key for key, kind in kinds.items() if not isinstance(meta.get(key), kind)]
    wrong += [key for key in ("seed", "episodes_done", "steps")
              if key not in wrong and meta[key] < 0]  # fmt: skip
    if "history" in meta:  # written before the episode log: the episodes in the meta
        history = meta["history"]
        ok = isinstance(history, dict) and sorted(history) == sorted(HISTORY_KEYS)
        if not (ok and all(len(v) == meta.get("episodes_done") for v in history.values())):
            wrong.append("history")
    elif meta.get("episode_log") != EPISODE_LOG:
        wrong.append("episode_log")
    if wrong:
        raise CheckpointError(f"{path} is not a training checkpoint: bad or missing {wrong}")
    try:
        config = TrainConfig.from_dict(meta["config"])
    except (TypeError, ValueError) as error:
        raise CheckpointError(f"{path} holds an invalid config: {error}") from error
    if meta.get("agent", config.algorithm) != config.algorithm:  # older ones have none
        raise CheckpointError(f"{path} is of agent {meta['agent']!r}, its config of "
                              f"{config.algorithm!r}")  # fmt: skip
    return meta, arrays, config


def read_history(path: Path, meta: dict[str, Any]) -> History:
    """The episodes a checkpoint covers: in its meta (older ones) or the episode log beside it."""
    if "history" in meta:
        return History(**meta["history"])
    log, count = path.parent / meta["episode_log"], meta["episodes_done"]
    history = History()
    try:
        for row in read_rows(log, count):  # a line cut short by a kill is not counted
            history.add(*_episode(row))
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise CheckpointError(f"{log} cannot give the episodes of {path}: {error!r}") from None
    if len(history) != count:
        raise CheckpointError(f"{log} holds {len(history)} episodes, but {path} was saved "
                              f"after {count}")  # fmt: skip
    if history.steps != meta["steps"]:  # an episode's length edited
        raise CheckpointError(f"{log}'s episodes take {history.steps} decisions, but {path} "
                              f"was saved after {meta['steps']}")  # fmt: skip
    return history


def _episode(row: dict[str, Any]) -> tuple[int, float, bool]:
    """A log line's ``(length, return, success)``, each of its own type (a hand edit is not)."""
    length, total, success = row["length"], row["return"], row["success"]
    if type(length) is not int or length < 1:
        raise ValueError(f"length {length!r} is not a whole number of decisions >= 1")
    if type(total) not in (int, float) or not np.isfinite(total):
        raise ValueError(f"return {total!r} is not a finite number")
    if type(success) is not bool:
        raise ValueError(f"success {success!r} is not true or false")
    return length, float(total), success


def _differs(mine: dict[str, Any], theirs: dict[str, Any]) -> list[str]:
    return sorted(k for k, v in theirs.items() if v != mine[k])


def check_same_run(path: Path, meta: dict, saved: TrainConfig, config: TrainConfig, seed: int,
                   may_differ: tuple[str, ...] = ()) -> None:  # fmt: skip
    """Refuse a checkpoint written with another config (but ``may_differ``) or seed."""
    differs = [k for k in _differs(config.to_dict(), saved.to_dict()) if k not in may_differ]
    if differs:
        raise CheckpointError(f"{path} was written with a different config ({differs})")
    if meta["seed"] != seed:
        raise CheckpointError(f"{path} was written for seed {meta['seed']}, not {seed}")


def read_for_resume(path: Path, config: TrainConfig, seed: int) -> tuple[History, StateNow]:
    """The history and arrays of a checkpoint that ``config`` and ``seed`` may continue."""
    meta, arrays, saved = read_checkpoint(path)
    check_same_run(path, meta, saved, config, seed, ("episodes", *RESUME_MAY_DIFFER))
    history = read_history(path, meta)
    if config.episodes < meta["episodes_done"]:
        raise CheckpointError(f"{path} already holds {meta['episodes_done']} episodes; resume "
                              f"needs episodes >= that, got {config.episodes}")  # fmt: skip
    if config.noise_until and config.episodes != saved.episodes:
        raise CheckpointError(f"{path}: the start-noise schedule depends on episodes "
                              f"({saved.episodes}), so resume cannot change it")  # fmt: skip
    return history, arrays


def load_into(load: Callable[[StateNow], None], arrays: StateNow, path: Path) -> None:
    """Give an agent (``load``: its ``load_state_dict``) a checkpoint's arrays, or refuse."""
    try:
        load(arrays)
    except (KeyError, ValueError, TypeError, IndexError) as error:
        raise CheckpointError(f"{path} does not fit its agent: {error!r}") from error


def read_kind(run_dir: Path, kind: str, what: str) -> dict[str, Any]:
    """``run_dir``'s ``run.json``, refused unless it records a run of ``kind`` (``what``: its
    name in the error)."""
    path = Path(run_dir) / RUN_FILE
    try:
        record = read_json(path)
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a readable run record: {error}") from None
    if not isinstance(record, dict) or record.get("kind") != kind:
        raise ValueError(f"{path} is not a {what} run (kind {kind!r})")
    return record


def check_record_agrees(run_dir: Path, config: TrainConfig, seed: int) -> None:
    """Refuse a checkpoint that is not the run ``run.json`` records (if there is one)."""
    run_file, path = run_dir / RUN_FILE, run_dir / CHECKPOINT_FILE
    if not run_file.exists() and not run_file.is_symlink():  # a link that leads nowhere is read
        return
    try:
        record = read_json(run_file)
        recorded, recorded_seed = TrainConfig.from_dict(record["config"]), record["seed"]
    except (OSError, ValueError, TypeError, KeyError) as error:
        raise CheckpointError(f"{run_file} is not a readable run record: {error!r}") from None
    if type(recorded_seed) is not int or recorded_seed != seed:
        raise CheckpointError(f"{path} is for seed {seed!r} but {run_file} records seed "
                              f"{recorded_seed!r}")  # fmt: skip
    done, lengths = record.get("episodes_done"), record.get("episode_lengths")
    wrong = [key for key, ok in (
        ("interrupted", type(record.get("interrupted", False)) is bool),
        ("episodes_done", type(done) is int and done >= 0),
        ("episode_lengths", isinstance(lengths, list) and len(lengths) == done
         and all(type(n) is int and n >= 0 for n in lengths)),
    ) if not ok]  # fmt: skip
    if wrong:
        raise CheckpointError(f"{run_file} is not a run record as train writes it: bad {wrong}")
    mine, theirs = config.to_dict(), recorded.to_dict()
    differs = _differs(mine, theirs)
    if differs:
        both = ", ".join(f"{k}: {mine[k]!r} vs {theirs[k]!r}" for k in differs)
        raise CheckpointError(f"{path} and {run_file} disagree on the config ({both})")


class Checkpoints:
    """A learner's checkpoint (None: none) and episode log (``tee``: its population's), holding
    the state after its last completed episode, so a run stopped mid-episode resumes exactly."""

    def __init__(self, path: Path | None, config: TrainConfig, seed: int,
                 learner: int | None = None, tee: RunLog | None = None) -> None:  # fmt: skip
        self.path, self.config, self.seed = path, config, seed
        self.log = None if path is None else EpisodeLog(path.parent / EPISODE_LOG, learner, tee)
        self._state: tuple[Any, int, int] | None = None
        self._logged = 0

    def start(self, history: History) -> None:
        """Begin at ``history``: the log keeps exactly its episodes."""
        if self.log is not None:
            self.log.start(history)
            self._logged = len(history)

    def snapshot(self, state: Callable[[], Any], history: History) -> None:
        """Log the episodes ``history`` gained, and keep ``state()`` (called only if there is a
        file to write; a ``Rewinding`` agent's may return a function giving the arrays)."""
        if self.log is None:
            return
        h = history
        for k in range(self._logged, len(h)):
            self.log.append(k, h.episode_lengths[k], h.episode_returns[k], h.episode_successes[k])
        self._logged = len(h)
        self._state = (state(), len(h), h.steps)

    def save(self) -> None:
        """Sync the log, then write the checkpoint (atomically) that counts its lines."""
        if self.path is None or self.log is None or self._state is None:  # log: None w/o path
            return
        arrays, episodes, steps = self._state
        if callable(arrays):
            arrays = arrays()
        self.log.sync()
        save_checkpoint(self.path, arrays, checkpoint_meta(self.config, self.seed, episodes, steps))

    def close(self) -> None:
        if self.log is not None:
            self.log.close()


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
    learning_curve(path, runs, f"{config.algorithm} ({config.features}), {label}",
                   [reference] if reference else [], ylabel=task.score.label,
                   log_y=task.score.log_scale)  # fmt: skip
