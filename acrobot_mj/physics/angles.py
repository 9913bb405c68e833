"""Angle wrapping, the one definition every part of the package uses."""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np

_TWO_PI = 2.0 * math.pi
Angle = TypeVar("Angle", float, np.ndarray)


def wrap_angle(angle: Angle) -> Angle:
    """``angle`` [rad] wrapped into ``[-pi, pi)``: a float for a float, an array for an array.

    Angles already in ``[-pi, pi)`` come back unchanged (bit for bit); the others become
    ``(a + pi) mod 2 pi - pi``, and the rare result that rounds to exactly ``pi`` becomes
    ``-pi``, so the interval stays half open.
    """
    if isinstance(angle, np.ndarray):
        inside = (angle >= -math.pi) & (angle < math.pi)
        if inside.all():
            return angle.copy()
        wrapped = (angle + math.pi) % _TWO_PI - math.pi
        wrapped[wrapped >= math.pi] -= _TWO_PI
        return np.where(inside, angle, wrapped)
    return wrap_float(angle)


def wrap_float(angle: float) -> float:
    """:func:`wrap_angle` of one float [rad] (plain arithmetic: numba compiles this very
    function for the analytic backend's observation, with the same numbers)."""
    if -math.pi <= angle < math.pi:
        return angle
    wrapped = (angle + math.pi) % _TWO_PI - math.pi
    return wrapped - _TWO_PI if wrapped >= math.pi else wrapped
