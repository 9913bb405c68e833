"""Swing-ups planned from any state (:class:`Planner`: CasADi and IPOPT, the ``control``
extra), online for a :class:`~acrobot_mj.control.tracker.PlanTracker` (:func:`replanner`:
wherever the arm is away from upright and no plan can be entered, as for the AI Olympics'
global policy, whose resets leave the arm anywhere) or offline to grow a plan set. The solves
are not real-time: each takes seconds of wall time while the simulation waits."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.checks import check_float, check_int, check_state
from acrobot_mj.control.trajopt import Trajectory, solve_or_none
from acrobot_mj.physics import integrators
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.physics.xp import symbolic, wrap_angle

LOG = logging.getLogger(__name__)
#: IPOPT's options for a plan from any state: a loose tolerance (TVLQR absorbs the rest; the
#: plan is rolled out on the model before it is used) and few iterations (a plan late is a plan
#: lost).
ONLINE_ITERATIONS = 60
ONLINE_IPOPT = {
    "print_level": 0,
    "max_iter": ONLINE_ITERATIONS,
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


@dataclass(frozen=True)
class TimeBelow:
    """A plan's objective that counts the time its tip spends below ``height`` times the arm's
    reach (the AI Olympics' up: 0.9): a logistic of ``width`` [m] centred ``margin`` [m] above
    that height, so that the plan clears it, plus ``weight`` times the mean squared distance
    below the highest point, which leads IPOPT up."""

    height: float = 0.9
    width: float = 0.02
    margin: float = 0.05
    weight: float = 0.1


class Planner:
    """Swing-ups of ``decisions`` torques, each held ``hold`` physics steps of ``params`` by
    ``method`` (the env's steps, as
    :func:`~acrobot_mj.olympics.swing_ups.performance_swing_up`), from a state to upright at
    rest: ``|u| <= params.max_torque``, the end at the target, minimising the tip's mean
    squared distance below its highest point (the time spent low) or ``below``'s time below a
    height, plus ``effort`` times the torques squared. One NLP (its start and target parameters)
    is built on first use and reused. A copy shares it: the planner holds no episode state."""

    def __init__(
        self,
        params: AcrobotParams,
        method: str = "rk4",
        *,
        decisions: int = 150,
        hold: int = 5,
        effort: float = 1e-3,
        below: TimeBelow | None = None,
        iterations: int = ONLINE_ITERATIONS,
    ) -> None:
        check_int("decisions", decisions, 2)
        check_int("hold", hold, 1)
        check_float("effort", effort, 0.0)
        integrators.method_code(method)  # a known method
        self.params, self.method = params, method
        self.decisions, self.hold, self.effort = decisions, hold, effort
        self.below, self.iterations = below, check_int("iterations", iterations, 1)
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
        reach, below = p.l1 + p.l2, self.below
        low = casadi.sumsqr(reach - tip) / n
        if below is not None:
            line = below.height * reach + below.margin
            low = (
                below.weight * low
                + casadi.sum2(1 / (1 + casadi.exp((tip - line) / below.width))) / n
            )
        opti.minimize(low + self.effort * casadi.sumsqr(us) / n)
        options = dict(ONLINE_IPOPT, max_iter=self.iterations)
        opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes", "expand": True}, options)
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


def replanner(planner: Planner, targets: int = 3) -> Callable[[np.ndarray, Any], Any]:
    """A :class:`~acrobot_mj.control.tracker.PlanTracker`'s planner online: ``planner``'s best
    plan from the state to its ``targets`` nearest upright states, each solve's wall time
    logged at INFO."""
    check_int("targets", targets, 1, 3)

    def plan(x: np.ndarray, near: Trajectory) -> Trajectory | None:
        started = time.perf_counter()
        found = planner.plan(x, targets)
        LOG.info(
            "replan from %s: %s in %.2f s",
            np.round(x, 2).tolist(), "found" if found else "none", time.perf_counter() - started,
        )  # fmt: skip
        return found

    return plan
