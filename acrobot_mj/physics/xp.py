"""The math namespaces the rules are written over, so that one source serves every kind of number.

This module is itself the namespace of Python floats (``FLOATS``): ``cos``, ``sin``, ``sqrt``,
``abs``, ``clip``, ``where``, ``maximum`` and ``wrap``, plain Python that numba also compiles.
:data:`ARRAY` gives numpy's functions under the same names (any array shape), and
:func:`symbolic` CasADi's, for trajectory optimisation. A rule takes ``xp=FLOATS`` by default::

    def tip(q1, q2, xp=FLOATS):
        return xp.sin(q1) + xp.sin(q1 + q2)

    tip(0.1, 0.2)                         # floats (and compiled by numba)
    tip(np.zeros(5), np.ones(5), ARRAY)   # arrays
"""

from __future__ import annotations

import math
import sys
from types import ModuleType, SimpleNamespace
from typing import Any, TypeVar

import numpy as np

from acrobot_mj.compiled import jitable

cos, sin, sqrt, exp = math.cos, math.sin, math.sqrt, math.exp
abs = abs  # the builtin, as a name of this namespace
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
def where(condition: bool, if_true: float, if_false: float) -> float:
    return if_true if condition else if_false


@jitable
def maximum(a: float, b: float) -> float:
    """The larger of ``a`` and ``b``; NaN if either is (as ``np.maximum``)."""
    return a if (a >= b or a != a) else b


@jitable
def wrap(angle: float) -> float:
    """``angle`` [rad] wrapped into ``[-pi, pi)``: unchanged when inside, else
    ``(a + pi) mod 2 pi - pi`` (a result that rounds to ``pi`` becomes ``-pi``)."""
    if -math.pi <= angle < math.pi:
        return angle
    wrapped = (angle + math.pi) % TWO_PI - math.pi
    return wrapped - TWO_PI if wrapped >= math.pi else wrapped


def wrap_array(angle: np.ndarray) -> np.ndarray:
    """:func:`wrap` of every element, in a new array (the same numbers)."""
    inside = (angle >= -math.pi) & (angle < math.pi)
    if inside.all():
        return angle.copy()
    wrapped = (angle + math.pi) % TWO_PI - math.pi
    wrapped[wrapped >= math.pi] -= TWO_PI
    return np.where(inside, angle, wrapped)


Angle = TypeVar("Angle", float, np.ndarray)


def wrap_angle(angle: Angle) -> Angle:
    """``angle`` [rad] wrapped into ``[-pi, pi)``, the one definition of wrapping: a float for a
    float, an array for an array."""
    return wrap_array(angle) if isinstance(angle, np.ndarray) else wrap(angle)


#: This module: the namespace of Python floats, the default of every rule.
FLOATS: ModuleType = sys.modules[__name__]
#: numpy's functions under the same names, for arrays of any shape.
ARRAY = SimpleNamespace(
    cos=np.cos, sin=np.sin, sqrt=np.sqrt, exp=np.exp, abs=np.abs, clip=np.clip,
    where=np.where, maximum=np.maximum, wrap=wrap_array,
)  # fmt: skip


def symbolic() -> Any:
    """CasADi's functions under the same names (trajectory optimisation: ``pip install
    acrobot-mj[control]``). ``clip`` leaves a value as it is: an optimisation states the
    velocity limits as constraints, and a clipped step is not smooth."""
    try:
        import casadi
    except ImportError as error:
        raise ImportError(
            "trajectory optimisation needs CasADi: pip install acrobot-mj[control]"
        ) from error
    return SimpleNamespace(
        cos=casadi.cos, sin=casadi.sin, sqrt=casadi.sqrt, exp=casadi.exp, abs=casadi.fabs,
        clip=lambda value, low, high: value, where=casadi.if_else, maximum=casadi.fmax,
    )  # fmt: skip
