"""The terms of the black box's library model (:mod:`~acrobot_mj.identify.library`): ``phi(x,
u)``, every product of a Fourier harmonic of each angle with a monomial of degree at most 2 in
the two velocities and the action, and ``psi(q)``, the angle products of a denominator. The same
terms serve numpy rows and CasADi symbols (:mod:`~acrobot_mj.physics.xp`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from acrobot_mj.physics.xp import wrap_angle

#: Harmonics of each angle in the library: 4 fits the acrobot's decisions to about 1e-4 rad/s
#: (3: about 5e-4), measured on 5,000 held-out transitions from uniform starts.
HARMONICS = 4


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


#: Harmonics of each angle in the denominators (an ODE's, a rational map's): a two-link arm's
#: mass matrix has determinant ``a - b cos^2 q2``, of harmonic 2, and its inverse no finite
#: Fourier sum.
DENOMINATOR_HARMONICS = 2
#: The denominators' terms (:func:`denominator_design`).
DENOMINATOR_TERMS = (1 + 2 * DENOMINATOR_HARMONICS) ** 2 - 1


def denominator_design(states: np.ndarray) -> np.ndarray:
    """The angle products of :data:`DENOMINATOR_HARMONICS` but the constant: ``(n, 24)``."""
    return reward_terms(states, DENOMINATOR_HARMONICS)[:, 1:]


def reward_terms(states: np.ndarray, harmonics: int) -> np.ndarray:
    """The angle part of :func:`features` of rows (angles first): ``(n, (1 + 2H)^2)``."""
    q1, q2 = np.asarray(states, dtype=np.float64)[:, :2].T
    terms = angle_products(q1, q2, harmonics, np)
    return np.stack(np.broadcast_arrays(*terms), axis=1)
