"""A model of one env decision learnt from data alone: ``x' = x + W' phi(x, u)``, where ``phi``
holds every product of a Fourier harmonic of each angle (up to ``harmonics``) with a monomial of
degree at most 2 in the two velocities and the action, and ``W`` comes from sequentially
thresholded least squares (SINDy: Brunton, Proctor and Kutz 2016). It is told only that the first
two observations are angles; nothing of masses, lengths, the equations or the integrator. The
same ``phi`` serves numpy rows and CasADi symbols (:mod:`~acrobot_mj.physics.xp`), so the planner
and the feedback gains use the very model the data fitted."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.physics.xp import wrap_angle

#: Harmonics of each angle in the library: 4 fits the acrobot's decisions to about 1e-4 rad/s
#: (3: about 5e-4), measured on 5,000 held-out transitions from uniform starts.
HARMONICS = 4
#: Coefficients below this, times their feature's RMS over the data, are dropped [rad, rad/s].
THRESHOLD = 1e-5


def angle_terms(angle: Any, harmonics: int, xp: Any) -> list[Any]:
    """``1, cos k a, sin k a`` for ``k = 1 .. harmonics``."""
    return [1.0] + [f(k * angle) for k in range(1, harmonics + 1) for f in (xp.cos, xp.sin)]


def monomial_terms(v1: Any, v2: Any, u: Any) -> list[Any]:
    """The monomials of degree <= 2 in the velocities and the action."""
    return [1.0, v1, v2, u, v1 * v1, v1 * v2, v2 * v2, v1 * u, v2 * u, u * u]


def features(x: Any, u: Any, harmonics: int, xp: Any = np) -> list[Any]:
    """``phi(x, u)``: ``(1 + 2H)^2 * 10`` terms of state ``x`` (four numbers, rows or symbols)
    and action ``u``."""
    q1, q2, v1, v2 = (x[i] for i in range(4))
    angles = [a * b for a in angle_terms(q1, harmonics, xp) for b in angle_terms(q2, harmonics, xp)]
    return [a * m for a in angles for m in monomial_terms(v1, v2, u)]


def design(states: np.ndarray, actions: np.ndarray, harmonics: int) -> np.ndarray:
    """``phi`` of each row: ``(n, features)``, the numbers :func:`features` gives, as outer
    products (the same products in the same order)."""
    x = np.asarray(states, dtype=np.float64).T
    u = np.asarray(actions, dtype=np.float64)
    q1, q2, v1, v2 = x

    def columns(terms: list[Any]) -> np.ndarray:
        return np.stack(np.broadcast_arrays(*terms), axis=1)

    first, second = (columns(angle_terms(q, harmonics, np)) for q in (q1, q2))
    monomials = columns(monomial_terms(v1, v2, u))
    rows = first[:, :, None, None] * second[:, None, :, None] * monomials[:, None, None, :]
    return rows.reshape(len(rows), -1)


def increments(states: np.ndarray, next_states: np.ndarray) -> np.ndarray:
    """``x' - x`` with the angles' difference wrapped (observations wrap at +-pi)."""
    delta = np.asarray(next_states, dtype=np.float64) - states
    delta[:, :2] = wrap_angle(delta[:, :2])
    return delta


def thresholded_least_squares(
    a: np.ndarray, b: np.ndarray, threshold: float, rounds: int = 5
) -> np.ndarray:
    """``W`` minimising ``|a W - b|`` column by column, the terms with ``|W| rms(a) <
    threshold`` dropped and the rest refitted, ``rounds`` times."""
    scale = np.sqrt(np.mean(a * a, axis=0))
    scale[scale == 0.0] = 1.0
    scaled = a / scale
    weights = np.linalg.lstsq(scaled, b, rcond=None)[0]
    for _ in range(rounds):
        keep = np.abs(weights) >= threshold
        weights = np.zeros_like(weights)
        for j in range(b.shape[1]):
            if keep[:, j].any():
                weights[keep[:, j], j] = np.linalg.lstsq(
                    scaled[:, keep[:, j]], b[:, j], rcond=None
                )[0]
    return weights / scale[:, None]


@dataclass(frozen=True)
class LibraryModel:
    """``x' = x + weights' phi(x, u)``: ``weights`` ``(features, 4)`` over
    :func:`features` of ``harmonics``."""

    harmonics: int
    weights: np.ndarray

    def __post_init__(self) -> None:
        size = len(features(np.zeros(4), 0.0, self.harmonics))
        if np.shape(self.weights) != (size, 4) or not np.isfinite(self.weights).all():
            raise ValueError(
                f"a library model of {self.harmonics} harmonics needs finite "
                f"weights of shape ({size}, 4), got "
                f"{np.shape(self.weights)}"
            )

    @classmethod
    def fit(
        cls,
        states: np.ndarray,
        actions: np.ndarray,
        next_states: np.ndarray,
        harmonics: int = HARMONICS,
        threshold: float = THRESHOLD,
    ) -> LibraryModel:
        """The model of the transitions ``(states[i], actions[i], next_states[i])``."""
        a = design(states, actions, harmonics)
        if len(a) < a.shape[1]:
            raise ValueError(f"{len(a)} transitions cannot fit {a.shape[1]} library terms")
        weights = thresholded_least_squares(a, increments(states, next_states), threshold)
        return cls(harmonics, weights)

    @functools.cached_property
    def used(self) -> np.ndarray:
        """Indices of the library terms in use (a nonzero weight for some state variable)."""
        return np.flatnonzero(np.abs(self.weights).sum(axis=1))

    @property
    def terms(self) -> int:
        """How many library terms are in use."""
        return len(self.used)

    def step(self, states: np.ndarray, actions: np.ndarray | float) -> np.ndarray:
        """The predicted next states of rows ``(n, 4)`` (or one state)."""
        states = np.asarray(states, dtype=np.float64)
        rows = np.atleast_2d(states)
        phi = design(rows, np.broadcast_to(actions, len(rows)), self.harmonics)
        return (rows + phi @ self.weights).reshape(states.shape)

    def errors(self, states: np.ndarray, actions: np.ndarray, next_states: np.ndarray) -> dict:
        """RMS and largest prediction errors [rad, rad/s] per state variable on transitions."""
        miss = self.step(states, actions) - states - increments(states, next_states)
        return {
            "rms": np.sqrt(np.mean(miss**2, axis=0)).tolist(),
            "max": np.abs(miss).max(axis=0).tolist(),
        }

    @functools.cached_property
    def function(self) -> Any:
        """The step as a CasADi function ``(x, u, h) -> x'`` (``h`` unused: the env's step)."""
        import casadi

        x, u, h = casadi.SX.sym("x", 4), casadi.SX.sym("u"), casadi.SX.sym("h")
        phi = features(x, u, self.harmonics, casadi)
        terms = casadi.vertcat(*[phi[i] for i in self.used])
        step = x + casadi.mtimes(self.weights[self.used].T, terms)
        return casadi.Function("step", [x, u, h], [step])

    @functools.cached_property
    def _jacobians(self) -> Any:
        import casadi

        x, u, h = casadi.SX.sym("x", 4), casadi.SX.sym("u"), casadi.SX.sym("h")
        nxt = self.function(x, u, h)
        jacobians = [casadi.jacobian(nxt, x), casadi.jacobian(nxt, u)]
        return casadi.Function("jacobians", [x, u, h], jacobians)

    def jacobians(self, x: np.ndarray, u: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """``A`` (4, 4) and ``B`` (4, 1) of the step at ``x``, action ``u``."""
        a, b = self._jacobians(np.asarray(x, dtype=float), float(u), 0.0)
        return np.array(a), np.array(b).reshape(4, 1)

    def equilibrium(self, angles: np.ndarray, iterations: int = 50) -> np.ndarray:
        """The state at rest nearest ``angles`` where zero action leaves the velocities at rest
        (Newton on the velocity increments); ValueError where there is none."""
        x = np.array([*angles, 0.0, 0.0], dtype=float)
        for _ in range(iterations):
            residual = self.step(x, 0.0)[2:]
            a = self.jacobians(x)[0][2:, :2]
            move = np.linalg.lstsq(a, -residual, rcond=None)[0]
            x[:2] += move
            if np.abs(move).max() < 1e-13:
                break
        if np.abs(self.step(x, 0.0)[2:]).max() > 1e-9 or np.abs(x[:2] - angles).max() > 0.5:
            raise ValueError(
                f"the learnt model holds no state at rest near {[float(a) for a in angles]}"
            )
        return x

    def to_dict(self) -> dict[str, Any]:
        return {
            "harmonics": self.harmonics,
            "terms": self.used.tolist(),
            "weights": self.weights[self.used].tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> LibraryModel:
        harmonics = int(data["harmonics"])
        weights = np.zeros((len(features(np.zeros(4), 0.0, harmonics)), 4))
        weights[np.asarray(data["terms"], dtype=int)] = np.asarray(data["weights"], dtype=float)
        return cls(harmonics, weights)


def reward_terms(states: np.ndarray, harmonics: int) -> np.ndarray:
    """The angle part of :func:`features` of rows (angles first): ``(n, (1 + 2H)^2)``."""
    q1, q2 = np.asarray(states, dtype=np.float64)[:, :2].T
    terms = [a * b for a in angle_terms(q1, harmonics, np) for b in angle_terms(q2, harmonics, np)]
    return np.stack(np.broadcast_arrays(*terms), axis=1)


def best_angles(
    states: np.ndarray, rewards: np.ndarray, harmonics: int = HARMONICS, grid: int = 721
) -> tuple[np.ndarray, float]:
    """The angles where a reward fitted on the states' angles (least squares on the angle
    harmonics) is highest, searched on a ``grid`` x ``grid`` lattice, and the fit's RMS error."""
    a = reward_terms(states, harmonics)
    weights = np.linalg.lstsq(a, rewards, rcond=None)[0]
    rms = float(np.sqrt(np.mean((a @ weights - rewards) ** 2)))
    axis = np.linspace(-np.pi, np.pi, grid)
    lattice = np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1).reshape(-1, 2)
    values = reward_terms(lattice, harmonics) @ weights
    return lattice[int(np.argmax(values))], rms
