"""A swing-up trajectory: states and torques at every physics step, checked against the model.

A :class:`Trajectory` is trusted only after :meth:`Trajectory.check`: it starts hanging at rest,
ends upright at rest, keeps ``|u| <= u_max`` and the velocity limits, and each state follows from
the one before through the env's physics step (the numpy model, clipping included) to 1e-9. The
package ships trajectories found by :func:`acrobot_mj.control.trajopt.min_time`
(``acrobot_mj/control/trajectories/``), re-checked whenever they are loaded.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.control.lqr import state_error
from acrobot_mj.files import write_json
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.params import REPORT, AcrobotParams

#: Largest difference [rad, rad/s] between a stored state and the model's step of the one
#: before: 1e-9 is ~1e5 times the rounding of one step, and any modelling difference (another
#: integrator, a parameter off by 1e-6) shows at 1e-7 or more.
TOLERANCE = 1e-9
SHIPPED = Path(__file__).resolve().parent / "trajectories"
FORMAT = "acrobot_mj.trajectory"


@dataclass(frozen=True)
class Trajectory:
    """``states`` ``(N + 1, 4)`` [rad, rad/s] and ``torques`` ``(N,)`` [N m], one per physics
    step of ``dt`` [s] under ``method``, with ``|u| <= u_max``, on the model of ``params`` (the
    report's acrobot, or one identified from data: :mod:`acrobot_mj.train.plan`)."""

    states: np.ndarray
    torques: np.ndarray
    dt: float
    method: str
    u_max: float
    params: AcrobotParams = REPORT

    @property
    def steps(self) -> int:
        return len(self.torques)

    @property
    def seconds(self) -> float:
        return self.steps * self.dt

    def residual(self) -> float:
        """Largest gap between each stored state and the model's step of the one before."""
        nxt = integrators.step_states(self.states[:-1], self.torques, self.params, method=self.method)
        return float(np.abs(nxt - self.states[1:]).max())

    def check(self, tolerance: float = TOLERANCE) -> Trajectory:
        """Raise ValueError naming the first property that fails; returns the trajectory."""
        if self.states.shape != (self.steps + 1, 4) or self.steps < 1:
            raise ValueError(f"a trajectory needs N + 1 states of 4 and N torques, got "
                             f"{self.states.shape} and {self.torques.shape}")  # fmt: skip
        if not (np.isfinite(self.states).all() and np.isfinite(self.torques).all()):
            raise ValueError("the trajectory holds non-finite numbers")
        p = self.params
        if self.dt != p.dt or self.method not in ("semi_implicit_euler", "rk4"):
            raise ValueError(f"the trajectory is for dt={self.dt}, {self.method!r}: not the env's")
        if not 0.0 < self.u_max <= p.max_torque or np.abs(self.torques).max() > self.u_max + 1e-12:
            raise ValueError(f"a torque exceeds u_max={self.u_max} N m (at most {p.max_torque})")
        limits = np.array([p.max_vel1, p.max_vel2])
        if (np.abs(self.states[:, 2:]) > limits + 1e-12).any():
            raise ValueError("a state exceeds the velocity limits")
        end = state_error(self.states[-1])
        if np.abs(self.states[0] - HANGING).max() > tolerance or np.abs(end).max() > tolerance:
            raise ValueError("the trajectory does not go from hanging at rest to upright at rest")
        gap = self.residual()
        if gap > tolerance:
            raise ValueError(f"the trajectory misses the model's step by {gap:.2g} > {tolerance}")
        return self

    def to_dict(self) -> dict[str, Any]:
        model = {} if self.params == REPORT else {"params": asdict(self.params)}
        return {
            "format": FORMAT,
            **model,
            "dt": self.dt,
            "method": self.method,
            "u_max": self.u_max,
            "steps": self.steps,
            "states": self.states.tolist(),  # JSON floats round-trip exactly
            "torques": self.torques.tolist(),
        }

    def save(self, path: str | Path) -> Path:
        """Write the trajectory (checked first) as JSON, atomically."""
        return write_json(path, self.check().to_dict())

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """A stored trajectory, checked (a file that fails any check is refused)."""
        path = Path(path)
        try:
            data = json.loads(path.read_text())
            if data.get("format") != FORMAT:
                raise ValueError(f"not a trajectory file (format {data.get('format')!r})")
            trajectory = cls(
                np.asarray(data["states"], dtype=float),
                np.asarray(data["torques"], dtype=float),
                float(data["dt"]),
                str(data["method"]),
                float(data["u_max"]),
                AcrobotParams(**data["params"]) if "params" in data else REPORT,
            )
            return trajectory.check()
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as error:
            raise ValueError(f"{path} is not a usable trajectory: {error}") from None


def shipped(name: str) -> Trajectory:
    """A trajectory shipped with the package (``"min_time"`` or ``"reserve"``), checked."""
    path = SHIPPED / f"{name}.json"
    if not path.is_file():
        known = sorted(p.stem for p in SHIPPED.glob("*.json"))
        raise ValueError(f"no shipped trajectory {name!r}; shipped: {known}")
    return Trajectory.load(path)
