"""The swing-up the AI Olympics entries follow on ``ai_olympics``, planned from an acrobot's
parameters alone for the protocol's performance criteria (:func:`performance_swing_up`; shipped
as :data:`~acrobot_mj.control.planned.PLANNED`'s); the entries built on it are
:mod:`acrobot_mj.olympics.entries`."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from acrobot_mj.control.trajopt import IPOPT, Trajectory, solve_or_none
from acrobot_mj.identify.library import LibraryModel
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT
from acrobot_mj.physics.models import AcrobotModel
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.physics.xp import symbolic

#: The performance criteria's normalisers (the protocol's v2: J, N^2 m^2 s, N m, rad^2/s).
NORMS = {"energy": 60.0, "torque_cost": 20.0, "smoothness": 0.1, "velocity_cost": 400.0}
#: The length [s] of the swing-up planned on a learnt model: ``ai_olympics``' plan's, 200
#: decisions of 0.01 s.
SECONDS = 2.0
#: IPOPT's options on a learnt model: the exact Hessian of its 121 terms over 200 decisions
#: (with the criteria's dense couplings) took over 4 GB and 10 minutes without an iteration,
#: so a limited-memory one, and a looser tolerance (TVLQR absorbs the rest).
LEARNT = {
    **IPOPT,
    "hessian_approximation": "limited-memory",
    "tol": 1e-6,
    "acceptable_tol": 1e-4,
    "acceptable_iter": 10,
}


def _objective(xs: Any, us: Any, h: float, samples: int) -> Any:
    """The performance score's criteria but the swing-up time, each as ``tanh(pi c / n)``,
    smoothed where it has a kink (``|x|`` and the standard deviation at 0)."""
    import casadi

    moved = xs[1, 1:] - xs[1, :-1]
    criteria = {
        "energy": casadi.sum2(casadi.sqrt((moved * us) ** 2 + 1e-6)),
        "torque_cost": casadi.sumsqr(us) * h,
        "smoothness": casadi.sqrt(casadi.sumsqr(us[0, 1:] - us[0, :-1]) / samples + 1e-8),
        "velocity_cost": casadi.sumsqr(xs[2:, :]) * h,
    }
    return sum(casadi.tanh(math.pi * c / NORMS[k]) for k, c in criteria.items())


def planned_torques(
    step: Any, limit: float, h: float, samples: int, decisions: int, options: Any = IPOPT
) -> np.ndarray:
    """The ``decisions`` torques [N m] within ``limit`` of a swing-up from hanging at rest to
    upright at rest on ``step`` (a CasADi function ``(x, u) -> x'`` of one decision of ``h``
    [s]) that minimise the protocol's performance criteria (energy, torque cost, smoothness
    over an episode of ``samples`` steps, velocity cost). IPOPT (its ``options``) from a
    straight line at tiny random torques; ValueError where it finds none."""
    import casadi

    opti = casadi.Opti()
    xs, us = opti.variable(4, decisions + 1), opti.variable(1, decisions)
    opti.subject_to(xs[:, 0] == HANGING)
    opti.subject_to(xs[:, 1:] == step.map(decisions)(xs[:, :-1], us))
    opti.subject_to(opti.bounded(-limit, us, limit))
    opti.subject_to(xs[:, decisions] == UPRIGHT)
    opti.minimize(_objective(xs, us, h, samples))
    opti.set_initial(xs, np.linspace(HANGING, UPRIGHT, decisions + 1).T)
    rng = np.random.default_rng(decisions)
    opti.set_initial(us, 0.1 * rng.standard_normal((1, decisions)))
    opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes", "expand": True}, options)
    solution = solve_or_none(opti)
    if solution is None:
        raise ValueError(f"IPOPT found no swing-up in {decisions} decisions of {h:g} s")
    return np.atleast_1d(solution.value(us))


def performance_swing_up(
    model: AcrobotModel, decisions: int = 200, hold: int = 5, seconds: float = 10.0
) -> Trajectory:
    """:func:`planned_torques` in ``decisions`` torques, each held for ``hold`` physics steps,
    on the physics steps of ``model`` (its integrator) over an episode of ``seconds``, so a
    tracking controller follows it exactly."""
    import casadi

    p, method = model.analytic, integrators.ENV_INTEGRATORS[model.integrator]
    code, h = integrators.method_code(method), p.dt * hold
    x, u = casadi.SX.sym("x", 4), casadi.SX.sym("u")
    new = integrators.step(
        *(x[i] for i in range(4)), u, p.lumped, p.dt, integrators.UNLIMITED, hold, code, symbolic()
    )
    step = casadi.Function("step", [x, u], [casadi.vertcat(*new)])
    held = planned_torques(
        step, p.max_torque, h, integrators.steps_in(seconds, p.dt) - 1, decisions
    )
    torques = np.repeat(held, hold)
    states = integrators.simulate(HANGING.copy(), torques, method, p)
    return Trajectory(states, torques, p.dt, method, p.max_torque, p)


def learnt_swing_up(
    model: LibraryModel, limits: AcrobotParams, physics_dt: float, seconds: float = 10.0
) -> Trajectory:
    """:func:`planned_torques` on a learnt ``model`` of one decision of ``limits.dt`` [s] (its
    action and velocity bounds), in the decisions of 2 s, scored over an episode of
    ``seconds`` in steps of ``physics_dt`` [s]; the plan rolled out on the learnt model (the
    model the tracker follows it on)."""
    import casadi

    decisions = integrators.steps_in(SECONDS, limits.dt)
    x, u = casadi.SX.sym("x", 4), casadi.SX.sym("u")
    step = casadi.Function("step", [x, u], [model.function(x, u, 0.0)])
    samples = integrators.steps_in(seconds, physics_dt) - 1
    torques = planned_torques(step, limits.max_torque, limits.dt, samples, decisions, LEARNT)
    states = [HANGING.copy()]
    for torque in torques:
        states.append(np.asarray(model.step(states[-1], float(torque)), dtype=float))
    return Trajectory(np.array(states), torques, limits.dt, "learned", limits.max_torque, limits)
