"""Swing-ups planned offline, stored compactly (:class:`PlanSet`: each plan's start and held
torques, its states rolled out on the model at load), for a
:class:`~acrobot_mj.control.tracker.PlanTracker` to enter: a trajectory library (Atkeson and
Stolle). The set is grown by planning (:class:`~acrobot_mj.control.replan.Planner`) from the
states the tracker could not enter, offline (``scripts/grow_plans.py``)."""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.files import write_atomic
from acrobot_mj.physics import integrators
from acrobot_mj.physics.params import AcrobotParams


@dataclass(frozen=True)
class PlanSet:
    """Plans from ``starts`` (M, 4) [rad, rad/s], plan ``i`` holding each of ``held[i]``
    (M, D) [N m] for ``hold`` physics steps; the states are not stored but rolled out on the
    model at load (:meth:`plans`)."""

    starts: np.ndarray
    held: np.ndarray
    hold: int

    def __post_init__(self) -> None:
        starts, held = np.asarray(self.starts, float), np.asarray(self.held, float)
        if starts.ndim != 2 or starts.shape[1:] != (4,) or held.shape[:1] != starts.shape[:1]:
            raise ValueError(
                f"a plan set needs starts (M, 4) and held torques (M, D), got {starts.shape} "
                f"and {held.shape}"
            )
        if held.ndim != 2 or not (np.isfinite(starts).all() and np.isfinite(held).all()):
            raise ValueError("a plan set's held torques must be (M, D) finite numbers")
        if self.hold < 1:
            raise ValueError(f"hold must be at least 1 step, got {self.hold}")

    def __len__(self) -> int:
        return len(self.starts)

    def plans(self, params: AcrobotParams, method: str) -> list[Trajectory]:
        """Each plan rolled out on ``params`` by ``method`` (one physics step a torque); a
        torque past the model's limit is a set for another model: ValueError."""
        if len(self) == 0:
            return []
        if np.abs(self.held).max() > params.max_torque + 1e-12:
            raise ValueError(f"a plan's torque exceeds the model's {params.max_torque} N m")
        torques = np.repeat(self.held, self.hold, axis=1)  # (M, T)
        states = integrators.simulate(self.starts, torques.T, method, params)  # (T + 1, M, 4)
        return [
            Trajectory(states[:, i], torques[i], params.dt, method, params.max_torque, params)
            for i in range(len(self))
        ]

    def with_plan(self, plan: Trajectory) -> PlanSet:
        """This set and ``plan`` (its torques held ``hold`` steps each)."""
        held = plan.torques[:: self.hold]
        if not np.array_equal(np.repeat(held, self.hold), plan.torques):
            raise ValueError(f"the plan does not hold its torques {self.hold} steps each")
        starts = np.vstack([self.starts.reshape(-1, 4), plan.states[0]])
        if len(self):
            held = np.vstack([self.held, held])
        return PlanSet(starts, np.atleast_2d(held), self.hold)

    def save(self, path: Path) -> None:
        """Write the set to ``path`` (.npz), atomically."""
        starts, held, hold = self.starts, self.held, np.asarray(self.hold)
        write_atomic(path, lambda f: np.savez_compressed(f, starts=starts, held=held, hold=hold))

    @classmethod
    def load(cls, path: Path) -> PlanSet:
        """The set at ``path``; a missing or corrupt file: ValueError in one line."""
        try:
            with np.load(path) as data:
                return cls(data["starts"], data["held"], int(data["hold"]))
        except FileNotFoundError:
            raise ValueError(f"no plan set at {path}") from None
        except (OSError, KeyError, ValueError, TypeError, zipfile.BadZipFile) as error:
            message = str(error).splitlines()[0] if str(error) else type(error).__name__
            raise ValueError(f"the plan set {path} is unreadable: {message}") from None


def warm_torques(plan: Trajectory, hold: int, decisions: int) -> np.ndarray:
    """``plan``'s held torques (``decisions``,) [N m] from its start, padded with zeros:
    a warm start for a plan from a state near it."""
    held = plan.torques[::hold][:decisions]
    return np.concatenate([held, np.zeros(decisions - len(held))])
