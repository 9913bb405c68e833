"""Swing-ups planned online from the current state (:class:`Planner`: CasADi and IPOPT, the
``control`` extra) and a controller that plans one whenever the arm is away from upright and
the funnel along the shipped swing-up does not hold it (:class:`Replanning`), as for the AI
Olympics' global policy, whose resets leave the arm anywhere. The solves are not real-time:
each takes seconds of wall time while the simulation waits (docs/guide/olympics.md)."""

from __future__ import annotations

import copy
import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from acrobot_mj.checks import check_float, check_int, check_state
from acrobot_mj.control.feedback import FunnelController
from acrobot_mj.control.lqr import tvlqr, tvlqr_torque
from acrobot_mj.control.trajopt import Trajectory, solve_or_none
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import UPRIGHT, state_error
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.physics.xp import symbolic, wrap_angle

LOG = logging.getLogger(__name__)
#: IPOPT's options for a replan: a loose tolerance (TVLQR absorbs the rest; the plan is rolled
#: out on the model before it is used) and few iterations (a plan late is a plan lost).
IPOPT = {
    "print_level": 0,
    "max_iter": 60,
    "tol": 1e-6,
    "constr_viol_tol": 1e-8,
    "acceptable_tol": 1e-4,
    "acceptable_iter": 3,
}
#: Largest end error [rad, rad/s] of a plan rolled out on the model that is still used: the
#: LQR at upright catches far more (its level set spans tenths of a radian).
END_TOLERANCE = 0.05


def upright_targets(x: np.ndarray, count: int = 3) -> list[np.ndarray]:
    """The ``count`` (1 to 3) upright-at-rest states nearest ``x`` (4,): ``q1`` the nearest of
    ``pi/2 + 2 pi k`` and ``q2`` the nearest of ``2 pi m``, then each angle's second nearest."""
    check_int("count", count, 1, 3)
    near, second = [], []
    for q, base in ((x[0], np.pi / 2), (x[1], 0.0)):
        k = (q - base) / (2 * np.pi)
        first = base + 2 * np.pi * round(k)
        other = first + 2 * np.pi * (1.0 if q > first else -1.0)
        near.append(first)
        second.append(other)
    found = [
        np.array([near[0], near[1], 0.0, 0.0]),
        np.array([near[0], second[1], 0.0, 0.0]),
        np.array([second[0], near[1], 0.0, 0.0]),
    ]
    return found[:count]


