"""The global test's bound: an estimate of the most uptime any controller within the torque
limit could reach in a drawn episode. It takes the arm upright at rest as each reset begins
(the better of ``theta1 = pi`` and ``-pi`` for the reset's PID), runs the reset as the protocol
does, and counts the arm up from the fastest return to "up" (the tip's height, not a balance)
the trajectory optimiser finds, to the next reset; before the first reset, from hanging at
rest. It is an estimate, not a proof, in two ways: the returns are local optima (several warm
starts, each checked on the env's own steps), so the true minimum may be shorter; and an arm
not upright as a reset begins could in principle be left better placed by it."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.olympics import protocol
from acrobot_mj.olympics.episodes import global_run
from acrobot_mj.olympics.protocol import GLOBAL, GlobalPolicy, from_protocol, to_protocol
from acrobot_mj.olympics.scores import is_up
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT
from acrobot_mj.physics.integrators import ENV_INTEGRATORS
from acrobot_mj.physics.models import AcrobotModel, resolve

#: The acrobot the bound is measured on (:func:`check_model`).
MEASURED = "ai_olympics"
#: The knots of the minimum-time problem (its step is the free time over them).
KNOTS = 30
#: Above the protocol's height [m] the problem's end must reach: the check on the env's own
#: steps then reaches the height itself despite the coarser knots.
MARGIN = 1e-3
#: The warm starts' horizon [fraction of the resets' gap] and their torques: full torque with 0,
#: 1 or 2 switches evenly spaced (bang-bang, as a minimum-time optimum is), each sign first.
WARM_TIME, WARM_SWITCHES = 0.1, (0, 1, 2)
#: Upright at rest in the protocol's convention, the two windings a controller may hold it at:
#: ``theta1 = pi`` and ``-pi``.
WINDINGS = (to_protocol(UPRIGHT), to_protocol(UPRIGHT) - [2 * math.pi, 0.0, 0.0, 0.0])


@dataclass(frozen=True)
class Returns:
    """The fastest returns to "up" on ``model`` in ``policy``'s episodes: a CasADi function
    from a start state (ours) and a warm start to the free time and torques of
    :data:`KNOTS` knots, each answer checked on the env's steps."""

    model: AcrobotModel
    policy: GlobalPolicy = GLOBAL

    @property
    def method(self) -> str:
        return ENV_INTEGRATORS[self.model.integrator]

    @cached_property
    def _solve(self) -> Any:
        import casadi

        from acrobot_mj.control.trajopt import IPOPT, symbolic_step

        p, g = self.model.params, self.policy
        opti = casadi.Opti()
        xs, us, seconds = opti.variable(4, KNOTS + 1), opti.variable(1, KNOTS), opti.variable()
        start = opti.parameter(4)
        x, u, h = casadi.SX.sym("x", 4), casadi.SX.sym("u"), casadi.SX.sym("h")
        step = casadi.Function("step", [x, u, h], [symbolic_step(x, u, h, self.method, p)])
        opti.subject_to(xs[:, 0] == start)
        opti.subject_to(xs[:, 1:] == step.map(KNOTS)(xs[:, :-1], us, seconds / KNOTS))
        opti.subject_to(opti.bounded(-p.max_torque, us, p.max_torque))
        for row, limit in ((2, p.max_vel1), (3, p.max_vel2)):
            if limit < math.inf:
                opti.subject_to(opti.bounded(-limit, xs[row, :], limit))
        opti.subject_to(opti.bounded(g.dt, seconds, self.gap))
        q1, q2 = xs[0, KNOTS], xs[1, KNOTS]
        tip = p.l1 * casadi.sin(q1) + p.l2 * casadi.sin(q1 + q2)
        opti.subject_to(tip >= g.height * (p.l1 + p.l2) + MARGIN)
        opti.minimize(seconds)
        opti.solver(
            "ipopt",
            {"print_time": False, "ipopt.sb": "yes", "expand": True, "error_on_fail": False},
            {**IPOPT, "max_iter": 300},
        )
        return opti.to_function("fastest", [start, xs, us, seconds], [seconds, us])

    @property
    def gap(self) -> float:
        """The resets' spacing [s]: no return longer than it counts."""
        return self.policy.t_final / (self.policy.resets + 1)

    def steps(self, start: np.ndarray) -> int | None:
        """The fewest env steps found from ``start`` (ours) to a state up (0: up already;
        None: none found within :attr:`gap`)."""
        p = self.model.params
        if self._up(start[None])[0]:
            return 0
        best, seconds = None, WARM_TIME * self.gap
        coarse = dataclasses.replace(p, dt=seconds / KNOTS)
        for switches in WARM_SWITCHES:
            pattern = (-1.0) ** (np.arange(KNOTS) * (switches + 1) // KNOTS)
            for sign in (1.0, -1.0):
                torques = sign * p.max_torque * pattern
                warm = integrators.simulate(start, torques, self.method, coarse, limits=False)
                found, us = self._solve(start, warm.T, torques[None], seconds)
                steps = self._checked(start, float(found), np.ravel(np.array(us)))
                if steps is not None and (best is None or steps < best):
                    best = steps
        return best

    def _up(self, states: np.ndarray) -> np.ndarray:
        p = self.model.params
        return is_up(to_protocol(states), p.l1, p.l2, self.policy.height)

    def _checked(self, start: np.ndarray, seconds: float, torques: np.ndarray) -> int | None:
        """The first env step at which the knots' torques, held over the env's steps, have the
        tip up (None: never within :attr:`gap`)."""
        p = self.model.params
        if not (math.isfinite(seconds) and np.isfinite(torques).all()):
            return None
        n = integrators.steps_in(min(seconds, self.gap), p.dt)
        knot = np.minimum((np.arange(n) * p.dt / (seconds / KNOTS)).astype(int), KNOTS - 1)
        held = np.clip(torques[knot], -p.max_torque, p.max_torque)
        states = integrators.simulate(start, held, self.method, p)
        up = np.flatnonzero(self._up(states))
        return int(up[0]) if up.size else None


class _Still(Controller):
    """No torque; the times [s] at which it was asked."""

    def __init__(self) -> None:
        self.times: list[float] = []

    def act(self, x: np.ndarray, t: float) -> float:
        self.times.append(t)
        return 0.0


def reset_from_upright(
    model: str, target: np.ndarray, policy: GlobalPolicy = GLOBAL
) -> list[tuple[np.ndarray, np.ndarray]]:
    """For each upright winding (:data:`WINDINGS`): which of the rows of a reset to ``target``
    (protocol convention) that begins upright at rest have the tip up, from its first row on,
    and the state (ours) where the controller takes over."""
    lasts = dataclasses.replace(policy, t_final=policy.reset_length + 20 * policy.dt)
    times = protocol.episode_times(lasts.t_final, lasts.dt)
    p, found = resolve(model).params, []
    for upright in WINDINGS:
        still = _Still()
        run = global_run(
            still, model, np.asarray(target)[None], times[1:2], lasts, start=from_protocol(upright)
        )
        back = times.tolist().index(still.times[1])  # the row the controller acts again
        up = is_up(to_protocol(run.X[1:back]), p.l1, p.l2, policy.height)
        found.append((up, run.X[back]))
    return found


def check_model(model: str) -> None:
    """Refuse, in one line, an acrobot the bound is not measured on: its returns are planned on
    :data:`KNOTS` knots and checked on :data:`MEASURED`'s steps only."""
    if model != MEASURED:
        raise ValueError(
            f"the global test's bound is measured on {MEASURED}, not {model!r}: its returns "
            f"are planned on {KNOTS} knots, checked on {MEASURED}'s steps only"
        )


@dataclass(frozen=True)
class Bound:
    """The bound on one drawn episode: ``uptime`` [s], ``score`` (uptime over the episode's
    length) and the ``returns`` [s] found, from hanging and after each reset (None: none found,
    and the arm counted up at once, so that the bound stays one)."""

    uptime: float
    score: float
    returns: tuple[float | None, ...]

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def uptime_bound(model: str, seed: int, policy: GlobalPolicy = GLOBAL) -> Bound:
    """The bound on the uptime of ``policy``'s episode of ``seed`` on ``model``."""
    check_model(model)
    acrobot = resolve(model)
    targets, reset_times = policy.draw(seed)
    times = protocol.episode_times(policy.t_final, policy.dt)
    rows = len(times) - 1  # the rows the score counts (the last state is not one)
    begins = [int(np.searchsorted(times, r, side="left")) for r in reset_times] + [rows]
    returns = Returns(acrobot, policy)
    up = np.zeros(rows, dtype=bool)
    first = returns.steps(HANGING)
    up[first or 0 : begins[0]] = True  # none found: up at once, so the bound stays one
    found: list[float | None] = [None if first is None else first * policy.dt]
    for k, begin in enumerate(begins[:-1]):
        best: tuple[bool, int] = (False, -1)
        best_rows, best_steps = None, None
        for during, end in reset_from_upright(model, targets[k], policy):
            back = begin + len(during)  # the row where the controller acts again
            steps = returns.steps(end)
            candidate = np.zeros(rows, dtype=bool)
            candidate[begin:back] = during[: max(0, rows - begin)]
            candidate[back + (steps or 0) : begins[k + 1]] = True
            # A winding with a return found beats one without (up at once only where neither
            # finds one), then the more rows up.
            if (steps is not None, int(candidate.sum())) > best:
                best, best_rows, best_steps = (
                    (steps is not None, int(candidate.sum())),
                    candidate,
                    steps,
                )
        up |= best_rows
        found.append(None if best_steps is None else best_steps * policy.dt)
    up[0] = False  # row 0 counts no time
    uptime = float(np.sum(np.diff(times[:rows], prepend=0.0)[up]))
    return Bound(uptime, uptime / policy.t_final, tuple(found))
