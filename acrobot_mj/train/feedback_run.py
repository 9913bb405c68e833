"""``acrobot-mj balance --feedback``: the state-feedback controller
(:class:`~acrobot_mj.control.tracker.PlanTracker` along one swing-up) as a run that
``evaluate`` and ``render`` take like any other. It is built on the report's model (it is
told the equations), along the shipped swing-up of its ``reserve``, in well under a second;
its own evaluation starts both angles uniform on the circle."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from acrobot_mj.control.adaptive import Adaptive
from acrobot_mj.control.controller import Controller
from acrobot_mj.control.tracker import FunnelSettings, PlanTracker, TrackerSettings
from acrobot_mj.control.trajopt import Trajectory, shipped
from acrobot_mj.envs.control_loop import (
    BalanceActor,
    assess_from_rest,
    balance_env,
    discrete_setting,
)
from acrobot_mj.envs.rollout import Actor
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.physics.integrators import steps_in
from acrobot_mj.settings import Settings, setting
from acrobot_mj.train.controller_run import ControllerLearner
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.records import TRAJECTORY_FILE
from acrobot_mj.train.run import Run

#: The shipped swing-ups by torque bound [N m].
SWING_UPS = {0.8: "reserve", 1.0: "min_time"}
#: The funnel's levels by default.
FUNNEL = FunnelSettings()


@dataclass(frozen=True)
class FeedbackConfig(Settings):
    """The state-feedback run's settings: its torques, the shipped swing-up whose funnel it
    follows, the funnel's levels (:class:`~acrobot_mj.control.tracker.FunnelSettings`), the
    seconds of each episode, and whether it identifies the model and replans in each episode
    (:class:`~acrobot_mj.control.adaptive.Adaptive`)."""

    discrete: bool = discrete_setting()
    reserve: float = setting(
        0.8, "torque bound of the shipped swing-up it follows", "N m", choices=tuple(SWING_UPS)
    )
    funnel: FunnelSettings = setting(FUNNEL, "the funnel's levels", cli=False)
    seconds: float = setting(
        120.0, "simulated seconds of each episode", "s", low=0.0, low_open=True, high=86_400.0
    )
    adaptive: bool = setting(
        False, "identify the model from each episode's first 3 s and replan the swing-up on it"
    )

    what = "state-feedback"


class FeedbackLearner(ControllerLearner):
    """Builds the controller (``learn``); acts through it from any start, with no clock."""

    kind, kind_name = "state_feedback", "state-feedback"
    describes = "state feedback: TVLQR funnel, constrained LQR, energy removal"
    protocol = HeldOut(episodes=100, start_noise=0.01, seed=0, starts_from="uniform", seconds=120.0)

    def __init__(self, config: FeedbackConfig, seed: int, trajectory: Trajectory | None = None):
        super().__init__(config, seed)
        self.trajectory = trajectory or shipped(SWING_UPS[config.reserve])
        start = time.perf_counter()
        # The entry check rolls out continuous torques: with {-1, 0, +1} it made catches later.
        settings = TrackerSettings(rollout=not config.discrete)
        self.tracker = PlanTracker([self.trajectory], config.funnel, settings)
        self.build_seconds = time.perf_counter() - start

    def learn(self, run: Run) -> dict[str, Any]:
        with self.env() as env:
            actor = BalanceActor(env, self.controller(), self.config.discrete)
            rest = assess_from_rest(env, actor, self.seed)
        return self.keep(
            run,
            {
                "task": Balance.name,
                "swing_up": SWING_UPS[self.config.reserve],
                "greedy_from_rest": rest,
                "build_seconds": self.build_seconds,
            },
        )

    def save(self, out: Path) -> None:
        self.trajectory.save(out / TRAJECTORY_FILE)

    def env(self, **kwargs: Any) -> gym.Env:
        steps = steps_in(self.config.seconds, self.trajectory.dt)
        kwargs.setdefault("max_episode_steps", steps)
        return balance_env(self.trajectory, self.config.discrete, 0.0, **kwargs)

    def actor(self, env: gym.Env, episode: int) -> Actor:
        return BalanceActor(env, self.controller(), self.config.discrete)

    def controller(self) -> Controller:
        """The controller, on the state."""
        return Adaptive(self.tracker) if self.config.adaptive else self.tracker

    @classmethod
    def load(cls, run_dir: Path) -> FeedbackLearner:
        record = cls.read_run(run_dir)
        config = FeedbackConfig.from_dict(record["config"])
        trajectory = Trajectory.load(Path(run_dir) / TRAJECTORY_FILE)
        if trajectory.u_max != config.reserve:
            raise ValueError(
                f"{Path(run_dir) / TRAJECTORY_FILE} is not the swing-up of "
                f"reserve {config.reserve} N m"
            )
        return cls(config, int(record["seed"]), trajectory)