class Planner:
    """Swing-ups of ``decisions`` torques, each held ``hold`` physics steps of ``params`` by
    ``method`` (the env's steps, as
    :func:`~acrobot_mj.olympics.controllers.performance_swing_up`), from a state to upright at
    rest: ``|u| <= params.max_torque``, the end at the target, minimising the tip's distance
    below its highest point summed over the plan (the time spent low) plus ``effort`` times the
    torques squared. One NLP (its start and target parameters) is built on first use and
    reused. A copy shares it: the planner holds no episode state."""

    def __init__(
        self,
        params: AcrobotParams,
        method: str = "rk4",
        *,
        decisions: int = 150,
        hold: int = 5,
        effort: float = 1e-3,
    ) -> None:
        check_int("decisions", decisions, 2)
        check_int("hold", hold, 1)
        check_float("effort", effort, 0.0)
        integrators.method_code(method)  # a known method
        self.params, self.method = params, method
        self.decisions, self.hold, self.effort = decisions, hold, effort
        self._nlp: tuple[Any, ...] | None = None

    def __deepcopy__(self, memo: dict[int, Any]) -> Planner:
        return self

    @property
    def seconds(self) -> float:
        """The plan's length [s]."""
        return self.decisions * self.hold * self.params.dt

    def _build(self) -> tuple[Any, ...]:
        import casadi

        p, n = self.params, self.decisions
        code = integrators.method_code(self.method)
        x, u = casadi.SX.sym("x", 4), casadi.SX.sym("u")
        new = integrators.step(
            *(x[i] for i in range(4)), u, p.lumped, p.dt, integrators.UNLIMITED, self.hold, code,
            symbolic(),
        )  # fmt: skip
        step = casadi.Function("step", [x, u], [casadi.vertcat(*new)])
        opti = casadi.Opti()
        xs, us = opti.variable(4, n + 1), opti.variable(1, n)
        start, target = opti.parameter(4), opti.parameter(4)
        opti.subject_to(xs[:, 0] == start)
        opti.subject_to(xs[:, 1:] == step.map(n)(xs[:, :-1], us))
        opti.subject_to(opti.bounded(-p.max_torque, us, p.max_torque))
        opti.subject_to(xs[:, n] == target)
        tip = p.l1 * casadi.sin(xs[0, 1:]) + p.l2 * casadi.sin(xs[0, 1:] + xs[1, 1:])
        low = casadi.sumsqr(p.l1 + p.l2 - tip) / n
        opti.minimize(low + self.effort * casadi.sumsqr(us) / n)
        opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes", "expand": True}, IPOPT)
        return opti, xs, us, start, target

    def solve(
        self, x0: np.ndarray, target: np.ndarray, warm: np.ndarray | None = None
    ) -> tuple[Trajectory, float] | None:
        """The plan from ``x0`` to ``target`` (upright at rest, angles near ``x0``'s) and its
        objective, rolled out on the model, one torque a physics step; ``warm``: torques
        (``decisions``,) to start IPOPT from (default: none, the states on a straight line).
        None where IPOPT finds none or the rollout ends more than :data:`END_TOLERANCE` off."""
        x0, target = check_state("the start", x0), np.asarray(target, dtype=float)
        if self._nlp is None:
            self._nlp = self._build()
        opti, xs, us, start, end = self._nlp
        opti.set_value(start, x0)
        opti.set_value(end, target)
        p, n = self.params, self.decisions
        if warm is None:
            opti.set_initial(xs, np.linspace(x0, target, n + 1).T)
            opti.set_initial(us, np.zeros((1, n)))
        else:
            torques = np.clip(np.asarray(warm, dtype=float), -p.max_torque, p.max_torque)
            opti.set_initial(us, torques[None])
            states = integrators.simulate(x0, np.repeat(torques, self.hold), self.method, p)
            opti.set_initial(xs, states[:: self.hold].T)
        solution = solve_or_none(opti)
        if solution is None:
            return None
        held = np.clip(np.atleast_1d(solution.value(us)), -p.max_torque, p.max_torque)
        torques = np.repeat(held, self.hold)
        states = integrators.simulate(x0, torques, self.method, p)
        if np.abs(states[-1] - target).max() > END_TOLERANCE:
            return None
        plan = Trajectory(states, torques, p.dt, self.method, p.max_torque, p)
        return plan, float(solution.value(opti.f))

    def plan(self, x0: np.ndarray, targets: int = 3) -> Trajectory | None:
        """The best (least objective) of the plans from ``x0`` to its ``targets`` nearest
        upright states (:func:`upright_targets`), or None if none is found. ``x0``'s angles
        are wrapped into ``[-pi, pi)`` first."""
        x0 = check_state("the start", x0)
        x0[:2] = wrap_angle(x0[:2])
        best: tuple[Trajectory, float] | None = None
        for target in upright_targets(x0, targets):
            found = self.solve(x0, target)
            if found is not None and (best is None or found[1] < best[1]):
                best = found
        return None if best is None else best[0]


@dataclass(frozen=True)
class ReplanSettings:
    """When :class:`Replanning` plans: within ``window`` [J] of the upright energy; from the
    ``targets`` (1 to 3) nearest upright states; after a failed plan, not again for ``wait``
    calls (0.5 s at 0.002 s: a failed solve costs seconds of wall time, and the states that
    fail, spinning fast, take a while to slow down); a jump of the estimated angles past
    ``jump`` [rad] between calls is a reset."""

    window: float = 8.0
    targets: int = 3
    wait: int = 250
    jump: float = 0.1

    def __post_init__(self) -> None:
        check_float("window", self.window, 0.0)
        check_int("targets", self.targets, 1, 3)
        check_int("wait", self.wait, 0)
        check_float("jump", self.jump, 1e-9)


@dataclass
class SolveLog:
    """Wall times [s] of the plans made (``seconds``) and whether each found one (``found``)."""

    seconds: list[float] = field(default_factory=list)
    found: list[bool] = field(default_factory=list)


