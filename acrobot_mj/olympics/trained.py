"""A trained run directory as the controller the protocol scores: the state feedback of
``acrobot-mj balance --feedback`` (kind ``state_feedback``) or the black box of ``acrobot-mj
train --preset black_box`` (kind ``black_box``), on the model it was trained on. Names in
:data:`~acrobot_mj.olympics.entries.ENTRIES` stay entries; anything else is a run directory.
:func:`check` and :func:`build` are what :mod:`acrobot_mj.olympics.run` calls for both."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.olympics import entries
from acrobot_mj.physics.models import resolve
from acrobot_mj.train.records import RUN_FILE, read_record

#: The run kinds that are controllers (each acts on the observation, angles wrapped).
CONTROLLER_KINDS = ("state_feedback", "black_box")
_BUILT: dict[tuple[str, str], Any] = {}


def trained_model(record: dict[str, Any]) -> str:
    """The model a controller run was trained on: its config's ``model`` (the black box's
    ``--model``), else the report's (the state feedback trains on the default acrobot only)."""
    config = record.get("config")
    name = config.get("model") if isinstance(config, dict) else None
    return "report" if name is None else str(name)


def _record(run_dir: str) -> dict[str, Any]:
    path = Path(run_dir)
    if not path.is_dir():
        raise ValueError(
            f"controller {run_dir!r} is neither an entry {list(entries.ENTRIES)} nor a run folder"
        )
    record = read_record(path / RUN_FILE, "trained run")
    kind = record.get("kind")
    if kind not in CONTROLLER_KINDS:
        raise ValueError(
            f"{run_dir} is a run of kind {kind!r}, not a controller run "
            f"(one of {list(CONTROLLER_KINDS)})"
        )
    return record


def check(entry: str, model: str) -> None:
    """Refuse, in one line, an unknown entry, a folder that is not a controller run, or a run
    trained on another model than ``model``."""
    if entry in entries.ENTRIES:
        entries.check(entry, model)
        return
    record = _record(entry)
    trained = trained_model(record)
    if resolve(trained) != resolve(model):
        raise ValueError(f"{entry} was trained on the model {trained!r}, not {model!r}")


class RunController:
    """A run's state feedback as an entry: ``reset()`` starts a fresh copy; ``controller(obs)``
    is the elbow torque [N m] within the model's limit, the feedback told each torque. A run
    that decides every ``every`` physics steps (the black box on RealAIGym's acrobot: 0.01 s)
    is asked every ``every`` calls, its torque held in between."""

    def __init__(self, feedback: Any, limit: float, every: int = 1) -> None:
        self.feedback, self.limit, self.every = feedback, limit, every
        self.reset()

    def reset(self) -> None:
        """A new episode: a fresh copy of the feedback, with no memory."""
        self.current, self.calls, self.held = self.feedback.fresh(), 0, 0.0

    def __call__(self, obs: np.ndarray) -> float:
        if self.calls % self.every == 0:
            u = self.current(np.asarray(obs, dtype=float))
            self.held = float(np.clip(u, -self.limit, self.limit))
            self.current.record(self.held)
        self.calls += 1
        return self.held


def _build(run_dir: str, model: str) -> RunController:
    from acrobot_mj.train.trainer import load_learner

    learner: Any = load_learner(run_dir)
    feedback = learner.feedback() if hasattr(learner, "feedback") else learner.controller
    params = resolve(model).params
    decision = learner.trajectory.dt if hasattr(learner, "trajectory") else params.dt
    return RunController(feedback, params.max_torque, max(1, round(decision / params.dt)))


def build(entry: str, model: str) -> Any:
    """A fresh controller for ``entry`` (an entry's name or a run folder) on ``model``:
    ``reset()`` and ``controller(obs) -> elbow torque`` [N m]."""
    if entry in entries.ENTRIES:
        return entries.build(entry, model)
    key = (entry, model)
    if key not in _BUILT:
        check(entry, model)
        _BUILT[key] = _build(entry, model)
    return copy.deepcopy(_BUILT[key])
