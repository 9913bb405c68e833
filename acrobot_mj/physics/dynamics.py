"""The acrobot's equations of motion in manipulator form, as in the report (corrected).

Convention (``docs/design.md``): ``q = (q1, q2)`` with q1 the angle of link 1 from the horizontal
+x axis and q2 the angle of link 2 relative to link 1, counter-clockwise positive; hanging at rest
is ``(-pi/2, 0)``. Heights are measured up from the pivot. The elbow torque ``tau`` [N m] is the
only input.

    M(q) ddq + h(q, dq) + phi(q) = (0, tau)

with ``M = [[d11, d12], [d12, d22]]``, Coriolis and centrifugal terms ``h`` and gravity ``phi``
(the report's equations (1) to (8), with its two errata fixed: the second row of the mass matrix
is ``(d21, d22)`` with ``d21 = d12``, and ``d12 = m2 (lc2^2 + l1 lc2 cos q2) + I2``).
``bias_forces = h + phi`` is what MuJoCo calls ``qfrc_bias``.

Every function takes one state or arrays of states: ``q`` and ``dq`` have shape ``(..., 2)``,
``tau`` has shape ``(...)`` (or is a float), and the leading dimensions broadcast.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acrobot_mj.physics.params import AcrobotParams

DEFAULT_PARAMS = AcrobotParams()


def _split(x: ArrayLike) -> tuple[NDArray, NDArray]:
    x = np.asarray(x, dtype=np.float64)
    if x.shape[-1:] != (2,):
        raise ValueError(f"expected a last dimension of size 2 (q1, q2), got shape {x.shape}")
    return x[..., 0], x[..., 1]


def inertia_terms(q2: Any, p: AcrobotParams = DEFAULT_PARAMS, xp: Any = np) -> tuple:
    """``d11, d12, d22`` [kg m^2] of ``M(q)`` (report eqs. 3, 4 and the erratum's ``d12``),
    element-wise in ``q2`` [rad]: floats, numpy arrays, or CasADi symbols with ``xp=casadi``
    (``xp`` supplies ``cos`` and ``sin``). Every other function here is built on these terms."""
    c2 = xp.cos(q2)
    d11 = p.m1 * p.lc1**2 + p.m2 * (p.l1**2 + p.lc2**2 + 2 * p.l1 * p.lc2 * c2) + p.I1 + p.I2
    d12 = p.m2 * (p.lc2**2 + p.l1 * p.lc2 * c2) + p.I2
    d22 = p.m2 * p.lc2**2 + p.I2
    return d11, d12, d22


def coriolis_terms(
    q2: Any, dq1: Any, dq2: Any, p: AcrobotParams = DEFAULT_PARAMS, xp: Any = np
) -> tuple:
    """``h1, h2`` [N m], the Coriolis and centrifugal terms (report eqs. 5, 6), element-wise."""
    k = p.m2 * p.l1 * p.lc2 * xp.sin(q2)
    h1 = -k * dq2**2 - 2 * k * dq2 * dq1
    h2 = k * dq1**2
    return h1, h2


def gravity_terms(q1: Any, q2: Any, p: AcrobotParams = DEFAULT_PARAMS, xp: Any = np) -> tuple:
    """``phi1, phi2`` = dV/dq [N m], the gravity terms (report eqs. 7, 8), element-wise."""
    phi2 = p.m2 * p.lc2 * p.g * xp.cos(q1 + q2)
    phi1 = (p.m1 * p.lc1 + p.m2 * p.l1) * p.g * xp.cos(q1) + phi2
    return phi1, phi2


def cramer(a: Any, b: Any, d: Any, f1: Any, f2: Any) -> tuple:
    """The solution ``(x1, x2)`` of ``[[a, b], [b, d]] x = (f1, f2)``, element-wise."""
    det = a * d - b * b
    return (d * f1 - b * f2) / det, (a * f2 - b * f1) / det


def accelerations(
    q1: Any, q2: Any, dq1: Any, dq2: Any, tau: Any, p: AcrobotParams = DEFAULT_PARAMS, xp: Any = np
) -> tuple:
    """``ddq1, ddq2`` [rad/s^2] element-wise, from the same terms as :func:`forward_dynamics`
    (with ``xp=casadi`` for symbolic states, as trajectory optimisation needs)."""
    d11, d12, d22 = inertia_terms(q2, p, xp)
    h1, h2 = coriolis_terms(q2, dq1, dq2, p, xp)
    phi1, phi2 = gravity_terms(q1, q2, p, xp)
    return cramer(d11, d12, d22, 0.0 - (h1 + phi1), tau - (h2 + phi2))


def mass_matrix(q: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """Joint-space inertia ``M(q)`` [kg m^2], shape ``(..., 2, 2)``.

    q: angles [rad], shape ``(..., 2)``.
    """
    _, q2 = _split(q)
    d11, d12, d22 = inertia_terms(q2, p)
    d22 = np.broadcast_to(d22, d11.shape)
    return np.stack([np.stack([d11, d12], -1), np.stack([d12, d22], -1)], -2)


def coriolis_forces(q: ArrayLike, dq: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """Coriolis and centrifugal terms ``h(q, dq)`` [N m], shape ``(..., 2)`` (report eqs. 5, 6)."""
    _, q2 = _split(q)
    dq1, dq2 = _split(dq)
    return np.stack(np.broadcast_arrays(*coriolis_terms(q2, dq1, dq2, p)), -1)


def gravity_forces(q: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """Gravity terms ``phi(q)`` = dV/dq [N m], shape ``(..., 2)`` (report eqs. 7, 8)."""
    q1, q2 = _split(q)
    return np.stack(gravity_terms(q1, q2, p), -1)


def bias_forces(q: ArrayLike, dq: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """``h(q, dq) + phi(q)`` [N m], shape ``(..., 2)``: MuJoCo's ``qfrc_bias``."""
    return coriolis_forces(q, dq, p) + gravity_forces(q, p)


def generalized_forces(tau: ArrayLike) -> NDArray:
    """The elbow torque as joint forces ``(0, tau)`` [N m], shape ``(..., 2)``."""
    tau = np.asarray(tau, dtype=np.float64)
    return np.stack([np.zeros_like(tau), tau], -1)


def solve_2x2(m: NDArray, f: NDArray) -> NDArray:
    """Solve ``m x = f`` for symmetric 2x2 ``m`` (``(..., 2, 2)``) by Cramer's rule, batched."""
    return np.stack(cramer(m[..., 0, 0], m[..., 0, 1], m[..., 1, 1], f[..., 0], f[..., 1]), -1)


def forward_dynamics(
    q: ArrayLike, dq: ArrayLike, tau: ArrayLike = 0.0, p: AcrobotParams = DEFAULT_PARAMS
) -> NDArray:
    """Joint accelerations ``ddq = M^-1 ((0, tau) - h - phi)`` [rad/s^2], shape ``(..., 2)``.

    q: angles [rad], dq: velocities [rad/s], both ``(..., 2)``; tau: elbow torque [N m], ``(...)``.
    """
    rhs = generalized_forces(tau) - bias_forces(q, dq, p)
    return solve_2x2(mass_matrix(q, p), rhs)


def kinetic_energy(q: ArrayLike, dq: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """``T = dq^T M(q) dq / 2`` [J], shape ``(...)``."""
    dq = np.asarray(dq, dtype=np.float64)
    return 0.5 * np.einsum("...i,...ij,...j->...", dq, mass_matrix(q, p), dq)


def potential_energy(q: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """Gravitational energy ``V(q)`` [J] with zero at the pivot's height, shape ``(...)``."""
    q1, q2 = _split(q)
    return p.g * ((p.m1 * p.lc1 + p.m2 * p.l1) * np.sin(q1) + p.m2 * p.lc2 * np.sin(q1 + q2))


def total_energy(q: ArrayLike, dq: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """``T + V`` [J], shape ``(...)``; conserved when ``tau = 0``."""
    return kinetic_energy(q, dq, p) + potential_energy(q, p)


def state_energy(q1: float, q2: float, dq1: float, dq2: float,
                 p: AcrobotParams = DEFAULT_PARAMS) -> float:  # fmt: skip
    """:func:`total_energy` [J] of one state on Python floats (angles [rad], velocities
    [rad/s]): the same number bit for bit, a fraction of the cost of numpy calls on one state.
    The kinetic term is summed in the order ``einsum`` sums ``dq^T M dq`` (row by row, then the
    rows); ``tests/test_physics.py`` checks equality over many states."""
    d11, d12, d22 = inertia_terms(q2, p, xp=math)
    kinetic = 0.5 * ((dq1 * d11 * dq1 + dq1 * d12 * dq2) + (dq2 * d12 * dq1 + dq2 * d22 * dq2))
    k1, k2 = p.m1 * p.lc1 + p.m2 * p.l1, p.m2 * p.lc2
    return kinetic + p.g * (k1 * math.sin(q1) + k2 * math.sin(q1 + q2))


def elbow_position(q: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """Elbow ``(x, z)`` [m] relative to the pivot, shape ``(..., 2)``."""
    q1, _ = _split(q)
    return np.stack([p.l1 * np.cos(q1), p.l1 * np.sin(q1)], -1)


def tip_position(q: ArrayLike, p: AcrobotParams = DEFAULT_PARAMS) -> NDArray:
    """Tip of link 2 ``(x, z)`` [m] relative to the pivot, shape ``(..., 2)``.

    The goal of the task is ``tip_position(q)[..., 1] > l1``.
    """
    q1, q2 = _split(q)
    return elbow_position(q, p) + np.stack([p.l2 * np.cos(q1 + q2), p.l2 * np.sin(q1 + q2)], -1)


def equilibria() -> NDArray:
    """The four zero-torque equilibria ``(q1, q2)`` [rad], shape ``(4, 2)``.

    Rows: hanging ``(-pi/2, 0)`` (stable), upright ``(pi/2, 0)`` (the balancing target),
    ``(-pi/2, pi)`` (link 1 down, link 2 folded up) and ``(pi/2, pi)`` (link 1 up, link 2 folded
    down). They do not depend on the parameters: gravity terms vanish when both links are vertical.
    """
    h = np.pi / 2
    return np.array([[-h, 0.0], [h, 0.0], [-h, np.pi], [h, np.pi]])


def linearize(
    q: ArrayLike,
    dq: ArrayLike = (0.0, 0.0),
    tau: ArrayLike = 0.0,
    p: AcrobotParams = DEFAULT_PARAMS,
) -> tuple[NDArray, NDArray]:
    """Continuous-time Jacobians of ``dx/dt = f(x, tau)`` at ``x = (q, dq)``, from the analytic
    derivatives of the equations of motion (no finite differences).

    Returns ``A`` with shape ``(..., 4, 4)`` (state order ``q1, q2, dq1, dq2``) and ``B`` with
    shape ``(..., 4, 1)`` [per N m]. Uses ``d(M^-1 f)/dx = M^-1 (df/dx - dM/dx M^-1 f)``.
    """
    q1, q2 = _split(q)
    dq1, dq2 = _split(dq)
    m = mass_matrix(q, p)
    ddq = forward_dynamics(q, dq, tau, p)
    s2, c2 = np.sin(q2), np.cos(q2)
    s12 = np.sin(q1 + q2)
    k = p.m2 * p.l1 * p.lc2
    shape = np.broadcast_shapes(q1.shape, dq1.shape, np.shape(tau))
    zero = np.zeros(shape)

    def col(a: ArrayLike, b: ArrayLike) -> NDArray:
        return np.stack(np.broadcast_arrays(a, b, zero)[:2], -1)

    # d(M ddq)/dq2 at fixed ddq: only M depends on q2 (dM/dq1 = 0).
    dm_ddq_dq2 = col(-k * s2 * (2 * ddq[..., 0] + ddq[..., 1]), -k * s2 * ddq[..., 0])
    # Gravity terms phi(q).
    g12 = p.m2 * p.lc2 * p.g * s12
    dphi_dq1 = col(-(p.m1 * p.lc1 + p.m2 * p.l1) * p.g * np.sin(q1) - g12, -g12)
    dphi_dq2 = col(-g12, -g12)
    # Coriolis and centrifugal terms h(q, dq).
    dh_dq2 = col(-k * c2 * (dq2**2 + 2 * dq1 * dq2), k * c2 * dq1**2)
    dh_ddq1 = col(-2 * k * s2 * dq2, 2 * k * s2 * dq1)
    dh_ddq2 = col(-2 * k * s2 * (dq2 + dq1), zero)

    # Columns of d(ddq)/dx: M^-1 (-(dh + dphi)/dx_j - dM/dx_j ddq).
    rhs = np.stack(
        [-dphi_dq1, -(dh_dq2 + dphi_dq2 + dm_ddq_dq2), -dh_ddq1, -dh_ddq2], -1
    )  # (..., 2, 4)
    m_b = np.broadcast_to(m, (*shape, 2, 2))
    dddq_dx = np.stack([solve_2x2(m_b, rhs[..., j]) for j in range(4)], -1)
    dddq_du = solve_2x2(m_b, np.broadcast_to(generalized_forces(1.0), (*shape, 2)))

    a = np.zeros((*shape, 4, 4))
    a[..., 0, 2] = a[..., 1, 3] = 1.0
    a[..., 2:, :] = dddq_dx
    b = np.zeros((*shape, 4, 1))
    b[..., 2:, 0] = dddq_du
    return a, b
