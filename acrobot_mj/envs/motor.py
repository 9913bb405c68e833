"""A motor between the agent or controller and the acrobot: the AI Olympics protocol's torque
response, torque noise, torque limit and pulse perturbations (dfki-ric-underactuated-lab/
double_pendulum, src/python/double_pendulum/simulation/simulation.py,
``Simulator.get_real_applied_u``, and simulation/perturbations.py,
``get_random_gauss_perturbation_array``), applied to any acrobot env without changing its step
(docs/envs/disturbances.md)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.checks import check_float
from acrobot_mj.envs.links import acrobot_under
from acrobot_mj.envs.spaces import action_torque

#: The spawn key of a motor's stream seeded at reset.
MOTOR_KEY = 0x307
#: The largest torque response: past 2 each decision overshoots the command by more than the
#: last error (the protocol's levels end at 2.0).
MAX_RESPONSE = 2.0


def stream(rng: np.random.Generator | int | None, key: int) -> np.random.Generator:
    """A wrapper's generator: ``rng`` itself, or one seeded by the integer ``rng`` (spawn key
    ``key``, so a seed shared with the env gives another stream); None: unseeded."""
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is not None and (not isinstance(rng, (int, np.integer)) or isinstance(rng, bool)):
        raise TypeError(f"rng must be a numpy Generator, an integer seed or None, got {rng!r}")
    if rng is not None and rng < 0:
        raise ValueError(f"seed must be >= 0, got {rng}")
    return np.random.default_rng(
        None if rng is None else np.random.SeedSequence(int(rng), spawn_key=(key,))
    )


class Motor(gym.Wrapper):
    """The torque the motor applies for a commanded one ``u`` [N m] (the env's torque of the
    action), per decision of ``dt`` [s]: ``nu = last + response (u - last)`` (``last``: the
    torque applied at the decision before, pulse included; 0 after a reset), plus
    ``N(0, sigma)`` [N m] on the actuated joint, clipped to the model's torque limit, plus
    ``pulses[:, int(t / dt)]`` [N m] (``(2, steps)``, rows shoulder and elbow, beyond the
    limit; none past its end).

    The env's step is unchanged: it sets ``ctrl = u``; the wrapper adds ``nu - u`` on the
    elbow to MuJoCo's ``qfrc_applied``, held over the decision's physics steps, keeping its
    own contribution apart so other writers compose. As the protocol's acrobot
    (``B = diag(0, 1)``) the shoulder's torque never acts: its pulses are drawn and recorded
    but not applied, and its limit is 0. ``applied`` holds the episode's torques ``nu``
    ``(decisions, 2)`` (both joints, what the protocol's scores use). Noise is two normals a
    decision from ``rng`` (a Generator or an integer seed); without one, ``reset(seed=s)``
    seeds it from ``s``."""

    def __init__(
        self,
        env: gym.Env,
        response: float = 1.0,
        sigma: float = 0.0,
        pulses: Any = None,
        rng: np.random.Generator | int | None = None,
    ) -> None:
        super().__init__(env)
        if check_float("response", response, -1e6, MAX_RESPONSE) <= 0.0:
            raise ValueError(f"response must be in (0, {MAX_RESPONSE:g}], got {response:g}")
        self.response = response
        self.sigma = check_float("sigma", sigma, 0.0, 1e6)
        self.rng, self._reseed = stream(rng, MOTOR_KEY), rng is None
        self.pulses = pulses
        acrobot = acrobot_under(env, "Motor")
        model = acrobot.model
        motor = model.actuator(0)  # the acrobot's one motor, on either joint
        joint = int(motor.trnid[0])
        #: The actuated joint's dof, 0 (shoulder) or 1 (elbow), and each joint's torque limit.
        self.dof = int(model.jnt_dofadr[joint])
        self.limit = np.zeros(2)
        self.limit[self.dof] = float(np.max(np.abs(motor.ctrlrange)))
        self._sigmas = np.zeros(2)
        self._sigmas[self.dof] = self.sigma
        self._dt = float(acrobot.dt)
        self._mine = (0.0, 0.0)
        self._last, self._t = (0.0, 0.0), 0.0
        # Each step's torques as a tuple of floats (the same numbers as numpy's, a fifth of
        # the time on two-element arrays).
        self._applied: list[tuple[float, float]] = []

    @property
    def pulses(self) -> np.ndarray:
        """The pulse torques ``(2, steps)`` [N m], one column a decision from t = 0."""
        return self._pulses

    @pulses.setter
    def pulses(self, pulses: Any) -> None:
        try:
            array = np.zeros((2, 0)) if pulses is None else np.asarray(pulses, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"pulses must be torques, shape (2, steps), got {pulses!r}") from None
        if array.ndim != 2 or array.shape[0] != 2 or not np.all(np.isfinite(array)):
            raise ValueError(
                f"pulses must be finite torques of shape (2, steps), got {array.shape}"
            )
        self._pulses = array
        self._columns = array.T.tolist()  # per decision: (shoulder, elbow) as floats

    @property
    def applied(self) -> np.ndarray:
        """The episode's applied torques ``(decisions, 2)`` [N m], shoulder and elbow."""
        return np.array(self._applied).reshape(-1, 2)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        self._set((0.0, 0.0))
        if self._reseed and kwargs.get("seed") is not None:
            self.rng = stream(int(kwargs["seed"]), MOTOR_KEY)
        self._last, self._t, self._applied = (0.0, 0.0), 0.0, []
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        acrobot: Any = self.env.unwrapped
        commanded = action_torque(action, acrobot.continuous, acrobot.torque_limit)
        # On floats, each operation numpy's on the two joints (the same numbers): a normal is
        # ``loc + scale * z`` of a standard normal z, two drawn a decision.
        dof, response = self.dof, self.response
        last0, last1 = self._last
        u0, u1 = (commanded, 0.0) if dof == 0 else (0.0, commanded)
        nu0, nu1 = last0 + response * (u0 - last0), last1 + response * (u1 - last1)
        if self.sigma:  # without noise nothing is drawn: nu + 0 z is nu (but for a zero's sign)
            z0, z1 = self.rng.standard_normal(2).tolist()
            s0, s1 = self._sigmas.tolist()
            nu0, nu1 = nu0 + s0 * z0, nu1 + s1 * z1
        limit0, limit1 = self.limit.tolist()
        # np.maximum then np.minimum (the first argument where equal or NaN)
        nu0 = nu0 if nu0 >= -limit0 or nu0 != nu0 else -limit0
        nu1 = nu1 if nu1 >= -limit1 or nu1 != nu1 else -limit1
        nu0 = nu0 if nu0 <= limit0 or nu0 != nu0 else limit0
        nu1 = nu1 if nu1 <= limit1 or nu1 != nu1 else limit1
        index = int(self._t / self._dt)
        if index < len(self._columns):
            p0, p1 = self._columns[index]
            nu0, nu1 = nu0 + p0, nu1 + p1
        extra = (nu0 - commanded, 0.0) if dof == 0 else (0.0, nu1 - commanded)
        self._set(extra)
        self._last, self._t = (nu0, nu1), self._t + self._dt
        self._applied.append((nu0, nu1))
        return self.env.step(action)

    def _set(self, extra: tuple[float, float]) -> None:
        """Make this motor's part of ``qfrc_applied`` [N m] ``extra`` (read through the env,
        not held: a copy or an unpickled motor writes into its own env's data)."""
        qfrc = self.env.unwrapped.data.qfrc_applied  # type: ignore[attr-defined]
        # qfrc -= mine (exactly 0 where no other writer adds), then qfrc += extra, on floats
        (q0, q1), (m0, m1), (e0, e1) = qfrc.tolist(), self._mine, extra
        qfrc[:] = (q0 - m0 + e0, q1 - m1 + e1)
        self._mine = (e0, e1)
