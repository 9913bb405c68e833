"""Held-out evaluation of a balance-preset run (:mod:`acrobot_mj.train.plan`): its policy in
MuJoCo from the protocol's starts, with what it did at every physics step.

``eval.json`` holds, per episode, the exact ``start_states`` [rad, rad/s], the ``actions``
given to the env (torques [N m] as float32 for ``Box`` torques, or ``Discrete(3)`` indices),
the ``torques`` MuJoCo applied at each physics step [N m], the ``final_states`` and the outcome
(swing-up time, hold time, balanced or not, largest error while balanced): replaying the
actions with ``env.reset(options={"state": start})`` gives the same torques and states.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.control.model import HANGING
from acrobot_mj.control.trajectory import Trajectory
from acrobot_mj.control.tvlqr import SwingUpController
from acrobot_mj.envs.episode import run_episode
from acrobot_mj.files import write_json
from acrobot_mj.report.balance import BalanceActor, outcome
from acrobot_mj.train.heldout import Protocol
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.plan import balance_env_for, load_plan
from acrobot_mj.train.plan_config import BALANCE_NOISE, PlanConfig
from acrobot_mj.train.rundir import EVAL_FILE
from acrobot_mj.train.stats import spread
from acrobot_mj.version import versions

#: The held-out starts of the balance learner's results: U(-0.01, 0.01) around rest.
BALANCE_PROTOCOL = Protocol(episodes=100, start_noise=BALANCE_NOISE, seed=0)


def policy_episode(
    config: PlanConfig, trajectory: Trajectory, start: np.ndarray, env: Any
) -> dict[str, Any]:
    """The policy's episode from the exact ``start`` in ``env`` (the MuJoCo balance env of
    :func:`balance_env_for`): its actions, per-step torques, final state and outcome."""
    actor = BalanceActor(env, SwingUpController(trajectory), config.discrete, None)
    actions: list[Any] = []
    episode = run_episode(
        env,
        actor,
        options={"state": np.asarray(start, dtype=float)},
        on_step=lambda action, *_: actions.append(_plain(action)),
    )
    states = np.array(actor.states)
    result = outcome(states, trajectory.steps, env.unwrapped.task, trajectory.dt)
    return {
        "start_state": states[0].tolist(),
        "actions": actions,
        "torques": actor.torques,
        "final_state": states[-1].tolist(),
        "return": episode.episode_return,
        **result,
    }


def _plain(action: Any) -> Any:
    """An action as JSON keeps it exactly: an index, or the float32 torque as a float."""
    if isinstance(action, np.ndarray):
        return float(action[0])
    return int(action)


def evaluate_plan(run_dir: str | Path, protocol: Protocol = BALANCE_PROTOCOL) -> dict[str, Any]:
    """Evaluate a balance run from the held-out starts of ``protocol`` (the rest start apart)
    and write ``eval.json``; the run directory is locked meanwhile."""
    run_dir = Path(run_dir)
    with RunLock(run_dir, "evaluate", create=False):
        config, seed, trajectory = load_plan(run_dir)
        env = balance_env_for(config, trajectory)
        try:
            rest = policy_episode(config, trajectory, HANGING, env)
            starts = protocol.starts(HANGING)
            episodes = [policy_episode(config, trajectory, s, env) for s in starts]
        finally:
            env.close()
        record = {
            "run": str(run_dir),
            "run_seed": seed,
            "kind": "identify_and_plan",
            "config": config.to_dict(),
            "versions": versions(),
            "protocol": protocol.to_dict(),
            "summary": summarise(episodes),
            "rest": rest,
            **{name: [e[key] for e in episodes] for name, key in PER_EPISODE.items()},
        }
        write_json(run_dir / EVAL_FILE, record)
    return record


#: What eval.json lists per held-out episode: its name there, and the episode's key.
PER_EPISODE = {
    "start_states": "start_state",
    "actions": "actions",
    "torques": "torques",
    "final_states": "final_state",
    "balanced": "balanced",
    "hold_seconds": "hold_seconds",
    "swing_up_seconds": "swing_up_seconds",
    "max_errors_during_hold": "max_error_during_hold",
    "returns": "return",
}


def summarise(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """How many episodes ended balanced, and the spread of the hold times [s]."""
    return {
        "episodes": len(episodes),
        "balanced": sum(e["balanced"] for e in episodes),
        "hold_seconds": spread([e["hold_seconds"] for e in episodes]),
        "largest_error_while_balanced": max(
            (e["max_error_during_hold"] or 0.0 for e in episodes if e["balanced"]), default=None
        ),
    }


def render_plan(
    run_dir: str | Path,
    out: str | Path,
    seed: int = 0,
    width: int = 480,
    height: int = 480,
    camera: str = "side",
    max_steps: int | None = None,
    strip: str | Path | None = None,
    captions: bool = True,
    progress: bool = False,
) -> dict[str, Any]:
    """A video of a balance run's policy from hanging at rest: the swing-up and the hold
    (``progress``: a bar of the frames)."""
    from acrobot_mj.report.video import record_episode

    with RunLock(Path(run_dir), "render", create=False):
        config, run_seed, trajectory = load_plan(run_dir)
    env = balance_env_for(
        config, trajectory, render_mode="rgb_array", width=width, height=height, camera=camera
    )
    try:
        actor = BalanceActor(env, SwingUpController(trajectory), config.discrete, None)
        options = {"state": HANGING}
        record = record_episode(
            env, actor, out, seed, max_steps, options, captions, strip, progress=progress
        )
    finally:
        env.close()
    states = np.array(actor.states)
    result = outcome(states, trajectory.steps, env.unwrapped.task, trajectory.dt)
    record.update(run=str(run_dir), run_seed=run_seed, policy="identified model + TVLQR", **result)
    write_json(Path(out).with_suffix(".json"), record)
    return record
