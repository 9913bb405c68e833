"""The ``balance`` preset: a model-based learner that swings up AND balances with
``|tau| <= 1`` N m: it identifies the lumped parameters from random-torque decisions, plans a
minimum-time swing-up on the model with ``|u| <= reserve``, and follows it with TVLQR, then LQR
at upright."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.tracker import clocked
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.envs.control_loop import (
    BalanceActor,
    balance_env,
    closed_loop,
    discrete_setting,
    hold_setting,
    reserve_setting,
)
from acrobot_mj.envs.rollout import Actor
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.identify.lumped import realise
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.settings import Settings, setting
from acrobot_mj.train.learners import HeldOut, Learner
from acrobot_mj.train.model_based import identified_model
from acrobot_mj.train.records import TRAJECTORY_FILE
from acrobot_mj.train.run import Run


@dataclass(frozen=True)
class PlanConfig(Settings):
    """The balance preset's settings; ``targets`` are indices of
    :data:`~acrobot_mj.control.trajopt.TARGETS`, ``starts`` one of
    :data:`~acrobot_mj.control.trajopt.STARTS` (None: the search's defaults)."""

    identify_decisions: int = setting(200, "decisions of random-torque data", "decisions", low=3)
    data_noise: float = setting(
        1.0, "start noise of the data episodes", "rad, rad/s", low=0.0, high=1.0
    )
    reserve: float = reserve_setting()
    discrete: bool = discrete_setting()
    horizons: tuple[int, int, int] | None = setting(
        None, "start horizons of the search, START:STOP:STEP", "physics steps", low=1, sep=":"
    )
    targets: tuple[int, ...] | None = setting(
        None, "upright poses the search tries, e.g. 1,4", low=0, high=5, sep=","
    )
    hold: float = hold_setting()
    starts: str = setting(
        "rest", "warm starts of the search: rest or pumping", choices=("rest", "pumping")
    )

    what = "balance-preset"

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PlanConfig:
        """A record's settings; one written before 0.5 searched from pumping starts."""
        return super().from_dict({"starts": "pumping", **data})


class PlanLearner(Learner):
    """The balance preset's learner: ``learn`` identifies and plans; it acts through TVLQR."""

    kind, kind_name = "identify_and_plan", "balance-preset"
    describes = "identified model + TVLQR"
    protocol = HeldOut(episodes=100, start_noise=0.01, seed=0)

    def __init__(self, config: PlanConfig, seed: int, trajectory: Trajectory | None = None):
        super().__init__(config, seed)
        self.trajectory = trajectory

    @property
    def swing_up(self) -> int | None:  # type: ignore[override]
        return None if self.trajectory is None else self.trajectory.steps

    def learn(self, run: Run) -> dict[str, Any]:
        from acrobot_mj.control.trajopt import (  # CasADi: the control extra
            TARGETS,
            WarmStarts,
            min_time,
        )

        config, start = self.config, time.perf_counter()
        model = learn_model(config, self.seed)
        targets = None if config.targets is None else tuple(TARGETS[i] for i in config.targets)
        horizons = None if config.horizons is None else range(*config.horizons)
        p = AcrobotParams(**model["params"])
        warm = WarmStarts(config.starts, horizons, targets)
        self.trajectory = min_time(config.reserve, warm=warm, p=p, progress=run.progress)
        trained = time.perf_counter() - start
        with self.env() as env:
            result = closed_loop(self.trajectory, config.discrete, config.hold, env=env)
        torques = np.asarray(result.pop("torques"))
        result.pop("states")
        rest = result | {"steps": len(torques), "mean_abs_torque": float(np.abs(torques).mean())}
        return self.keep(
            run,
            {
                "task": Balance.name,
                "model": model,
                "plan": plan_summary(self.trajectory),
                "greedy_from_rest": rest,
                "decisions_total": model["data_decisions"] + len(torques),
                "wall_seconds": trained,
            },
        )

    def save(self, out: Path) -> None:
        self._planned().save(out / TRAJECTORY_FILE)

    def _planned(self) -> Trajectory:
        if self.trajectory is None:
            raise ValueError("this learner has no trajectory yet: learn() or load() one first")
        return self.trajectory

    def env(self, **kwargs: Any) -> gym.Env:
        return balance_env(self._planned(), self.config.discrete, self.config.hold, **kwargs)

    def actor(self, env: gym.Env, episode: int) -> Actor:
        return BalanceActor(env, clocked(self._planned()), self.config.discrete)

    @classmethod
    def load(cls, run_dir: Path) -> PlanLearner:
        record = cls.read_run(run_dir)
        trajectory = Trajectory.load(Path(run_dir) / TRAJECTORY_FILE)
        if dataclasses.asdict(trajectory.params) != record["model"]["params"]:
            raise ValueError(
                f"{Path(run_dir) / TRAJECTORY_FILE} was planned on another model than the run's"
            )
        return cls(PlanConfig.from_dict(record["config"]), int(record["seed"]), trajectory)


def learn_model(config: PlanConfig, seed: int) -> dict[str, Any]:
    """The data and the identified model, with its realisation."""
    with data_env(config) as env:
        decisions, theta, rms, told = identified_model(
            env, config.identify_decisions, seed, config.data_noise
        )
    return {
        "data_decisions": decisions,
        "theta": theta.tolist(),
        "rms": rms,
        "params": dataclasses.asdict(realise(theta, told)),
    }


def data_env(config: PlanConfig, **kwargs: Any) -> gym.Env:
    return gym.make(Balance.env_id, continuous=not config.discrete, **kwargs)


def plan_summary(trajectory: Trajectory) -> dict[str, Any]:
    torques = trajectory.torques
    return {
        "steps": trajectory.steps,
        "seconds": trajectory.seconds,
        "u_max": trajectory.u_max,
        "mean_abs_torque": float(np.abs(torques).mean()),
        "full_torque_fraction": float(np.mean(np.abs(torques) >= trajectory.u_max - 1e-6)),
        "residual": trajectory.residual(),
    }
