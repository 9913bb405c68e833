"""The one plan tracker (:class:`PlanTracker`): TVLQR along one plan or many, entered by state
(the LQR-tree's test of Tedrake's, ``e' S e`` below a level, and optionally a rollout of the
plan on the model, as Reist and Tedrake's simulation-based funnels) or followed by the clock;
the constrained LQR at upright; and a fallback law everywhere else (energy removal by default,
which brings the acrobot down towards hanging, where the first plan begins). A planner may add
plans where none can be entered: online (each plan followed once) or offline (the plan joins
the set, a trajectory library as Atkeson and Stolle's)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from acrobot_mj.checks import check_state
from acrobot_mj.compiled import compiled, jitable
from acrobot_mj.control.controller import Controller, EnergyRemoval
from acrobot_mj.control.lqr import LQR, MPC, Jacobians, tvlqr, tvlqr_torque
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import UPRIGHT, state_error
from acrobot_mj.physics.integrators import step_one
from acrobot_mj.physics.xp import clip, wrap
from acrobot_mj.settings import Settings, setting

#: The TVLQR and LQR weights on the state error and the torque.
Q, R = (10.0, 10.0, 1.0, 1.0), 1.0
#: No limit on the steps a rollout spends low.
NO_LIMIT = 2**62
#: A planner: a state (4,) and the plan whose entry point is nearest it to a new plan from that
#: state, or None.
PlanningHook = Callable[[np.ndarray, Trajectory], "Trajectory | None"]


@dataclass(frozen=True)
class FunnelSettings(Settings):
    """Levels of the LQR costs ``e' S e`` (dimensionless: the costs of
    :class:`~acrobot_mj.control.lqr.LQR`'s weights) that switch between the modes: at upright
    below ``upright``; a followed plan point is kept below ``track`` and entered below
    ``entry``, or below ``track`` where a rollout of the plan on the model from there reaches
    upright (:meth:`PlanTracker.reaches`); elsewhere by default ``tau = -clip(damping dq2, -1,
    1)`` [N m, N m s/rad] takes energy out. The balancer at upright is the constrained LQR over
    ``horizon`` steps (:class:`~acrobot_mj.control.lqr.MPC`), or the saturated LQR where it is
    0. The levels were chosen on the analytic model, from 100 uniform starts and 200 kicks at
    upright of seeds other than the evaluation's; 40 steps (2 s) hold every kick of
    ``U(-0.05, 0.05)`` rad/s that 80 hold in MuJoCo (100 kicks, evaluation seed 0)."""

    upright: float = setting(
        100.0, "LQR cost level at upright below which it balances", low=0.0, low_open=True
    )
    track: float = setting(
        200.0, "TVLQR cost level below which it keeps its funnel point", low=0.0, low_open=True
    )
    entry: float = setting(
        20.0, "TVLQR cost level below which it enters the funnel", low=0.0, low_open=True
    )
    damping: float = setting(
        1.0, "gain of the energy removal elsewhere", "N m s/rad", low=0.0, low_open=True
    )
    horizon: int = setting(
        40,
        "constrained LQR's horizon, shortened where its QP is ill-conditioned (0: the saturated "
        "LQR)",
        "steps",
        low=0,
    )

    what = "funnel"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.entry > self.track:
            raise ValueError(f"entry ({self.entry:g}) must be at most track ({self.track:g})")


@dataclass(frozen=True)
class TrackerSettings(Settings):
    """How plans are entered, dropped and added."""

    stride: int = setting(1, "physics steps between a plan's entry points", "steps", low=1)
    rollout: bool = setting(
        True, "enter below the track level where a rollout of the plan on the model reaches upright"
    )
    candidates: int = setting(
        1,
        "the entry points of least cost tried by rollout, in order of cost: the first that "
        "reaches upright is entered, or the one ``below`` chooses (else the least, below the "
        "entry level)",
        "points",
        low=1,
    )
    on: float = setting(
        0.0,
        "TVLQR cost below which the point of least cost is entered without a rollout: the "
        "state is on a plan, as at hanging at rest on the swing-up (0: never)",
        low=0.0,
    )
    below: float | None = setting(
        None,
        "of the candidates whose rollout reaches upright, enter the one whose tip spends the "
        "fewest steps at or below this fraction of the arm's reach above the shoulder (the "
        "AI Olympics' up is above 0.9); none: the first in order of cost",
        low=-1.0,
        high=1.0,
    )
    jump: float | None = setting(
        None,
        "an angle jump between calls past which the plan followed is dropped (a reset); none: "
        "no such test",
        "rad",
        low=0.0,
        low_open=True,
    )
    clock: bool = setting(
        False, "follow the first plan by the clock from t = 0, with no entry test, then balance"
    )
    pause: int = setting(
        0,
        "calls without a search for an entry after one found none (the fallback acts)",
        "calls",
        low=0,
    )
    window: float = setting(8.0, "the planner plans within this of upright's energy", "J", low=0.0)
    wait: int = setting(250, "calls without planning after a failed plan", "calls", low=0)

    what = "tracker"


class PlanTracker(Controller):
    """``u = pi(x)`` [N m] on the model of ``plans`` (the first one's parameters and step):
    TVLQR along the plan point it follows while the tracking cost stays below ``levels.track``;
    else the balancer in the LQR's level set at upright; else the entry point of least TVLQR
    cost over every plan, where below ``levels.entry`` (or below ``track`` where the settings
    enter by rollout and the rollout reaches upright); else a plan from ``planner``
    (within the energy window; ``keep``: it joins the set); else ``fallback`` (default:
    :class:`~acrobot_mj.control.controller.EnergyRemoval` at ``levels.damping``). ``linear``
    and ``step``: the Jacobians and the step ``x' = step(x, u)`` of a learnt model the plans
    were made on (without ``step`` a learnt model's entries are not checked by rollout)."""

    def __init__(
        self,
        plans: Sequence[Trajectory],
        levels: FunnelSettings = FunnelSettings(),
        settings: TrackerSettings = TrackerSettings(),
        *,
        fallback: Controller | None = None,
        planner: PlanningHook | None = None,
        keep: bool = False,
        linear: Jacobians | None = None,
        step: Callable[[np.ndarray, float], np.ndarray] | None = None,
    ) -> None:
        if not plans:
            raise ValueError("a plan tracker needs at least one plan")
        first = plans[0]
        self.params, self.method = first.params, first.method
        self.levels, self.settings, self.linear = levels, settings, linear
        self.planner, self.keep = planner, keep
        if step is None and linear is None:
            step = partial(integrators.step_states, p=first.params, method=first.method)
        self.step = step if settings.rollout else None
        # The LQR at the first plan's end (upright at rest), on the model the gains come from.
        end = UPRIGHT.copy() if linear is None else first.states[-1].copy()
        self.lqr = LQR(Q, R, first.params, end, linear)
        self.balancer: Controller = MPC(self.lqr, levels.horizon) if levels.horizon else self.lqr
        self.fallback = fallback or EnergyRemoval(levels.damping, first.params.max_torque)
        self.upright_energy = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], self.params))
        self.plans: list[Trajectory] = []
        self.tracking: list[tuple[np.ndarray, np.ndarray]] = []
        for plan in plans:
            self.add(plan, index=False)
        self._index()
        #: Plans the planner made, and how many times it found none.
        self.planned: list[Trajectory] = []
        self.failed = 0
        self.reset()

    def add(self, plan: Trajectory, index: bool = True) -> None:
        """Add ``plan`` (on the same model) to the plans entered."""
        if plan.params != self.params or plan.method != self.method:
            raise ValueError("every plan must be on the first plan's model parameters and method")
        self.plans.append(plan)
        self.tracking.append(tvlqr(plan, self.lqr, Q, R, self.linear))
        if index:
            self._index()

    def _index(self) -> None:
        """Stack every ``stride``-th point of every plan for the search."""
        stride, points, costs, which = self.settings.stride, [], [], []
        for i, (plan, (cost, _)) in enumerate(zip(self.plans, self.tracking, strict=True)):
            ks = np.arange(0, plan.steps, stride)
            points.append(plan.states[ks])
            costs.append(cost[ks])
            which.append(np.stack([np.full_like(ks, i), ks], -1))
        self.points, self.costs = np.concatenate(points), np.concatenate(costs)
        self.which = np.concatenate(which)
        self.nearest(UPRIGHT)  # compiled now (or loaded from numba's cache), not at a call

    def reset(self, seed: int | None = None) -> None:
        """A new episode: no plan followed, no planning blocked, the fallback reset."""
        self.following: tuple[Trajectory, np.ndarray, np.ndarray] | None = None
        self.k, self.blocked, self.paused = 0, 0, 0
        self.last: np.ndarray | None = None
        #: Who gave the last torque: ``"plan"``, ``"balancer"`` or ``"fallback"``.
        self.mode = ""
        self.fallback.reset(seed)

    def nearest(self, x: np.ndarray) -> tuple[int, int, float]:
        """The plan, its step and the TVLQR cost ``e' S e`` of the entry point of least cost
        for state ``x`` (4,)."""
        levels = self._levels(x)
        i, k = self.which[int(np.argmin(levels))]
        return int(i), int(k), float(levels.min())

    def _levels(self, x: np.ndarray) -> np.ndarray:
        """The TVLQR cost ``e' S e`` of every entry point for state ``x`` (4,)."""
        levels = np.empty(len(self.points))
        compiled(point_costs)(np.asarray(x, dtype=float), self.points, self.costs, levels)
        return levels

    def entry(self, x: np.ndarray) -> tuple[int, int, bool]:
        """The plan and step to enter from state ``x`` (4,), and whether to: the point of
        least cost where its cost is below ``on``; else of the ``candidates`` entry points of
        least cost below ``track`` whose rollout reaches upright (:meth:`rollout`), the first
        in order of cost, or where the settings give ``below`` the one whose rollout spends
        the fewest steps with the tip that low (ties: the cheaper); else the point of least
        cost, where below ``entry``."""
        levels, count = self._levels(x), self.settings.candidates
        if count == 1:
            order = [int(np.argmin(levels))]
        else:  # the count least, in order of cost
            some = np.argpartition(levels, count)[:count] if count < len(levels) else None
            ranked = np.argsort(levels) if some is None else some[np.argsort(levels[some])]
            order = ranked.tolist()
        best, choosing = order[0], self.settings.below is not None
        if levels[best] < self.settings.on:  # on a plan: followed as it is
            i, k = (int(v) for v in self.which[best])
            return i, k, True
        chosen, fewest = None, NO_LIMIT
        for b in order:
            if levels[b] >= self.levels.track:
                break
            i, k = (int(v) for v in self.which[b])
            if count == 1 and levels[b] < self.levels.entry:  # entered with or without a rollout
                return i, k, True
            low = self.rollout(x, i, k, fewest - 1)  # only a rollout lower than the best yet
            if low >= 0 and not choosing:
                return i, k, True
            if low >= 0:
                chosen, fewest = (i, k), low
        if chosen is not None:
            return (*chosen, True)
        i, k = (int(v) for v in self.which[best])
        return i, k, bool(levels[best] < self.levels.entry)

    def follow(self, i: int, k: int) -> None:
        """Follow plan ``i`` from its step ``k``."""
        plan, (costs, gains) = self.plans[i], self.tracking[i]
        self.following, self.k = (plan, costs, gains), k

    def _tracked(self, x: np.ndarray) -> float | None:
        """TVLQR along the plan followed, or None where it ends or the cost passes ``track``."""
        assert self.following is not None
        plan, costs, gains = self.following
        k = self.k
        if k >= plan.steps:
            self.following = None
            return None
        e = state_error(x, plan.states[k])
        if e @ costs[k] @ e > self.levels.track:
            self.following = None
            return None
        self.k = k + 1
        return tvlqr_torque(plan, gains, k, x)

    def _jumped(self, x: np.ndarray) -> bool:
        last, self.last = self.last, x.copy()
        jump = self.settings.jump
        if last is None or jump is None:
            return False
        # On floats: the largest wrapped angle change past ``jump`` (the state is finite).
        q1, q2 = x.tolist()[:2]
        l1, l2 = last.tolist()[:2]
        return abs(wrap(q1 - l1)) > jump or abs(wrap(q2 - l2)) > jump

    def reaches(self, x: np.ndarray, i: int, k: int) -> bool:
        """Does plan ``i``, followed from its point ``k`` in state ``x`` on the tracker's own
        model, stay within ``track`` and end inside the balancer's level set? (False where it
        enters by no rollout.)"""
        return self.rollout(x, i, k) >= 0

    def rollout(self, x: np.ndarray, i: int, k: int, most: int = NO_LIMIT) -> int:
        """Plan ``i`` followed from its point ``k`` in state ``x`` on the tracker's own model:
        the steps it spends with the tip at or below the settings' ``below`` (0 without one),
        or -1 where it leaves ``track``, does not end inside the balancer's level set, or
        spends more than ``most`` steps low (or where the tracker enters by no rollout)."""
        if self.step is None:
            return -1
        plan, (costs, gains) = self.plans[i], self.tracking[i]
        limit, p, fraction = plan.params.max_torque, plan.params, self.settings.below
        levels = (self.levels.track, self.levels.upright, limit)
        reach = p.l1 + p.l2
        low = (p.l1, p.l2, -np.inf if fraction is None else fraction * reach, most)
        constants = self._constants()
        if constants is not None:  # the model's own step: the whole rollout compiled
            arrays, lqr = (
                (plan.states, plan.torques, gains, costs),
                (self.lqr.target, self.lqr.cost),
            )
            return int(compiled(plan_rollout)(x, k, arrays, levels, lqr, constants, low))
        state, steps = np.asarray(x, dtype=float), 0
        for j in range(k, plan.steps):
            steps += int(dynamics.tip_height(state, p) <= low[2])
            e = state_error(state, plan.states[j])
            if steps > most or e @ costs[j] @ e > self.levels.track:
                return -1
            u = clip(float(plan.torques[j]) - float(gains[j] @ e), -limit, limit)
            state = np.asarray(self.step(state, u), dtype=float)
        error = state_error(state, self.lqr.target)
        return steps if error @ self.lqr.cost @ error < self.levels.upright else -1

    def _constants(self) -> tuple | None:
        """The compiled step's constants after the state and torque (lumped parameters, step,
        velocity limits, substeps, method) where ``step`` is
        :func:`~acrobot_mj.physics.integrators.step_states` on a model; else None (a learnt
        model's step)."""
        step = self.step
        if not (
            isinstance(step, partial)
            and step.func is integrators.step_states
            and not step.args
            and set(step.keywords) == {"p", "method"}
        ):
            return None
        p = step.keywords["p"]
        floats = tuple(float(v) for v in (*p.lumped, p.dt, *p.max_vel))
        return (*floats, 1, integrators.method_code(step.keywords["method"]))

    def _planned(self, x: np.ndarray, near: int) -> bool:
        """Plan from ``x`` (within the energy window, unless blocked) and follow the plan."""
        assert self.planner is not None
        energy = float(dynamics.total_energy(x[:2], x[2:], self.params))
        if abs(energy - self.upright_energy) > self.settings.window or self.blocked > 0:
            self.blocked = max(self.blocked - 1, 0)
            return False
        plan = self.planner(x, self.plans[near])
        if plan is None:
            self.failed += 1
            self.blocked = self.settings.wait
            return False
        self.planned.append(plan)
        if self.keep:
            self.add(plan)
            self.follow(len(self.plans) - 1, 0)
        else:
            self.following, self.k = (plan, *tvlqr(plan, self.lqr, Q, R, self.linear)), 0
        return True

    def _clocked(self, x: np.ndarray, t: float) -> float:
        """The first plan's TVLQR at the step the clock is at, then the balancer."""
        plan, (_, gains) = self.plans[0], self.tracking[0]
        k = round(t / plan.dt)
        if k >= plan.steps:
            self.mode = "balancer"
            return self.balancer.act(x, t)
        self.mode = "plan"
        return tvlqr_torque(plan, gains, k, x)

    def act(self, x: np.ndarray, t: float) -> float:
        """The torque [N m] in state ``x`` (4,) at ``t`` [s]; ``mode`` says who gave it."""
        x = check_state("the state", x)
        if self.settings.clock:
            return self._clocked(x, t)
        if self._jumped(x):
            self.following, self.blocked, self.paused = None, 0, 0
        if self.following is not None:
            torque = self._tracked(x)
            if torque is not None:
                self.mode = "plan"
                return torque
        error = state_error(x, self.lqr.target)
        if error @ self.lqr.cost @ error < self.levels.upright:
            self.mode = "balancer"
            if self.balancer is self.lqr:  # the saturated LQR, on the error just computed
                return self.lqr.torque(error)
            return self.balancer.act(x, t)
        if self.paused > 0:  # no search for a while after one found no entry
            self.paused -= 1
        else:
            i, k, entered = self.entry(x)
            if entered:
                self.follow(i, k)
            if entered or (self.planner is not None and self._planned(x, i)):
                torque = self._tracked(x)
                if torque is not None:
                    self.mode = "plan"
                    return torque
            self.paused = self.settings.pause
        self.mode = "fallback"
        return self.fallback.act(x, t)


