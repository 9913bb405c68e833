"""Trajectory optimisation to upright at rest, on the env's exact discrete map (CasADi + IPOPT).

Multiple shooting: every state ``x_0 .. x_N`` and torque ``u_0 .. u_{N-1}`` is a variable, and the
constraints are the env's physics step ``x_{k+1} = step(x_k, u_k)`` (semi-implicit Euler at
0.05 s, or RK4), ``|u_k| <= u_max``, the velocity limits (so the env's clipping never acts), the
start hanging at rest and the end upright at rest. The step is built from the same terms as
:mod:`acrobot_mj.physics.dynamics` (``accelerations(..., xp=casadi)``), so a trajectory the solver
finds is checked against the numpy model to 1e-9 (:meth:`Trajectory.check`).

Upright is ``q1 = pi/2`` or ``-3 pi/2`` (a swing either way) with ``q2 = 0`` or ``+-2 pi`` (the
elbow may turn once): six targets, all the same pose. :func:`min_time` is a multi-start search
for the shortest horizon (:func:`min_time`'s docstring states it); its result is an upper bound on
the true minimum. CasADi is an optional dependency: ``pip install acrobot-mj[control]``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from acrobot_mj.bars import Steps
from acrobot_mj.control.energy import energy_pumping_torque
from acrobot_mj.control.model import HANGING, P, step
from acrobot_mj.control.trajectory import Trajectory
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.params import AcrobotParams

#: The six upright-at-rest targets (q1, q2, dq1, dq2).
TARGETS = tuple(
    np.array([q1, q2, 0.0, 0.0])
    for q1 in (np.pi / 2, -3 * np.pi / 2)
    for q2 in (0.0, 2 * np.pi, -2 * np.pi)
)
_IPOPT = {"print_level": 0, "max_iter": 3000, "tol": 1e-10, "constr_viol_tol": 1e-12}


def _casadi() -> Any:
    try:
        import casadi
    except ImportError as error:
        raise ImportError(
            "trajectory optimisation needs CasADi: pip install acrobot-mj[control]"
        ) from error
    return casadi


def symbolic_step(x: Any, u: Any, h: Any, method: str, p: AcrobotParams = P) -> Any:
    """One physics step of ``method`` on CasADi symbols (state ``x`` (4,), torque ``u``, step
    ``h`` [s]), from the same terms as the numpy model."""
    ca = _casadi()

    def derivative(s: Any) -> Any:
        a1, a2 = dynamics.accelerations(s[0], s[1], s[2], s[3], u, p, ca)
        return ca.vertcat(s[2], s[3], a1, a2)

    if method == "semi_implicit_euler":
        a1, a2 = dynamics.accelerations(x[0], x[1], x[2], x[3], u, p, ca)
        v1, v2 = x[2] + h * a1, x[3] + h * a2
        return ca.vertcat(x[0] + h * v1, x[1] + h * v2, v1, v2)
    if method != "rk4":
        raise ValueError(f"method must be 'semi_implicit_euler' or 'rk4', got {method!r}")
    k1 = derivative(x)
    k2 = derivative(x + 0.5 * h * k1)
    k3 = derivative(x + 0.5 * h * k2)
    k4 = derivative(x + h * k3)
    return x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def shooting_problem(
    horizon: int, u_max: float, method: str, free_time: bool = False, p: AcrobotParams = P
) -> tuple[Any, Any, Any, Any]:
    """The multiple-shooting NLP every optimisation here shares, without its objective and end:
    states ``(4, horizon + 1)`` from hanging at rest, torques ``(1, horizon)``, the env's step
    between them, ``|u| <= u_max`` and the velocity limits. Returns ``(opti, states, torques,
    step length)`` (the step a variable with ``free_time``)."""
    ca = _casadi()
    opti = ca.Opti()
    xs, us = opti.variable(4, horizon + 1), opti.variable(1, horizon)
    h = opti.variable() if free_time else p.dt
    opti.subject_to(xs[:, 0] == HANGING)
    for k in range(horizon):
        opti.subject_to(xs[:, k + 1] == symbolic_step(xs[:, k], us[0, k], h, method, p))
    opti.subject_to(opti.bounded(-u_max, us, u_max))
    opti.subject_to(opti.bounded(-p.max_vel1, xs[2, :], p.max_vel1))
    opti.subject_to(opti.bounded(-p.max_vel2, xs[3, :], p.max_vel2))
    return opti, xs, us, h


def solve(
    horizon: int,
    target: np.ndarray,
    warm: tuple[np.ndarray, np.ndarray],
    u_max: float = 1.0,
    method: str = "semi_implicit_euler",
    objective: str = "feasible",
    free_time: bool = False,
    p: AcrobotParams = P,
) -> tuple[np.ndarray, np.ndarray, float] | None:
    """One NLP from the warm start ``(states, torques)``: ``objective`` ``"feasible"`` (reach
    ``target`` exactly), ``"effort"`` (reach it with the least ``sum u^2``) or ``"closest"``
    (the nearest end state, for warm starts that do not yet reach it). With ``free_time`` the
    step length is a variable too and the total time is minimised. Returns the states, torques
    and step length [s], or None if IPOPT finds no solution."""
    ca = _casadi()
    opti, xs, us, h = shooting_problem(horizon, u_max, method, free_time, p)
    effort = ca.sumsqr(us)
    if objective == "closest":
        opti.minimize(ca.sumsqr((xs[:, horizon] - target) * np.array([1.0, 1.0, 0.3, 0.3])))
    else:
        opti.subject_to(xs[:, horizon] == target)
        weight = 1.0 if objective == "effort" else 1e-3
        opti.minimize(horizon * h + 1e-4 * effort if free_time else weight * effort)
    if free_time:
        opti.subject_to(opti.bounded(0.5 * p.dt, h, 2.5 * p.dt))
        opti.set_initial(h, p.dt)
    opti.set_initial(xs, warm[0].T)
    opti.set_initial(us, np.clip(warm[1], -u_max, u_max)[None])
    opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes"}, _IPOPT)
    try:
        solution = opti.solve()
    except RuntimeError:
        if objective != "closest":
            return None
        solution = opti.debug  # the nearest point found is the answer
    step = float(solution.value(h)) if free_time else p.dt
    return solution.value(xs).T, np.atleast_1d(solution.value(us)), step


def pumping_warm_start(horizon: int, u_max: float, p: AcrobotParams = P) -> tuple:
    """The energy-pumping law (clipped to ``u_max``) rolled out for ``horizon`` steps: a
    dynamically consistent start for the solver."""
    x, xs, us = HANGING.copy(), [HANGING.copy()], []
    for _ in range(horizon):
        u = float(np.clip(energy_pumping_torque(x, p=p), -u_max, u_max))
        x = step(x, u, p=p)
        xs.append(x)
        us.append(u)
    return np.array(xs), np.array(us)


def resample(states: np.ndarray, torques: np.ndarray, horizon: int) -> tuple:
    """A trajectory stretched to ``horizon`` steps (linear in time): a warm start."""
    old, new = np.linspace(0, 1, len(states)), np.linspace(0, 1, horizon + 1)
    xs = np.stack([np.interp(new, old, states[:, i]) for i in range(4)], 1)
    us = np.interp(np.linspace(0, 1, horizon), np.linspace(0, 1, len(torques)), torques)
    return xs, us


def approach(
    horizon: int, target: np.ndarray, warm: tuple, u_max: float, method: str, p: AcrobotParams = P
) -> tuple:
    """From ``warm``, the ``horizon``-step trajectory whose end is closest to ``target``, and,
    if that end is within 0.1 of it, the exact one: ``(near, exact)``, each None if not found."""
    near = solve(horizon, target, warm, u_max, method, "closest", p=p)
    if near is None or np.abs(near[0][-1] - target).max() > 0.1:
        return None, None
    exact = solve(horizon, target, near[:2], u_max, method, "feasible", p=p)
    return near[:2], None if exact is None else exact[:2]


def reach(
    horizon: int, target: np.ndarray, warm: tuple, u_max: float, method: str, p: AcrobotParams = P
) -> tuple[np.ndarray, np.ndarray] | None:
    """A trajectory of exactly ``horizon`` steps to ``target`` from ``warm`` (None if
    :func:`approach` finds none)."""
    return approach(horizon, target, warm, u_max, method, p)[1]


def shorten(
    start: tuple[np.ndarray, np.ndarray],
    target: np.ndarray,
    u_max: float,
    method: str,
    p: AcrobotParams = P,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The shortest fixed-step trajectory near ``start`` (one that reaches ``target``, or ends
    near it): the free-time optimum of its family (same steps, the step length a variable, so
    the phase of the swings can adjust), rounded up to whole 0.05 s steps."""
    free = solve(len(start[1]), target, start, u_max, method, "feasible", free_time=True, p=p)
    if free is None:
        return None
    horizon = int(np.ceil(len(start[1]) * free[2] / p.dt - 1e-9))
    for steps in range(horizon, horizon + 8):
        result = reach(steps, target, resample(free[0], free[1], steps), u_max, method, p)
        if result is not None:
            return result
    return None


