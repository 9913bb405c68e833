"""Compiled passes over a batch's rows that both vector-env backends share (numba, the ``fast``
extra; imported only when a batch of more than :data:`~acrobot_mj.envs.batch_physics.FEW`
acrobots is built, or by the analytic backend).

Each replaces a few numpy calls of the same rule: the velocity limits after a physics step
(``np.clip``'s numbers, NaN kept; the MuJoCo backend's: the analytic one limits inside its
step), the observation (``wrap_angle``'s numbers, the same tests as
:func:`~acrobot_mj.envs.batch_physics.checked_observation`) and the discrete actions' torques
(:func:`~acrobot_mj.envs.spaces.action_torques`' test, written only when every action is
valid). A call costs about a microsecond up to a few hundred rows and grows with the rows beyond
(the observation 14 us at 4096), where each numpy call costs a microsecond or more and there are
several (measured: docs/speed.md); the numbers are the same bit for bit
(``tests/test_row_kernels.py``).
"""

from __future__ import annotations

from acrobot_mj.physics.angles import wrap_float

try:
    from numba import njit
except ImportError as error:  # pragma: no cover  (the fast extra is missing)
    raise ImportError("the row kernels need numba: pip install acrobot-mj[fast]") from error

#: :func:`~acrobot_mj.physics.angles.wrap_float`, compiled (wrap_angle's numbers).
wrap_jit = njit(cache=True)(wrap_float)


@njit(cache=True)
def observe_rows(state, obs, max_angle, huge):  # pragma: no cover  (compiled)
    """Write the observations of ``state``'s rows ``(q1, q2, dq1, dq2)`` into ``obs`` (angles
    wrapped); False if any row has an angle beyond ``max_angle``, a velocity beyond ``huge`` or
    a NaN (``obs`` is then not to be used: the caller raises)."""
    ok = True
    for i in range(state.shape[0]):
        q1, q2, v1, v2 = state[i, 0], state[i, 1], state[i, 2], state[i, 3]
        if not (abs(q1) < max_angle and abs(q2) < max_angle and abs(v1) < huge and abs(v2) < huge):
            ok = False
        obs[i, 0], obs[i, 1], obs[i, 2], obs[i, 3] = wrap_jit(q1), wrap_jit(q2), v1, v2
    return ok


@njit(cache=True)
def _limit(v, limit):  # pragma: no cover  (compiled)
    """``np.clip(v, -limit, limit)`` of one float: NaN stays NaN."""
    if v > limit:
        return limit
    if v < -limit:
        return -limit
    return v


@njit(cache=True)
def limit_rows(qvel, lim1, lim2):  # pragma: no cover  (compiled)
    """Clip each row's ``(dq1, dq2)`` of ``qvel`` (``(N, 2)``, in place, any strides) to
    ``[-lim1, lim1]`` and ``[-lim2, lim2]`` [rad/s]; rows inside are not written."""
    for i in range(qvel.shape[0]):
        v1, v2 = qvel[i, 0], qvel[i, 1]
        if not (-lim1 <= v1 <= lim1):  # outside, or NaN (written back unchanged)
            qvel[i, 0] = _limit(v1, lim1)
        if not (-lim2 <= v2 <= lim2):
            qvel[i, 1] = _limit(v2, lim2)


@njit(cache=True)
def discrete_torques(actions, torques, ctrl):  # pragma: no cover  (compiled)
    """Write ``torques[actions[i]]`` into ``ctrl[i, 0]`` for every row and return -1, or, if
    any action is outside ``0 .. len(torques) - 1``, the first such row, writing nothing."""
    top = torques.shape[0]
    for i in range(actions.shape[0]):
        if not (0 <= actions[i] < top):
            return i
    for i in range(actions.shape[0]):
        ctrl[i, 0] = torques[actions[i]]
    return -1
