"""The acrobot's equations of motion in manipulator form: the report's, its errata fixed.

``q = (q1, q2)``: q1 is link 1's angle from the horizontal +x axis, q2 link 2's relative to link
1, counter-clockwise positive; hanging at rest is ``(-pi/2, 0)``; heights are up from the pivot.
The elbow torque ``tau`` [N m] is the only input::

    M(q) ddq + h(q, dq) + phi(q) = (0, tau)

    d11 = a + 2 b cos q2,  d12 = c + b cos q2,  d22 = c              M(q)     [kg m^2]
    h1 = -b sin q2 (dq2^2 + 2 dq1 dq2),  h2 = b sin q2 dq1^2         h        [N m]
    phi1 = d cos q1 + phi2,  phi2 = e cos(q1 + q2)                   phi      [N m]

with the lumped constants ``(a, b, c, d, e)`` of :attr:`AcrobotParams.lumped
<acrobot_mj.physics.params.AcrobotParams.lumped>`; ``h + phi`` is MuJoCo's ``qfrc_bias``.
:func:`terms`, :func:`accelerations` and :func:`energies` are written over a math namespace
(:mod:`acrobot_mj.physics.xp`); the functions below them take ``q``, ``dq`` ``(..., 2)`` and
``tau`` ``(...)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acrobot_mj.compiled import jitable
from acrobot_mj.physics import xp as FLOATS
from acrobot_mj.physics.params import REPORT, AcrobotParams, Lumped
from acrobot_mj.physics.xp import ARRAY, wrap, wrap_angle

#: Hanging at rest and upright at rest, ``(q1, q2, dq1, dq2)`` [rad, rad/s].
HANGING = np.array([-np.pi / 2, 0.0, 0.0, 0.0])
UPRIGHT = np.array([np.pi / 2, 0.0, 0.0, 0.0])


@jitable
def terms(q1, q2, dq1, dq2, theta: Lumped, xp=FLOATS) -> tuple:
    """``d11, d12, d22`` [kg m^2], ``h1, h2``, ``phi1, phi2`` [N m] at ``(q1, q2, dq1, dq2)``."""
    a, b, c, d, e = theta
    c2, s2 = xp.cos(q2), xp.sin(q2)
    d11, d12, d22 = a + 2.0 * b * c2, c + b * c2, c
    h1 = -b * s2 * (dq2 * dq2 + 2.0 * dq1 * dq2)
    h2 = b * s2 * dq1 * dq1
    phi2 = e * xp.cos(q1 + q2)
    phi1 = d * xp.cos(q1) + phi2
    return d11, d12, d22, h1, h2, phi1, phi2


@jitable
def accelerations(q1, q2, dq1, dq2, tau, theta: Lumped, xp=FLOATS) -> tuple:
    """``ddq1, ddq2`` [rad/s^2] under elbow torque ``tau`` [N m], by Cramer's rule."""
    d11, d12, d22, h1, h2, phi1, phi2 = terms(q1, q2, dq1, dq2, theta, xp)
    f1, f2 = -(h1 + phi1), tau - (h2 + phi2)
    det = d11 * d22 - d12 * d12
    return (d22 * f1 - d12 * f2) / det, (d11 * f2 - d12 * f1) / det


@jitable
def energies(q1, q2, dq1, dq2, theta: Lumped, xp=FLOATS) -> tuple:
    """Kinetic ``T = dq^T M dq / 2`` and gravitational ``V = d sin q1 + e sin(q1 + q2)`` [J]."""
    d11, d12, d22 = terms(q1, q2, dq1, dq2, theta, xp)[:3]
    kinetic = 0.5 * (d11 * dq1 * dq1 + 2.0 * d12 * dq1 * dq2 + d22 * dq2 * dq2)
    return kinetic, theta[3] * xp.sin(q1) + theta[4] * xp.sin(q1 + q2)


