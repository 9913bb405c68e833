"""Balancing at upright: infinite-horizon discrete LQR, its saturated form and basin, and the
bound no controller with |tau| <= 1 N m can beat (all on the analytic model)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from acrobot_mj.control.model import UPRIGHT, P, discrete_model, state_error, step
from acrobot_mj.physics import dynamics
from acrobot_mj.physics.params import AcrobotParams


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
    #: The model it is designed on (the report's acrobot, or an identified one).
    p: AcrobotParams = P
    gain: np.ndarray = field(init=False)
    #: The Riccati solution: the infinite-horizon cost-to-go ``x' S x`` of the error.
    cost: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        a, b = discrete_model(p=self.p)
        self.gain, self.cost = dlqr(a, b, np.diag(self.q), np.array([[self.r]]))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        error = state_error(x)
        limit = self.p.max_torque
        return np.clip(-(error @ self.gain.T)[..., 0], -limit, limit)


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
    return np.all(np.abs(state_error(x)) < tolerance, axis=1)


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
