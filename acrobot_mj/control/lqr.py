"""Linear feedback: exact Jacobians of the env's step, discrete LQR at upright (saturated, its
basin, and the bound no controller with ``|tau| <= 1`` N m can beat), the constrained LQR (linear
MPC) whose basin reaches that bound, TVLQR along a swing-up (joining the LQR's cost at upright
without a seam) and sigma-delta for {-1, 0, +1} torques."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from acrobot_mj.checks import check_float, check_int
from acrobot_mj.control.controller import Controller
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import UPRIGHT, state_error
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.physics.xp import clip

#: A feedback law on many states at once: states (n, 4) to torques (n,) [N m].
BatchLaw = Callable[[np.ndarray], np.ndarray]


def step_jacobians(
    x: np.ndarray,
    u: float | np.ndarray = 0.0,
    method: str = "semi_implicit_euler",
    p: AcrobotParams = REPORT,
) -> tuple[np.ndarray, np.ndarray]:
    """Exact Jacobians ``A`` (..., 4, 4) and ``B`` (..., 4, 1) of one step at ``x`` (..., 4),
    torque ``u`` (...) [N m]: one state or many at once."""
    x, h, tau = np.asarray(x, dtype=float), p.dt, np.asarray(u, dtype=float)
    if method == "semi_implicit_euler":
        a_c, b_c = dynamics.linearize(x[..., :2], x[..., 2:], tau, p)
        eye = np.eye(2)
        aq, av, bu = a_c[..., 2:, :2], a_c[..., 2:, 2:], b_c[..., 2:, :]
        top = np.concatenate([eye + h * h * aq, h * (eye + h * av)], -1)
        bottom = np.concatenate([h * aq, eye + h * av], -1)
        return np.concatenate([top, bottom], -2), np.concatenate([h * h * bu, h * bu], -2)
    if method != "rk4":
        raise ValueError(f"method must be 'semi_implicit_euler' or 'rk4', got {method!r}")
    # The chain rule through the four stages, each stage's Jacobian at its own state.
    shape = np.broadcast_shapes(x.shape[:-1], tau.shape)
    j_sum, g_sum = np.zeros((*shape, 4, 4)), np.zeros((*shape, 4, 1))
    j, g, slope = np.zeros((*shape, 4, 4)), np.zeros((*shape, 4, 1)), np.zeros((*shape, 4))
    for weight, fraction in ((1, 0.0), (2, 0.5), (2, 0.5), (1, 1.0)):
        stage = x + fraction * h * slope
        a_c, b_c = dynamics.linearize(stage[..., :2], stage[..., 2:], tau, p)
        j = a_c @ (np.eye(4) + fraction * h * j)
        g = a_c @ (fraction * h * g) + b_c
        slope = integrators.state_derivative(stage, tau, p)
        j_sum, g_sum = j_sum + weight * j, g_sum + weight * g
    return np.eye(4) + h / 6 * j_sum, h / 6 * g_sum


def discrete_model(
    x0: np.ndarray = UPRIGHT, frame_skip: int = 1, p: AcrobotParams = REPORT
) -> tuple[np.ndarray, np.ndarray]:
    """Exact Jacobians of the env's decision of ``frame_skip`` steps at ``x0``, zero torque."""
    a, b = step_jacobians(x0, 0.0, p=p)
    a_k, b_k = np.eye(4), np.zeros((4, 1))
    for _ in range(frame_skip):
        a_k, b_k = a @ a_k, a @ b_k + b
    return a_k, b_k


