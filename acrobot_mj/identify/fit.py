"""The fits of the black box's library model (:mod:`~acrobot_mj.identify.library`) to
transitions: sequentially thresholded least squares (SINDy: Brunton, Proctor and Kutz 2016) for
a map, the same on the implicit form of a rational map, and Gauss-Newton through RK4 steps for a
rational ODE."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.identify.terms import DENOMINATOR_TERMS, denominator_design, design

#: Coefficients below this, times their feature's RMS over the data, are dropped [rad, rad/s].
THRESHOLD = 1e-5


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


def rational_fit(
    phi: np.ndarray, psi: np.ndarray, delta: np.ndarray, threshold: float
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator weights of the map ``x' - x = (W' phi) / (1 + w' psi)`` whose
    increments are ``delta``: thresholded least squares on its implicit form ``delta = W' phi -
    delta w' psi``, linear in both (SINDy-PI: Kaheman, Kutz and Brunton 2020). Exact where the
    data are and the map is in the library: one semi-implicit Euler step of a two-link arm is,
    its inverse mass matrix having the determinant as denominator."""
    weights, denominators = np.zeros((phi.shape[1], 4)), np.zeros((psi.shape[1], 4))
    for i in range(4):
        implicit = np.hstack([phi, -delta[:, i : i + 1] * psi])
        both = thresholded_least_squares(implicit, delta[:, i : i + 1], threshold)[:, 0]
        weights[:, i], denominators[:, i] = both[: phi.shape[1]], both[phi.shape[1] :]
    return weights, denominators
