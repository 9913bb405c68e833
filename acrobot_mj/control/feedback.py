"""A state-feedback controller ``u = pi(x)`` that swings up and balances from anywhere: the
TVLQR funnel along one swing-up, entered by state, the constrained LQR at upright, and energy
removal everywhere else, which brings the acrobot down towards hanging at rest, where the funnel
begins. It needs no clock: its only memory is which point of the funnel it is following."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from acrobot_mj.control.lqr import LQR, MPC, Jacobians, tvlqr, tvlqr_torque
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import UPRIGHT, state_error
from acrobot_mj.physics.integrators import Stepping
from acrobot_mj.settings import check, setting


@dataclass(frozen=True)
class FunnelSettings:
    """Levels of the LQR costs ``e' S e`` (dimensionless: the costs of
    :class:`~acrobot_mj.control.lqr.LQR`'s weights) that switch between the modes: at upright
    below ``upright``; a followed funnel point is kept below ``track`` and entered below
    ``entry``, or below ``track`` where a rollout of the funnel on the model from there reaches
    upright (:meth:`FunnelController.reaches`); elsewhere ``tau = -clip(damping dq2, -1, 1)``
    [N m, N m s/rad] takes energy out. The balancer at upright is the constrained LQR over
    ``horizon`` steps (:class:`~acrobot_mj.control.lqr.MPC`), or the saturated LQR where it is
    0. The levels were chosen on the analytic model, from 100 uniform starts and 200 kicks at
    upright of seeds other than the evaluation's; 40 steps (2 s) hold every kick of
    ``U(-0.05, 0.05)`` rad/s that 80 hold in MuJoCo (100 kicks, evaluation seed 0)."""

    upright: float = setting(
        100.0, "LQR cost level at upright below which it balances", low=0.0, low_open=True
    )
    track: float = setting(
        200.0, "TVLQR cost level below which it keeps its funnel point", low=0.0, low_open=True
    )
    entry: float = setting(
        20.0, "TVLQR cost level below which it enters the funnel", low=0.0, low_open=True
    )
    damping: float = setting(
        1.0, "gain of the energy removal elsewhere", "N m s/rad", low=0.0, low_open=True
    )
    horizon: int = setting(
        40,
        "constrained LQR's horizon, shortened where its QP is ill-conditioned (0: the saturated "
        "LQR)",
        "steps",
        low=0,
    )

    def __post_init__(self) -> None:
        check(self)
        if self.entry > self.track:
            raise ValueError(f"entry ({self.entry:g}) must be at most track ({self.track:g})")


class FunnelController:
    """``u = pi(x)`` [N m] on ``trajectory``'s model: the constrained LQR inside the LQR's level
    set at upright, else TVLQR at the funnel point it follows (entered at the point of least
    cost), else :meth:`removal`; ``linear`` and ``step``: the
    Jacobians and the step ``x' = step(x, u)`` of a learnt model the trajectory was planned on
    (without ``step`` a learnt model's entries are not checked by rollout); ``check``: whether
    to check entries by rollout at all (its rollout applies continuous torques, so not for
    {-1, 0, +1}). Call :meth:`reset` (or take a :meth:`fresh` copy) before each episode."""

    def __init__(
        self,
        trajectory: Trajectory,
        settings: FunnelSettings = FunnelSettings(),
        *,
        q: tuple[float, ...] = (10.0, 10.0, 1.0, 1.0),
        r: float = 1.0,
        linear: Jacobians | None = None,
        elsewhere: Callable[[np.ndarray], Any] | None = None,
        step: Callable[[np.ndarray, float], np.ndarray] | None = None,
        check: bool = True,
    ) -> None:
        self.trajectory, self.settings, self.elsewhere = trajectory, settings, elsewhere
        if step is None and linear is None:
            step = partial(integrators.step_states, p=trajectory.params, method=trajectory.method)
        self.check = check
        self.step = step if check else None
        # The LQR at the swing-up's end (upright at rest), on the model the gains come from.
        end = UPRIGHT.copy() if linear is None else trajectory.states[-1].copy()
        self.lqr = LQR(q, r, trajectory.params, end, linear)
        self.balancer = MPC(self.lqr, settings.horizon) if settings.horizon else self.lqr
        self.limit = trajectory.params.max_torque
        self.costs, self.gains = tvlqr(trajectory, self.lqr, q, r, linear)
        self.index: int | None = None  # the funnel point followed now

    def reset(self) -> None:
        """Follow no funnel point, and reset the law ``elsewhere`` where it keeps a memory: a
        new episode."""
        self.index = None
        reset = getattr(self.elsewhere, "reset", None)
        if reset is not None:
            reset()

    def fresh(self) -> FunnelController:
        """A copy that shares the gains and follows nothing yet (with its own law
        ``elsewhere``)."""
        other = copy.copy(self)
        other.elsewhere = copy.deepcopy(self.elsewhere)
        other.reset()
        return other

    def removal(self, x: np.ndarray) -> float:
        """The torque [N m] where the funnel does not act: the law ``elsewhere``, and where it
        has none or gives None, energy removal ``-clip(damping dq2)``."""
        torque = None if self.elsewhere is None else self.elsewhere(x)
        if torque is None:
            return float(np.clip(-self.settings.damping * x[3], -self.limit, self.limit))
        return float(torque)

    def record(self, torque: float) -> None:
        """The torque [N m] the env applied after the last call: unused (it does not adapt)."""

    def mode(self, x: np.ndarray) -> str:
        """``"upright"``, ``"funnel"`` or ``"damping"`` for state ``x``, updating the memory: a
        funnel point followed is kept while its cost stays below ``track`` (the funnel ends at
        upright, in the LQR's cost), then the LQR's level set, then the cheapest entry."""
        points, costs = self.trajectory.states[:-1], self.costs[:-1]
        if self.index is not None:
            e = state_error(x, points[self.index])
            if e @ costs[self.index] @ e <= self.settings.track:
                return "funnel"
            self.index = None
        error = state_error(x, self.lqr.target)
        if error @ self.lqr.cost @ error < self.settings.upright:
            return "upright"
        e = state_error(x[None], points)
        levels = np.einsum("ki,kij,kj->k", e, costs, e)
        best = int(np.argmin(levels))
        if levels[best] < self.settings.entry or (
            levels[best] < self.settings.track and self.reaches(x, best)
        ):
            self.index = best
            return "funnel"
        return "damping"

    def reaches(self, x: np.ndarray, k: int) -> bool:
        """Does the funnel, followed from point ``k`` in state ``x`` on the controller's own
        model, stay within ``track`` and end inside the balancer's level set? (False where it
        has no model step.) A simulation-based check of the funnel, as Reist and Tedrake's."""
        if self.step is None:
            return False
        for j in range(k, self.trajectory.steps):
            e = state_error(x, self.trajectory.states[j])
            if e @ self.costs[j] @ e > self.settings.track:
                return False
            x = np.asarray(self.step(x, self.funnel_torque(j, x)), dtype=float)
        error = state_error(x, self.lqr.target)
        return bool(error @ self.lqr.cost @ error < self.settings.upright)

    def funnel_torque(self, k: int, x: np.ndarray) -> float:
        """TVLQR at funnel point ``k`` (:func:`~acrobot_mj.control.lqr.tvlqr_torque`) [N m]."""
        return tvlqr_torque(self.trajectory, self.gains, k, x)

    def __call__(self, x: np.ndarray) -> float:
        """The torque [N m] in state ``x``; it moves the memory one funnel point on."""
        x = np.asarray(x, dtype=float)
        mode = self.mode(x)
        if mode == "upright":
            return float(self.balancer(x))
        if mode == "damping":
            return self.removal(x)
        k = self.index
        assert k is not None
        self.index = k + 1 if k + 1 < self.trajectory.steps else None
        return self.funnel_torque(k, x)


#: Steps added to the nominal swing-up's length for each warm start of a replan, in order.
REPLAN_STEPS = (0, 8, -8, 16)


class AdaptiveFunnel:
    """:class:`FunnelController` that identifies the lumped parameters from its own first
    ``samples`` transitions (:mod:`~acrobot_mj.control.identification`: it is told the
    structure and the step, as the balance preset is) and, where they differ from its model,
    replans the swing-up on the identified model, warm-started from its own (CasADi: the
    ``control`` extra), then follows that funnel. It adapts once an episode; a replan that
    fails leaves the funnel it had. Told each applied torque through :meth:`record`."""

    def __init__(self, funnel: FunnelController, samples: int = 60) -> None:
        self.nominal, self.samples = funnel, samples
        self.reset()

    def reset(self) -> None:
        """The nominal funnel, no data, not adapted: a new episode."""
        self.funnel = self.nominal.fresh()
        self.data: list[tuple[list[float], float, list[float]]] = []
        self.last: np.ndarray | None = None
        self.torque: float | None = None
        #: None until it has adapted; then what it did ("kept", "replanned", or why not).
        self.adapted: str | None = None

    def fresh(self) -> AdaptiveFunnel:
        """A copy for a new episode."""
        return AdaptiveFunnel(self.nominal, self.samples)

    def record(self, torque: float) -> None:
        """The torque [N m] the env applied in the step after the last call."""
        self.torque = torque

    def __call__(self, x: np.ndarray) -> float:
        x = np.asarray(x, dtype=float)
        if self.adapted is None and self.last is not None and self.torque is not None:
            limits = np.asarray(self.nominal.trajectory.params.max_vel)
            if np.all(np.abs(x[2:]) < limits - 1e-9):  # a clipped step is not the dynamics
                self.data.append((self.last.tolist(), self.torque, x.tolist()))
            if len(self.data) >= self.samples:
                self.adapted = self._adapt()
        self.last, self.torque = x, None
        return self.funnel(x)

    def _adapt(self) -> str:
        from acrobot_mj.control.identification import identify, realise

        nominal = self.nominal.trajectory
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
        self.funnel = FunnelController(
            optimiser.trajectory(found), self.nominal.settings, check=self.nominal.check
        )
        return "replanned"


#: The state feedbacks: ``u = pi(x)``, with ``fresh()`` for each episode.
Feedback = FunnelController | AdaptiveFunnel
