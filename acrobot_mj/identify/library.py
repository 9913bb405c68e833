"""A model of one env decision learnt from data alone: ``x' = x + W' phi(x, u)`` (a map),
``x' = x + W' phi(x, u) / (1 + w' psi(q))`` (a rational map), or ``dx/dt = W' phi(x, u) / (1 +
w' psi(q))`` integrated by ``substeps`` RK4 steps of ``h`` seconds (an ODE). ``phi`` holds every
product of a Fourier harmonic of each angle (up to ``harmonics``) with a monomial of degree at
most 2 in the two velocities and the action, ``psi`` the angle products of harmonics up to 2
(:mod:`~acrobot_mj.identify.terms`); the weights come from sequentially thresholded least
squares (SINDy: Brunton, Proctor and Kutz 2016), on the rational map's implicit form, or through
the RK4 steps by Gauss-Newton (:mod:`~acrobot_mj.identify.fit`). It is told only that the
first two observations are angles, and for the ODE how many physics steps of what seconds make
a decision; nothing of masses, lengths, the equations or the integrator. The same ``phi``
serves numpy rows and CasADi symbols (:mod:`~acrobot_mj.physics.xp`), so the planner and the
feedback gains use the very model the data fitted."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.identify.fit import (
    THRESHOLD,
    Substeps,
    ode_fit,
    rates,
    rational_fit,
    rk4_end,
    rk4_step,
    thresholded_least_squares,
)
from acrobot_mj.identify.terms import (
    DENOMINATOR_HARMONICS,
    DENOMINATOR_TERMS,
    HARMONICS,
    angle_products,
    denominator_design,
    design,
    features,
    increments,
    reward_terms,
)


def library_size(harmonics: int, form: str = "map") -> int:
    """How many weights per state variable a ``form`` of ``harmonics`` fits: the ``(1 + 2H)^2 *
    10`` terms of :func:`~acrobot_mj.identify.terms.features`, and a rational map's
    :data:`~acrobot_mj.identify.terms.DENOMINATOR_TERMS` denominators."""
    terms = len(features(np.zeros(4), 0.0, harmonics))
    return terms + (DENOMINATOR_TERMS if form == "rational" else 0)


def transitions(
    states: np.ndarray, actions: np.ndarray, next_states: np.ndarray, terms: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States and actions as floats and the increments
    (:func:`~acrobot_mj.identify.terms.increments`), refused where fewer than the
    ``terms`` a fit solves for."""
    states, actions = np.asarray(states, dtype=np.float64), np.asarray(actions, dtype=np.float64)
    if len(states) < terms:
        raise ValueError(f"{len(states)} transitions cannot fit {terms} library terms")
    return states, actions, increments(states, next_states)


@dataclass(frozen=True)
class LibraryModel:
    """``x' = x + (weights' phi(x, u)) / (1 + denominators' psi(q))`` (``substeps`` 0: a map,
    rational where it has denominators), or ``dx/dt = (weights' phi(x, u)) / (1 +
    denominators' psi(q))`` integrated by ``substeps`` RK4 steps of ``h`` [s] (an ODE):
    ``weights`` ``(features, 4)`` over :func:`~acrobot_mj.identify.terms.features` of
    ``harmonics``, ``denominators`` ``(24, 4)`` over
    :func:`~acrobot_mj.identify.terms.denominator_design` (None: all 1)."""

    harmonics: int
    weights: np.ndarray
    substeps: int = 0
    h: float = 0.0
    denominators: np.ndarray | None = None

    def __post_init__(self) -> None:
        size = library_size(self.harmonics)
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
            if np.shape(self.denominators) != shape:
                raise ValueError(f"denominators need shape {shape}")
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
        """``"ode"``, ``"rational"`` (a map with denominators) or ``"map"``."""
        if self.substeps:
            return "ode"
        return "map" if self.denominators is None else "rational"

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
        (:func:`~acrobot_mj.identify.fit.ode_fit`)."""
        states, actions, delta = transitions(states, actions, next_states, library_size(harmonics))
        if ode is not None:
            substeps, h = ode
            steps = Substeps(harmonics, h, substeps)
            top, bottom = ode_fit(states, actions, delta, steps, threshold)
            return cls(harmonics, top, substeps, h, bottom)
        weights = thresholded_least_squares(design(states, actions, harmonics), delta, threshold)
        return cls(harmonics, weights)

    @classmethod
    def fit_rational(
        cls,
        states: np.ndarray,
        actions: np.ndarray,
        next_states: np.ndarray,
        harmonics: int = HARMONICS,
        threshold: float = THRESHOLD,
    ) -> LibraryModel:
        """The map with denominators of the transitions
        (:func:`~acrobot_mj.identify.fit.rational_fit`)."""
        terms = library_size(harmonics, "rational")
        states, actions, delta = transitions(states, actions, next_states, terms)
        phi, psi = design(states, actions, harmonics), denominator_design(states)
        top, bottom = rational_fit(phi, psi, delta, threshold)
        return cls(harmonics, top, denominators=bottom)

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
        if self.denominators is not None:
            change = rates(rows, actions, self.weights, self.denominators, self.harmonics)[0]
            return (rows + change).reshape(states.shape)
        return (rows + design(rows, actions, self.harmonics) @ self.weights).reshape(states.shape)

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
        if self.denominators is not None:
            angles = angle_products(x[0], x[1], DENOMINATOR_HARMONICS, casadi)[1:]
            top = top / (1.0 + casadi.mtimes(self.bottoms.T, casadi.vertcat(*angles)))
        weighted = casadi.Function("weighted", [x, u], [top])
        if not self.substeps:
            return casadi.Function("step", [x, u, h], [x + weighted(x, u)])
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
        extra = {"substeps": self.substeps, "h": self.h} if self.substeps else {}
        if self.denominators is not None:
            extra["denominators"] = self.bottoms.tolist()
        return {
            "harmonics": self.harmonics,
            "terms": self.used.tolist(),
            "weights": self.weights[self.used].tolist(),
            **extra,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> LibraryModel:
        harmonics = int(data["harmonics"])
        weights = np.zeros((library_size(harmonics), 4))
        weights[np.asarray(data["terms"], dtype=int)] = np.asarray(data["weights"], dtype=float)
        bottom = data.get("denominators")
        return cls(
            harmonics,
            weights,
            int(data.get("substeps", 0)),
            float(data.get("h", 0.0)),
            None if bottom is None else np.asarray(bottom, dtype=float),
        )


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
