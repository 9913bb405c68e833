"""What every acrobot task shares: the spaces, actions as torques and the reset options, each
validated (anything outside the space or unknown raises; nothing is clipped)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces

from acrobot_mj.checks import check_float
from acrobot_mj.compiled import compiled, jitable
from acrobot_mj.physics.params import REPORT

#: The report's velocity limits [rad/s]; an env takes its own from its model's parameters.
MAX_VEL1, MAX_VEL2 = REPORT.max_vel
#: Integer types whose values index the discrete torques directly (the env's fast path).
INT_TYPES = (int, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64)


class TorqueLimit:
    """An env's torque limit ``max_torque`` [N m]: the torques of the discrete actions 0, 1, 2
    (``levels``: ``-max_torque, 0, +max_torque``, also as the dict ``of`` and the array
    ``array``) and ``high``, the bound of continuous actions (``max_torque`` as float32, the
    action space's)."""

    def __init__(self, max_torque: float) -> None:
        self.max_torque = check_float("max_torque", max_torque, 0.0)
        if self.max_torque == 0.0:
            raise ValueError("max_torque must be > 0 [N m], got 0")
        self.levels = (-self.max_torque, 0.0, self.max_torque)
        self.of = dict(enumerate(self.levels))
        self.array = np.array(self.levels)
        self.high = float(np.float32(self.max_torque))

    def __repr__(self) -> str:
        return f"TorqueLimit({self.max_torque!r})"


#: The report's torque limit (1 N m) and its discrete torques [N m].
REPORT_TORQUES = TorqueLimit(REPORT.max_torque)
TORQUES = REPORT_TORQUES.levels
#: The single env's reset options: this episode's noise, or an exact start state.
RESET_OPTIONS = ("start_noise", "state")
#: What the envs observe: the state as it is, or Gymnasium's ``Acrobot-v1`` form.
OBSERVATIONS = ("state", "cos_sin")


def observation_space(
    kind: str = "state", max_vel: tuple[float, float] = REPORT.max_vel
) -> spaces.Box:
    """``"state"``: ``(q1, q2, dq1, dq2)`` float64, angles in [-pi, pi), velocities to their
    limits ``max_vel`` [rad/s] (inf: unbounded). ``"cos_sin"``: ``(cos q1, sin q1, cos q2, sin
    q2, dq1, dq2)`` float32, as Gymnasium's ``Acrobot-v1`` (no jump where an angle wraps)."""
    if kind == "cos_sin":
        high = np.array([1.0, 1.0, 1.0, 1.0, *max_vel], dtype=np.float32)
        return spaces.Box(-high, high, dtype=np.float32)
    if kind != "state":
        raise ValueError(f"observation must be one of {OBSERVATIONS}, got {kind!r}")
    high = np.array([math.pi, math.pi, *max_vel])
    return spaces.Box(-high, high, dtype=np.float64)


def cos_sin(states: np.ndarray) -> np.ndarray:
    """``"cos_sin"`` observations of ``"state"`` ones, shape ``(..., 4)`` -> ``(..., 6)``."""
    q1, q2, dq1, dq2 = np.moveaxis(np.asarray(states), -1, 0)
    out = np.stack([np.cos(q1), np.sin(q1), np.cos(q2), np.sin(q2), dq1, dq2], axis=-1)
    return out.astype(np.float32)


def action_space(continuous: bool, torques: TorqueLimit = REPORT_TORQUES) -> spaces.Space:
    """``Box(-max_torque, max_torque, (1,), float32)`` torques [N m], or ``Discrete(3)``."""
    if continuous:
        return spaces.Box(-torques.max_torque, torques.max_torque, (1,), np.float32)
    return spaces.Discrete(len(torques.levels))


def action_torque(action: Any, continuous: bool, torques: TorqueLimit = REPORT_TORQUES) -> float:
    """The motor torque [N m] of one ``action``; raises on anything outside the action space."""
    if continuous:
        array = np.asarray(action)
        if array.dtype.kind not in "fiu":
            raise TypeError(f"action must be a float array of shape (1,), got {action!r}")
        if array.shape != (1,):
            raise ValueError(f"action must have shape (1,), got shape {array.shape}: {action!r}")
        torque, high = float(array[0]), torques.high
        if not -high <= torque <= high:  # also refuses NaN
            raise ValueError(
                f"action {torque} N m is outside the torque range [-{high:g}, {high:g}] N m"
            )
        return torque
    if isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu":
        action = action.item()
    if isinstance(action, (int, np.integer)) and not isinstance(action, (bool, np.bool_)):
        found = torques.of.get(int(action))
        if found is not None:
            return found
        low, _, high = torques.levels
        raise ValueError(
            f"action {action} is outside Discrete(3): use 0 ({low:g} N m), 1 (0 N m) or "
            f"2 (+{high:g} N m)"
        )
    raise TypeError(
        f"action must be an integer 0, 1 or 2, got {action!r} ({type(action).__name__})"
    )


@jitable
def discrete_torques(actions, torques, ctrl) -> int:
    """``ctrl[i, 0] = torques[actions[i]]`` for every row and -1, or the first row whose action
    is out of range, writing nothing."""
    for i in range(actions.shape[0]):
        if not (0 <= actions[i] < torques.shape[0]):
            return i
    for i in range(actions.shape[0]):
        ctrl[i, 0] = torques[actions[i]]
    return -1


def write_torques(
    actions: Any, continuous: bool, ctrl: np.ndarray, torques: TorqueLimit = REPORT_TORQUES
) -> None:
    """Write the torques [N m] of a batch of actions into ``ctrl`` ``(N, 1)``; anything outside
    the space raises, writing nothing."""
    n, a = len(ctrl), np.asarray(actions)
    if continuous:
        if a.dtype.kind not in "fiu" or a.shape != (n, 1):
            raise ValueError(
                f"actions must be a float array of shape ({n}, 1), got {a.dtype} {a.shape}"
            )
        high = torques.high
        inside = (a[:, 0] >= -high) & (a[:, 0] <= high)  # False for NaN too
        if not inside.all():
            raise ValueError(
                f"torques outside [-{high:g}, {high:g}] N m at sub-envs "
                f"{np.flatnonzero(~inside).tolist()}"
            )
        ctrl[:, 0] = a[:, 0]
        return
    if a.dtype.kind not in "iu" or a.shape != (n,):
        raise ValueError(f"actions must be integers of shape ({n},), got {a.dtype} {a.shape}")
    if compiled(discrete_torques)(a.astype(np.int64, copy=False), torques.array, ctrl) >= 0:
        bad = (a < 0) | (a > 2)
        raise ValueError(
            f"actions outside Discrete(3) at sub-envs {np.flatnonzero(bad).tolist()}: "
            f"{a[bad].tolist()}"
        )


def reset_noise(options: Any, default: float, known: tuple[str, ...] = ("start_noise",)) -> float:
    """A reset's ``options["start_noise"]`` (validated), else ``default``; a non-dict or an
    option outside ``known`` raises."""
    if options is not None and not isinstance(options, Mapping):
        raise TypeError(f"reset options must be a dict, got {options!r}")
    unknown = sorted(set(options or ()) - set(known))
    if unknown:
        raise ValueError(f"unknown reset options {unknown}; known: {list(known)}")
    if options and "start_noise" in options:
        return check_float("start_noise", options["start_noise"], 0.0, 1.0)
    return default


def reset_state(options: Any) -> np.ndarray | None:
    """A reset's exact start ``options["state"]`` as 4 floats (or None); not with
    ``start_noise``."""
    if not isinstance(options, Mapping) or options.get("state") is None:
        return None
    if "start_noise" in options:
        raise ValueError("reset options 'state' and 'start_noise' exclude each other; give one")
    try:
        given = np.asarray(options["state"])
        state = given.astype(np.float64) if given.dtype.kind in "fiu" else None  # not complex
    except (TypeError, ValueError):
        state = None
    if state is None or state.shape != (4,):
        raise ValueError(
            f"reset option 'state' must be 4 numbers (q1, q2, dq1, dq2), got {options['state']!r}"
        )
    return state
