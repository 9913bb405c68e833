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
from acrobot_mj.control.planned import LEVELS, PLANNED, kindred, shipped_name
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
from acrobot_mj.physics.integrators import ENV_INTEGRATORS, steps_in
from acrobot_mj.physics.models import AcrobotModel, resolve
from acrobot_mj.settings import SettingError, Settings, setting
from acrobot_mj.train.controller_run import ControllerLearner
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.records import TRAJECTORY_FILE
from acrobot_mj.train.run import Run

#: The report's shipped swing-ups by torque bound [N m].
SWING_UPS = {0.8: "reserve", 1.0: "min_time"}


@dataclass(frozen=True)
class FeedbackConfig(Settings):
    """The state-feedback run's settings: its torques, the shipped swing-up whose funnel it
    follows, the funnel's levels (:class:`~acrobot_mj.control.tracker.FunnelSettings`; None:
    those chosen for the acrobot), the seconds of each episode, whether it identifies the model
    and replans in each episode (:class:`~acrobot_mj.control.adaptive.Adaptive`), and the
    acrobot (None: the report's; another one with a planned swing-up,
    :data:`~acrobot_mj.control.planned.PLANNED`)."""

    discrete: bool = discrete_setting()
    reserve: float = setting(
        0.8,
        "torque bound of the report's shipped swing-up it follows",
        "N m",
        choices=tuple(SWING_UPS),
    )
    funnel: FunnelSettings | None = setting(
        None, "the funnel's levels (default: those chosen for the acrobot)", cli=False
    )
    seconds: float = setting(
        120.0, "simulated seconds of each episode", "s", low=0.0, low_open=True, high=86_400.0
    )
    adaptive: bool = setting(
        False, "identify the model from each episode's first 3 s and replan the swing-up on it"
    )
    model: str | None = setting(
        None,
        "the acrobot: a shipped model's name or a .json/.toml file, with a planned swing-up "
        "(default: the report's)",
        metavar="NAME|FILE",
    )

    what = "state-feedback"

    def __post_init__(self) -> None:
        super().__post_init__()
        try:  # a model file refused where it is given, not when the swing-up is planned
            resolve(self.model)
        except (TypeError, ValueError) as error:
            raise SettingError(f"config model: {error}") from None


def feedback_swing_up(config: FeedbackConfig) -> Trajectory:
    """The swing-up a new run follows: the report's shipped plan of ``config.reserve``, or
    another acrobot's swing-up, shipped or planned on first use
    (:func:`~acrobot_mj.olympics.swing_ups.swing_up_for`); refused in one line where there is
    none, or where an option is the report's alone."""
    from acrobot_mj.olympics.swing_ups import swing_up_for

    if config.model is None or shipped_name(config.model) == "report":
        return shipped(SWING_UPS[config.reserve])
    plan = swing_up_for(config.model)
    flags = {"discrete": config.discrete, "adaptive": config.adaptive}
    given = [f"--{name}" for name, value in flags.items() if value]
    if config.reserve != FeedbackConfig.reserve:
        given.append("--reserve")
    if given:
        raise SettingError(
            f"{', '.join(given)}: for the report's acrobot only (its 1 N m levels, its plans); "
            f"{config.model} follows its one planned swing-up"
        )
    return plan


class FeedbackLearner(ControllerLearner):
    """Builds the controller (``learn``); acts through it from any start, with no clock."""

    kind, kind_name = "state_feedback", "state-feedback"
    describes = "state feedback: TVLQR funnel, constrained LQR, energy removal"
    protocol = HeldOut(episodes=100, start_noise=0.01, seed=0, starts_from="uniform", seconds=120.0)

    def __init__(self, config: FeedbackConfig, seed: int, trajectory: Trajectory | None = None):
        super().__init__(config, seed)
        self.trajectory = trajectory or feedback_swing_up(config)
        start = time.perf_counter()
        # The entry check rolls out continuous torques: with {-1, 0, +1} it made catches later.
        settings = TrackerSettings(rollout=not config.discrete)
        integrator = {m: e for e, m in ENV_INTEGRATORS.items()}[self.trajectory.method]
        #: The acrobot, as the run's plan carries it.
        self.acrobot = AcrobotModel(self.trajectory.params, integrator=integrator)
        self.name = shipped_name(self.acrobot)
        levels = config.funnel or LEVELS.get(kindred(self.acrobot) or "", FunnelSettings())
        self.tracker = PlanTracker([self.trajectory], levels, settings)
        self.build_seconds = time.perf_counter() - start

    def learn(self, run: Run) -> dict[str, Any]:
        with self.env() as env:
            actor = BalanceActor(env, self.controller(), self.config.discrete)
            rest = assess_from_rest(env, actor, self.seed)
        return self.keep(
            run,
            {
                "task": Balance.name,
                "swing_up": SWING_UPS[self.config.reserve]
                if self.name == "report"
                else PLANNED.get(self.name or "", "first-use"),
                "greedy_from_rest": rest,
                "build_seconds": self.build_seconds,
            },
        )

    def save(self, out: Path) -> None:
        self.trajectory.save(out / TRAJECTORY_FILE)

    def env(self, **kwargs: Any) -> gym.Env:
        steps = steps_in(self.config.seconds, self.trajectory.dt)
        kwargs.setdefault("max_episode_steps", steps)
        if self.name != "report":
            kwargs.setdefault("model", self.acrobot)
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
        if config.model is None and trajectory.u_max != config.reserve:
            raise ValueError(
                f"{Path(run_dir) / TRAJECTORY_FILE} is not the swing-up of "
                f"reserve {config.reserve} N m"
            )
        return cls(config, int(record["seed"]), trajectory)