def clocked(plan: Trajectory) -> PlanTracker:
    """TVLQR along ``plan`` by the clock from ``t = 0`` (no entry test), then the constrained
    LQR at upright, both on the plan's model."""
    return PlanTracker([plan], settings=TrackerSettings(clock=True))


def point_costs(x, points, costs, out):  # kernel
    """Into ``out`` (P,): ``e' S e`` for ``e = x - point`` (angles wrapped) of every point of
    ``points`` (P, 4), ``S`` the point's cost (P, 4, 4); one pass, compiled."""
    e = np.empty(4)
    for k in range(points.shape[0]):
        for i in range(4):
            e[i] = x[i] - points[k, i]
        for i in range(2):
            e[i] = (e[i] + np.pi) % (2.0 * np.pi) - np.pi
        out[k] = quadratic(e, costs[k])


def plan_rollout(x, k, arrays, levels, lqr, constants, low):  # kernel
    """:meth:`PlanTracker.rollout` of a plan (``arrays``: its states (T + 1, 4), torques (T,),
    TVLQR gains (T, 4) and costs (T, 4, 4)) from its point ``k`` in state ``x`` (4,):
    ``levels`` the track and upright levels and the torque limit, ``lqr`` the balancer's target
    (4,) and cost (4, 4), ``constants``
    :func:`~acrobot_mj.physics.integrators.step_one`'s after the state and torque, ``low`` the
    link lengths [m], the tip height counted as low [m] and the most steps low. Compiled: in
    Python a rollout of up to a plan's length at every call outside the funnel took 0.5 to 4 ms."""
    states, torques, gains, costs = arrays
    track, upright, limit = levels
    target, cost = lqr
    l1, l2, height, most = low
    q1, q2, dq1, dq2 = x[0], x[1], x[2], x[3]
    e = np.empty(4)
    steps = 0
    for j in range(k, torques.shape[0]):
        if l1 * np.sin(q1) + l2 * np.sin(q1 + q2) <= height:
            steps += 1
        e[0], e[1] = wrap(q1 - states[j, 0]), wrap(q2 - states[j, 1])
        e[2], e[3] = dq1 - states[j, 2], dq2 - states[j, 3]
        if steps > most or quadratic(e, costs[j]) > track:
            return -1
        u = torques[j]
        for i in range(4):
            u -= gains[j, i] * e[i]
        q1, q2, dq1, dq2 = step_one(q1, q2, dq1, dq2, clip(u, -limit, limit), *constants)
    e[0], e[1] = wrap(q1 - target[0]), wrap(q2 - target[1])
    e[2], e[3] = dq1 - target[2], dq2 - target[3]
    return steps if quadratic(e, cost) < upright else -1


@jitable
def quadratic(e, cost):
    """``e' S e`` of a vector ``e`` (4,) and a matrix ``cost`` (4, 4)."""
    total = 0.0
    for i in range(4):
        row = 0.0
        for j in range(4):
            row += cost[i, j] * e[j]
        total += e[i] * row
    return total


def tracker_stats(tracker: Any) -> dict[str, int]:
    """How many plans the tracker holds, planned, and failed to plan."""
    return {
        "plans": len(tracker.plans),
        "planned": len(tracker.planned),
        "failed": tracker.failed,
    }