def _split(x: ArrayLike) -> tuple[NDArray, NDArray]:
    x = np.asarray(x, dtype=np.float64)
    if x.shape[-1:] != (2,):
        raise ValueError(f"expected a last dimension of size 2 (q1, q2), got shape {x.shape}")
    return x[..., 0], x[..., 1]


def _over_arrays(function, q: ArrayLike, dq: ArrayLike, p: AcrobotParams) -> tuple:
    return function(*_split(q), *_split(dq), p.lumped, ARRAY)


def mass_matrix(q: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """Joint-space inertia ``M(q)`` [kg m^2], shape ``(..., 2, 2)``."""
    d11, d12, d22 = _over_arrays(terms, q, np.zeros_like(q, dtype=float), p)[:3]
    d22 = np.broadcast_to(d22, np.shape(d11))
    return np.stack([np.stack([d11, d12], -1), np.stack([d12, d22], -1)], -2)


def coriolis_forces(q: ArrayLike, dq: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """Coriolis and centrifugal terms ``h(q, dq)`` [N m], shape ``(..., 2)``."""
    return np.stack(np.broadcast_arrays(*_over_arrays(terms, q, dq, p)[3:5]), -1)


def gravity_forces(q: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """Gravity terms ``phi(q) = dV/dq`` [N m], shape ``(..., 2)``."""
    return np.stack(_over_arrays(terms, q, np.zeros_like(q, dtype=float), p)[5:], -1)


def bias_forces(q: ArrayLike, dq: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """``h(q, dq) + phi(q)`` [N m], shape ``(..., 2)``: MuJoCo's ``qfrc_bias``."""
    return coriolis_forces(q, dq, p) + gravity_forces(q, p)


def generalized_forces(tau: ArrayLike) -> NDArray:
    """The elbow torque as joint forces ``(0, tau)`` [N m], shape ``(..., 2)``."""
    tau = np.asarray(tau, dtype=np.float64)
    return np.stack([np.zeros_like(tau), tau], -1)


def solve_2x2(m: NDArray, f: NDArray) -> NDArray:
    """Solve ``m x = f`` for symmetric 2x2 ``m`` (``(..., 2, 2)``) by Cramer's rule, batched."""
    a, b, d, f1, f2 = m[..., 0, 0], m[..., 0, 1], m[..., 1, 1], f[..., 0], f[..., 1]
    det = a * d - b * b
    return np.stack([(d * f1 - b * f2) / det, (a * f2 - b * f1) / det], -1)


def forward_dynamics(
    q: ArrayLike, dq: ArrayLike, tau: ArrayLike = 0.0, p: AcrobotParams = REPORT
) -> NDArray:
    """Joint accelerations ``ddq`` [rad/s^2], shape ``(..., 2)``."""
    ddq = accelerations(*_split(q), *_split(dq), np.asarray(tau, dtype=float), p.lumped, ARRAY)
    return np.stack(np.broadcast_arrays(*ddq), -1)


def potential_energy(q: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """Gravitational energy ``V(q)`` [J], zero at the pivot's height, shape ``(...)``."""
    return _over_arrays(energies, q, np.zeros_like(q, dtype=float), p)[1]


def total_energy(q: ArrayLike, dq: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """``T + V`` [J], shape ``(...)``; conserved when ``tau = 0``."""
    kinetic, potential = _over_arrays(energies, q, dq, p)
    return kinetic + potential


def tip_position(q: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """Tip of link 2 ``(x, z)`` [m] relative to the pivot, shape ``(..., 2)``."""
    q1, q2 = _split(q)
    x = p.l1 * np.cos(q1) + p.l2 * np.cos(q1 + q2)
    return np.stack([x, p.l1 * np.sin(q1) + p.l2 * np.sin(q1 + q2)], -1)


def tip_height(x: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """Height of the tip above the pivot [m] of states ``(..., 4)`` (or angles ``(..., 2)``)."""
    return tip_position(np.asarray(x)[..., :2], p)[..., 1]


def state_error(x: np.ndarray, reference: np.ndarray | tuple = UPRIGHT) -> np.ndarray:
    """``x - reference`` [rad, rad/s], shape ``(..., 4)``, angles wrapped to ``[-pi, pi)``. One
    state from one reference (an array or 4 floats) on floats: the same numbers, a fifth of
    the time (a call every physics step, where numpy's small arrays cost most)."""
    x = np.asarray(x, dtype=float)
    if x.shape == (4,) and len(reference) == 4 and np.ndim(reference) == 1:
        r = reference.tolist() if isinstance(reference, np.ndarray) else reference
        return np.array(float_error(x.tolist(), r))
    error = x - np.asarray(reference, dtype=float)
    error[..., :2] = wrap_angle(error[..., :2])
    return error


def float_error(x: Sequence[float], reference: Sequence[float]) -> tuple[float, ...]:
    """:func:`state_error` of one state from one reference, 4 floats each: 4 floats."""
    return (
        wrap(x[0] - reference[0]),
        wrap(x[1] - reference[1]),
        x[2] - reference[2],
        x[3] - reference[3],
    )


def equilibria() -> NDArray:
    """The zero-torque equilibria ``(q1, q2)`` [rad]: hanging, upright, and link 2 folded."""
    h = np.pi / 2
    return np.array([[-h, 0.0], [h, 0.0], [-h, np.pi], [h, np.pi]])


def linearize(
    q: ArrayLike, dq: ArrayLike = (0.0, 0.0), tau: ArrayLike = 0.0, p: AcrobotParams = REPORT
) -> tuple[NDArray, NDArray]:
    """Jacobians ``A`` ``(..., 4, 4)`` and ``B`` ``(..., 4, 1)`` [per N m] of ``dx/dt = f(x,
    tau)`` at ``x = (q, dq)``: ``d(M^-1 f)/dx = M^-1 (df/dx - dM/dx M^-1 f)``."""
    q1, q2 = _split(q)
    dq1, dq2 = _split(dq)
    _, b, _, d, e = p.lumped
    m, ddq = mass_matrix(q, p), forward_dynamics(q, dq, tau, p)
    s2, c2, s12 = np.sin(q2), np.cos(q2), np.sin(q1 + q2)
    shape = np.broadcast_shapes(q1.shape, dq1.shape, np.shape(tau))
    zero = np.zeros(shape)

    def col(x: ArrayLike, y: ArrayLike) -> NDArray:
        return np.stack(np.broadcast_arrays(x, y, zero)[:2], -1)

    # dM/dq2 times ddq (M depends on q2 only), then the gravity and Coriolis derivatives.
    dm_ddq_dq2 = col(-b * s2 * (2 * ddq[..., 0] + ddq[..., 1]), -b * s2 * ddq[..., 0])
    g12 = e * s12
    dphi_dq1, dphi_dq2 = col(-d * np.sin(q1) - g12, -g12), col(-g12, -g12)
    dh_dq2 = col(-b * c2 * (dq2**2 + 2 * dq1 * dq2), b * c2 * dq1**2)
    dh_ddq1 = col(-2 * b * s2 * dq2, 2 * b * s2 * dq1)
    dh_ddq2 = col(-2 * b * s2 * (dq2 + dq1), zero)
    rhs = np.stack([-dphi_dq1, -(dh_dq2 + dphi_dq2 + dm_ddq_dq2), -dh_ddq1, -dh_ddq2], -1)
    m_b = np.broadcast_to(m, (*shape, 2, 2))
    a = np.zeros((*shape, 4, 4))
    a[..., 0, 2] = a[..., 1, 3] = 1.0
    a[..., 2:, :] = np.stack([solve_2x2(m_b, rhs[..., j]) for j in range(4)], -1)
    b_matrix = np.zeros((*shape, 4, 1))
    b_matrix[..., 2:, 0] = solve_2x2(m_b, np.broadcast_to(generalized_forces(1.0), (*shape, 2)))
    return a, b_matrix
