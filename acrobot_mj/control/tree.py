"""A library of swing-ups planned offline (:class:`Library`: each plan's start and held
torques, its states regenerated on the model at load) and a controller that follows them with
TVLQR and no optimisation at run time (:class:`TreeController`): a trajectory library
(Atkeson and Stolle) entered by the LQR-tree's test of Tedrake's, ``e' S e`` below a level. The
library is grown by planning (:class:`~acrobot_mj.control.replan.Planner`) from the states the
controller could not enter (``TreeController.grow``), offline."""

from __future__ import annotations

import copy
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.checks import check_state
from acrobot_mj.compiled import compiled
from acrobot_mj.control.feedback import FunnelController
from acrobot_mj.control.lqr import tvlqr, tvlqr_torque
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.files import write_atomic
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import UPRIGHT, state_error
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.physics.xp import wrap_angle

#: What a planner for ``TreeController.grow`` is: a state (4,) and the index of the
#: library's plan nearest it (or None) to a new plan from that state, or None.
Grow = Callable[[np.ndarray, "int | None"], "Trajectory | None"]


@dataclass(frozen=True)
class Library:
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
                f"a library needs starts (M, 4) and held torques (M, D), got {starts.shape} "
                f"and {held.shape}"
            )
        if held.ndim != 2 or not (np.isfinite(starts).all() and np.isfinite(held).all()):
            raise ValueError("a library's held torques must be (M, D) finite numbers")
        if self.hold < 1:
            raise ValueError(f"hold must be at least 1 step, got {self.hold}")

    def __len__(self) -> int:
        return len(self.starts)

    def plans(self, params: AcrobotParams, method: str) -> list[Trajectory]:
        """Each plan rolled out on ``params`` by ``method`` (one physics step a torque); a
        torque past the model's limit is a library for another model: ValueError."""
        if len(self) == 0:
            return []
        if np.abs(self.held).max() > params.max_torque + 1e-12:
            raise ValueError(f"a library torque exceeds the model's {params.max_torque} N m")
        torques = np.repeat(self.held, self.hold, axis=1)  # (M, T)
        states = integrators.simulate(self.starts, torques.T, method, params)  # (T + 1, M, 4)
        return [
            Trajectory(states[:, i], torques[i], params.dt, method, params.max_torque, params)
            for i in range(len(self))
        ]

    def with_plan(self, plan: Trajectory) -> Library:
        """This library and ``plan`` (its torques held ``hold`` steps each)."""
        held = plan.torques[:: self.hold]
        if not np.array_equal(np.repeat(held, self.hold), plan.torques):
            raise ValueError(f"the plan does not hold its torques {self.hold} steps each")
        starts = np.vstack([self.starts.reshape(-1, 4), plan.states[0]])
        if len(self):
            held = np.vstack([self.held, held])
        return Library(starts, np.atleast_2d(held), self.hold)

    def save(self, path: Path) -> None:
        """Write the library to ``path`` (.npz), atomically."""
        starts, held, hold = self.starts, self.held, np.asarray(self.hold)
        write_atomic(path, lambda f: np.savez_compressed(f, starts=starts, held=held, hold=hold))

    @classmethod
    def load(cls, path: Path) -> Library:
        """The library at ``path``; a missing or corrupt file: ValueError in one line."""
        try:
            with np.load(path) as data:
                return cls(data["starts"], data["held"], int(data["hold"]))
        except FileNotFoundError:
            raise ValueError(f"no plan library at {path}") from None
        except (OSError, KeyError, ValueError, TypeError, zipfile.BadZipFile) as error:
            message = str(error).splitlines()[0] if str(error) else type(error).__name__
            raise ValueError(f"the plan library {path} is unreadable: {message}") from None


@dataclass(frozen=True)
class TreeSettings:
    """Entry points every ``stride`` physics steps of each plan; a jump of the angles past
    ``jump`` [rad] between calls is a reset; offline growth plans within ``window`` [J] of the
    upright energy and, after a failed plan, not again for ``wait`` calls."""

    stride: int = 5
    jump: float = 0.1
    window: float = 8.0
    wait: int = 250

    def __post_init__(self) -> None:
        if self.stride < 1 or self.wait < 0 or self.jump <= 0.0 or self.window < 0.0:
            raise ValueError(f"invalid tree settings: {self}")


