"""A controller of :mod:`acrobot_mj.control` closed loop on ``acrobot_mj/AcrobotBalance-v0``:
:class:`BalanceActor` (the controller as an episode-loop actor, beside
:class:`~acrobot_mj.envs.rollout.PolicyActor`), the env of a swing-up, and :func:`closed_loop`,
which runs one under a :class:`~acrobot_mj.envs.disturbances.Perturbation` and assesses it.
Balanced: within the task's tolerance (0.05 rad) from the end of the swing-up to the end of the
run."""

from __future__ import annotations

import functools
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.control.lqr import SigmaDelta
from acrobot_mj.control.tracker import clocked
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.envs.disturbances import Perturbation
from acrobot_mj.envs.links import scale_links
from acrobot_mj.envs.rollout import Hooks, acrobot_of, run_episode, run_from_rest
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.physics.integrators import ENV_INTEGRATORS, steps_in
from acrobot_mj.settings import setting


def discrete_setting() -> bool:
    """The ``discrete`` setting of a controller: {-1, 0, +1} N m torques or continuous ones."""
    return setting(False, "{-1, 0, +1} N m torques (sigma-delta), not continuous")


def reserve_setting() -> float:
    """The ``reserve`` setting of a swing-up: its nominal torque bound [N m]."""
    return setting(
        0.8,
        "nominal torque bound of the plan (1: minimum time, no reserve)",
        "N m",
        low=0.0,
        low_open=True,
        high=1.0,
        metavar="U",
    )


def hold_setting() -> float:
    """The ``hold`` setting of a swing-up: the seconds of balance after it [s]."""
    return setting(
        60.0, "seconds of balance after the swing-up", "s", low=0.05, high=3600.0, metavar="SECONDS"
    )


class BalanceActor:
    """A :class:`~acrobot_mj.control.controller.Controller` as an episode-loop actor, reset as
    the episode begins, told the time and each applied torque; records each step's state and
    applied torque."""

    def __init__(
        self,
        env: gym.Env,
        controller: Controller,
        discrete: bool,
        noise: Any = None,
        observed: bool = False,
    ) -> None:
        self.env = acrobot_of(env)
        # observed: the controller sees the observation (angles wrapped), not MuJoCo's state.
        self.observed = observed
        self.obs: np.ndarray | None = None
        self.controller = controller
        self.modulator = SigmaDelta() if discrete else None
        self.noise = noise  # a generator and a standard deviation, or None
        self.states: list[list[float]] = []
        self.torques: list[float] = []

    def _act(self) -> Any:
        t = len(self.torques) * self.env.dt
        seen = self.obs if self.observed and self.obs is not None else self.env.state
        u = self.controller.act(seen, t)
        if self.noise is not None:
            rng, sigma = self.noise
            self.env.data.qfrc_applied[1] = sigma * rng.standard_normal()
        return np.array([u], dtype=np.float32) if self.modulator is None else self.modulator(u)

    def begin(self, obs: np.ndarray) -> Any:
        self.controller.reset()
        self.obs = np.asarray(obs, dtype=np.float64)
        self.states.append(self.env.state.tolist())
        return self._act()

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        self.obs = np.asarray(obs, dtype=np.float64)
        self.states.append(self.env.state.tolist())
        self.torques.append(float(self.env.data.ctrl[0]))
        self.controller.applied(self.torques[-1])
        return None if terminated or truncated else self._act()


def assess_from_rest(env: gym.Env, actor: BalanceActor, seed: int) -> dict[str, Any]:
    """The task's assessment of ``actor``'s episode on ``env`` from rest (no start noise)."""
    run_from_rest(env, actor, seed)
    acrobot = acrobot_of(env)
    return acrobot.task.assess(np.array(actor.states), acrobot.dt)


def balance_env(trajectory: Trajectory, discrete: bool, hold: float, **kwargs: Any) -> gym.Env:
    """The balance task's env for a swing-up along ``trajectory`` and ``hold`` seconds more
    (unless ``kwargs`` give ``max_episode_steps``)."""
    steps = trajectory.steps + steps_in(hold, trajectory.dt)
    kwargs.setdefault("max_episode_steps", steps)
    return gym.make(
        Balance.env_id,
        continuous=not discrete,
        integrator={m: e for e, m in ENV_INTEGRATORS.items()}[trajectory.method],
        **kwargs,
    )


def closed_loop(
    trajectory: Trajectory,
    discrete: bool = False,
    hold: float = 60.0,
    perturbation: Perturbation = Perturbation(),  # noqa: B008 (frozen)
    env: gym.Env | None = None,
    record: Any = None,
) -> dict[str, Any]:
    """:meth:`~acrobot_mj.envs.tasks.Balance.assess` of the controller on ``env``, with per-step
    ``torques`` and ``states``; ``record(env, actor, *, hooks)`` runs the episode instead
    (videos)."""
    env = env or balance_env(trajectory, discrete, hold)
    scale_links(env, perturbation.mass_scale, perturbation.inertia_scale)
    rng = np.random.default_rng(perturbation.seed)
    noise = (rng, perturbation.torque_noise) if perturbation.torque_noise > 0 else None
    actor = BalanceActor(env, clocked(trajectory), discrete, noise)
    offset = np.asarray(perturbation.start_offset, dtype=float)

    def start(obs: np.ndarray, info: dict[str, Any]) -> None:
        if offset.any():
            state = acrobot_of(env).state + offset
            acrobot_of(env).set_state(state[:2], state[2:])

    record = record or functools.partial(run_episode, seed=perturbation.seed)
    record(env, actor, hooks=Hooks(on_reset=start))
    result = acrobot_of(env).task.assess(np.array(actor.states), trajectory.dt, trajectory.steps)
    return {**result, "torques": actor.torques, "states": actor.states}