def riccati_step(
    a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, cost: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One step of the discrete Riccati recursion back from the cost-to-go ``cost`` (4, 4) under
    ``x' = a x + b u`` with weights ``q`` (4, 4) and ``r`` (1, 1): the gain K (1, 4) of
    ``u = -K x`` and the cost-to-go (4, 4) one step earlier."""
    gain = np.linalg.solve(r + b.T @ cost @ b, b.T @ cost @ a)
    return gain, q + a.T @ cost @ (a - b @ gain)


def dlqr(
    a: np.ndarray, b: np.ndarray, q: np.ndarray, r: np.ndarray, tol: float = 1e-12
) -> tuple[np.ndarray, np.ndarray]:
    """Infinite-horizon discrete LQR by Riccati iteration: gain K (``u = -K x``) and cost P."""
    cost = q.copy()
    for _ in range(10_000):
        gain, new = riccati_step(a, b, q, r, cost)
        if np.max(np.abs(new - cost)) <= tol * max(1.0, np.max(np.abs(new))):
            return gain, new
        cost = new
    raise RuntimeError("the Riccati iteration did not converge")


#: The Jacobians ``A`` (4, 4) and ``B`` (4, 1) of a model's step at a state and torque: a learnt
#: model's (:class:`~acrobot_mj.identify.library.LibraryModel`) instead of the equations'.
Jacobians = Callable[[np.ndarray, float], tuple[np.ndarray, np.ndarray]]


@dataclass
class LQR(Controller):
    """Saturated LQR at ``target`` (upright at rest) on the env's discrete model, or on the model
    whose Jacobians ``linear`` gives: ``clip(-K (x - x*), -1, 1)`` N m; called on one state or
    many ``(..., 4)``."""

    q: tuple[float, ...] = (10.0, 10.0, 1.0, 1.0)
    r: float = 1.0
    p: AcrobotParams = REPORT
    target: np.ndarray = field(default_factory=lambda: UPRIGHT.copy())
    linear: Jacobians | None = None
    gain: np.ndarray = field(init=False)
    #: The Riccati solution: the cost-to-go ``x' S x`` of the error.
    cost: np.ndarray = field(init=False)
    #: The step's Jacobians ``A`` (4, 4) and ``B`` (4, 1) at ``target``, zero torque.
    a: np.ndarray = field(init=False, repr=False)
    b: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.linear is None:
            self.a, self.b = discrete_model(p=self.p)
        else:
            self.a, self.b = self.linear(self.target, 0.0)
        self.gain, self.cost = dlqr(self.a, self.b, np.diag(self.q), np.array([[self.r]]))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        limit = self.p.max_torque
        return np.clip(-(state_error(x, self.target) @ self.gain.T)[..., 0], -limit, limit)

    def act(self, x: np.ndarray, t: float) -> float:
        x = np.asarray(x, dtype=float)
        if x.shape != (4,):
            return float(self(x))
        # One state: __call__'s numbers, its error and clip on floats.
        return self.torque(state_error(x, self.target))

    def torque(self, error: np.ndarray) -> float:
        """The torque [N m] of one state's error ``x - target`` (4,), angles wrapped."""
        return clip(-float((error @ self.gain.T)[0]), -self.p.max_torque, self.p.max_torque)


def balances(
    controller: BatchLaw, starts: np.ndarray, seconds: float = 20.0, tolerance: float = 1e-3
) -> np.ndarray:
    """For each start ``(n, 4)``: is it within ``tolerance`` of upright after ``seconds``?"""
    x = np.array(starts, dtype=float)
    for _ in range(integrators.steps_in(seconds, REPORT.dt)):
        x = integrators.step_states(x, controller(x))
    return np.all(np.abs(state_error(x)) < tolerance, axis=1)


def q1_basin(
    controller: BatchLaw, upper: float = 0.5, resolution: float = 1e-4
) -> tuple[float, float]:
    """The largest q1 offsets [rad] below and above upright that ``controller`` balances from."""
    limits = []
    for sign in (-1.0, 1.0):
        good, bad = 0.0, upper
        while bad - good > resolution:
            mid = (good + bad) / 2
            start = UPRIGHT + np.array([sign * mid, 0.0, 0.0, 0.0])
            good, bad = (mid, bad) if balances(controller, start[None])[0] else (good, mid)
        limits.append(sign * good)
    return limits[0], limits[1]


def unstable_mode_bound(p: AcrobotParams = REPORT) -> dict[str, float]:
    """Per unstable eigenvalue, the largest q1 offset [rad] any ``|tau| <= max_torque`` recovers
    from, linearised: ``dz/dt = lambda z + (w B) tau`` is lost past ``|w B| tau_max / lambda``."""
    a, b = dynamics.linearize(UPRIGHT[:2], UPRIGHT[2:], 0.0, p)
    values, left = np.linalg.eig(a.T)
    bounds = {}
    for k in np.flatnonzero(values.real > 1e-9):
        w = left[:, k].real
        bounds[f"{values[k].real:.4f}"] = (
            abs(w @ b[:, 0]) * p.max_torque / (values[k].real * abs(w[0]))
        )
    return bounds


def null_controllable(
    offsets: np.ndarray, p: AcrobotParams = REPORT, directions: int = 720
) -> np.ndarray:
    """For each state offset from upright ``(n, 4)`` [rad, rad/s]: can any torque sequence with
    ``|tau| <= max_torque``, held for each step of the env's discrete map, bring the unstable
    modes of the linearisation back to zero? (:class:`NullRegion` of the env's step.)"""
    return NullRegion(*discrete_model(p=p), p.max_torque, directions).contains(offsets)


class NullRegion:
    """The null-controllable region of the unstable modes of ``x' = A x + B u``, ``|u| <=
    limit``: the set of ``-sum_k L^-(k+1) b u_k`` in the modes' coordinates. An offset is inside
    where its unstable part is within the region's support in each of ``directions``
    directions: a bound no controller beats, up to the linearisation."""

    def __init__(self, a: np.ndarray, b: np.ndarray, limit: float, directions: int = 720):
        a = _real_matrix("A", a)
        b = _real_matrix("b", b)
        if a.ndim != 2 or a.shape[0] != a.shape[1] or b.shape != (a.shape[0], 1):
            raise ValueError(f"A must be (n, n) and b (n, 1), got {a.shape} and {b.shape}")
        limit = check_float("limit", limit, 0.0)
        directions = check_int("directions", directions, 2)
        if limit == 0.0:
            raise ValueError("limit must be > 0 N m, got 0")
        values, right = np.linalg.eig(a)
        unstable = np.flatnonzero(np.abs(values) > 1.0 + 1e-12)
        real = np.abs(values[unstable].imag) <= 1e-12 * np.abs(values[unstable])
        if len(unstable) != 2 or not np.all(real) or np.any(values[unstable].real < 0.0):
            raise ValueError(
                "NullRegion needs A with exactly two unstable modes, real and > 1 (the "
                f"acrobot's at upright), got eigenvalues {np.round(values, 6).tolist()}"
            )
        self.rows = np.linalg.inv(right)[unstable].real  # left eigenvectors of those modes
        growth, beta = values[unstable].real, (self.rows @ b)[:, 0] * limit
        steps = int(np.ceil(np.log(1e18) / np.log(growth.min())))  # until the terms vanish
        terms = growth[None, :] ** -np.arange(1.0, steps + 1)[:, None] * beta  # (steps, modes)
        angle = np.linspace(0.0, np.pi, directions, endpoint=False)
        self.directions = np.stack([np.cos(angle), np.sin(angle)], axis=1)
        # The same for c and -c: the region is symmetric.
        self.support = np.abs(terms @ self.directions.T).sum(axis=0)
        if not np.all(self.support > 0.0):
            raise ValueError("b moves no unstable mode of A: the region is a point")

    def depth(self, offsets: np.ndarray) -> np.ndarray:
        """How far out each offset ``(..., 4)`` lies: 1 on the region's edge, below 1 inside."""
        z = np.asarray(offsets, dtype=float) @ self.rows.T
        return np.max(np.abs(z @ self.directions.T) / self.support, axis=-1)

    def contains(self, offsets: np.ndarray) -> np.ndarray:
        """Is each offset ``(..., 4)`` inside the region?"""
        return self.depth(offsets) <= 1.0


def _real_matrix(name: str, value: object) -> np.ndarray:
    """``value`` as a float64 array, refused in one line unless it is one of finite numbers."""
    refused = TypeError(
        f"{name} must be an array of real numbers, got {' '.join(repr(value).split()):.40}"
    )
    if isinstance(value, (str, bytes)):
        raise refused
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise refused from None
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got NaN or infinity in an array of {array.shape}")
    return array


def box_qp(h: np.ndarray, f: np.ndarray, limit: float) -> np.ndarray:
    """``argmin 0.5 u' H u + f' u`` over ``|u_i| <= limit``, ``H`` positive definite: a primal
    active-set method (Nocedal and Wright, ch. 16.5). It holds some coordinates at a bound and
    minimises exactly over the rest; a minimiser outside the box is stepped towards up to the
    first bound, which is then held; a held coordinate whose gradient points into the box is
    let go; it ends when none does."""
    u = np.clip(np.linalg.solve(h, -f), -limit, limit)
    held = np.where(np.abs(u) >= limit, np.sign(u), 0.0)  # +1 upper, -1 lower, 0 free
    slack = 1e-12 * (np.max(np.abs(f)) + np.max(np.abs(h)) * limit)  # rounding in H u + f
    for _ in range(10 * len(f)):
        free = held == 0
        goal = np.where(free, 0.0, held * limit)
        goal[free] = np.linalg.solve(h[np.ix_(free, free)], -(f + h @ goal)[free])
        outside = free & (np.abs(goal) > limit)
        if outside.any():  # step towards the face's minimum up to the first bound, and hold it
            d = goal - u
            reach = np.full(len(u), np.inf)
            reach[outside] = (np.sign(d[outside]) * limit - u[outside]) / d[outside]
            first = int(np.argmin(reach))
            u = u + reach[first] * d
            held[first] = np.sign(d[first])
            u[first] = held[first] * limit
            continue
        u = goal
        pull = held * (h @ u + f)  # > 0: the held coordinate would rather move inside
        if np.max(pull) <= slack:
            return u
        held[int(np.argmax(pull))] = 0.0
    raise RuntimeError("the box-constrained QP did not converge")


def condensed(lqr: LQR, horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """The constrained LQR's QP over ``horizon`` steps of ``lqr``'s linear model, condensed to
    the torques: its Hessian ``H`` and ``F`` of its linear term ``F e_0`` in the start's error."""
    a, b, q = lqr.a, lqr.b, np.diag(lqr.q)
    # The errors e_1..e_N as ``Phi e_0 + Gamma u``: powers of A, and A^(k-1-j) B.
    powers = [np.eye(4)]
    for _ in range(horizon):
        powers.append(a @ powers[-1])
    phi = np.stack(powers[1:])
    gamma = np.zeros((horizon, 4, horizon))
    for k in range(horizon):
        for j in range(k + 1):
            gamma[k, :, j] = (powers[k - j] @ b)[:, 0]
    weights = np.stack([q] * (horizon - 1) + [lqr.cost])
    hessian = lqr.r * np.eye(horizon) + np.einsum("kim,kij,kjn->mn", gamma, weights, gamma)
    return hessian, np.einsum("kim,kij,kjn->mn", gamma, weights, phi)


#: The largest condition number of the constrained LQR's QP. Condensed over ``N`` steps its
#: Hessian grows as the unstable mode's ``|lambda|^(2N)``: on Gymnasium's acrobot (0.2 s steps,
#: ``|lambda|`` 1.74) 40 steps give 1e21 and a first-step gain 110 N m/rad off the LQR's, 13
#: give 5.6e7 and 14 give 1.8e8; the report's 40 steps give 1.8e6 (measured).
MAX_CONDITION = 1e8


class MPC(Controller):
    """The constrained LQR at ``lqr``'s target: over ``horizon`` steps of its linear model it
    minimises ``sum e' Q e + r u^2`` plus its cost-to-go ``e' S e`` at the end, subject to
    ``|u| <= max_torque`` N m, and applies the first torque (linear MPC). Where no torque of the
    plan saturates this is the LQR exactly; where they saturate it uses the torque it has, so
    its basin approaches the :class:`NullRegion` (measured: docs/guide/balance.md). A function
    of the state alone: it keeps no memory between calls. ``horizon`` is shortened to the longest
    whose QP has a condition number within :data:`MAX_CONDITION` (only where the unstable mode
    grows fast over a step)."""

    def __init__(self, lqr: LQR, horizon: int = 40) -> None:
        if isinstance(horizon, bool) or not isinstance(horizon, int) or horizon < 1:
            raise ValueError(f"horizon must be a positive number of steps, got {horizon!r}")
        self.lqr, self.limit = lqr, lqr.p.max_torque
        self.hessian, self.linear_term = condensed(lqr, horizon)
        while horizon > 1 and np.linalg.cond(self.hessian) > MAX_CONDITION:
            horizon -= 1
            self.hessian, self.linear_term = condensed(lqr, horizon)
        self.horizon = horizon
        self.free = -np.linalg.solve(self.hessian, self.linear_term)  # the plan with no bound

    def plan(self, x: np.ndarray) -> tuple[np.ndarray, bool]:
        """The ``horizon`` torques [N m] it plans from state ``x`` ``(4,)``, and whether any
        is at the bound (where none is, it is the plan with no bound)."""
        if not np.all(np.isfinite(x)):
            raise ValueError(f"the constrained LQR needs a finite state, got {np.asarray(x)}")
        error = state_error(x, self.lqr.target)
        free = self.free @ error
        if np.max(np.abs(free)) <= self.limit:
            return free, False
        return box_qp(self.hessian, self.linear_term @ error, self.limit), True

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The torque [N m] in state ``x`` ``(4,)``, or one per state of ``(n, 4)``: the LQR's
        own where the plan does not saturate (the same number, so the two agree exactly)."""
        x = np.asarray(x, dtype=float)
        if x.ndim > 1:
            return np.array([self(row) for row in x.reshape(-1, 4)]).reshape(x.shape[:-1])
        torques, saturated = self.plan(x)
        return np.asarray(torques[0]) if saturated else self.lqr(x)

    def act(self, x: np.ndarray, t: float) -> float:
        return float(self(x))


def controllability_rank(a: np.ndarray, b: np.ndarray) -> int:
    """Rank of ``[B, AB, A^2 B, A^3 B]``."""
    blocks = [b]
    for _ in range(a.shape[0] - 1):
        blocks.append(a @ blocks[-1])
    return int(np.linalg.matrix_rank(np.hstack(blocks)))


def tvlqr(
    trajectory: Trajectory,
    lqr: LQR,
    q: tuple[float, ...],
    r: float,
    linear: Jacobians | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """TVLQR along ``trajectory`` ending in ``lqr``'s cost: the costs-to-go ``S_k`` (N + 1, 4, 4)
    of the error and the gains ``K_k`` (N, 4), ``u_k = u*_k - K_k (x - x*_k)``; ``linear``: the
    Jacobians of a learnt model (default: the trajectory's equations)."""
    weights, torque_cost, steps = np.diag(q), np.array([[r]]), trajectory.steps
    costs, gains = np.zeros((steps + 1, 4, 4)), np.zeros((steps, 4))
    costs[steps] = lqr.cost
    points, torques = trajectory.states[:steps], trajectory.torques
    if linear is None:  # all the steps' Jacobians at once
        every = step_jacobians(points, torques, trajectory.method, trajectory.params)
    for k in reversed(range(steps)):
        if linear is None:
            a, b = every[0][k], every[1][k]
        else:
            a, b = linear(points[k], torques[k])
        gain, costs[k] = riccati_step(a, b, weights, torque_cost, costs[k + 1])
        gains[k] = gain[0]
    return costs, gains


def tvlqr_torque(trajectory: Trajectory, gains: np.ndarray, k: int, x: np.ndarray) -> float:
    """TVLQR at point ``k`` of ``trajectory`` (``gains`` from :func:`tvlqr`) in state ``x``:
    ``clip(u*_k - K_k (x - x*_k), -u_max, u_max)`` [N m], ``u_max`` the model's torque bound."""
    error = state_error(x, trajectory.states[k])
    u = float(trajectory.torques[k]) - float(gains[k] @ error)
    limit = trajectory.params.max_torque
    return clip(u, -limit, limit)


class SigmaDelta:
    """First-order sigma-delta: {-1, 0, +1} N m torques summing like a continuous torque."""

    def __init__(self) -> None:
        self.carried = 0.0

    def __call__(self, u: float) -> int:
        """The ``Discrete(3)`` action for the continuous torque ``u`` [N m]."""
        wanted = u + self.carried
        level = int(np.clip(np.rint(wanted), -1, 1))
        self.carried = wanted - level
        return level + 1
