"""The report's equation (2) as printed, ``d12 ddq1 + d12 ddq2 + h2 + phi2 = tau`` (the second
``d12`` should be ``d22``), kept to show that only the corrected model agrees with MuJoCo."""

from __future__ import annotations

from numpy.typing import ArrayLike, NDArray

from acrobot_mj.physics.dynamics import bias_forces, generalized_forces, mass_matrix, solve_2x2
from acrobot_mj.physics.params import REPORT, AcrobotParams


def mass_matrix_as_printed(q: ArrayLike, p: AcrobotParams = REPORT) -> NDArray:
    """The report's matrix ``[[d11, d12], [d12, d12]]`` (eq. 2 as printed), ``(..., 2, 2)``."""
    m = mass_matrix(q, p).copy()
    m[..., 1, 1] = m[..., 0, 1]
    return m


def forward_dynamics_as_printed(
    q: ArrayLike, dq: ArrayLike, tau: ArrayLike = 0.0, p: AcrobotParams = REPORT
) -> NDArray:
    """Accelerations [rad/s^2] from equations (1) and (2) exactly as printed, ``(..., 2)``."""
    rhs = generalized_forces(tau) - bias_forces(q, dq, p)
    return solve_2x2(mass_matrix_as_printed(q, p), rhs)
