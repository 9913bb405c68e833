"""Trajectory optimisation to upright at rest (``q1 = pi/2`` or ``-3 pi/2``, ``q2 = 0`` or
``+-2 pi``) on the env's exact discrete map: multiple shooting with CasADi and IPOPT (the
``control`` extra); :func:`min_time` searches many starts for the shortest horizon."""

from __future__ import annotations

import contextlib
import json
import math
import signal
import sys
import threading
from dataclasses import asdict, dataclass
from itertools import starmap
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
from acrobot_mj.pool import WorkerPool

#: Largest gap [rad, rad/s] between a stored state and the step of the one before (far above
#: rounding, far below any modelling difference).
TOLERANCE = 1e-9
SHIPPED = Path(__file__).resolve().parent / "trajectories"
FORMAT = "acrobot_mj.trajectory"


@dataclass(frozen=True)
class Trajectory:
    """``states`` ``(N + 1, 4)`` [rad, rad/s] and ``torques`` ``(N,)`` [N m], one per physics
    step of ``dt`` [s] under ``method``, with ``|u| <= u_max``, on the model ``params``."""

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
        p, method = self.params, self.method
        nxt = integrators.step_states(self.states[:-1], self.torques, p, method=method)
        return float(np.abs(nxt - self.states[1:]).max())

    def check(self, tolerance: float = TOLERANCE) -> Trajectory:
        """Raise ValueError naming the first property that fails; returns the trajectory."""
        if self.states.shape != (self.steps + 1, 4) or self.steps < 1:
            raise ValueError(
                f"a trajectory needs N + 1 states of 4 and N torques, got "
                f"{self.states.shape} and {self.torques.shape}"
            )
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
        # JSON has no infinity: an unbounded speed is stored as null.
        params = {k: None if v == math.inf else v for k, v in asdict(self.params).items()}
        model = {} if self.params == REPORT else {"params": params}
        return {
            "format": FORMAT,
            **model,
            "dt": self.dt,
            "method": self.method,
            "u_max": self.u_max,
            "steps": self.steps,
            "states": self.states.tolist(),
            "torques": self.torques.tolist(),
        }

    def save(self, path: str | Path, tolerance: float = TOLERANCE) -> Path:
        """Write the trajectory, checked to ``tolerance``, as JSON."""
        return write_json(path, self.check(tolerance).to_dict())

    @classmethod
    def load(cls, path: str | Path, tolerance: float = TOLERANCE) -> Trajectory:
        """A stored trajectory; ValueError if it fails any check (to ``tolerance``)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
            if data.get("format") != FORMAT:
                raise ValueError(f"not a trajectory file (format {data.get('format')!r})")
            states = np.asarray(data["states"], dtype=float)
            torques = np.asarray(data["torques"], dtype=float)
            dt, method, u_max = float(data["dt"]), str(data["method"]), float(data["u_max"])
            stored = data.get("params")
            params = (
                AcrobotParams(**{k: math.inf if v is None else v for k, v in stored.items()})
                if stored is not None
                else REPORT
            )
            return cls(states, torques, dt, method, u_max, params).check(tolerance)
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as error:
            raise ValueError(f"{path} is not a usable trajectory: {error}") from None


def shipped(name: str, folder: Path = SHIPPED, what: str = "shipped trajectory") -> Trajectory:
    """A trajectory shipped with the package in ``folder`` (here: ``"min_time"`` or
    ``"reserve"``); ``what`` names it in the error for an unknown ``name``."""
    path = folder / f"{name}.json"
    if not path.is_file():
        known = sorted(p.stem for p in folder.glob("*.json"))
        raise ValueError(f"no {what} {name!r}; there are: {known}")
    return Trajectory.load(path)


#: The six upright-at-rest targets (q1, q2, dq1, dq2).
TARGETS = tuple(
    np.array([q1, q2, 0.0, 0.0])
    for q1 in (np.pi / 2, -3 * np.pi / 2)
    for q2 in (0.0, 2 * np.pi, -2 * np.pi)
)
IPOPT = {"print_level": 0, "max_iter": 3000, "tol": 1e-10, "constr_viol_tol": 1e-12}
#: A trajectory as arrays: states ``(N + 1, 4)`` and torques ``(N,)``.
Arrays = tuple[np.ndarray, np.ndarray]


def solve_or_none(opti: Any) -> Any:
    """``opti.solve()``'s solution, or None where IPOPT finds none. A Ctrl-C or SIGTERM during
    the solve is raised after it: IPOPT stops on the exception its handler raises, but reports
    it as a failed solve, which a multi-start search would pass over."""
    caught: list[BaseException] = []

    def keeping(handler: Any) -> Any:
        def handle(signum: int, frame: Any) -> None:
            try:
                handler(signum, frame)
            except BaseException as error:
                caught.append(error)
                raise

        return handle

    class Stderr:  # after a stop, CasADi warns of it (in pieces); the caller says it in one line
        def __init__(self, stream: Any) -> None:
            self.stream = stream

        def write(self, text: str) -> int:
            return len(text) if caught else self.stream.write(text)

        def __getattr__(self, name: str) -> Any:
            return getattr(self.stream, name)

    kept = {}
    if threading.current_thread() is threading.main_thread():
        kept = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
        for s, handler in kept.items():
            if callable(handler):
                signal.signal(s, keeping(handler))
    stderr, sys.stderr = sys.stderr, Stderr(sys.stderr)
    try:
        solution = opti.solve()
    except RuntimeError:
        solution = None
    finally:
        sys.stderr = stderr
        for s, handler in kept.items():
            signal.signal(s, handler)
    if caught:
        raise caught[0]
    return solution


def symbolic_step(x: Any, u: Any, h: Any, method: str, p: AcrobotParams = REPORT) -> Any:
    """The physics step on CasADi symbols (torque ``u`` [N m], step ``h`` [s]), no limits."""
    import casadi

    code = integrators.method_code(method)
    new = integrators.step(
        *(x[i] for i in range(4)), u, p.lumped, h, integrators.UNLIMITED, 1, code, symbolic()
    )
    return casadi.vertcat(*new)


@dataclass(frozen=True)
class Optimiser:
    """The NLPs of one model ``p``: torques ``|u| <= u_max`` [N m], the step ``method``; or of a
    learnt ``model`` (its CasADi ``function``; ``p`` then gives only the limits and ``dt``),
    from ``start`` (default: hanging at rest)."""

    u_max: float = 1.0
    method: str = "semi_implicit_euler"
    p: AcrobotParams = REPORT
    model: Any = None
    start: tuple[float, ...] = tuple(float(v) for v in HANGING)

    def __post_init__(self) -> None:
        u_max, top = self.u_max, self.p.max_torque
        if not (isinstance(u_max, (int, float)) and 0.0 < u_max <= top):
            raise ValueError(f"u_max must be in (0, {top:g}] N m, got {u_max!r}")

    def problem(self, horizon: int, free_time: bool = False) -> tuple[Any, Any, Any, Any]:
        """``(opti, states (4, N + 1), torques (1, N), step [s])``, without objective and end."""
        import casadi

        p, opti = self.p, casadi.Opti()
        xs, us = opti.variable(4, horizon + 1), opti.variable(1, horizon)
        h = opti.variable() if free_time else p.dt
        opti.subject_to(xs[:, 0] == np.array(self.start))
        # One step function, mapped over the horizon: the graph is built once, not N times.
        if self.model is not None:
            if free_time:
                raise ValueError("a learnt model has one step: it cannot free the time")
            step = self.model.function
        else:
            x, u, dt = casadi.SX.sym("x", 4), casadi.SX.sym("u"), casadi.SX.sym("h")
            step = casadi.Function("step", [x, u, dt], [symbolic_step(x, u, dt, self.method, p)])
        opti.subject_to(xs[:, 1:] == step.map(horizon)(xs[:, :-1], us, h))
        opti.subject_to(opti.bounded(-self.u_max, us, self.u_max))
        opti.subject_to(opti.bounded(-p.max_vel1, xs[2, :], p.max_vel1))
        opti.subject_to(opti.bounded(-p.max_vel2, xs[3, :], p.max_vel2))
        # expand: the NLP as SX, whose derivatives evaluate about 3x faster than MX's (one warm
        # start of the search: 44 s -> 14 s, the same trajectory).
        opti.solver("ipopt", {"print_time": False, "ipopt.sb": "yes", "expand": True}, IPOPT)
        return opti, xs, us, h

    def solve(
        self, target: np.ndarray, warm: Arrays, objective: str = "feasible", free_time: bool = False
    ) -> tuple[np.ndarray, np.ndarray, float] | None:
        """States, torques and step [s] from ``warm`` (None if none): reach ``target``
        (``"feasible"``), or end nearest it (``"closest"``)."""
        import casadi

        horizon = len(warm[1])
        opti, xs, us, h = self.problem(horizon, free_time)
        if objective == "closest":
            weights = np.array([1.0, 1.0, 0.3, 0.3])
            opti.minimize(casadi.sumsqr((xs[:, horizon] - target) * weights))
        else:
            opti.subject_to(xs[:, horizon] == target)
            effort = 1e-3 * casadi.sumsqr(us)
            opti.minimize(horizon * h + 1e-4 * casadi.sumsqr(us) if free_time else effort)
        if free_time:
            opti.subject_to(opti.bounded(0.5 * self.p.dt, h, 2.5 * self.p.dt))
            opti.set_initial(h, self.p.dt)
        opti.set_initial(xs, warm[0].T)
        opti.set_initial(us, np.clip(warm[1], -self.u_max, self.u_max)[None])
        solution = solve_or_none(opti)
        if solution is None:
            if objective != "closest":
                return None
            solution = opti.debug  # the nearest point found is the answer
        step = float(solution.value(h)) if free_time else self.p.dt
        return solution.value(xs).T, np.atleast_1d(solution.value(us)), step

    def pumping(self, horizon: int) -> Arrays:
        """The energy-pumping law rolled out for ``horizon`` steps: a warm start."""
        xs, us = [HANGING.copy()], []
        for _ in range(horizon):
            u = float(np.clip(energy_pumping_torque(xs[-1], p=self.p), -self.u_max, self.u_max))
            xs.append(integrators.step_states(xs[-1], u, self.p))
            us.append(u)
        return np.array(xs), np.array(us)

    def reach(self, target: np.ndarray, warm: Arrays) -> tuple[Arrays, Arrays | None]:
        """``(nearest to target, exact if the nearest ends within`` :data:`NEAR` ``of it)``, the
        exact None where not found."""
        near = self.solve(target, warm, "closest")
        assert near is not None  # "closest" answers with the nearest point IPOPT found
        if miss(near[0], target) > NEAR:
            return near[:2], None
        exact = self.solve(target, near[:2])
        return near[:2], None if exact is None else exact[:2]

    def approach(self, target: np.ndarray, warm: Arrays) -> tuple[Arrays | None, Arrays | None]:
        """``(nearest to target, exact if the nearest is within`` :data:`NEAR` ``)``, None where
        not found."""
        near, exact = self.reach(target, warm)
        return (None, None) if miss(near[0], target) > NEAR else (near, exact)

    def shorten(self, target: np.ndarray, start: Arrays) -> Arrays | None:
        """The free-time optimum near ``start``, rounded up to whole steps."""
        free = self.solve(target, start, free_time=True)
        if free is None:
            return None
        horizon = integrators.steps_in(len(start[1]) * free[2], self.p.dt)
        for steps in range(horizon, horizon + 8):
            found = self.approach(target, resample(free[0], free[1], steps))[1]
            if found is not None:
                return found
        return None

    def tiny_torques(self, horizon: int) -> Arrays:
        """A rollout from ``start`` of ``horizon`` steps of torques ``N(0, 0.01^2)`` N m, drawn from
        the horizon alone, on the model: almost at rest, a warm start that commits to no way of
        swinging."""
        torques = 0.01 * np.random.default_rng([0, horizon]).standard_normal(horizon)
        if self.model is None:
            return integrators.simulate(np.array(self.start), torques, self.method, self.p), torques
        states = [np.array(self.start)]
        for u in torques:
            states.append(self.model.step(states[-1], u))
        return np.array(states), torques

    def candidates(self, horizon: int, target: np.ndarray, starts: str = "rest") -> list[Arrays]:
        """The exact and shortened trajectories from the ``starts`` rollout (``"rest"`` or
        ``"pumping"``) of ``horizon`` steps."""
        warm = self.tiny_torques(horizon) if starts == "rest" else self.pumping(horizon)
        near, exact = self.approach(target, warm)
        if near is None:
            return []
        found = [] if exact is None else [exact]
        short = self.shorten(target, near if exact is None else exact)
        return found + ([] if short is None else [short])

    def trajectory(self, path: Arrays) -> Trajectory:
        return Trajectory(path[0], path[1], self.p.dt, self.method, self.u_max, self.p)


#: How near [rad, rad/s] the nearest path must end to the target for the exact solve to start
#: from it.
NEAR = 0.1


def miss(states: np.ndarray, target: np.ndarray) -> float:
    """How far the path ``states`` ends from ``target``: the largest difference."""
    return float(np.abs(states[-1] - target).max())


def waiting(states: np.ndarray, torques: np.ndarray, horizon: int) -> Arrays:
    """The path stretched to ``horizon`` steps by first waiting at its start with zero torque:
    as feasible as the path where its start is a rest point (a warm start for a longer plan)."""
    wait = horizon - len(torques)
    return np.vstack([np.repeat(states[:1], wait, axis=0), states]), np.concatenate(
        [np.zeros(wait), torques]
    )


def resample(states: np.ndarray, torques: np.ndarray, horizon: int) -> Arrays:
    """A trajectory stretched to ``horizon`` steps (linear in time)."""
    old, new = np.linspace(0, 1, len(states)), np.linspace(0, 1, horizon + 1)
    xs = np.stack([np.interp(new, old, states[:, i]) for i in range(4)], 1)
    us = np.interp(np.linspace(0, 1, horizon), np.linspace(0, 1, len(torques)), torques)
    return xs, us


#: The warm starts of a search: near rest (the default) or the energy-pumping law.
STARTS = ("rest", "pumping")


def default_horizons(u_max: float, starts: str = "rest") -> range:
    """The start horizons [steps]: from rest, two, 40 apart, from 380 steps at full torque (60
    more at 0.8 N m); pumping, 25 from 300 steps at full torque, 60 more per 0.1 N m less."""
    if starts == "rest":
        first = 380 + round(300 * (REPORT.max_torque - u_max))
        return range(first, first + 80, 40)
    start = 300 + round(600 * (REPORT.max_torque - u_max))
    return range(start, start + 100, 4)


#: Longer ranges of start horizons a search with the default ones tries before it gives up.
LONGER = 3


def longer_horizons(u_max: float, starts: str = "rest") -> list[range]:
    """The default start horizons [steps], then :data:`LONGER` ranges after them, each as
    long."""
    first = default_horizons(u_max, starts)
    shift = len(first) * first.step
    return [
        range(first.start + k * shift, first.stop + k * shift, first.step)
        for k in range(LONGER + 1)
    ]


def _candidates(
    optimiser: Optimiser, horizon: int, target: np.ndarray, starts: str
) -> list[Arrays]:
    return optimiser.candidates(horizon, target, starts)


@dataclass(frozen=True)
class WarmStarts:
    """Where a minimum-time search starts its solves: ``starts`` near rest or along the
    energy-pumping law (:data:`STARTS`), each of ``horizons`` [steps] (None:
    :func:`default_horizons`) to each of ``targets`` (None: from rest the three with
    ``q1 = pi/2``, whose mirror images are the other three; pumping, all of :data:`TARGETS`)."""

    starts: str = "rest"
    horizons: range | None = None
    targets: tuple[np.ndarray, ...] | None = None

    def __post_init__(self) -> None:
        if self.starts not in STARTS:
            raise ValueError(f"starts must be one of {STARTS}, got {self.starts!r}")


def min_time(
    u_max: float = 1.0,
    method: str = "semi_implicit_euler",
    *,
    warm: WarmStarts = WarmStarts(),
    p: AcrobotParams = REPORT,
    progress: bool = False,
    jobs: int = 2,
) -> Trajectory:
    """The shortest swing-up found from every :class:`WarmStarts` (start, horizon and target;
    ties: the least effort), an upper bound on the minimum, over ``jobs`` processes;
    ``progress``: a bar on stderr. From rest it tries the three targets with ``q1 = pi/2``: the
    swing-ups to the other three are their mirror images. Where the default horizons find none,
    it tries :data:`LONGER` ranges after them, each as long. Times and lengths found:
    docs/guide/balance.md."""
    starts, horizons, targets = warm.starts, warm.horizons, warm.targets
    optimiser = Optimiser(u_max, method, p)
    tries = [horizons] if horizons is not None else longer_horizons(u_max, starts)
    if targets is None:
        targets = TARGETS[:3] if starts == "rest" else TARGETS
    for tried in tries:
        work = [(optimiser, horizon, target, starts) for horizon in tried for target in targets]
        best = _search(work, jobs, progress)
        if best is not None:
            return optimiser.trajectory(best)
    raise ValueError(
        f"no swing-up to upright found with u_max={u_max} N m over horizons "
        f"{tries[0].start}..{tries[-1].stop - 1}: give longer ones (WarmStarts' horizons; "
        "train --preset balance --horizons START:STOP:STEP)"
    )


def _search(work: list[tuple[Optimiser, int, np.ndarray, str]], jobs: int, progress: bool) -> Any:
    """The best of each start's candidates (None if there are none), on ``jobs`` processes
    where there are several; a bar on stderr with ``progress``."""
    best = None
    jobs = min(jobs, len(work))
    # A stop kills the workers: an IPOPT solve runs in C for seconds and has nothing to save.
    pool = WorkerPool(jobs, terminate=True) if jobs > 1 else None
    with (
        pool or contextlib.nullcontext(),
        Steps(len(work), "swing-up search", progress, "warm starts") as bar,
    ):
        found_each = starmap(_candidates, work) if pool is None else pool.map(_candidates, work)
        for found_here in found_each:  # in order: the same best every time
            for found in found_here:
                if best is None or _cost(found) < _cost(best):
                    best = found
            bar.done("" if best is None else f"best {len(best[1])} steps")
    return best


def _cost(path: Arrays) -> tuple[int, float]:
    return len(path[1]), float(np.sum(path[1] ** 2))


def shortest_to_height(
    torques: np.ndarray, goal_height: float = 1.0, method: str = "semi_implicit_euler"
) -> Trajectory:
    """The fewest steps in which continuous torques get the tip above ``goal_height`` [m],
    shortening ``torques`` (which do) a step at a time while IPOPT finds a solution."""
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
        solution = solve_or_none(opti)
        if solution is None:
            break
        best = (solution.value(states).T, np.atleast_1d(solution.value(us)))
    return optimiser.trajectory(best)
