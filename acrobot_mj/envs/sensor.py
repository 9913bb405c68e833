"""A sensor between the acrobot and its agent or controller: the AI Olympics protocol's
measurement delay and Gaussian noise (dfki-ric-underactuated-lab/double_pendulum,
src/python/double_pendulum/simulation/simulation.py, ``Simulator.get_measurement``), applied to
the observation of any acrobot env (docs/envs/disturbances.md)."""

from __future__ import annotations

from collections import deque
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.checks import check_float
from acrobot_mj.envs.acrobot import observation
from acrobot_mj.envs.links import acrobot_under
from acrobot_mj.envs.motor import stream
from acrobot_mj.envs.spaces import cos_sin

#: What a delay holds back: every state variable, or the velocities only.
DELAY_MODES = ("posvel", "vel")
#: The spawn key of a wrapper's stream seeded at reset (the env's own stream has none).
SENSOR_KEY = 0x5E45


def sigmas(sigma: Any, n: int, name: str) -> np.ndarray:
    """``sigma`` [unit of each component] as ``n`` standard deviations: one number for all or
    ``n`` of them; each finite and >= 0."""
    try:
        refused = sigma is None or isinstance(sigma, (str, bool))
        array = None if refused else np.asarray(sigma, dtype=np.float64)
    except (TypeError, ValueError):
        array = None
    if array is None or array.ndim > 1 or (array.ndim == 1 and array.shape != (n,)):
        raise ValueError(f"{name} must be one number or {n} of them, got {sigma!r}")
    for value in np.atleast_1d(array):
        check_float(name, float(value), 0.0, 1e6)
    return np.broadcast_to(array, (n,)).copy()


class Sensor(gym.Wrapper):
    """The observation of the true state ``env.unwrapped.state`` ``delay`` [s] ago, plus
    Gaussian noise of standard deviations ``sigma`` [rad, rad, rad/s, rad/s] (one number or
    four), in the env's own form (angles wrapped into [-pi, pi); ``"cos_sin"`` computed from
    the noisy state). Rewards, ends and ``info`` stay the env's, from the true state.

    The protocol's delay: ``n = int(delay / dt) + 1`` with ``dt`` the env's decision time [s];
    the measured state is the true state ``n - 1`` decisions ago (the oldest while fewer have
    passed), all of it (``mode="posvel"``) or its velocities only (``"vel"``, the angles
    current). Noise is drawn, four normals a measurement (zero sigmas included), from ``rng``
    (a Generator or an integer seed); without one, ``reset(seed=s)`` seeds it from ``s``.
    ``measured`` holds the episode's measured states, shape ``(decisions + 1, 4)``, unwrapped.
    """

    def __init__(
        self,
        env: gym.Env,
        delay: float = 0.0,
        sigma: Any = 0.0,
        mode: str = "posvel",
        rng: np.random.Generator | int | None = None,
    ) -> None:
        super().__init__(env)
        acrobot_under(env, "Sensor")
        delay = check_float("delay", delay, 0.0, 86_400.0)
        if mode not in DELAY_MODES:
            raise ValueError(f"mode must be one of {DELAY_MODES}, got {mode!r}")
        self.delay, self.mode = delay, mode
        self.sigma = sigmas(sigma, 4, "sigma")
        #: Decisions back, plus one (the protocol's n).
        self.n = int(delay / env.unwrapped.dt) + 1  # type: ignore[attr-defined]
        self.rng, self._reseed = stream(rng, SENSOR_KEY), rng is None
        # States as tuples of floats: numpy's arithmetic on four numbers, a fifth of the time.
        self._true: deque[tuple[float, ...]] = deque(maxlen=self.n)
        self._measured: list[tuple[float, ...]] = []
        self._cos_sin = env.unwrapped.observation == "cos_sin"  # type: ignore[attr-defined]

    @property
    def measured(self) -> np.ndarray:
        """The episode's measured states ``(decisions + 1, 4)`` [rad, rad/s], unwrapped."""
        return np.array(self._measured).reshape(-1, 4)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        _, info = self.env.reset(**kwargs)
        if self._reseed and kwargs.get("seed") is not None:
            self.rng = stream(int(kwargs["seed"]), SENSOR_KEY)
        self._true.clear()
        self._measured = []
        return self._measure(), info

    def step(self, action: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        _, reward, terminated, truncated, info = self.env.step(action)
        return self._measure(), reward, terminated, truncated, info

    def _measure(self) -> np.ndarray:
        acrobot: Any = self.env.unwrapped
        state = (*acrobot.data.qpos.tolist(), *acrobot.data.qvel.tolist())  # acrobot.state
        self._true.append(state)
        measured = state
        if self.n > 1:
            late = self._true[0]
            measured = late if self.mode == "posvel" else (*state[:2], *late[2:])
        # rng.normal(measured, sigma): loc + scale * z for four standard normals z, in order;
        # without noise nothing is drawn (m + 0 z is m, but for a zero's sign)
        sigma = self.sigma.tolist()
        if any(sigma):
            z = self.rng.standard_normal(4).tolist()
            measured = tuple(m + s * w for m, s, w in zip(measured, sigma, z, strict=True))
        self._measured.append(measured)
        obs = observation(*measured)
        if obs is None:
            raise RuntimeError(f"the measured state {list(measured)} is not finite")
        return cos_sin(obs) if self._cos_sin else obs
