"""The one shape of everything that gives the acrobot a torque (:class:`Controller`), and the
pieces that compose controllers: the first of a chain of laws that acts (:class:`Fallbacks`),
a switch between two controllers (:class:`Combined`, as ``double_pendulum``'s
``CombinedController``), a controller that decides every few calls (:class:`Held`),
energy removal (:class:`EnergyRemoval`), and a controller whose calls are timed (:class:`Timed`).

In our convention throughout: the state ``x = (q1, q2, dq1, dq2)`` [rad, rad/s] with ``q1`` from
the horizontal, the time ``t`` [s] since the episode began, the elbow torque [N m]."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence

import numpy as np

#: A condition on the state ``x`` (4,) and the time ``t`` [s].
Condition = Callable[[np.ndarray, float], bool]


class Controller(ABC):
    """A controller of the acrobot's elbow. A caller calls :meth:`reset` before each episode,
    then :meth:`act` once a step, and tells it the torque the plant applied
    (:meth:`applied`) where that may differ from the one it gave (a {-1, 0, +1} modulator, a
    clipped or held torque). :meth:`covers` says where it acts, for a chain of
    :class:`Fallbacks`."""

    def reset(self, seed: int | None = None) -> None:  # noqa: B027 (by default: no memory)
        """A new episode: every memory cleared; randomness drawn anew from ``seed`` (None: the
        controller's own seed)."""

    @abstractmethod
    def act(self, x: np.ndarray, t: float) -> float:
        """The elbow torque [N m] for what it observes, ``x`` (4,), at ``t`` [s]."""

    def applied(self, torque: float) -> None:  # noqa: B027 (by default: not heard)
        """The torque [N m] the plant applied after the last :meth:`act`."""

    def covers(self, x: np.ndarray) -> bool:
        """Whether it acts in state ``x`` (4,) (a :class:`Fallbacks` link passes the others on)."""
        return True


class Fallbacks(Controller):
    """The first of ``laws`` that covers the state acts (the last covers every state)."""

    def __init__(self, laws: Sequence[Controller]) -> None:
        if not laws:
            raise ValueError("a chain of fallbacks needs at least one law")
        self.laws = tuple(laws)

    def reset(self, seed: int | None = None) -> None:
        for law in self.laws:
            law.reset(seed)

    def act(self, x: np.ndarray, t: float) -> float:
        for law in self.laws[:-1]:
            if law.covers(x):
                return law.act(x, t)
        return self.laws[-1].act(x, t)


class Combined(Controller):
    """``first`` acts until ``to_second(x, t)`` holds, then ``second`` until ``to_first(x, t)``
    holds, and so on (each condition is asked while the other controller acts); both hear
    every applied torque."""

    def __init__(
        self,
        first: Controller,
        second: Controller,
        to_second: Condition,
        to_first: Condition = lambda x, t: False,
    ) -> None:
        self.controllers, self.conditions = (first, second), (to_first, to_second)
        self.active = 0

    def reset(self, seed: int | None = None) -> None:
        self.active = 0
        for controller in self.controllers:
            controller.reset(seed)

    def act(self, x: np.ndarray, t: float) -> float:
        other = 1 - self.active
        if self.conditions[other](x, t):
            self.active = other
        return self.controllers[self.active].act(x, t)

    def applied(self, torque: float) -> None:
        for controller in self.controllers:
            controller.applied(torque)


class Held(Controller):
    """``controller`` asked every ``every`` calls (a decision spans that many physics steps),
    its torque clipped to ``limit`` [N m] and held in between; it hears the torque it holds."""

    def __init__(self, controller: Controller, limit: float, every: int = 1) -> None:
        if every < 1:
            raise ValueError(f"every must be a whole number of calls >= 1, got {every}")
        self.controller, self.limit, self.every = controller, limit, every
        self.calls, self.held = 0, 0.0

    def reset(self, seed: int | None = None) -> None:
        self.controller.reset(seed)
        self.calls, self.held = 0, 0.0

    def act(self, x: np.ndarray, t: float) -> float:
        if self.calls % self.every == 0:
            u = self.controller.act(np.asarray(x, dtype=float), t)
            self.held = float(np.clip(u, -self.limit, self.limit))
            self.controller.applied(self.held)
        self.calls += 1
        return self.held


class EnergyRemoval(Controller):
    """``tau = -clip(damping dq2, -limit, limit)`` [N m] (``damping`` [N m s/rad]): the elbow
    works against its own motion, and the arm falls towards hanging at rest."""

    def __init__(self, damping: float, limit: float) -> None:
        self.damping, self.limit = damping, limit

    def act(self, x: np.ndarray, t: float) -> float:
        return float(np.clip(-self.damping * x[3], -self.limit, self.limit))


class Timed(Controller):
    """``controller``, the wall time [s] of each of its calls of
    :meth:`~acrobot_mj.control.controller.Controller.act` kept in ``seconds`` (every call since
    it was made); it passes everything else on."""

    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.seconds: list[float] = []

    def reset(self, seed: int | None = None) -> None:
        self.controller.reset(seed)

    def act(self, x: np.ndarray, t: float) -> float:
        start = time.perf_counter()
        u = self.controller.act(x, t)
        self.seconds.append(time.perf_counter() - start)
        return u

    def applied(self, torque: float) -> None:
        self.controller.applied(torque)

    def covers(self, x: np.ndarray) -> bool:
        return self.controller.covers(x)

    def summary(self, step: float) -> dict[str, float]:
        """The calls, their median, 99th percentile and longest time [ms], and the fraction of
        calls longer than ``step`` [s]."""
        if not self.seconds:
            raise ValueError("no call was timed")
        ms = np.asarray(self.seconds) * 1e3
        return {
            "calls": len(ms),
            "median_ms": float(np.median(ms)),
            "p99_ms": float(np.percentile(ms, 99)),
            "max_ms": float(ms.max()),
            "over_step": float(np.mean(ms > step * 1e3)),
        }
