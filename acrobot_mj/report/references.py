"""The references the learners are measured against, in the MuJoCo env: energy pumping, the
saturated and the constrained LQR and their basins, the bound for any controller, and the
minimum-time swing-up."""

from __future__ import annotations

import functools
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.lqr import (
    LQR,
    MPC,
    NullRegion,
    balances,
    discrete_model,
    q1_basin,
    unstable_mode_bound,
)
from acrobot_mj.control.policies import energy_pumping_torque, pumping_energies
from acrobot_mj.control.search import Beam, min_time_search
from acrobot_mj.control.trajopt import shortest_to_height
from acrobot_mj.envs.rollout import Hooks, PolicyActor, SequenceActor, acrobot_of, run_episode
from acrobot_mj.envs.tasks import HeightGoal
from acrobot_mj.physics import dynamics
from acrobot_mj.physics.params import REPORT as P
from acrobot_mj.report.crosscheck import COMPARED


def controllers(quick: bool = False) -> dict[str, Any]:
    """Energy pumping from rest, the saturated and the constrained LQR and their basins, and the
    bound for ``|tau| <= 1``."""
    pumping = energy_pumping()
    lqr = LQR()
    low, high = q1_basin(lqr, upper=0.2, resolution=1e-3 if quick else 1e-4)
    mpc = MPC(lqr)
    mpc_basin = q1_basin(mpc, upper=0.05, resolution=1e-3 if quick else 1e-4)
    region = NullRegion(*discrete_model(), P.max_torque)
    joint = float(1.0 / region.depth(np.array([1.0, 0.0, 0.0, 0.0])))  # the region is linear
    n, scale = 200 if quick else 2000, np.array([0.02, 0.02, 0.05, 0.05])
    starts = dynamics.UPRIGHT + np.random.default_rng(0).uniform(-1, 1, (n, 4)) * scale
    bound = unstable_mode_bound()
    return {
        "energy_pumping": pumping,
        "lqr": {
            "gain": lqr.gain[0].tolist(),
            "q": list(lqr.q),
            "r": lqr.r,
            "q1_basin_rad": [low, high],
            "sampled_box": scale.tolist(),
            "sampled": n,
            "sampled_fraction_balanced": float(np.mean(balances(lqr, starts))),
        },
        "constrained_lqr": {"horizon": mpc.horizon, "q1_basin_rad": list(mpc_basin)},
        "bound_any_controller_q1_rad": joint,
        "bound_one_mode_q1_rad": min(bound.values()),
        "bound_per_unstable_mode": bound,
    }


def energy_pumping() -> dict[str, Any]:
    """Energy pumping from rest in the env (continuous torques): steps to the goal, the energy
    [J] it starts and ends with, and how monotonically it rises."""
    env = gym.make(HeightGoal.env_id, continuous=True)
    energies: list[float] = []

    def record_energy(*_: Any) -> None:
        state = acrobot_of(env).state
        energies.append(float(dynamics.total_energy(state[:2], state[2:])))

    def pump(obs: np.ndarray) -> np.ndarray:  # the law needs the state, not the observation
        return np.array([float(energy_pumping_torque(acrobot_of(env).state))], dtype=np.float32)

    hooks = Hooks(record_energy, record_energy)
    episode = run_episode(env, PolicyActor(pump), 0, None, max_steps=1000, hooks=hooks)
    fine = {dt: np.diff(pumping_energies(dt)).min() for dt in (1e-2, 1e-3)}
    return {
        "law": "tau = clip(50 (E* - E) dq2, -1, 1) N m, E* = 19.6 J (upright)",
        "reference": "the energy approach of Spong, 'The swing up control problem for the "
        "acrobot', IEEE Control Systems 1995; the same law shape as Fantoni, Lozano and "
        "Spong's for the Pendubot (IEEE TAC 2000)",
        "reached_goal": episode.success,
        "steps_to_goal": episode.length,
        "seconds": episode.length * P.dt,
        "energy_start_J": energies[0],
        "energy_end_J": energies[-1],
        "env_steps_losing_energy": int(np.sum(np.diff(energies) < 0)),
        "monotone_check": "RK4 with the torque held over dt: the largest energy drop of a "
        "step in the pumping phase shrinks as dt^2 (dq2 changing sign within a step), so "
        "the energy rises monotonically in continuous time",
        "largest_drop_J_rk4_dt_0.01": float(-min(fine[1e-2], 0.0)),
        "largest_drop_J_rk4_dt_0.001": float(-min(fine[1e-3], 0.0)),
    }


def minimum_time(quick: bool = False) -> dict[str, Any]:
    """Beam searches for the fewest decisions to the goal from rest, replayed in the env."""
    width = 3000 if quick else 20_000
    search4 = functools.partial(min_time_search, frame_skip=4, beam=Beam(width))
    best4 = search4()
    # At frame_skip 1 a sequence may hold a torque for k steps: search with holds of 1, 3, 4.
    holds = {1: min_time_search(frame_skip=1, beam=Beam(2000 if quick else 5000)), 4: best4}
    if not quick:
        holds[3] = min_time_search(frame_skip=3, beam=Beam(width))
    per_hold = {k: r.decisions * k for k, r in holds.items() if r.decisions is not None}
    k_best = min(per_hold, key=per_hold.__getitem__)
    fs1_actions = [a for a in holds[k_best].actions for _ in range(k_best)]
    replay = {"frame_skip_1": _replay(fs1_actions, 1), "frame_skip_4": _replay(best4.actions, 4)}
    by_integrator = {
        m: (best4 if m == "semi_implicit_euler" else search4(method=m)).decisions for m in COMPARED
    }
    return {
        "continuous_torque": None if quick else continuous_torque_height(fs1_actions),
        "min_time_decisions_frame_skip_4": best4.decisions,
        "min_time_steps_frame_skip_1": len(fs1_actions),
        "actions_frame_skip_4": best4.actions,
        "actions_frame_skip_1": fs1_actions,
        "frame_skip_1_steps_by_hold": per_hold,
        "beam_width": width,
        "replayed_in_env": replay,
        "decisions_frame_skip_4_by_integrator": by_integrator,
    }


def continuous_torque_height(actions: list[int]) -> dict[str, Any] | None:
    """Steps to the height goal with continuous torques from ``actions`` (None without CasADi)."""
    try:
        trajectory = shortest_to_height(np.array([-1.0, 0.0, 1.0])[actions])
    except ImportError:
        return None
    env = gym.make(HeightGoal.env_id, continuous=True)
    torques = [np.array([u], dtype=np.float32) for u in trajectory.torques]
    episode = run_episode(env, SequenceActor(torques), seed=0, max_steps=len(torques))
    return {
        "steps": trajectory.steps,
        "residual": trajectory.residual(),
        "replayed_steps": episode.length,
        "reached_goal": episode.success,
    }


def _replay(actions: list[int], frame_skip: int) -> dict[str, Any]:
    """Play ``actions`` in the MuJoCo env from rest: when does it terminate?"""
    env = gym.make(HeightGoal.env_id, frame_skip=frame_skip)
    episode = run_episode(env, SequenceActor(actions), seed=0, max_steps=len(actions))
    if not (episode.success or episode.truncated):  # it ran out of actions
        return {"steps": len(actions), "reached_goal": False, "at_last_action": True}
    return {
        "steps": episode.length,
        "reached_goal": episode.success,
        "at_last_action": episode.length == len(actions),
        "tip_height": episode.info["tip_height"],
    }
