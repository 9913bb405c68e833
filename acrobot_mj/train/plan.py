"""The ``balance`` preset: a model-based learner that swings up AND balances with |tau| <= 1 N m.

Everything it knows of the acrobot comes from interaction with ``acrobot_mj/AcrobotBalance-v0``
in MuJoCo:

1. **data**: ``identify_decisions`` decisions of uniformly random torques, in episodes of at most
   100 decisions from rest plus ``U(-data_noise, data_noise)`` on each angle and velocity
   (:func:`acrobot_mj.train.model_based.collect`);
2. **model**: the five lumped parameters identified from them; the learner is told the
   equations' structure and the env's step, not the masses, lengths, inertias or gravity; a
   model that misses its data is refused;
3. **plan**: the multi-start minimum-time search (:func:`acrobot_mj.control.trajopt.min_time`)
   on the identified model, nominal torques ``|u| <= reserve`` (the rest is the feedback's);
4. **policy**: TVLQR along the plan, then the saturated LQR at upright, both designed on the
   identified model: ``u = pi(k, x)``, ``k`` the physics steps since the reset, ``|u| <= 1``
   N m; with ``discrete`` sigma-delta modulated to ``{-1, 0, +1}`` N m.

A run directory holds ``run.json`` (``kind`` :data:`KIND`: the config, the model, the plan, the
closed loop from rest) and ``trajectory.json`` (the plan with the identified parameters,
re-checked on every load); it evaluates and renders as every other run.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.checks import check_float, check_int
from acrobot_mj.control.identification import realise
from acrobot_mj.control.lqr import SwingUpController
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.envs.rollout import Actor
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.files import versions, write_json
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.report.balance import BalanceActor, balance_env, closed_loop
from acrobot_mj.train.learners import Learner, Protocol, Run
from acrobot_mj.train.model_based import identified_model
from acrobot_mj.train.records import RUN_FILE

#: ``run.json``'s ``kind`` of a balance-preset run, and its plan's file.
KIND, TRAJECTORY_FILE = "identify_and_plan", "trajectory.json"


@dataclass(frozen=True)
class PlanConfig:
    """The balance preset's settings: decisions of data, the data's start noise [rad, rad/s]
    (wide: the data should cover many states), the plan's torque bound [N m], {-1, 0, +1}
    torques, the search's start horizons ``(start, stop, step)`` [physics steps] and upright
    targets (indices 0-5 of :data:`~acrobot_mj.control.trajopt.TARGETS`; None: the defaults),
    and the seconds of balance asked for after the swing-up."""

    identify_decisions: int = 200
    data_noise: float = 1.0
    reserve: float = 0.8
    discrete: bool = False
    horizons: tuple[int, int, int] | None = None
    targets: tuple[int, ...] | None = None
    hold: float = 60.0

    def __post_init__(self) -> None:
        check_int("identify_decisions", self.identify_decisions, 3)
        check_float("data_noise", self.data_noise, 0.0, 1.0)
        if not check_float("reserve", self.reserve, 0.0, 1.0) > 0:
            raise ValueError("reserve must be > 0 N m (the plan's torque bound)")
        if not isinstance(self.discrete, bool):
            raise TypeError(f"discrete must be True or False, got {self.discrete!r}")
        check_float("hold", self.hold, 0.05, 3600.0)
        if self.horizons is not None:
            h = tuple(self.horizons)
            if len(h) != 3 or not all(isinstance(v, int) and v > 0 for v in h) or h[1] <= h[0]:
                raise ValueError(f"horizons must be (start, stop, step) steps > 0, got {h!r}")
            object.__setattr__(self, "horizons", h)
        if self.targets is not None:
            t = tuple(self.targets)
            if not t or not all(isinstance(v, int) and 0 <= v < 6 for v in t):
                raise ValueError(f"targets must be indices 0-5 of the six upright poses, got {t!r}")
            object.__setattr__(self, "targets", t)

    def replace(self, **changes: Any) -> PlanConfig:
        unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(self)})
        if unknown:
            names = [f.name for f in dataclasses.fields(self)]
            raise ValueError(f"unknown balance-preset settings {unknown}; known: {names}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        for name in ("horizons", "targets"):
            data[name] = None if data[name] is None else list(data[name])
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PlanConfig:
        data = {k: tuple(v) if k in ("horizons", "targets") and v else v for k, v in data.items()}
        return cls().replace(**data)


class PlanLearner(Learner):
    """The balance preset's learner (see the module docstring): ``learn`` identifies and plans;
    it acts through TVLQR along its plan."""

    kind = KIND
    #: The held-out starts of its results: U(-0.01, 0.01) around rest.
    protocol = Protocol(episodes=100, start_noise=0.01, seed=0)

    def __init__(self, config: PlanConfig, seed: int, trajectory: Trajectory | None = None):
        super().__init__(config, seed)
        self.trajectory = trajectory

    @property
    def swing_up(self) -> int | None:  # type: ignore[override]
        return None if self.trajectory is None else self.trajectory.steps

    def learn(self, run: Run) -> dict[str, Any]:
        from acrobot_mj.control.trajopt import TARGETS, min_time  # CasADi: the control extra

        config, start = self.config, time.perf_counter()
        model = learn_model(config, self.seed)
        targets = TARGETS if config.targets is None else tuple(TARGETS[i] for i in config.targets)
        horizons = None if config.horizons is None else range(*config.horizons)
        self.trajectory = min_time(config.reserve, horizons=horizons, targets=targets,
                                   p=AcrobotParams(**model["params"]), progress=run.progress)  # fmt: skip
        trained = time.perf_counter() - start
        env = self.env()
        try:
            result = closed_loop(self.trajectory, config.discrete, config.hold, env=env)
        finally:
            env.close()
        torques = np.asarray(result.pop("torques"))
        result.pop("states")
        record = {
            "kind": KIND, "config": config.to_dict(), "seed": self.seed, "task": Balance.name,
            "model": model, "plan": plan_summary(self.trajectory),
            "greedy_from_rest": result | {"steps": len(torques),
                                          "mean_abs_torque": float(np.abs(torques).mean())},
            "decisions_total": model["data_decisions"] + len(torques),
            "wall_seconds": trained, "versions": versions(),
        }  # fmt: skip
        if run.out is not None:
            self.trajectory.save(run.out / TRAJECTORY_FILE)
            write_json(run.out / RUN_FILE, record)
        return record

    def env(self, **kwargs: Any) -> gym.Env:
        """The balance env of an episode: the swing-up and ``hold`` seconds more."""
        return balance_env(self.trajectory, self.config.discrete, self.config.hold, **kwargs)

    def actor(self, env: gym.Env, episode: int) -> Actor:
        return BalanceActor(env, SwingUpController(self.trajectory), self.config.discrete)

    @classmethod
    def load(cls, run_dir: Path) -> PlanLearner:
        record = read_plan_record(Path(run_dir))
        trajectory = Trajectory.load(Path(run_dir) / TRAJECTORY_FILE)
        if dataclasses.asdict(trajectory.params) != record["model"]["params"]:
            raise ValueError(f"{Path(run_dir) / TRAJECTORY_FILE} was planned on another model "
                             "than the run's")  # fmt: skip
        return cls(PlanConfig.from_dict(record["config"]), int(record["seed"]), trajectory)


def learn_model(config: PlanConfig, seed: int) -> dict[str, Any]:
    """Steps 1 and 2: the data and the identified model, with its realisation."""
    env = data_env(config)
    try:
        decisions, theta, rms, told = identified_model(env, config.identify_decisions, seed,
                                                       config.data_noise)  # fmt: skip
    finally:
        env.close()
    return {"data_decisions": decisions, "theta": theta.tolist(), "rms": rms,
            "params": dataclasses.asdict(realise(theta, told))}  # fmt: skip


def data_env(config: PlanConfig, **kwargs: Any) -> gym.Env:
    """The balance task's env with the config's torques (for the data)."""
    return gym.make(Balance.env_id, continuous=not config.discrete, **kwargs)


def plan_summary(trajectory: Trajectory) -> dict[str, Any]:
    """The plan in numbers: its length, torque bound and effort."""
    torques = trajectory.torques
    return {
        "steps": trajectory.steps, "seconds": trajectory.seconds, "u_max": trajectory.u_max,
        "mean_abs_torque": float(np.abs(torques).mean()),
        "full_torque_fraction": float(np.mean(np.abs(torques) >= trajectory.u_max - 1e-6)),
        "residual": trajectory.residual(),
    }  # fmt: skip


def read_plan_record(run_dir: Path) -> dict[str, Any]:
    """``run.json`` of a balance run (anything else is refused, naming what it is)."""
    path = run_dir / RUN_FILE
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a readable run record: {error}") from None
    if not isinstance(record, dict) or record.get("kind") != KIND:
        raise ValueError(f"{path} is not a balance-preset run (kind {KIND!r})")
    return record
