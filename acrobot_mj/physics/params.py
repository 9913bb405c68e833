"""The acrobot's physical parameters in the report's symbols, each field's unit, source and
meaning in its metadata; the defaults (the report's table) match ``models/acrobot.xml``."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, fields

from acrobot_mj.checks import shown_number

_REPORT = "report, parameter table"
_SUTTON_BARTO = "Sutton and Barto (1998/2018), acrobot; Gymnasium Acrobot-v1"

#: The lumped parameters ``(a, b, c, d, e)`` of the equations of motion: ``a, b, c`` [kg m^2],
#: ``d, e`` [N m].
Lumped = tuple[float, float, float, float, float]
#: The fields that may be ``inf``: no limit.
_UNBOUNDED = ("max_vel1", "max_vel2")


#: The range [low, high] each kind of field takes, in its unit: wide enough for any acrobot on
#: a table or in orbit, narrow enough that MuJoCo takes it (its mjMINVAL is 1e-15, and it
#: zeroes a control past its mjMAXVAL, 1e10) and the equations stay finite.
_RANGES = {
    "m": (1e-6, 1e6),
    "kg": (1e-6, 1e6),
    "kg m^2": (1e-9, 1e6),
    "m/s^2": (1e-6, 1e6),
    "N m": (1e-6, 1e9),
    "rad/s": (1e-6, 1e9),
    "s": (1e-6, 10.0),
}


def _param(default: float, unit: str, source: str, doc: str) -> float:
    low, high = _RANGES[unit]
    metadata = {"unit": unit, "source": source, "doc": doc, "low": low, "high": high}
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class AcrobotParams:
    """The acrobot's physical and task constants (SI units; see each field's metadata)."""

    l1: float = _param(1.0, "m", _REPORT, "length of link 1 (shoulder to elbow)")
    l2: float = _param(1.0, "m", _REPORT, "length of link 2 (elbow to tip)")
    lc1: float = _param(0.5, "m", _REPORT, "shoulder to centre of mass of link 1")
    lc2: float = _param(0.5, "m", _REPORT, "elbow to centre of mass of link 2")
    m1: float = _param(1.0, "kg", _REPORT, "mass of link 1")
    m2: float = _param(1.0, "kg", _REPORT, "mass of link 2")
    I1: float = _param(1.0, "kg m^2", _REPORT, "inertia of link 1 about its centre of mass")
    I2: float = _param(1.0, "kg m^2", _REPORT, "inertia of link 2 about its centre of mass")
    g: float = _param(9.8, "m/s^2", _SUTTON_BARTO, "gravitational acceleration")
    max_torque: float = _param(1.0, "N m", _REPORT, "motor torque limit, |tau| <= max_torque")
    max_vel1: float = _param(4 * math.pi, "rad/s", _REPORT, "shoulder speed limit |dq1| (or inf)")
    max_vel2: float = _param(9 * math.pi, "rad/s", _REPORT, "elbow speed limit |dq2| (or inf)")
    dt: float = _param(0.05, "s", _REPORT, "physics time step")

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise TypeError(f"AcrobotParams.{f.name} must be a number, got {value!r}")
            try:
                number = float(value)  # numpy's scalars too
            except OverflowError:
                number = math.inf
            low, high, unit = f.metadata["low"], f.metadata["high"], f.metadata["unit"]
            unbounded = f.name in _UNBOUNDED and number == math.inf  # inf: no limit
            if not (low <= number <= high or unbounded):
                what = f"in [{low:g}, {high:g}]" + (
                    " (or inf: none)" if f.name in _UNBOUNDED else ""
                )
                raise ValueError(
                    f"AcrobotParams.{f.name} must be {what} [{unit}], got {shown_number(value)}"
                )
            if not isinstance(value, (int, float)):  # a numpy scalar: stored as Python's
                object.__setattr__(self, f.name, number)

    @property
    def lumped(self) -> Lumped:
        """``a = m1 lc1^2 + m2 (l1^2 + lc2^2) + I1 + I2``, ``b = m2 l1 lc2``, ``c = m2 lc2^2 +
        I2``, ``d = (m1 lc1 + m2 l1) g``, ``e = m2 lc2 g`` (3.5, 0.5, 1.25, 14.7, 4.9 here)."""
        p = self
        a = p.m1 * p.lc1**2 + p.m2 * (p.l1**2 + p.lc2**2) + p.I1 + p.I2
        b, c = p.m2 * p.l1 * p.lc2, p.m2 * p.lc2**2 + p.I2
        return (a, b, c, (p.m1 * p.lc1 + p.m2 * p.l1) * p.g, p.m2 * p.lc2 * p.g)

    @property
    def max_vel(self) -> tuple[float, float]:
        """The velocity limits ``(|dq1|, |dq2|)`` [rad/s]."""
        return (self.max_vel1, self.max_vel2)


REPORT = AcrobotParams()


def describe(params: AcrobotParams = REPORT) -> str:
    """A table of the parameters with units and sources, one line per field (a value other
    than the report's is the model's own: ``acrobot_mj.physics.models`` cites its source)."""
    return "\n".join(
        f"{f.name:<10} {getattr(params, f.name):<10.6g} {f.metadata['unit']:<7} "
        f"{f.metadata['doc']} "
        f"({f.metadata['source'] if getattr(params, f.name) == f.default else 'the model'})"
        for f in fields(params)
    )
