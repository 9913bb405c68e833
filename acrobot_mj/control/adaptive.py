"""A plan tracker that adapts to the acrobot it meets (:class:`Adaptive`): it identifies the
lumped parameters from its own first transitions and, where they differ from its model, plans
the swing-up again on the identified model and tracks that plan instead."""

from __future__ import annotations

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.control.tracker import PlanTracker
from acrobot_mj.physics.integrators import Stepping

#: Steps added to the nominal swing-up's length for each warm start of a replan, in order.
REPLAN_STEPS = (0, 8, -8, 16)


class Adaptive(Controller):
    """``nominal`` (a :class:`~acrobot_mj.control.tracker.PlanTracker` along one swing-up) that
    identifies the lumped parameters from its own first ``samples`` transitions
    (:mod:`~acrobot_mj.identify.lumped`: it is told the structure and the step, as the
    balance preset is) and, where they differ from its model, replans the swing-up on the
    identified model, warm-started from its own (CasADi: the ``control`` extra), then tracks
    that plan. It adapts once an episode; a replan that fails leaves the plan it had. It learns
    from the torques the plant applied (:meth:`applied`)."""

    def __init__(self, nominal: PlanTracker, samples: int = 60) -> None:
        self.nominal, self.samples = nominal, samples
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """The nominal tracker, no data, not adapted: a new episode."""
        self.tracker = self.nominal
        self.tracker.reset(seed)
        self.data: list[tuple[list[float], float, list[float]]] = []
        self.last: np.ndarray | None = None
        self.torque: float | None = None
        #: None until it has adapted; then what it did ("kept", "replanned", or why not).
        self.adapted: str | None = None

    def applied(self, torque: float) -> None:
        """The torque [N m] the env applied in the step after the last call."""
        self.torque = torque

    def act(self, x: np.ndarray, t: float) -> float:
        x = np.asarray(x, dtype=float)
        if self.adapted is None and self.last is not None and self.torque is not None:
            limits = np.asarray(self.nominal.params.max_vel)
            if np.all(np.abs(x[2:]) < limits - 1e-9):  # a clipped step is not the dynamics
                self.data.append((self.last.tolist(), self.torque, x.tolist()))
            if len(self.data) >= self.samples:
                self.adapted = self._adapt()
        self.last, self.torque = x, None
        return self.tracker.act(x, t)

    def _adapt(self) -> str:
        from acrobot_mj.identify.lumped import identify, realise

        nominal = self.nominal.plans[0]
        told = Stepping(dt=nominal.dt, max_vel=nominal.params.max_vel, method=nominal.method)
        try:
            theta, rms = identify(self.data, told)
            model = realise(theta, told, nominal.params.max_torque)
        except ValueError as error:
            return f"kept: {error}"
        if rms > 1e-6:
            return f"kept: the structure fits the data only to {rms:.2g} RMS"
        if np.allclose(model.lumped, nominal.params.lumped, rtol=1e-9, atol=0.0):
            return "kept"
        from acrobot_mj.control.trajopt import Optimiser, resample  # CasADi: control extra

        optimiser = Optimiser(nominal.u_max, nominal.method, model)
        for extra in REPLAN_STEPS:  # the nominal swing-up stretched: the first that solves
            warm = resample(nominal.states, nominal.torques, nominal.steps + extra)
            found = optimiser.approach(nominal.states[-1], warm)[1]
            if found is not None:
                break
        else:
            return "kept: no swing-up found on the identified model"
        self.tracker = PlanTracker(
            [optimiser.trajectory(found)],
            self.nominal.levels,
            self.nominal.settings,
            fallback=self.nominal.fallback,
        )
        self.tracker.reset()
        return "replanned"
