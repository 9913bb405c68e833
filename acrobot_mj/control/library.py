"""A model of one env decision learnt from data alone: ``x' = x + W' phi(x, u)`` (a map), or
``dx/dt = W' phi(x, u) / (1 + w' psi(q))`` integrated by ``substeps`` RK4 steps of ``h``
seconds (an ODE). ``phi`` holds every product of a Fourier harmonic of each angle (up to
``harmonics``) with a monomial of degree at most 2 in the two velocities and the action, ``psi``
the angle products of harmonics up to 2; ``W`` comes from sequentially thresholded least squares
(SINDy: Brunton, Proctor and Kutz 2016). It is told only that the first two observations are
angles, and for the ODE how many physics steps of what seconds make a decision; nothing of
masses, lengths, the equations or the integrator. The same ``phi`` serves numpy rows and CasADi
symbols (:mod:`~acrobot_mj.physics.xp`), so the planner and the feedback gains use the very
model the data fitted."""

from __future__ import annotations

import functools
from collections.abc import Callable
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


def angle_products(q1: Any, q2: Any, harmonics: int, xp: Any) -> list[Any]:
    """Every product of :func:`angle_terms` of ``q1`` with those of ``q2`` (the constant first)."""
    return [a * b for a in angle_terms(q1, harmonics, xp) for b in angle_terms(q2, harmonics, xp)]


def monomial_terms(v1: Any, v2: Any, u: Any) -> list[Any]:
    """The monomials of degree <= 2 in the velocities and the action."""
    return [1.0, v1, v2, u, v1 * v1, v1 * v2, v2 * v2, v1 * u, v2 * u, u * u]


def features(x: Any, u: Any, harmonics: int, xp: Any = np) -> list[Any]:
    """``phi(x, u)``: ``(1 + 2H)^2 * 10`` terms of state ``x`` (four numbers, rows or symbols)
    and action ``u``."""
    q1, q2, v1, v2 = (x[i] for i in range(4))
    angles = angle_products(q1, q2, harmonics, xp)
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


