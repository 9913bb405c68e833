"""Math namespaces, so that one rule serves every kind of number: this module (:data:`FLOATS`,
Python floats, which numba compiles too), :data:`ARRAY` (numpy) and :func:`symbolic` (CasADi)
give ``cos``, ``sin``, ``clip``, ``maximum`` and ``wrap``; a rule takes ``xp=FLOATS``."""

from __future__ import annotations

import math
import sys
from types import ModuleType, SimpleNamespace
from typing import Any, TypeVar

import numpy as np

from acrobot_mj.compiled import jitable

cos, sin = math.cos, math.sin
TWO_PI = 2.0 * math.pi


@jitable
def clip(value: float, low: float, high: float) -> float:
    """``value`` limited to ``[low, high]``; NaN stays NaN (as ``np.clip``)."""
    if value > high:
        return high
    if value < low:
        return low
    return value


@jitable
def maximum(a: float, b: float) -> float:
    """The larger of ``a`` and ``b``; NaN if either is (as ``np.maximum``)."""
    return a if (a >= b or a != a) else b


@jitable
def wrap(angle: float) -> float:
    """``angle`` [rad] wrapped into ``[-pi, pi)`` (unchanged when inside)."""
    if -math.pi <= angle < math.pi:
        return angle
    wrapped = (angle + math.pi) % TWO_PI - math.pi
    return wrapped - TWO_PI if wrapped >= math.pi else wrapped


#: A float or an array of angles [rad].
Angle = TypeVar("Angle", float, np.ndarray)


def wrap_angle(angle: Angle) -> Angle:
    """``angle`` [rad] wrapped into ``[-pi, pi)`` as :func:`wrap` does: a float, or a new array."""
    if not isinstance(angle, np.ndarray):
        return wrap(angle)
    inside = (angle >= -math.pi) & (angle < math.pi)
    if inside.all():
        return angle.copy()
    wrapped = (angle + math.pi) % TWO_PI - math.pi
    wrapped[wrapped >= math.pi] -= TWO_PI
    return np.where(inside, angle, wrapped)


#: The namespace of Python floats: this module (numba compiles its rules).
FLOATS: ModuleType = sys.modules[__name__]
#: The namespace of numpy arrays.
ARRAY = SimpleNamespace(cos=np.cos, sin=np.sin, clip=np.clip, maximum=np.maximum, wrap=wrap_angle)


def symbolic() -> Any:
    """CasADi's functions (the ``control`` extra); ``clip`` is the identity, as an optimisation
    states the velocity limits as constraints."""
    try:
        import casadi
    except ImportError as error:
        message = "trajectory optimisation needs CasADi: pip install acrobot-mj[control]"
        raise ImportError(message) from error
    return SimpleNamespace(
        cos=casadi.cos, sin=casadi.sin, maximum=casadi.fmax, clip=lambda value, low, high: value
    )
