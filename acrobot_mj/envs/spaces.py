"""The action and observation spaces every acrobot task shares, and actions turned into torques.

Actions are ``Discrete(3)`` (torques -1, 0, +1 N m) or, continuous, ``Box(-1, 1, (1,))`` N m;
anything outside the space raises an error that names it (nothing is clipped). Observations are
``(q1, q2, dq1, dq2)`` with angles wrapped into [-pi, pi) and velocities within the task's limits.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from acrobot_mj.physics.params import AcrobotParams

_REPORT = AcrobotParams()
#: Velocity limits [rad/s] (the report, after Sutton and Barto), applied after every physics step.
MAX_VEL1 = _REPORT.max_vel1
MAX_VEL2 = _REPORT.max_vel2
#: Torque [N m] of each discrete action.
TORQUES = (-1.0, 0.0, 1.0)
#: Ranges of the observation's variables: angles on the circle, velocities to their limits.
OBS_LOW = (-math.pi, -math.pi, -MAX_VEL1, -MAX_VEL2)
OBS_HIGH = (math.pi, math.pi, MAX_VEL1, MAX_VEL2)
#: Integer types whose values index TORQUES directly (the env's fast path).
INT_TYPES = (int, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64)
TORQUE_OF = dict(enumerate(TORQUES))
#: :data:`TORQUES` as an array, indexed by actions.
TORQUE_ARRAY = np.array(TORQUES)
#: Batches of actions up to this size are range-tested in Python (cheaper than numpy's calls).
_FEW = 8


def observation_space() -> spaces.Box:
    """``Box((4,), float64)`` over :data:`OBS_LOW` .. :data:`OBS_HIGH`."""
    return spaces.Box(np.array(OBS_LOW), np.array(OBS_HIGH), dtype=np.float64)


def action_space(continuous: bool) -> spaces.Space:
    """``Box(-1, 1, (1,), float32)`` torques [N m], or ``Discrete(3)``."""
    if continuous:
        return spaces.Box(-1.0, 1.0, (1,), np.float32)
    return spaces.Discrete(len(TORQUES))


def action_torque(action: Any, continuous: bool) -> float:
    """The elbow torque [N m] of one ``action``; raises on anything outside the action space."""
    if continuous:
        array = np.asarray(action)
        if array.dtype.kind not in "fiu":
            raise TypeError(f"action must be a float array of shape (1,), got {action!r}")
        if array.shape != (1,):
            raise ValueError(f"action must have shape (1,), got shape {array.shape}: {action!r}")
        torque = float(array[0])
        if not -1.0 <= torque <= 1.0:  # also refuses NaN
            raise ValueError(f"action {torque} N m is outside the torque range [-1, 1] N m")
        return torque
    if action.__class__ in INT_TYPES:
        torque = TORQUE_OF.get(action)
        if torque is not None:
            return torque
        raise ValueError(
            f"action {action} is outside Discrete(3): use 0 (-1 N m), 1 (0 N m) or 2 (+1 N m)"
        )
    if isinstance(action, (int, np.integer)) and not isinstance(action, (bool, np.bool_)):
        return action_torque(int(action), False)  # e.g. np.longlong or an IntEnum member
    if isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu":
        return action_torque(action.item(), False)
    raise TypeError(
        f"action must be an integer 0, 1 or 2, got {action!r} ({type(action).__name__})"
    )


def action_torques(actions: Any, continuous: bool, num_envs: int) -> np.ndarray:
    """Per-sub-env torques [N m] of a batch of actions; anything outside the space raises."""
    a = np.asarray(actions)
    if continuous:
        if a.dtype.kind not in "fiu" or a.shape != (num_envs, 1):
            raise ValueError(
                f"actions must be a float array of shape ({num_envs}, 1), got {a.dtype} {a.shape}"
            )
        a = a[:, 0].astype(np.float64)
        inside = (a >= -1.0) & (a <= 1.0)  # False for NaN too
        if np.count_nonzero(inside) < num_envs:  # faster than all() on small batches
            raise ValueError(
                f"torques outside [-1, 1] N m at sub-envs {np.flatnonzero(~inside).tolist()}"
            )
        return a
    if num_envs <= _FEW and a.dtype.kind in "iu" and a.shape == (num_envs,):
        values = a.tolist()  # a few: Python's min and max cost less than numpy's tests
        if min(values) >= 0 and max(values) <= 2:
            return TORQUE_ARRAY[a]
    if a.dtype.kind not in "iu" or a.shape != (num_envs,):
        raise ValueError(
            f"actions must be integers of shape ({num_envs},), got {a.dtype} {a.shape}"
        )
    bad = (a < 0) | (a > 2)
    if np.count_nonzero(bad):  # faster than any() on small batches
        raise ValueError(
            f"actions outside Discrete(3) at sub-envs "
            f"{np.flatnonzero(bad).tolist()}: {a[bad].tolist()}"
        )
    return TORQUE_ARRAY[a]
