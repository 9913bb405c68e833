"""Trajectory optimisation to upright at rest on the env's exact discrete map (CasADi + IPOPT).

Multiple shooting: every state ``x_0 .. x_N`` and torque ``u_0 .. u_{N-1}`` is a variable, and
the constraints are the physics step ``x_{k+1} = step(x_k, u_k)`` (the one step of
:mod:`acrobot_mj.physics.integrators` on CasADi's symbols: semi-implicit Euler at 0.05 s, or RK4),
``|u_k| <= u_max``, the velocity limits (so the env's clipping never acts), the start hanging at
rest and the end upright at rest; a solution is then checked against the numpy step to 1e-9
(:meth:`Trajectory.check`).

Upright is ``q1 = pi/2`` or ``-3 pi/2`` (a swing either way) with ``q2 = 0`` or ``+-2 pi`` (the
elbow may turn once): six targets, one pose. :func:`min_time` is a multi-start search for the
shortest horizon, an upper bound on the true minimum. CasADi is the ``control`` extra.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.bars import Steps
from acrobot_mj.control.policies import energy_pumping_torque
from acrobot_mj.files import write_json
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING, state_error
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.physics.xp import symbolic

#: Largest difference [rad, rad/s] between a stored state and the model's step of the one
#: before: 1e-9 is ~1e5 times the rounding of one step, and any modelling difference (another
#: integrator, a parameter off by 1e-6) shows at 1e-7 or more.
TOLERANCE = 1e-9
SHIPPED = Path(__file__).resolve().parent / "trajectories"
FORMAT = "acrobot_mj.trajectory"


@dataclass(frozen=True)
class Trajectory:
    """``states`` ``(N + 1, 4)`` [rad, rad/s] and ``torques`` ``(N,)`` [N m], one per physics
    step of ``dt`` [s] under ``method``, with ``|u| <= u_max``, on the model of ``params`` (the
    report's acrobot, or one identified from data: :mod:`acrobot_mj.train.plan`)."""

    states: np.ndarray
    torques: np.ndarray
    dt: float
    method: str
    u_max: float
    params: AcrobotParams = REPORT

    @property
    def steps(self) -> int:
        return len(self.torques)

    @property
    def seconds(self) -> float:
        return self.steps * self.dt

    def residual(self) -> float:
        """Largest gap between each stored state and the model's step of the one before."""
        nxt = integrators.step_states(
            self.states[:-1], self.torques, self.params, method=self.method
        )
        return float(np.abs(nxt - self.states[1:]).max())

    def check(self, tolerance: float = TOLERANCE) -> Trajectory:
        """Raise ValueError naming the first property that fails; returns the trajectory."""
        if self.states.shape != (self.steps + 1, 4) or self.steps < 1:
            raise ValueError(f"a trajectory needs N + 1 states of 4 and N torques, got "
                             f"{self.states.shape} and {self.torques.shape}")  # fmt: skip
        if not (np.isfinite(self.states).all() and np.isfinite(self.torques).all()):
            raise ValueError("the trajectory holds non-finite numbers")
        p = self.params
        if self.dt != p.dt or self.method not in ("semi_implicit_euler", "rk4"):
            raise ValueError(f"the trajectory is for dt={self.dt}, {self.method!r}: not the env's")
        if not 0.0 < self.u_max <= p.max_torque or np.abs(self.torques).max() > self.u_max + 1e-12:
            raise ValueError(f"a torque exceeds u_max={self.u_max} N m (at most {p.max_torque})")
        limits = np.array([p.max_vel1, p.max_vel2])
        if (np.abs(self.states[:, 2:]) > limits + 1e-12).any():
            raise ValueError("a state exceeds the velocity limits")
        end = state_error(self.states[-1])
        if np.abs(self.states[0] - HANGING).max() > tolerance or np.abs(end).max() > tolerance:
            raise ValueError("the trajectory does not go from hanging at rest to upright at rest")
        gap = self.residual()
        if gap > tolerance:
            raise ValueError(f"the trajectory misses the model's step by {gap:.2g} > {tolerance}")
        return self

    def to_dict(self) -> dict[str, Any]:
        model = {} if self.params == REPORT else {"params": asdict(self.params)}
        return {
            "format": FORMAT,
            **model,
            "dt": self.dt,
            "method": self.method,
            "u_max": self.u_max,
            "steps": self.steps,
            "states": self.states.tolist(),  # JSON floats round-trip exactly
            "torques": self.torques.tolist(),
        }

    def save(self, path: str | Path) -> Path:
        """Write the trajectory (checked first) as JSON, atomically."""
        return write_json(path, self.check().to_dict())

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """A stored trajectory, checked (a file that fails any check is refused)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
            if data.get("format") != FORMAT:
                raise ValueError(f"not a trajectory file (format {data.get('format')!r})")
            trajectory = cls(
                np.asarray(data["states"], dtype=float),
                np.asarray(data["torques"], dtype=float),
                float(data["dt"]),
                str(data["method"]),
                float(data["u_max"]),
                AcrobotParams(**data["params"]) if "params" in data else REPORT,
            )
            return trajectory.check()
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as error:
            raise ValueError(f"{path} is not a usable trajectory: {error}") from None


def shipped(name: str) -> Trajectory:
    """A trajectory shipped with the package (``"min_time"`` or ``"reserve"``), checked."""
    path = SHIPPED / f"{name}.json"
    if not path.is_file():
        known = sorted(p.stem for p in SHIPPED.glob("*.json"))
        raise ValueError(f"no shipped trajectory {name!r}; shipped: {known}")
    return Trajectory.load(path)


#: The six upright-at-rest targets (q1, q2, dq1, dq2).
TARGETS = tuple(
    np.array([q1, q2, 0.0, 0.0])
    for q1 in (np.pi / 2, -3 * np.pi / 2)
    for q2 in (0.0, 2 * np.pi, -2 * np.pi)
)
_IPOPT = {"print_level": 0, "max_iter": 3000, "tol": 1e-10, "constr_viol_tol": 1e-12}
#: A trajectory as arrays: states ``(N + 1, 4)`` and torques ``(N,)``.
Arrays = tuple[np.ndarray, np.ndarray]


def symbolic_step(x: Any, u: Any, h: Any, method: str, p: AcrobotParams = REPORT) -> Any:
    """One physics step of ``method`` on CasADi symbols (state ``x`` (4,), torque ``u``, step
    ``h`` [s]): :func:`acrobot_mj.physics.integrators.step` itself, without the limits."""
    import casadi

    code = integrators.method_code(method)
    new = integrators.step(*(x[i] for i in range(4)), u, p.lumped, h, integrators.UNLIMITED,
                           1, code, symbolic())  # fmt: skip
    return casadi.vertcat(*new)


def check_u_max(u_max: Any, p: AcrobotParams = REPORT) -> float:
    if not (isinstance(u_max, (int, float)) and 0.0 < u_max <= p.max_torque):
        raise ValueError(f"u_max must be in (0, {p.max_torque:g}] N m, got {u_max!r}")
    return float(u_max)


@dataclass(frozen=True)
class Optimiser:
    """The NLPs of one model: nominal torques ``|u| <= u_max`` [N m], the step ``method``, the
    model ``p`` (the report's acrobot, or one identified from data)."""

    u_max: float = 1.0
    method: str = "semi_implicit_euler"
    p: AcrobotParams = REPORT

    def __post_init__(self) -> None:
        check_u_max(self.u_max, self.p)

    def problem(self, horizon: int, free_time: bool = False) -> tuple[Any, Any, Any, Any]:
        """The multiple-shooting NLP without its objective and end: ``(opti, states (4, N + 1),
        torques (1, N), step length)`` (the step a variable with ``free_time``)."""
        import casadi

        p, opti = self.p, casadi.Opti()
        xs, us = opti.variable(4, horizon + 1), opti.variable(1, horizon)
        h = opti.variable() if free_time else p.dt
        opti.subject_to(xs[:, 0] == HANGING)
        for k in range(horizon):
            opti.subject_to(xs[:, k + 1] == symbolic_step(xs[:, k], us[0, k], h, self.method, p))
        opti.subject_to(opti.bounded(-self.u_max, us, self.u_max))
        opti.subject_to(opti.bounded(-p.max_vel1, xs[2, :], p.max_vel1))
        opti.subject_to(opti.bounded(-p.max_vel2, xs[3, :], p.max_vel2))
        opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes"}, _IPOPT)
        return opti, xs, us, h

    def solve(
        self, target: np.ndarray, warm: Arrays, objective: str = "feasible", free_time: bool = False
    ) -> tuple[np.ndarray, np.ndarray, float] | None:
        """One NLP of ``len(warm[1])`` steps from the warm start: ``objective`` ``"feasible"``
        (reach ``target`` exactly), ``"effort"`` (reach it with the least ``sum u^2``) or
        ``"closest"`` (the nearest end state). With ``free_time`` the step length is a variable
        and the total time is minimised. The states, torques and step length [s], or None."""
        import casadi

        horizon = len(warm[1])
        opti, xs, us, h = self.problem(horizon, free_time)
        if objective == "closest":
            weights = np.array([1.0, 1.0, 0.3, 0.3])
            opti.minimize(casadi.sumsqr((xs[:, horizon] - target) * weights))
        else:
            opti.subject_to(xs[:, horizon] == target)
            effort = (1.0 if objective == "effort" else 1e-3) * casadi.sumsqr(us)
            opti.minimize(horizon * h + 1e-4 * casadi.sumsqr(us) if free_time else effort)
        if free_time:
            opti.subject_to(opti.bounded(0.5 * self.p.dt, h, 2.5 * self.p.dt))
            opti.set_initial(h, self.p.dt)
        opti.set_initial(xs, warm[0].T)
        opti.set_initial(us, np.clip(warm[1], -self.u_max, self.u_max)[None])
        try:
            solution = opti.solve()
        except RuntimeError:
            if objective != "closest":
                return None
            solution = opti.debug  # the nearest point found is the answer
        step = float(solution.value(h)) if free_time else self.p.dt
        return solution.value(xs).T, np.atleast_1d(solution.value(us)), step

    def pumping(self, horizon: int) -> Arrays:
        """The energy-pumping law (clipped to ``u_max``) rolled out for ``horizon`` steps: a
        dynamically consistent warm start."""
        xs, us = [HANGING.copy()], []
        for _ in range(horizon):
            u = float(np.clip(energy_pumping_torque(xs[-1], p=self.p), -self.u_max, self.u_max))
            xs.append(integrators.step_states(xs[-1], u, self.p))
            us.append(u)
        return np.array(xs), np.array(us)

    def approach(self, target: np.ndarray, warm: Arrays) -> tuple[Arrays | None, Arrays | None]:
        """From ``warm``, the trajectory of its length whose end is closest to ``target`` and, if
        that end is within 0.1 of it, the exact one: ``(near, exact)``, None where not found."""
        near = self.solve(target, warm, "closest")
        if near is None or np.abs(near[0][-1] - target).max() > 0.1:
            return None, None
        exact = self.solve(target, near[:2])
        return near[:2], None if exact is None else exact[:2]

    def shorten(self, target: np.ndarray, start: Arrays) -> Arrays | None:
        """The shortest fixed-step trajectory near ``start``: the free-time optimum of its family
        (the step length a variable, so the swings' phase can adjust), rounded up to whole
        steps."""
        free = self.solve(target, start, free_time=True)
        if free is None:
            return None
        horizon = int(np.ceil(len(start[1]) * free[2] / self.p.dt - 1e-9))
        for steps in range(horizon, horizon + 8):
            found = self.approach(target, resample(free[0], free[1], steps))[1]
            if found is not None:
                return found
        return None

    def candidates(self, horizon: int, target: np.ndarray) -> list[Arrays]:
        """What one warm start gives: from the pumping rollout of ``horizon`` steps, the closest
        end; if it is near ``target``, the exact trajectory of that many steps (where there is
        one) and the shortened one of its family."""
        near, exact = self.approach(target, self.pumping(horizon))
        if near is None:
            return []
        found = [] if exact is None else [exact]
        short = self.shorten(target, exact if found else near)
        return found + ([] if short is None else [short])

    def trajectory(self, path: Arrays) -> Trajectory:
        return Trajectory(path[0], path[1], self.p.dt, self.method, self.u_max, self.p)


def resample(states: np.ndarray, torques: np.ndarray, horizon: int) -> Arrays:
    """A trajectory stretched to ``horizon`` steps (linear in time): a warm start."""
    old, new = np.linspace(0, 1, len(states)), np.linspace(0, 1, horizon + 1)
    xs = np.stack([np.interp(new, old, states[:, i]) for i in range(4)], 1)
    us = np.interp(np.linspace(0, 1, horizon), np.linspace(0, 1, len(torques)), torques)
    return xs, us


def default_horizons(u_max: float) -> range:
    """The start horizons :func:`min_time` tries: 25, four steps apart, from 300 steps at full
    torque and 60 more for every 0.1 N m less (less torque, more swings)."""
    start = 300 + round(600 * (REPORT.max_torque - u_max))
    return range(start, start + 100, 4)


def min_time(
    u_max: float = 1.0,
    method: str = "semi_implicit_euler",
    horizons: range | None = None,
    targets: tuple[np.ndarray, ...] = TARGETS,
    p: AcrobotParams = REPORT,
    progress: bool = False,
) -> Trajectory:
    """The shortest swing-up to upright at rest this multi-start procedure finds: for every start
    horizon (default :func:`default_horizons`) and target, the candidates of
    :meth:`Optimiser.candidates`; the shortest kept (ties: the least effort). A local method:
    an upper bound on the true minimum. ``p``: the model; ``progress``: a bar on stderr."""
    optimiser = Optimiser(u_max, method, p)
    horizons = default_horizons(u_max) if horizons is None else horizons
    best = None
    starts = [(horizon, target) for horizon in horizons for target in targets]
    with Steps(len(starts), "swing-up search", progress, "warm starts") as bar:
        for horizon, target in starts:
            for found in optimiser.candidates(horizon, target):
                if best is None or _cost(found) < _cost(best):
                    best = found
            bar.done("" if best is None else f"best {len(best[1])} steps")
    if best is None:
        raise ValueError(
            f"no swing-up to upright found with u_max={u_max} N m over horizons "
            f"{horizons.start}..{horizons.stop - 1}: try longer horizons"
        )
    return optimiser.trajectory(best)


def _cost(path: Arrays) -> tuple[int, float]:
    return len(path[1]), float(np.sum(path[1] ** 2))


def optimise(
    horizon: int,
    u_max: float = 1.0,
    method: str = "semi_implicit_euler",
    objective: str = "feasible",
    warm: Trajectory | None = None,
) -> Trajectory:
    """A swing-up of exactly ``horizon`` steps to upright at rest with ``|u| <= u_max``
    (``objective`` ``"feasible"`` or ``"effort"``), warm-started from ``warm`` (stretched) or
    the pumping law; an infeasible horizon is an error that says so."""
    if not isinstance(horizon, int) or isinstance(horizon, bool) or horizon < 1:
        raise ValueError(f"horizon must be an integer >= 1 step, got {horizon!r}")
    optimiser = Optimiser(u_max, method)
    if objective not in ("feasible", "effort"):
        raise ValueError(f"objective must be 'feasible' or 'effort', got {objective!r}")
    for target in TARGETS if warm is None else (warm.states[-1],):
        start = (
            optimiser.pumping(horizon)
            if warm is None
            else resample(warm.states, warm.torques, horizon)
        )
        found = optimiser.approach(target, start)[1]
        if found is not None and objective == "effort":
            found = optimiser.solve(target, found, "effort")
        if found is not None:
            return optimiser.trajectory(found[:2]).check()
    raise ValueError(
        f"no trajectory of {horizon} steps ({horizon * REPORT.dt:g} s) to upright at rest with "
        f"|u| <= {u_max:g} N m was found: the horizon is too short, or the warm start too far "
        "(min_time searches over horizons)"
    )


def min_effort(reference: Trajectory, extra_steps: int = 0) -> Trajectory:
    """The least-effort trajectory (``sum u^2``) to the same target as ``reference``, with
    ``extra_steps`` more steps (warm-started from it, stretched)."""
    optimiser = Optimiser(reference.u_max, reference.method, reference.params)
    warm = resample(reference.states, reference.torques, reference.steps + extra_steps)
    result = optimiser.solve(reference.states[-1], warm, "effort")
    if result is None:
        raise ValueError(f"no least-effort trajectory of {len(warm[1])} steps was found")
    return optimiser.trajectory(result[:2])


def shortest_to_height(
    torques: np.ndarray, goal_height: float = 1.0, method: str = "semi_implicit_euler"
) -> Trajectory:
    """The fewest steps in which continuous torques reach the height goal (the tip above
    ``goal_height`` [m] at the last step, at any speed), from a sequence that reaches it:
    shortened a step at a time, each warm-started from the last, while IPOPT finds one. Seeded
    with the {-1, 0, +1} minimum (252 steps), this is how much continuous torque saves."""
    import casadi

    optimiser, p = Optimiser(REPORT.max_torque, method), REPORT
    best = (integrators.simulate(HANGING, torques, method), np.asarray(torques, dtype=float))
    while True:
        horizon = len(best[1]) - 1
        opti, states, us, _ = optimiser.problem(horizon)
        q1, q2 = states[0, horizon], states[1, horizon]
        tip = p.l1 * casadi.sin(q1) + p.l2 * casadi.sin(q1 + q2)
        opti.subject_to(tip >= goal_height + 1e-6)  # strictly above, as the env tests
        opti.minimize(-tip)
        warm = resample(*best, horizon)
        opti.set_initial(states, warm[0].T)
        opti.set_initial(us, warm[1][None])
        try:
            solution = opti.solve()
        except RuntimeError:
            break
        best = (solution.value(states).T, np.atleast_1d(solution.value(us)))
    return optimiser.trajectory(best)
