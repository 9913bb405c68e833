"""Model-based references for the learners: energy pumping, saturated LQR at upright, the bound
no bounded controller can beat, and a minimum-time search over torque sequences.

All work on the analytic model (:mod:`acrobot_mj.dynamics`, :mod:`acrobot_mj.integrators`),
which matches the MuJoCo env to rounding (``tests/test_crosscheck.py``); states are
``(q1, q2, dq1, dq2)`` [rad, rad/s], torques in N m.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from acrobot_mj import dynamics, integrators
from acrobot_mj.params import AcrobotParams

P = AcrobotParams()
UPRIGHT = np.array([np.pi / 2, 0.0, 0.0, 0.0])
HANGING = np.array([-np.pi / 2, 0.0, 0.0, 0.0])


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles [rad] into [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def step(
    x: np.ndarray,
    tau: np.ndarray,
    frame_skip: int = 1,
    method: str = "semi_implicit_euler",
    p: AcrobotParams = P,
) -> np.ndarray:
    """``frame_skip`` physics steps of ``method`` with the task's velocity clipping (the env's
    step, on arrays of states ``(..., 4)``)."""
    advance = integrators.STEPS[method]
    for _ in range(frame_skip):
        x = integrators.clip_velocity(advance(x, tau, p.dt, p), p)
    return x


def tip_height(x: np.ndarray, p: AcrobotParams = P) -> np.ndarray:
    return dynamics.tip_position(np.asarray(x)[..., :2], p)[..., 1]


# -- energy pumping ------------------------------------------------------------------------


def energy_pumping_torque(
    x: np.ndarray, target: float | None = None, gain: float = 50.0, p: AcrobotParams = P
) -> np.ndarray:
    """Energy pumping through the elbow's power, ``dE/dt = tau dq2`` (the energy-based swing-up
    idea of Spong, "The swing up control problem for the acrobot", IEEE Control Systems 1995,
    and Fantoni, Lozano and Spong 2000), in saturated form:

        tau = clip(gain (E* - E) dq2, -1, 1) N m,

    so while ``E < E*`` the torque always does non-negative work: the energy rises
    monotonically (in continuous time). ``E*`` defaults to the upright energy (19.6 J). From
    rest ``dq2 = 0``; the law then gives +1 N m to start the motion.
    """
    x = np.asarray(x, dtype=float)
    target = dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p) if target is None else target
    energy = dynamics.total_energy(x[..., :2], x[..., 2:], p)
    dq2 = x[..., 3]
    tau = np.clip(gain * (target - energy) * dq2, -p.max_torque, p.max_torque)
    return np.where(dq2 == 0.0, p.max_torque, tau)


def pumping_energies(dt: float = 1e-3, seconds: float = 20.0, p: AcrobotParams = P) -> np.ndarray:
    """Energy [J] under :func:`energy_pumping_torque` from rest, RK4 at ``dt`` with the torque
    held over each step, until it reaches the upright energy (the pumping phase)."""
    target = float(dynamics.total_energy(UPRIGHT[:2], UPRIGHT[2:], p))
    x = HANGING.copy()
    energies = [float(dynamics.total_energy(x[:2], x[2:], p))]
    while energies[-1] < target and len(energies) <= seconds / dt:
        x = integrators.rk4_step(x, float(energy_pumping_torque(x, target, p=p)), dt, p)
        energies.append(float(dynamics.total_energy(x[:2], x[2:], p)))
    return np.array(energies)


# -- LQR at upright ------------------------------------------------------------------------


def discrete_model(
    x0: np.ndarray = UPRIGHT, frame_skip: int = 1, p: AcrobotParams = P
) -> tuple[np.ndarray, np.ndarray]:
    """Exact Jacobians of the env's step (semi-implicit Euler, ``frame_skip`` steps) at ``x0``
    with zero torque, from the analytic continuous Jacobian."""
    a_c, b_c = dynamics.linearize(x0[:2], x0[2:], 0.0, p)
    h, eye = p.dt, np.eye(2)
    aq, av, bu = a_c[2:, :2], a_c[2:, 2:], b_c[2:]
    a = np.block([[eye + h * h * aq, h * (eye + h * av)], [h * aq, eye + h * av]])
    b = np.vstack([h * h * bu, h * bu])
    a_k, b_k = np.eye(4), np.zeros((4, 1))
    for _ in range(frame_skip):  # torque held over the frame
        a_k, b_k = a @ a_k, a @ b_k + b
    return a_k, b_k


def dlqr(
    a: np.ndarray,
    b: np.ndarray,
    q: np.ndarray,
    r: np.ndarray,
    iterations: int = 10_000,
    tol: float = 1e-12,
) -> tuple[np.ndarray, np.ndarray]:
    """Infinite-horizon discrete LQR by Riccati iteration: gain K (``u = -K x``) and cost P."""
    cost = q.copy()
    for _ in range(iterations):
        gain = np.linalg.solve(r + b.T @ cost @ b, b.T @ cost @ a)
        new = q + a.T @ cost @ (a - b @ gain)
        if np.max(np.abs(new - cost)) <= tol * max(1.0, np.max(np.abs(new))):
            return gain, new
        cost = new
    raise RuntimeError("the Riccati iteration did not converge")


@dataclass
class LQR:
    """Saturated LQR balancing at upright: ``tau = clip(-K (x - x*), -1, 1)`` N m, angles of
    ``x - x*`` wrapped. Designed on the env's discrete model (0.05 s, semi-implicit Euler)."""

    q: tuple[float, ...] = (10.0, 10.0, 1.0, 1.0)
    r: float = 1.0
    gain: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        a, b = discrete_model()
        self.gain, _ = dlqr(a, b, np.diag(self.q), np.array([[self.r]]))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        error = np.asarray(x, dtype=float) - UPRIGHT
        error[..., :2] = wrap(error[..., :2])
        return np.clip(-(error @ self.gain.T)[..., 0], -P.max_torque, P.max_torque)


