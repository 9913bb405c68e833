"""The balance preset's settings (:mod:`acrobot_mj.train.plan`), and telling its run
directories from the other learners' (light: the command line imports it)."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from acrobot_mj.checks import check_float, check_int
from acrobot_mj.train.rundir import RUN_FILE

#: ``run.json``'s ``kind`` of a balance-preset run, and its plan's file.
KIND = "identify_and_plan"
TRAJECTORY_FILE = "trajectory.json"
#: The held-out start noise of the balance results (:mod:`acrobot_mj.train.plan_eval`):
#: ``U(-0.01, 0.01)`` on each angle and velocity around rest [rad, rad/s].
BALANCE_NOISE = 0.01


@dataclass(frozen=True)
class PlanConfig:
    """The model-based balance learner's settings (see the module docstring)."""

    identify_decisions: int = 200
    #: Half-width of the data episodes' start noise [rad, rad/s] (wide: the data should cover
    #: many states, not only hanging).
    data_noise: float = 1.0
    #: Nominal torque bound of the plan [N m]; the rest of the 1 N m is the feedback's.
    reserve: float = 0.8
    discrete: bool = False
    #: Start horizons of the search ``(start, stop, step)`` [physics steps]; None: the default
    #: of :func:`acrobot_mj.control.trajopt.default_horizons`.
    horizons: tuple[int, int, int] | None = None
    #: Which upright targets the search tries (indices into
    #: :data:`acrobot_mj.control.trajopt.TARGETS`, six poses); None: all.
    targets: tuple[int, ...] | None = None
    #: Seconds of balance asked for after the swing-up.
    hold: float = 60.0

    def __post_init__(self) -> None:
        check_int("identify_decisions", self.identify_decisions, 3)
        check_float("data_noise", self.data_noise, 0.0, 1.0)
        check_float("reserve", self.reserve, 0.0, 1.0)
        if not self.reserve > 0:
            raise ValueError("reserve must be > 0 N m (the plan's torque bound)")
        if not isinstance(self.discrete, bool):
            raise TypeError(f"discrete must be True or False, got {self.discrete!r}")
        check_float("hold", self.hold, 0.05, 3600.0)
        if self.horizons is not None:
            h = tuple(self.horizons)
            if len(h) != 3 or not all(isinstance(v, int) and v > 0 for v in h) or h[1] <= h[0]:
                raise ValueError(f"horizons must be (start, stop, step) steps > 0, got {h!r}")
            object.__setattr__(self, "horizons", h)
        if self.targets is not None:
            t = tuple(self.targets)
            if not t or not all(isinstance(v, int) and 0 <= v < 6 for v in t):
                raise ValueError(f"targets must be indices 0-5 of the six upright poses, got {t!r}")
            object.__setattr__(self, "targets", t)

    def search_horizons(self) -> range | None:
        return None if self.horizons is None else range(*self.horizons)

    def replace(self, **overrides: Any) -> PlanConfig:
        unknown = sorted(set(overrides) - {f.name for f in dataclasses.fields(self)})
        if unknown:
            names = [f.name for f in dataclasses.fields(self)]
            raise ValueError(f"unknown balance-preset settings {unknown}; known: {names}")
        return dataclasses.replace(self, **overrides)

    def to_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        for name in ("horizons", "targets"):
            data[name] = None if data[name] is None else list(data[name])
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PlanConfig:
        data = dict(data)
        for name in ("horizons", "targets"):
            if data.get(name) is not None:
                data[name] = tuple(data[name])
        return cls().replace(**data)


#: The presets of this learner (the command line's ``--preset balance``).
PLANNERS: dict[str, PlanConfig] = {"balance": PlanConfig()}


def read_plan_record(run_dir: Path) -> dict[str, Any]:
    """``run.json`` of a balance run (anything else is refused, naming what it is)."""
    path = run_dir / RUN_FILE
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a readable run record: {error}") from None
    if not isinstance(record, dict) or record.get("kind") != KIND:
        raise ValueError(f"{path} is not a balance-preset run (kind {KIND!r})")
    return record


def is_plan_run(run_dir: str | Path) -> bool:
    """Whether ``run_dir`` holds a balance-preset run (its ``run.json`` says so)."""
    try:
        read_plan_record(Path(run_dir))
    except ValueError:
        return False
    return True
