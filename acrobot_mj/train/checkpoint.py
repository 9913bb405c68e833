"""A learner's checkpoint: ``checkpoint.npz`` (``.npz``, no pickle, versioned, checksummed; a
bad one raises :class:`CheckpointError`) beside its episode log, and what reads it back for a
resume. Every file is written atomically."""

from __future__ import annotations

import hashlib
import json
import math
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.files import read_json, write_atomic
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episode_log import EpisodeLog, RunLog, read_rows
from acrobot_mj.train.records import CHECKPOINT_FILE, EPISODE_LOG, HISTORY_KEYS, RUN_FILE, History

#: Config fields a resumed run may change: they change nothing learned.
RESUME_MAY_DIFFER = ("checkpoint_every",)


#: An agent's arrays (its ``state_dict``).
StateNow = dict[str, np.ndarray]


CHECKPOINT_FORMAT, VERSION = "acrobot_mj.checkpoint", 1


_RESERVED = ("format", "version", "meta", "sha256")


class CheckpointError(ValueError):
    """A checkpoint file that cannot be used, and why."""


def _array_digest(arrays: dict[str, np.ndarray]) -> str:
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
    payload |= {
        "format": np.array(CHECKPOINT_FORMAT),
        "version": np.array(VERSION),
        "meta": np.array(json.dumps(meta, sort_keys=True)),
    }
    payload["sha256"] = np.array(_array_digest(payload))
    return write_atomic(path, lambda f: np.savez(f, **payload))


def _check_sizes(path: Path) -> None:
    """ValueError where an array of the file declares more bytes than the file holds for it
    (a hand-made header would have numpy allocate them before finding out)."""
    with zipfile.ZipFile(path) as archive:
        for member in archive.infolist():
            with archive.open(member) as f:
                version = np.lib.format.read_magic(f)
                read = {
                    (1, 0): np.lib.format.read_array_header_1_0,
                    (2, 0): np.lib.format.read_array_header_2_0,
                }.get(version)
                if read is None:
                    raise ValueError(f"{member.filename} is an .npy of version {version}")
                shape, _, dtype = read(f)
            declared = math.prod(shape) * dtype.itemsize
            if declared > member.file_size:
                raise ValueError(
                    f"{member.filename} declares {declared:,} bytes of {dtype} "
                    f"{shape}, the file holds {member.file_size:,}"
                )


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
        raise CheckpointError(
            f"{path} is not a readable checkpoint (truncated or corrupt?): {why}"
        ) from error
    missing = [name for name in _RESERVED if name not in data]
    if missing:
        raise CheckpointError(f"{path} is not an acrobot_mj checkpoint: it lacks {missing}")
    if str(data["format"]) != CHECKPOINT_FORMAT:
        raise CheckpointError(
            f"{path} has format {str(data['format'])!r}, expected {CHECKPOINT_FORMAT!r}"
        )
    version = data["version"]
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != VERSION:
        raise CheckpointError(
            f"{path} has format version {version.tolist()!r}; "
            f"this acrobot_mj reads version {VERSION}"
        )
    stored = str(data.pop("sha256"))
    if _array_digest(data) != stored:
        raise CheckpointError(f"{path} fails its checksum: the file was modified or damaged")
    try:
        meta = json.loads(str(data["meta"]))
    except json.JSONDecodeError as error:
        raise CheckpointError(f"{path} has an unreadable meta document: {error}") from error
    if not isinstance(meta, dict):
        raise CheckpointError(f"{path} has a meta document that is not a JSON object")
    return meta, {name: value for name, value in data.items() if name not in _RESERVED}


def checkpoint_meta(config: TrainConfig, seed: int, episodes: int, steps: int) -> dict[str, Any]:
    """A checkpoint's JSON document: with the arrays and the episode log's first lines, a resume."""
    return {
        "config": config.to_dict(),
        "seed": seed,
        "episodes_done": episodes,
        "steps": steps,
        "episode_log": EPISODE_LOG,
        "agent": config.algorithm,
    }


def read_checkpoint(path: Path) -> tuple[dict[str, Any], StateNow, TrainConfig]:
    """A training checkpoint's meta (schema checked), arrays and config."""
    meta, arrays = load_checkpoint(path)
    kinds = {"config": dict, "seed": int, "episodes_done": int, "steps": int, "agent": str}
    wrong = [key for key, kind in kinds.items() if not isinstance(meta.get(key), kind)]
    wrong += [
        key for key in ("seed", "episodes_done", "steps") if key not in wrong and meta[key] < 0
    ]
    if "history" in meta:  # written by 0.1.0, before the episode log: the golden runs' form
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
    if meta["agent"] != config.algorithm:
        raise CheckpointError(
            f"{path} is of agent {meta['agent']!r}, its config of {config.algorithm!r}"
        )
    return meta, arrays, config


def read_history(path: Path, meta: dict[str, Any]) -> History:
    """The episodes a checkpoint covers: in its meta (0.1.0) or the episode log beside it."""
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
        raise CheckpointError(
            f"{log} holds {len(history)} episodes, but {path} was saved after {count}"
        )
    if history.steps != meta["steps"]:  # an episode's length edited
        raise CheckpointError(
            f"{log}'s episodes take {history.steps} decisions, but {path} "
            f"was saved after {meta['steps']}"
        )
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


def check_same_run(
    path: Path,
    meta: dict,
    saved: TrainConfig,
    config: TrainConfig,
    seed: int,
    may_differ: tuple[str, ...] = (),
) -> None:
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


def load_into(load: Callable[[StateNow], None], arrays: StateNow, path: Path) -> None:
    """Give an agent (``load``: its ``load_state_dict``) a checkpoint's arrays, or refuse."""
    try:
        load(arrays)
    except (KeyError, ValueError, TypeError, IndexError) as error:
        raise CheckpointError(f"{path} does not fit its agent: {error!r}") from error


class Checkpoints:
    """A learner's checkpoint (None: none) and episode log (``tee``: its population's), holding
    the state after its last completed episode, so a run stopped mid-episode resumes exactly."""

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
        raise CheckpointError(
            f"{path} is for seed {seed!r} but {run_file} records seed {recorded_seed!r}"
        )
    done, lengths = record.get("episodes_done"), record.get("episode_lengths")
    wrong = [
        key
        for key, ok in (
            ("interrupted", type(record.get("interrupted", False)) is bool),
            ("episodes_done", type(done) is int and done >= 0),
            (
                "episode_lengths",
                isinstance(lengths, list)
                and len(lengths) == done
                and all(type(n) is int and n >= 0 for n in lengths),
            ),
        )
        if not ok
    ]
    if wrong:
        raise CheckpointError(f"{run_file} is not a run record as train writes it: bad {wrong}")
    mine, theirs = config.to_dict(), recorded.to_dict()
    differs = _differs(mine, theirs)
    if differs:
        both = ", ".join(f"{k}: {mine[k]!r} vs {theirs[k]!r}" for k in differs)
        raise CheckpointError(f"{path} and {run_file} disagree on the config ({both})")
