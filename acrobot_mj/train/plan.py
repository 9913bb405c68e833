"""The ``balance`` preset: a model-based learner that swings up AND balances with |tau| <= 1 N m.

Everything it knows about the acrobot comes from interaction with
``acrobot_mj/AcrobotBalance-v0`` in MuJoCo:

1. **data**: ``identify_decisions`` decisions of uniformly random torques, in episodes of at most
   100 decisions from random starts (rest plus ``U(-data_noise, data_noise)`` on each angle and
   velocity), drawn from the run's seed on the data branch of the seed tree
   (:func:`acrobot_mj.train.model_based.collect`);
2. **model**: the five lumped parameters of the manipulator equations identified from them
   (:mod:`acrobot_mj.control.identification`): the learner is told the equations' structure and
   the env's step (semi-implicit Euler, dt, steps per decision, velocity limits), not the masses,
   lengths, inertias or gravity; a model that misses its data is refused;
3. **plan**: the multi-start minimum-time search of :func:`acrobot_mj.control.trajopt.min_time`
   on the identified model, nominal torques ``|u| <= reserve`` (the rest kept for feedback);
4. **policy**: TVLQR along that trajectory, then the saturated LQR at upright, both designed on
   the identified model (:class:`acrobot_mj.control.tvlqr.SwingUpController`): a time-varying
   state feedback ``u = pi(k, x)``, ``k`` the physics steps since the reset, ``|u| <= 1`` N m;
   with ``discrete`` its torque is sigma-delta modulated to ``{-1, 0, +1}`` N m.

The run then tries its policy from hanging at rest in MuJoCo (``greedy_from_rest``). A run
directory holds ``run.json`` (the config, the identified model, the plan, the result) and
``trajectory.json`` (the plan, with the identified parameters; re-checked on every load).
Held-out evaluation: :mod:`acrobot_mj.train.plan_eval`.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.identification import realise
from acrobot_mj.control.trajectory import Trajectory
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.files import write_json
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.report.balance import balance_env, closed_loop
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.model_based import identified_model
from acrobot_mj.train.plan_config import KIND, TRAJECTORY_FILE, PlanConfig, read_plan_record
from acrobot_mj.train.rundir import RUN_FILE, check_fresh
from acrobot_mj.train.trainer import check_seed
from acrobot_mj.version import versions


def data_env(config: PlanConfig, **kwargs: Any) -> gym.Env:
    """The balance task's env with the config's torques (for the data)."""
    return gym.make(Balance.env_id, continuous=not config.discrete, **kwargs)


def learn_model(config: PlanConfig, seed: int) -> dict[str, Any]:
    """Steps 1 and 2: the data and the identified model, with its realisation."""
    env = data_env(config)
    try:
        decisions, theta, rms, structure = identified_model(
            env, config.identify_decisions, seed, config.data_noise
        )
    finally:
        env.close()
    params = realise(theta, structure)
    return {"data_decisions": decisions, "theta": theta.tolist(), "rms": rms,
            "params": dataclasses.asdict(params)}  # fmt: skip


def train_plan(
    config: PlanConfig,
    seed: int,
    out: str | Path | None = None,
    progress: bool = False,
    overwrite: bool = False,
) -> dict[str, Any]:
    """Train the balance learner with ``seed`` (steps 1-4 of the module docstring) and try it
    from rest; with ``out``, write ``trajectory.json`` and then ``run.json`` there (a run
    directory that holds another run is refused unless ``overwrite``). Returns the record."""
    check_seed(seed)
    if out is None:
        return _train(config, seed, progress)[0]
    out = Path(out)
    with RunLock(out, "train", create=True):
        if not overwrite:
            check_fresh(out)
        record, trajectory = _train(config, seed, progress)
        trajectory.save(out / TRAJECTORY_FILE)
        write_json(out / RUN_FILE, record)
    return record


def _train(config: PlanConfig, seed: int, progress: bool) -> tuple[dict[str, Any], Trajectory]:
    from acrobot_mj.control.trajopt import TARGETS, min_time  # CasADi: the control extra

    start = time.perf_counter()
    model = learn_model(config, seed)
    params = AcrobotParams(**model["params"])
    targets = TARGETS if config.targets is None else tuple(TARGETS[i] for i in config.targets)
    search = {"horizons": config.search_horizons(), "targets": targets}
    trajectory = min_time(config.reserve, p=params, progress=progress, **search)
    trained = time.perf_counter() - start
    env = balance_env_for(config, trajectory)
    try:
        result = closed_loop(trajectory, config.discrete, config.hold, env=env)
    finally:
        env.close()
    record = {
        "kind": KIND,
        "config": config.to_dict(),
        "seed": seed,
        "task": Balance.name,
        "model": model,
        "plan": plan_summary(trajectory),
        "greedy_from_rest": summary_of(result),
        "decisions_total": model["data_decisions"] + len(result["torques"]),
        "wall_seconds": trained,
        "versions": versions(),
    }
    return record, trajectory


def balance_env_for(config: PlanConfig, trajectory: Trajectory, **kwargs: Any) -> gym.Env:
    """The balance env of an episode: the swing-up and ``config.hold`` seconds more."""
    return balance_env(trajectory, config.discrete, config.hold, **kwargs)


def plan_summary(trajectory: Trajectory) -> dict[str, Any]:
    """The plan in numbers: its length, torque bound and effort."""
    torques = trajectory.torques
    return {
        "steps": trajectory.steps,
        "seconds": trajectory.seconds,
        "u_max": trajectory.u_max,
        "mean_abs_torque": float(np.abs(torques).mean()),
        "full_torque_fraction": float(np.mean(np.abs(torques) >= trajectory.u_max - 1e-6)),
        "residual": trajectory.residual(),
    }


def summary_of(result: dict[str, Any]) -> dict[str, Any]:
    """A closed loop's outcome without its per-step lists."""
    torques = np.asarray(result["torques"])
    summary = {k: v for k, v in result.items() if k not in ("torques", "states")}
    return summary | {"steps": len(torques), "mean_abs_torque": float(np.abs(torques).mean())}


def load_plan(run_dir: str | Path) -> tuple[PlanConfig, int, Trajectory]:
    """A balance run's config, seed and plan (checked against the identified model)."""
    run_dir = Path(run_dir)
    record = read_plan_record(run_dir)
    trajectory = Trajectory.load(run_dir / TRAJECTORY_FILE)
    if dataclasses.asdict(trajectory.params) != record["model"]["params"]:
        raise ValueError(f"{run_dir / TRAJECTORY_FILE} was planned on another model than the run's")
    return PlanConfig.from_dict(record["config"]), int(record["seed"]), trajectory