def balances(
    controller: Callable[[np.ndarray], np.ndarray],
    starts: np.ndarray,
    seconds: float = 20.0,
    tolerance: float = 1e-3,
) -> np.ndarray:
    """For each start ``(n, 4)``: does ``controller`` bring it to within ``tolerance`` of
    upright (all four coordinates, angles wrapped) and keep it there at the end?"""
    x = np.array(starts, dtype=float)
    for _ in range(round(seconds / P.dt)):
        x = step(x, controller(x))
    error = x - UPRIGHT
    error[:, :2] = wrap(error[:, :2])
    return np.all(np.abs(error) < tolerance, axis=1)


def q1_basin(
    controller: Callable[[np.ndarray], np.ndarray], upper: float = 0.5, resolution: float = 1e-4
) -> tuple[float, float]:
    """Largest pure q1 offsets (below and above upright, at rest) from which ``controller``
    balances, by bisection; assumes the basin along q1 is an interval around 0."""
    limits = []
    for sign in (-1.0, 1.0):
        good, bad = 0.0, upper
        while bad - good > resolution:
            mid = (good + bad) / 2
            start = UPRIGHT + np.array([sign * mid, 0.0, 0.0, 0.0])
            good, bad = (mid, bad) if balances(controller, start[None])[0] else (good, mid)
        limits.append(sign * good)
    return limits[0], limits[1]


def unstable_mode_bound(p: AcrobotParams = P) -> dict[str, float]:
    """The largest pure q1 offset from upright any controller with ``|tau| <= max_torque``
    can recover from, in the linearisation.

    Each unstable mode ``z = w x`` (``w`` a left eigenvector, eigenvalue ``lambda > 0``) obeys
    ``dz/dt = lambda z + (w B) tau``; once ``|z| > |w B| max_torque / lambda`` no admissible
    torque can stop it growing. For ``x = (d, 0, 0, 0)`` that caps ``|d|`` at
    ``min_i |w_i B| max_torque / (lambda_i |w_i1|)``.
    """
    a, b = dynamics.linearize(UPRIGHT[:2], UPRIGHT[2:], 0.0, p)
    values, left = np.linalg.eig(a.T)  # columns: left eigenvectors of A
    bounds = {}
    for k in np.flatnonzero(values.real > 1e-9):
        w = left[:, k].real
        bounds[f"{values[k].real:.4f}"] = (
            abs(w @ b[:, 0]) * p.max_torque / (values[k].real * abs(w[0]))
        )
    return bounds


def controllability_rank(a: np.ndarray, b: np.ndarray) -> int:
    """Rank of ``[B, AB, A^2 B, A^3 B]``."""
    blocks = [b]
    for _ in range(a.shape[0] - 1):
        blocks.append(a @ blocks[-1])
    return int(np.linalg.matrix_rank(np.hstack(blocks)))


# -- minimum-time swing-up -----------------------------------------------------------------


@dataclass
class SearchResult:
    decisions: int | None  # None if the goal was not reached within max_decisions
    actions: list[int]  # Discrete(3) actions: 0 = -1 N m, 1 = 0, 2 = +1 N m
    expanded: int  # states expanded


def min_time_search(
    frame_skip: int = 4,
    width: int = 20_000,
    cell: tuple[float, ...] = (0.05, 0.05, 0.1, 0.2),
    method: str = "semi_implicit_euler",
    max_decisions: int = 1000,
    goal_height: float = 1.0,
) -> SearchResult:
    """Beam search over torque sequences in {-1, 0, +1} N m from rest for the fewest decisions
    to the goal (tip above ``goal_height``).

    Breadth-first by decision: every state in the beam is expanded by the three torques; states
    that fall in the same cell (``cell`` [rad, rad, rad/s, rad/s], angles wrapped) are merged,
    keeping one; if more than ``width`` remain, those with the most energy are kept (pumping
    energy in is what a swing-up has to do). The first depth where any state reaches the goal
    is returned with its action sequence: an upper bound on the true minimum, tight when the
    beam is wide and the cells fine.
    """
    torques = np.array([-1.0, 0.0, 1.0])
    beam = HANGING[None].copy()
    parents: list[np.ndarray] = []
    choices: list[np.ndarray] = []
    expanded = 0
    for depth in range(1, max_decisions + 1):
        n = len(beam)
        expanded += 3 * n
        children = step(np.repeat(beam, 3, axis=0), np.tile(torques, n), frame_skip, method)
        parent, choice = np.repeat(np.arange(n), 3), np.tile(np.arange(3), n)
        reached = np.flatnonzero(tip_height(children) > goal_height)
        if reached.size:
            actions = [int(choice[reached[0]])]
            index = parent[reached[0]]
            for level in range(depth - 2, -1, -1):
                actions.append(int(choices[level][index]))
                index = parents[level][index]
            return SearchResult(depth, actions[::-1], expanded)
        # Merge states in the same cell, then keep the most energetic.
        key = np.concatenate([wrap(children[:, :2]), children[:, 2:]], axis=1)
        _, first = np.unique(
            np.floor(key / np.asarray(cell)).astype(np.int64), axis=0, return_index=True
        )
        if first.size > width:
            energy = dynamics.total_energy(children[first, :2], children[first, 2:])
            first = first[np.argpartition(-energy, width)[:width]]
        beam = children[first]
        parents.append(parent[first])
        choices.append(choice[first])
    return SearchResult(None, [], expanded)
