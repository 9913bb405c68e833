"""The report's equations of motion exactly as printed, kept to show why they are wrong.

The report (IND E 599) prints its equation (2) as ``d12 ddq1 + d12 ddq2 + h2 + phi2 = tau``: the
second coefficient should be ``d22``. It also uses ``d12`` without defining it; here it is given
its correct value ``m2 (lc2^2 + l1 lc2 cos q2) + I2`` so that equation (2) is the only error
left. :mod:`acrobot_mj.physics.dynamics` has the corrected model; ``tests/test_errata.py``
shows that only the corrected one agrees with MuJoCo.
"""

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