def candidates(
    horizon: int, target: np.ndarray, u_max: float, method: str, p: AcrobotParams = P
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The trajectories one warm start leads to: from the energy-pumping rollout of
    ``horizon`` steps, the closest end state; if it is near ``target``, the exact trajectory of
    that many steps (where there is one) and the shortened one of its family."""
    warm = pumping_warm_start(horizon, u_max, p)
    near, exact = approach(horizon, target, warm, u_max, method, p)
    if near is None:
        return []
    found = [] if exact is None else [exact]
    short = shorten(exact if found else near, target, u_max, method, p)
    return found + ([] if short is None else [short])


def default_horizons(u_max: float) -> range:
    """The start horizons :func:`min_time` tries: 25, four steps apart, from 300 steps at full
    torque and 60 more for every 0.1 N m less (less torque, more swings)."""
    start = 300 + round(600 * (P.max_torque - u_max))
    return range(start, start + 100, 4)


def min_time(
    u_max: float = 1.0,
    method: str = "semi_implicit_euler",
    horizons: range | None = None,
    targets: tuple[np.ndarray, ...] = TARGETS,
    p: AcrobotParams = P,
    progress: bool = False,
) -> Trajectory:
    """The shortest swing-up to upright at rest found by this multi-start procedure:

    1. for every start horizon in ``horizons`` (default: :func:`default_horizons`) and every
       upright target, warm-start from the
       energy-pumping law rolled out for that horizon and solve for the closest end state;
    2. where it ends within 0.1 of the target: the exact trajectory of that horizon, and the
       free-time optimum of its family rounded up to the fewest whole steps that reach the
       target exactly (:func:`candidates`);
    3. keep the shortest (ties: the least effort).

    A local method: the result is an upper bound on the true minimum. ``p``: the model
    (default the report's acrobot); ``progress``: a bar over the warm starts, on stderr."""
    _check_u_max(u_max, p)
    horizons = default_horizons(u_max) if horizons is None else horizons
    best = None
    starts = [(horizon, target) for horizon in horizons for target in targets]
    with Steps(len(starts), "swing-up search", progress, "warm starts") as bar:
        for horizon, target in starts:
            for found in candidates(horizon, target, u_max, method, p):
                if best is None or _better(found, best):
                    best = found
            bar.done("" if best is None else f"best {len(best[1])} steps")
    if best is None:
        raise ValueError(
            f"no swing-up to upright found with u_max={u_max} N m over horizons "
            f"{horizons.start}..{horizons.stop - 1}: try longer horizons"
        )
    return Trajectory(best[0], best[1], p.dt, method, u_max, p)


def _check_u_max(u_max: Any, p: AcrobotParams = P) -> None:
    if not (isinstance(u_max, (int, float)) and 0.0 < u_max <= p.max_torque):
        raise ValueError(f"u_max must be in (0, {p.max_torque:g}] N m, got {u_max!r}")


def _better(a: tuple, b: tuple) -> bool:
    return (len(a[1]), float(np.sum(a[1] ** 2))) < (len(b[1]), float(np.sum(b[1] ** 2)))


def optimise(
    horizon: int,
    u_max: float = 1.0,
    method: str = "semi_implicit_euler",
    objective: str = "feasible",
    warm: Trajectory | None = None,
) -> Trajectory:
    """A swing-up of exactly ``horizon`` steps to upright at rest with ``|u| <= u_max``
    (``objective`` ``"feasible"`` or ``"effort"``), warm-started from ``warm`` (stretched) or
    from the energy-pumping law; every argument is checked, and an infeasible horizon is an
    error that says so."""
    if not isinstance(horizon, int) or isinstance(horizon, bool) or horizon < 1:
        raise ValueError(f"horizon must be an integer >= 1 step, got {horizon!r}")
    _check_u_max(u_max)
    if objective not in ("feasible", "effort"):
        raise ValueError(f"objective must be 'feasible' or 'effort', got {objective!r}")
    targets = TARGETS if warm is None else (warm.states[-1],)
    for target in targets:
        start = (
            pumping_warm_start(horizon, u_max)
            if warm is None
            else resample(warm.states, warm.torques, horizon)
        )
        found = reach(horizon, target, start, u_max, method)
        if found is not None and objective == "effort":
            found = solve(horizon, target, found, u_max, method, "effort")
        if found is not None:
            return Trajectory(found[0], found[1], P.dt, method, u_max).check()
    raise ValueError(
        f"no trajectory of {horizon} steps ({horizon * P.dt:g} s) to upright at rest with "
        f"|u| <= {u_max:g} N m was found: the horizon is too short, or the warm start too far "
        "(min_time searches over horizons)"
    )


def min_effort(reference: Trajectory, extra_steps: int = 0) -> Trajectory:
    """The least-effort trajectory (``sum u^2``) to the same target as ``reference``, with
    ``extra_steps`` more steps than it (warm-started from it, stretched)."""
    horizon = reference.steps + extra_steps
    warm = resample(reference.states, reference.torques, horizon)
    result = solve(
        horizon,
        reference.states[-1],
        warm,
        reference.u_max,
        reference.method,
        "effort",
        p=reference.params,
    )
    if result is None:
        raise ValueError(f"no least-effort trajectory of {horizon} steps was found")
    return Trajectory(
        result[0], result[1], reference.dt, reference.method, reference.u_max, reference.params
    )


def shortest_to_height(
    torques: np.ndarray, goal_height: float = 1.0, method: str = "semi_implicit_euler"
) -> Trajectory:
    """The fewest steps in which continuous torques reach the height goal (the tip above
    ``goal_height`` [m] at the last step, at any speed), from a sequence that reaches it:
    shortened one step at a time, each warm-started from the last (stretched), while IPOPT
    finds a solution. Seeded with the {-1, 0, +1} minimum (252 steps), this is how much
    continuous torque saves on the learning task."""
    ca = _casadi()
    best = (integrators.simulate(HANGING, torques, method), np.asarray(torques, dtype=float))
    while True:
        horizon = len(best[1]) - 1
        opti, states, us, _ = shooting_problem(horizon, P.max_torque, method)
        q1, q2 = states[0, horizon], states[1, horizon]
        tip = P.l1 * ca.sin(q1) + P.l2 * ca.sin(q1 + q2)
        opti.subject_to(tip >= goal_height + 1e-6)  # strictly above, as the env tests
        opti.minimize(-tip)
        warm = resample(*best, horizon)
        opti.set_initial(states, warm[0].T)
        opti.set_initial(us, warm[1][None])
        opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes"}, _IPOPT)
        try:
            solution = opti.solve()
        except RuntimeError:
            break
        best = (solution.value(states).T, np.atleast_1d(solution.value(us)))
    return Trajectory(best[0], best[1], P.dt, method, P.max_torque)