class Replanning:
    """``u = pi(x)`` [N m]: ``funnel`` (a :class:`~acrobot_mj.control.feedback.FunnelController`
    along the shipped swing-up, with energy pumping elsewhere) where it follows its swing-up or
    balances; elsewhere, within the energy window of upright, a swing-up planned from ``x`` by
    ``planner`` and followed with TVLQR (the funnel's weights and levels), then the funnel's
    balancer; a new plan where the tracking cost passes the funnel's ``track`` level or after a
    reset. From hanging at rest it acts as ``funnel`` does (its swing-up starts there)."""

    def __init__(
        self,
        funnel: FunnelController,
        planner: Planner,
        settings: ReplanSettings = ReplanSettings(),
        *,
        q: tuple[float, ...] = (10.0, 10.0, 1.0, 1.0),
        r: float = 1.0,
    ) -> None:
        if planner.params != funnel.trajectory.params:
            raise ValueError("the planner and the funnel must be on the same model parameters")
        self.funnel, self.planner, self.settings = funnel, planner, settings
        self.q, self.r = q, r
        p = planner.params
        self.upright_energy = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p))
        self.log = SolveLog()
        self.reset()

    def reset(self) -> None:
        """A new episode: no plan, the funnel's memory cleared (the log is kept)."""
        self.funnel.reset()
        self.plan: Trajectory | None = None
        self.gains: np.ndarray | None = None
        self.costs: np.ndarray | None = None
        self.index, self.blocked, self.calls = 0, 0, 0
        self.last: np.ndarray | None = None

    def fresh(self) -> Replanning:
        """A copy for a new episode, with its own log."""
        other = copy.copy(self)
        other.funnel = self.funnel.fresh()
        other.log = SolveLog()
        other.reset()
        return other

    def _replan(self, x: np.ndarray) -> bool:
        started = time.perf_counter()
        plan = self.planner.plan(x, self.settings.targets)
        seconds = time.perf_counter() - started
        self.log.seconds.append(seconds)
        self.log.found.append(plan is not None)
        LOG.info(
            "replan at call %d from %s: %s in %.2f s",
            self.calls, np.round(x, 2).tolist(), "found" if plan else "none", seconds,
        )  # fmt: skip
        if plan is None:
            self.blocked = self.settings.wait
            return False
        self.costs, gains = tvlqr(plan, self.funnel.lqr, self.q, self.r)
        self.plan, self.gains, self.index = plan, gains, 0
        return True

    def _follow(self, x: np.ndarray) -> float | None:
        """TVLQR along the plan, or None where it ends or its tracking cost is past ``track``."""
        assert self.plan is not None and self.costs is not None and self.gains is not None
        k = self.index
        if k >= self.plan.steps:
            self.plan = None
            return None
        e = state_error(x, self.plan.states[k])
        if e @ self.costs[k] @ e > self.funnel.settings.track:
            LOG.info("tracking lost at call %d, plan step %d", self.calls, k)
            self.plan = None
            return None
        self.index = k + 1
        return tvlqr_torque(self.plan, self.gains, k, x)

    def _jumped(self, x: np.ndarray) -> bool:
        last, self.last = self.last, x.copy()
        if last is None:
            return False
        return bool(np.abs(wrap_angle(x[:2] - last[:2])).max() > self.settings.jump)

    def __call__(self, x: np.ndarray) -> float:
        """The torque [N m] in state ``x`` (4,)."""
        x = check_state("the state", x)
        self.calls += 1
        if self._jumped(x):  # a reset moved the arm: start again from here
            self.plan, self.blocked = None, 0
            self.funnel.reset()
        if self.plan is not None:
            torque = self._follow(x)
            if torque is not None:
                return torque
        mode = self.funnel.mode(x)
        if mode == "upright":
            return float(self.funnel.balancer(x))
        if mode == "funnel":
            return _funnel_step(self.funnel, x)
        self.blocked = max(self.blocked - 1, 0)
        energy = float(dynamics.total_energy(x[:2], x[2:], self.planner.params))
        near = abs(energy - self.upright_energy) <= self.settings.window
        if near and self.blocked == 0 and self._replan(x):
            torque = self._follow(x)
            if torque is not None:
                return torque
        return self.funnel.removal(x)


def _funnel_step(funnel: FunnelController, x: np.ndarray) -> float:
    """The funnel's TVLQR at the point it follows, its memory moved on (as its ``__call__``)."""
    k = funnel.index
    assert k is not None
    funnel.index = k + 1 if k + 1 < funnel.trajectory.steps else None
    return funnel.funnel_torque(k, x)


def solve_stats(seconds: list[float]) -> dict[str, float]:
    """Count, median and max [s] of solve wall times."""
    if not seconds:
        return {"count": 0, "median": math.nan, "max": math.nan}
    return {
        "count": len(seconds),
        "median": float(np.median(seconds)),
        "max": float(np.max(seconds)),
    }