def unit_columns(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``a`` with each column divided by its RMS (an all-zero column by 1), and those RMS."""
    scale = np.sqrt(np.mean(a * a, axis=0))
    scale[scale == 0.0] = 1.0
    return a / scale, scale


def thresholded_least_squares(
    a: np.ndarray, b: np.ndarray, threshold: float, rounds: int = 5
) -> np.ndarray:
    """``W`` minimising ``|a W - b|`` column by column, the terms with ``|W| rms(a) <
    threshold`` dropped and the rest refitted, ``rounds`` times."""
    scaled, scale = unit_columns(a)
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


#: Harmonics of each angle in an ODE's denominators: a two-link arm's mass matrix has
#: determinant ``a - b cos^2 q2``, of harmonic 2, and its inverse no finite Fourier sum.
DENOMINATOR_HARMONICS = 2
#: Gauss-Newton rounds of the ODE fit (:func:`ode_fit`): the training error stops falling after
#: about 12 on dm_control's acrobot (measured).
ODE_ROUNDS = 14
#: Ridge on the denominators' weights, per transition: keeps a denominator at 1 where the data
#: need none, and the fit off the ``N g / D g`` valley. On 1,500 exact transitions of a known
#: rational field, 1e-8 recovers its terms (its bias: 6e-7 rad/s); 1e-10 and 1e-12 wander off
#: (measured).
RIDGE = 1e-8


def scaled_least_squares(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``W`` minimising ``|a W - b|``, the columns of ``a`` scaled to unit RMS."""
    scaled, scale = unit_columns(a)
    return np.linalg.lstsq(scaled, b, rcond=None)[0] / scale[:, None]


def denominator_design(states: np.ndarray) -> np.ndarray:
    """The angle products of :data:`DENOMINATOR_HARMONICS` but the constant: ``(n, 24)``."""
    return reward_terms(states, DENOMINATOR_HARMONICS)[:, 1:]


def rates(
    states: np.ndarray,
    actions: np.ndarray,
    weights: np.ndarray,
    denominators: np.ndarray,
    harmonics: int,
) -> tuple[np.ndarray, ...]:
    """``dx/dt = (phi' W) / (1 + psi' w)`` per column, with ``phi``, ``psi``, the numerators and
    the denominators."""
    phi, psi = design(states, actions, harmonics), denominator_design(states)
    top, bottom = phi @ weights, 1.0 + psi @ denominators
    return top / bottom, phi, psi, top, bottom


#: The classical RK4 tableau: each stage's weight and how far the next stage advances.
RK4 = ((1.0, 0.5), (2.0, 0.5), (2.0, 1.0), (1.0, 0.0))


def rk4_step(rate: Callable[[Any], Any], x: Any, h: float) -> Any:
    """One classical RK4 step of ``h`` [s] of ``dx/dt = rate(x)`` from ``x`` (rows or CasADi
    symbols)."""
    stage, total = x, 0.0
    for weight, advance in RK4:
        k = rate(stage)
        total = total + weight * k
        stage = x + (h * advance) * k
    return x + h / 6.0 * total


@dataclass(frozen=True)
class Substeps:
    """One decision as ``n`` RK4 steps of ``h`` [s] of a library model's ``harmonics``."""

    harmonics: int
    h: float
    n: int


def rk4_end(
    states: np.ndarray,
    actions: np.ndarray,
    weights: np.ndarray,
    denominators: np.ndarray,
    steps: Substeps,
) -> np.ndarray:
    """``steps`` of :func:`rates` from rows ``states``."""
    x = np.asarray(states, dtype=np.float64)
    for _ in range(steps.n):
        x = rk4_step(
            lambda s: rates(s, actions, weights, denominators, steps.harmonics)[0], x, steps.h
        )
    return x


def rk4_sensitivities(
    states: np.ndarray,
    actions: np.ndarray,
    weights: np.ndarray,
    denominators: np.ndarray,
    steps: Substeps,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The end of :func:`rk4_end`, and per column ``i`` the derivatives of its increment with
    the stages held: by ``W[:, i]`` ``(4, rows, features)`` and by ``w[:, i]`` ``(4, rows,
    24)``."""
    x, h = np.asarray(states, dtype=np.float64), steps.h
    by_top = np.zeros((4, len(x), weights.shape[0]))
    by_bottom = np.zeros((4, len(x), denominators.shape[0]))
    for _ in range(steps.n):
        stage, total = x, np.zeros_like(x)
        for weight, advance in RK4:
            k, phi, psi, top, bottom = rates(stage, actions, weights, denominators, steps.harmonics)
            c = h / 6.0 * weight
            for i in range(4):
                by_top[i] += (c / bottom[:, i : i + 1]) * phi
                by_bottom[i] -= (c * top[:, i] / bottom[:, i] ** 2)[:, None] * psi
            total = total + weight * k
            stage = x + (h * advance) * k
        x = x + h / 6.0 * total
    return x, by_top, by_bottom


def gauss_newton_step(
    miss: np.ndarray, by_top: np.ndarray, by_bottom: np.ndarray, denominators: np.ndarray
) -> np.ndarray:
    """Per column, the least-squares step of numerators and denominators that removes ``miss``
    to first order, with the ridge :data:`RIDGE` on the denominators: ``(features + 24, 4)``."""
    count, ridge = by_top.shape[2], np.sqrt(RIDGE * len(miss))
    step = np.zeros((count + len(denominators), 4))
    for i in range(4):
        jacobian = np.hstack([by_top[i], by_bottom[i]])
        prior = np.zeros((len(denominators), jacobian.shape[1]))
        prior[:, count:] = ridge * np.eye(len(denominators))
        scale = unit_columns(jacobian)[1]
        rows = np.vstack([jacobian, prior]) / scale
        target = np.concatenate([miss[:, i], -ridge * denominators[:, i]])
        step[:, i] = np.linalg.lstsq(rows, target, rcond=None)[0] / scale
    return step


def ode_fit(
    states: np.ndarray,
    actions: np.ndarray,
    delta: np.ndarray,
    steps: Substeps,
    threshold: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator weights of ``dx/dt = (W' phi) / (1 + w' psi)`` whose ``steps``
    give the increments ``delta`` (a rational SINDy model, as SINDy-PI fits; Kaheman, Kutz and
    Brunton 2020). It starts from the polynomial rate at each decision's midpoint (``w = 0``),
    takes :data:`ODE_ROUNDS` Gauss-Newton steps through the RK4 steps (each column's step
    halved until its error and ridge fall), then thresholds the numerators with the
    denominators held (SINDy)."""
    span = steps.h * steps.n
    midpoint = design(states + delta / 2, actions, steps.harmonics) * span
    weights = scaled_least_squares(midpoint, delta)
    denominators = np.zeros((DENOMINATOR_TERMS, 4))
    count = len(weights)

    def objective(top: np.ndarray, bottom: np.ndarray) -> np.ndarray:
        """Per column: the mean squared miss plus the ridge."""
        with np.errstate(all="ignore"):
            end = rk4_end(states, actions, top, bottom, steps)
            mean = np.mean((end - states - delta) ** 2, axis=0) + RIDGE * np.sum(bottom**2, axis=0)
        return np.where(np.isfinite(mean), mean, np.inf)

    for _ in range(ODE_ROUNDS):
        end, by_top, by_bottom = rk4_sensitivities(states, actions, weights, denominators, steps)
        miss = delta - (end - states)
        before = np.mean(miss**2, axis=0) + RIDGE * np.sum(denominators**2, axis=0)
        step = gauss_newton_step(miss, by_top, by_bottom, denominators)
        todo, share = np.ones(4, dtype=bool), 1.0
        for _ in range(8):
            top = np.where(todo, weights + share * step[:count], weights)
            bottom = np.where(todo, denominators + share * step[count:], denominators)
            better = todo & (objective(top, bottom) < before)
            weights[:, better], denominators[:, better] = top[:, better], bottom[:, better]
            todo &= ~better
            if not todo.any():
                break
            share /= 2
    by_top = rk4_sensitivities(states, actions, weights, denominators, steps)[1]
    for i in range(4):
        weights[:, i] = thresholded_least_squares(by_top[i], delta[:, i : i + 1], threshold)[:, 0]
    return weights, denominators


#: The denominators' terms (:func:`denominator_design`).
DENOMINATOR_TERMS = (1 + 2 * DENOMINATOR_HARMONICS) ** 2 - 1


@dataclass(frozen=True)
class LibraryModel:
    """``x' = x + weights' phi(x, u)`` (``substeps`` 0), or ``dx/dt = (weights' phi(x, u)) /
    (1 + denominators' psi(q))`` integrated by ``substeps`` RK4 steps of ``h`` [s]: ``weights``
    ``(features, 4)`` over :func:`features` of ``harmonics``, ``denominators`` ``(24, 4)`` over
    :func:`denominator_design` (None: all 1)."""

    harmonics: int
    weights: np.ndarray
    substeps: int = 0
    h: float = 0.0
    denominators: np.ndarray | None = None

    def __post_init__(self) -> None:
        size = len(features(np.zeros(4), 0.0, self.harmonics))
        if np.shape(self.weights) != (size, 4) or not np.isfinite(self.weights).all():
            raise ValueError(
                f"a library model of {self.harmonics} harmonics needs finite "
                f"weights of shape ({size}, 4), got "
                f"{np.shape(self.weights)}"
            )
        if self.substeps < 0 or (self.substeps > 0) != (self.h > 0.0):
            raise ValueError(
                f"an ODE library model needs substeps > 0 and h > 0 s (a map: both 0), got "
                f"substeps={self.substeps}, h={self.h}"
            )
        if self.denominators is not None:
            shape = (DENOMINATOR_TERMS, 4)
            if not self.substeps or np.shape(self.denominators) != shape:
                raise ValueError(f"denominators need an ODE and shape {shape}")
            if not np.isfinite(self.denominators).all():
                raise ValueError("a library model's denominators must be finite")

    @property
    def bottoms(self) -> np.ndarray:
        """The denominators' weights, zeros where there are none."""
        if self.denominators is None:
            return np.zeros((DENOMINATOR_TERMS, 4))
        return np.asarray(self.denominators, dtype=np.float64)

    def coarse(self) -> LibraryModel:
        """The same ODE by one RK4 step per decision (a map: itself): cheaper to plan on, about
        as accurate where the decision is short against the motion."""
        if self.substeps <= 1:
            return self
        return LibraryModel(
            self.harmonics, self.weights, 1, self.h * self.substeps, self.denominators
        )

    @property
    def form(self) -> str:
        return "ode" if self.substeps else "map"

    @classmethod
    def fit(
        cls,
        states: np.ndarray,
        actions: np.ndarray,
        next_states: np.ndarray,
        harmonics: int = HARMONICS,
        threshold: float = THRESHOLD,
        ode: tuple[int, float] | None = None,
    ) -> LibraryModel:
        """The model of the transitions ``(states[i], actions[i], next_states[i])``: a map, or
        with ``ode = (substeps, h)`` an ODE of that many RK4 steps of ``h`` [s]
        (:func:`ode_fit`)."""
        states, actions = (
            np.asarray(states, dtype=np.float64),
            np.asarray(actions, dtype=np.float64),
        )
        terms = len(features(np.zeros(4), 0.0, harmonics))
        if len(states) < terms:
            raise ValueError(f"{len(states)} transitions cannot fit {terms} library terms")
        delta = increments(states, next_states)
        if ode is not None:
            substeps, h = ode
            steps = Substeps(harmonics, h, substeps)
            top, bottom = ode_fit(states, actions, delta, steps, threshold)
            return cls(harmonics, top, substeps, h, bottom)
        weights = thresholded_least_squares(design(states, actions, harmonics), delta, threshold)
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
        actions = np.broadcast_to(np.asarray(actions, dtype=np.float64), len(rows))
        if self.substeps and len(rows) == 1:
            # One state (a rollout of the feedback): the compiled graph of the terms in use,
            # about 60 times faster than all terms' rows (measured on RealAIGym's acrobot).
            end = np.array(self.function(rows[0], float(actions[0]), 0.0)).ravel()
            return end.reshape(states.shape)
        if self.substeps:
            steps = Substeps(self.harmonics, self.h, self.substeps)
            end = rk4_end(rows, actions, self.weights, self.bottoms, steps)
            return end.reshape(states.shape)
        phi = design(rows, actions, self.harmonics)
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
        top = casadi.mtimes(self.weights[self.used].T, terms)
        if not self.substeps:
            weighted = casadi.Function("weighted", [x, u], [top])
            return casadi.Function("step", [x, u, h], [x + weighted(x, u)])
        angles = angle_products(x[0], x[1], DENOMINATOR_HARMONICS, casadi)[1:]
        bottom = 1.0 + casadi.mtimes(self.bottoms.T, casadi.vertcat(*angles))
        weighted = casadi.Function("weighted", [x, u], [top / bottom])
        end = x
        for _ in range(self.substeps):
            end = rk4_step(lambda s: weighted(s, u), end, self.h)
        return casadi.Function("step", [x, u, h], [end])

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
        ode = {"substeps": self.substeps, "h": self.h} if self.substeps else {}
        if self.denominators is not None:
            ode["denominators"] = self.bottoms.tolist()
        return {
            "harmonics": self.harmonics,
            "terms": self.used.tolist(),
            "weights": self.weights[self.used].tolist(),
            **ode,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> LibraryModel:
        harmonics = int(data["harmonics"])
        weights = np.zeros((len(features(np.zeros(4), 0.0, harmonics)), 4))
        weights[np.asarray(data["terms"], dtype=int)] = np.asarray(data["weights"], dtype=float)
        bottom = data.get("denominators")
        return cls(
            harmonics,
            weights,
            int(data.get("substeps", 0)),
            float(data.get("h", 0.0)),
            None if bottom is None else np.asarray(bottom, dtype=float),
        )


def reward_terms(states: np.ndarray, harmonics: int) -> np.ndarray:
    """The angle part of :func:`features` of rows (angles first): ``(n, (1 + 2H)^2)``."""
    q1, q2 = np.asarray(states, dtype=np.float64)[:, :2].T
    terms = angle_products(q1, q2, harmonics, np)
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