class TreeController:
    """``u = pi(x)`` [N m]: TVLQR along the plan it follows (``funnel``'s weights and levels)
    while the tracking cost stays below ``funnel``'s ``track``; else ``funnel``'s balancer in
    the LQR's level set at upright; else the entry point of least TVLQR cost over ``plans``
    and ``funnel``'s own swing-up, where below ``entry``; else ``funnel``'s removal.
    ``grow``: offline only, a planner called where no point can be entered (within the energy
    window), whose plan joins the library. Call :meth:`reset` before each episode."""

    def __init__(
        self,
        funnel: FunnelController,
        plans: list[Trajectory],
        settings: TreeSettings = TreeSettings(),
        *,
        q: tuple[float, ...] = (10.0, 10.0, 1.0, 1.0),
        r: float = 1.0,
    ) -> None:
        self.funnel, self.settings, self.q, self.r = funnel, settings, q, r
        params = funnel.trajectory.params
        self.upright_energy = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], params))
        self.plans: list[Trajectory] = [funnel.trajectory]
        self.tracking: list[tuple[np.ndarray, np.ndarray]] = [(funnel.costs, funnel.gains)]
        self.grow: Grow | None = None
        self.planned: list[Trajectory] = []
        self.failed = 0
        for plan in plans:
            self._add(plan, index=False)
        self._index()
        self.reset()

    def _add(self, plan: Trajectory, index: bool = True) -> None:
        if (
            plan.params != self.funnel.trajectory.params
            or plan.method != self.funnel.trajectory.method
        ):
            raise ValueError("a plan must be on the funnel's model parameters and method")
        self.plans.append(plan)
        self.tracking.append(tvlqr(plan, self.funnel.lqr, self.q, self.r))
        if index:
            self._index()

    def _index(self) -> None:
        """Stack the entry points of every plan for the vectorised search."""
        stride, points, costs, which = self.settings.stride, [], [], []
        for i, (plan, (cost, _)) in enumerate(zip(self.plans, self.tracking, strict=True)):
            ks = np.arange(0, plan.steps, stride)
            points.append(plan.states[ks])
            costs.append(cost[ks])
            which.append(np.stack([np.full_like(ks, i), ks], -1))
        self.points, self.costs = np.concatenate(points), np.concatenate(costs)
        self.which = np.concatenate(which)
        self.nearest(UPRIGHT)  # compiled now (or loaded from numba's cache), not at a call

    def reset(self) -> None:
        """A new episode: no plan followed, the funnel's memory cleared."""
        self.funnel.reset()
        self.plan: int | None = None
        self.step, self.blocked = 0, 0
        self.last: np.ndarray | None = None

    def fresh(self) -> TreeController:
        """A copy for a new episode that shares the plans and gains."""
        other = copy.copy(self)
        other.funnel = self.funnel.fresh()
        other.reset()
        return other

    def nearest(self, x: np.ndarray) -> tuple[int, int, float]:
        """The plan, its step and the TVLQR cost ``e' S e`` of the entry point of least cost
        for state ``x`` (4,)."""
        best, level = compiled(least_cost)(x, self.points, self.costs)
        i, k = self.which[best]
        return int(i), int(k), float(level)

    def _follow(self, x: np.ndarray) -> float | None:
        """TVLQR along the plan followed, or None where it ends or the cost passes ``track``."""
        assert self.plan is not None
        plan, (costs, gains), k = self.plans[self.plan], self.tracking[self.plan], self.step
        if k >= plan.steps:
            self.plan = None
            return None
        e = state_error(x, plan.states[k])
        if e @ costs[k] @ e > self.funnel.settings.track:
            self.plan = None
            return None
        self.step = k + 1
        return tvlqr_torque(plan, gains, k, x)

    def _jumped(self, x: np.ndarray) -> bool:
        last, self.last = self.last, x.copy()
        if last is None:
            return False
        return bool(np.abs(wrap_angle(x[:2] - last[:2])).max() > self.settings.jump)

    def _grown(self, x: np.ndarray, near: int) -> bool:
        """Plan from ``x`` offline (``grow``) and follow the new plan; False if none."""
        assert self.grow is not None
        params = self.funnel.trajectory.params
        energy = float(dynamics.total_energy(x[:2], x[2:], params))
        if abs(energy - self.upright_energy) > self.settings.window or self.blocked > 0:
            self.blocked = max(self.blocked - 1, 0)
            return False
        plan = self.grow(x, near)
        if plan is None:
            self.failed += 1
            self.blocked = self.settings.wait
            return False
        self._add(plan)
        self.planned.append(plan)
        self.plan, self.step = len(self.plans) - 1, 0
        return True

    def __call__(self, x: np.ndarray) -> float:
        """The torque [N m] in state ``x`` (4,)."""
        x = check_state("the state", x)
        if self._jumped(x):
            self.plan = None
        if self.plan is not None:
            torque = self._follow(x)
            if torque is not None:
                return torque
        funnel = self.funnel
        error = state_error(x, funnel.lqr.target)
        if error @ funnel.lqr.cost @ error < funnel.settings.upright:
            return float(funnel.balancer(x))
        i, k, level = self.nearest(x)
        if level < funnel.settings.entry or (self.grow is not None and self._grown(x, i)):
            if level < funnel.settings.entry:
                self.plan, self.step = i, k
            torque = self._follow(x)
            if torque is not None:
                return torque
        return funnel.removal(x)


def least_cost(x, points, costs):  # kernel
    """The index of the point of ``points`` (P, 4) of least ``e' S e`` for ``e = x - point``
    (angles wrapped), ``S`` the point's cost (P, 4, 4), and that cost: one pass, compiled."""
    best, level = 0, np.inf
    e = np.empty(4)
    for k in range(points.shape[0]):
        for i in range(4):
            e[i] = x[i] - points[k, i]
        for i in range(2):
            e[i] = (e[i] + np.pi) % (2.0 * np.pi) - np.pi
        total = 0.0
        for i in range(4):
            row = 0.0
            for j in range(4):
                row += costs[k, i, j] * e[j]
            total += e[i] * row
        if total < level:
            best, level = k, total
    return best, level


def warm_torques(plan: Trajectory, hold: int, decisions: int) -> np.ndarray:
    """``plan``'s held torques (``decisions``,) [N m] from its start, padded with zeros:
    a warm start for a plan from a state near it."""
    held = plan.torques[::hold][:decisions]
    return np.concatenate([held, np.zeros(decisions - len(held))])


def tree_stats(controller: Any) -> dict[str, int]:
    """How many plans the controller holds, planned while growing, and failed to plan."""
    return {
        "plans": len(controller.plans),
        "planned": len(controller.planned),
        "failed": controller.failed,
    }
