"""The analytic backend's physics step on plain floats: the lumped manipulator model stepped as
the MuJoCo env steps it (semi-implicit Euler, then the velocity limits). numba compiles this
very function (:mod:`acrobot_mj.envs.analytic_kernel`), so Python and compiled numbers are one
definition; this module itself imports neither numba nor MuJoCo."""

from __future__ import annotations

import math


def env_step(q1, q2, v1, v2, tau, a, b, c, d, e, dt, lim1, lim2, substeps) -> tuple:
    """``substeps`` physics steps of the lumped model ``(a, b, c, d, e)``
    (:func:`acrobot_mj.control.identification.lumped`) from ``(q1, q2, v1, v2)`` [rad, rad/s]
    with elbow torque ``tau`` [N m], as the MuJoCo env takes them: ``v' = v + dt * acc``
    (``acc`` solved by Cramer's rule), ``q' = q + dt * v'``, then ``v'`` clipped to ``lim1``,
    ``lim2`` [rad/s], NaN kept (as ``np.clip``). Plain floats and arithmetic only, so numba
    compiles this very function (:mod:`acrobot_mj.envs.analytic_kernel`)."""
    for _ in range(substeps):
        c2, s2 = math.cos(q2), math.sin(q2)
        d11, d12 = a + 2 * b * c2, c + b * c2
        phi2 = e * math.cos(q1 + q2)
        f1 = b * s2 * (v2 * v2 + 2 * v1 * v2) - d * math.cos(q1) - phi2
        f2 = tau - b * s2 * v1 * v1 - phi2
        det = d11 * c - d12 * d12
        v1 = v1 + dt * ((c * f1 - d12 * f2) / det)
        v2 = v2 + dt * ((d11 * f2 - d12 * f1) / det)
        q1, q2 = q1 + dt * v1, q2 + dt * v2
        if v1 > lim1:
            v1 = lim1
        elif v1 < -lim1:
            v1 = -lim1
        if v2 > lim2:
            v2 = lim2
        elif v2 < -lim2:
            v2 = -lim2
    return q1, q2, v1, v2
