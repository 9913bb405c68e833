"""A sweep's trials on disk: where each lives, whether it finished, and running one.

A trial counts as finished only when its ``run.json`` is readable, belongs to this sweep, and
says it completed all its episodes; any other trial runs (again), from its checkpoint when it
has one, and :func:`trial_state` says why.
"""

from __future__ import annotations

import json
import tempfile
import traceback
from pathlib import Path
from typing import Any

from acrobot_mj.files import write_json
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import evaluate_run
from acrobot_mj.train.heldout import DEFAULT
from acrobot_mj.train.rundir import CHECKPOINT_FILE, EVAL_FILE, RUN_FILE
from acrobot_mj.train.sweep_spec import Trial
from acrobot_mj.train.trainer import train

ERROR_FILE = "error.json"


def trial_dir(out: Path, trial: Trial) -> Path:
    """The run directory of ``trial`` in sweep directory ``out``."""
    return out / "trials" / trial.name


def complete(record: dict[str, Any], config: TrainConfig) -> bool:
    """Whether a run record says its run spent its whole budget (``config.finished``)."""
    return (
        record.get("interrupted") is False
        and config.finished(record)
        and isinstance(record.get("greedy_from_rest"), dict)
    )


def trial_state(out: Path, trial: Trial) -> tuple[dict[str, Any] | None, str]:
    """``(record, "")`` for a finished trial, else ``(None, why it must run)``; a record of
    another sweep's trial raises (this sweep would overwrite it)."""
    path = trial_dir(out, trial) / RUN_FILE
    if not path.exists():
        return None, "not run yet"
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        return None, f"its record {path} is unreadable ({error})"
    if not isinstance(record, dict) or not isinstance(record.get("config"), dict):
        return None, f"its record {path} is not a run record"
    try:
        config = TrainConfig.from_dict(record["config"])
    except (TypeError, ValueError) as error:
        return None, f"its record {path} holds no valid config ({error})"
    if config != trial.config or record.get("seed") != trial.seed:
        raise ValueError(
            f"{path} holds another sweep's trial (a different config or seed): "
            "give this sweep its own --out"
        )
    if not complete(record, trial.config):
        done = record.get("episodes_done")
        return None, f"its record says it stopped after {done} of {trial.config.episodes} episodes"
    return record, ""


def train_or_error(config: dict[str, Any], seed: int, run_dir: str | None) -> dict[str, Any]:
    """Train one trial (into its run directory if given, resuming from a checkpoint there), or
    describe its error. Ctrl-C (or the driver's stop) propagates: the run saved what it had."""
    try:
        resume = run_dir is not None and (Path(run_dir) / CHECKPOINT_FILE).exists()
        return train(TrainConfig.from_dict(config), seed, run_dir, resume=resume, overwrite=True)
    except Exception as error:  # a failing trial is recorded, the others go on
        return {
            "error": f"{type(error).__name__}: {error}",
            "traceback": traceback.format_exc(),
            "seed": seed,
            "config": config,
        }


def run_trial(config: dict[str, Any], seed: int, run_dir: str) -> dict[str, Any]:
    """One trial in this process: its files and its held-out evaluation, or ``error.json``."""
    record = train_or_error(config, seed, run_dir)
    if "error" in record:
        write_json(Path(run_dir) / ERROR_FILE, record)
    else:
        (Path(run_dir) / ERROR_FILE).unlink(missing_ok=True)
        evaluate_run(run_dir)
    return record


def train_elsewhere(config: dict[str, Any], seed: int) -> tuple[dict[str, Any], dict | None]:
    """One trial in a temporary directory of this (remote) process: its record and its
    held-out evaluation (None if it failed), for a driver without a shared file system."""
    with tempfile.TemporaryDirectory(prefix="acrobot-mj-trial-") as scratch:
        record = train_or_error(config, seed, scratch)
        return record, None if "error" in record else evaluate_run(scratch)


def trial_evaluation(out: Path, trial: Trial) -> dict[str, Any] | None:
    """A finished trial's held-out evaluation on the default protocol: its ``eval.json`` if
    that is of this trial and protocol, else evaluated now from its checkpoint (None without
    one)."""
    run_dir = trial_dir(out, trial)
    path = run_dir / EVAL_FILE
    if path.exists():
        saved = json.loads(path.read_text())
        if (
            saved.get("protocol") == DEFAULT.to_dict()
            and saved.get("run_seed") == trial.seed
            and saved.get("config") == trial.config.to_dict()
        ):
            return saved
    if not (run_dir / CHECKPOINT_FILE).exists():
        return None
    return evaluate_run(run_dir)


def run_trial_in_worker(config: dict[str, Any], seed: int, run_dir: str) -> dict[str, Any]:
    """:func:`run_trial` in a worker process: stopped by its driver, it returns (its run saved
    its checkpoint) instead of taking the worker down."""
    try:
        return run_trial(config, seed, run_dir)
    except KeyboardInterrupt:
        return {"interrupted": True, "seed": seed, "config": config}


def write_trial(
    out: Path, trial: Trial, record: dict[str, Any], evaluation: dict[str, Any] | None = None
) -> None:
    """A trial's record (or its error) and its held-out evaluation, written by the driver."""
    run = trial_dir(out, trial)
    if "error" in record:
        write_json(run / ERROR_FILE, record)
        return
    write_json(run / RUN_FILE, record)
    (run / ERROR_FILE).unlink(missing_ok=True)  # an earlier failure of this trial
    if evaluation is not None:
        write_json(run / EVAL_FILE, {**evaluation, "run": str(run)})
