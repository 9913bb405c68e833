"""Swing up AND balance at upright with |tau| <= 1 N m: the trajectories, the feedback, the
balance task and the closed loop in MuJoCo."""

from __future__ import annotations

import json
import math
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import acrobot_mj  # noqa: F401  registers the tasks
from acrobot_mj.cli import main
from acrobot_mj.control.lqr import step_jacobians
from acrobot_mj.control.trajopt import Trajectory, shipped
from acrobot_mj.envs.control_loop import closed_loop
from acrobot_mj.envs.disturbances import Perturbation
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.physics import integrators
from acrobot_mj.report.balance_run import load_trajectory

MIN_TIME, RESERVE = shipped("min_time"), shipped("reserve")


# -- trajectories --------------------------------------------------------------------------


@pytest.mark.parametrize(("trajectory", "u_max"), [(MIN_TIME, 1.0), (RESERVE, 0.8)])
def test_shipped_trajectories_follow_the_env_dynamics(trajectory, u_max) -> None:
    # The env's own step (semi-implicit Euler, clipping) maps each state to the next to 1e-9:
    # IPOPT met the constraints to 1e-12; the numpy and CasADi models differ only in rounding.
    assert trajectory.residual() < 1e-9 and trajectory.u_max == u_max
    assert np.abs(trajectory.torques).max() <= u_max + 1e-12
    # 86 % of the minimum-time steps are at full torque: it is nearly bang-bang.
    if u_max == 1.0:
        assert np.mean(np.abs(trajectory.torques) > 0.999) > 0.8


def test_a_trajectory_that_misses_the_dynamics_is_refused(tmp_path) -> None:
    states = RESERVE.states.copy()
    states[100, 0] += 1e-6  # one state off by a micro-radian
    with pytest.raises(ValueError, match="misses the model's step by 1e-06"):
        Trajectory(states, RESERVE.torques, 0.05, RESERVE.method, 0.8).check()
    data = RESERVE.to_dict() | {"states": states.tolist()}
    (tmp_path / "t.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"t\.json is not a usable trajectory"):
        Trajectory.load(tmp_path / "t.json")
    with pytest.raises(ValueError, match="exceeds u_max"):
        Trajectory(RESERVE.states, RESERVE.torques, 0.05, RESERVE.method, 0.5).check()


@pytest.mark.parametrize("method", ["semi_implicit_euler", "rk4"])
def test_step_jacobians_match_finite_differences(method) -> None:
    # Central differences at eps 1e-6 on entries O(1..10): truncation ~1e-11, rounding ~1e-10.
    x, u = np.array([0.3, -0.7, 1.2, -2.0]), 0.4
    a, b = step_jacobians(x, u, method)
    eps = 1e-6

    def step(x, u):
        return integrators.step_states(x, u, method=method, limits=False)

    columns = [(step(x + eps * e, u) - step(x - eps * e, u)) / (2 * eps) for e in np.eye(4)]
    np.testing.assert_allclose(a, np.stack(columns, 1), atol=1e-8)
    np.testing.assert_allclose(
        b[:, 0], (step(x, u + eps) - step(x, u - eps)) / (2 * eps), atol=1e-8
    )


@pytest.mark.parametrize("reserve", [0.0, 1.5, -0.2])
def test_a_reserve_outside_its_range_is_refused(reserve) -> None:
    # The balance preset's declared range: one check for the preset, the command and this.
    with pytest.raises(ValueError, match=r"config reserve must be (in \(0, 1\]|> 0)"):
        load_trajectory(reserve)


# -- the closed loop in MuJoCo --------------------------------------------------------------


@pytest.mark.parametrize(
    ("trajectory", "discrete"), [(RESERVE, False), (RESERVE, True), (MIN_TIME, False)]
)
def test_the_closed_loop_swings_up_and_balances_for_60_s(trajectory, discrete) -> None:
    result = closed_loop(trajectory, discrete=discrete, hold=60.0)
    assert result["balanced"] and result["hold_seconds"] == pytest.approx(60.0)
    # Continuous torques hold to rounding-level errors (1e-5 rad at most measured); the
    # {-1, 0, +1} torques of sigma-delta keep a limit cycle of about 0.01 rad.
    assert result["max_error_during_hold"] < (0.02 if discrete else 1e-4)
    assert len(result["torques"]) == trajectory.steps + 1200
    assert len(result["states"]) == len(result["torques"]) + 1
    if discrete:
        assert set(result["torques"]) <= {-1.0, 0.0, 1.0}


#: The robustness rows that hold (README, ``acrobot-mj validate``): the reserve trajectory keeps
#: balance through all of these with continuous torques, and through these with {-1, 0, +1}.
HOLDS = [
    ("q1 + 1e-3 rad", Perturbation(start_offset=(1e-3, 0, 0, 0)), (False, True)),
    ("q1 + 1e-2 rad", Perturbation(start_offset=(1e-2, 0, 0, 0)), (False, True)),
    ("masses + 1 %", Perturbation(mass_scale=1.01), (False,)),
    ("masses - 1 %", Perturbation(mass_scale=0.99), (False,)),
    ("inertias + 1 %", Perturbation(inertia_scale=1.01), (False,)),
    ("inertias - 1 %", Perturbation(inertia_scale=0.99), (False, True)),
    ("noise 0.05 N m", Perturbation(torque_noise=0.05), (False, True)),
]


@pytest.mark.parametrize(("label", "perturbation", "kinds"), HOLDS, ids=[h[0] for h in HOLDS])
def test_the_reserve_trajectory_tolerates_what_it_was_not_designed_for(label, perturbation, kinds):
    for discrete in kinds:
        assert closed_loop(RESERVE, discrete, 60.0, perturbation)["balanced"], (label, discrete)


@pytest.mark.slow
def test_without_reserve_the_minimum_time_swing_up_is_fragile() -> None:
    # The README's claim: at full torque there is none left for the feedback, and a start
    # 1e-4 rad off (or {-1, 0, +1} torques) is enough to fall.
    assert not closed_loop(MIN_TIME, False, 60.0, Perturbation(start_offset=(1e-4, 0, 0, 0)))[
        "balanced"
    ]
    assert not closed_loop(MIN_TIME, True, 60.0)["balanced"]


# -- the balance task ------------------------------------------------------------------------


@pytest.mark.parametrize("kwargs", [{}, {"continuous": True}])
def test_the_balance_env_passes_gymnasiums_checks(kwargs) -> None:
    env = gym.make(Balance.env_id, **kwargs)
    check_env(env.unwrapped, skip_render_check=True)
    assert env.spec.max_episode_steps == 2000


def test_the_balance_env_is_deterministic_and_pickles() -> None:
    def rollout(env, seed):
        obs, _ = env.reset(seed=seed)
        rows = [obs]
        for k in range(200):
            obs, reward, _, _, info = env.step(k % 3)
            rows.append(np.append(obs, [reward, info["upright_error"]]))
        return rows

    a = rollout(gym.make(Balance.env_id, start_noise=0.1), 3)
    b = rollout(gym.make(Balance.env_id, start_noise=0.1), 3)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    env = gym.make(Balance.env_id)
    env.reset(seed=0)
    for _ in range(30):
        env.step(2)
    twin = pickle.loads(pickle.dumps(env.unwrapped))
    assert np.array_equal(twin.state, env.unwrapped.state) and twin.task.tolerance == 0.05


def test_balanced_is_within_the_tolerance_of_upright() -> None:
    env = gym.make(Balance.env_id, tolerance=0.1)
    env.reset(seed=0)
    env.unwrapped.set_state([math.pi / 2 + 0.05, -0.02])  # both errors inside 0.1 rad
    _, reward, terminated, _, info = env.step(1)
    assert info["is_balanced"] and info["is_success"] and not terminated
    # Both errors under 0.1 rad: reward = (1 + cos e1)(1 + cos e2) / 4 >= ((1 + cos 0.1) / 2)^2.
    assert info["upright_error"] < 0.1 and 0.99501 < reward <= 1.0
    with pytest.raises(TypeError, match=r"unknown arguments \['goal_height'\] for task 'balance'"):
        gym.make(Balance.env_id, goal_height=1.0)
    with pytest.raises(ValueError, match=r"tolerance must be inside \(0, pi\)"):
        gym.make(Balance.env_id, tolerance=0.0)


def test_the_vector_env_runs_the_balance_task_as_the_single_env_does() -> None:
    vec = gym.make_vec(Balance.env_id, num_envs=2, max_episode_steps=50)
    singles = [gym.make(Balance.env_id, max_episode_steps=50) for _ in range(2)]
    vec.reset(seed=1)
    for k, env in enumerate(singles):
        env.reset(seed=1 + k)
    for t in range(40):
        actions = np.array([t % 3, (t + 1) % 3])
        obs, reward, terminated, _, info = vec.step(actions)
        for k, env in enumerate(singles):
            o, r, te, _, i = env.step(int(actions[k]))
            np.testing.assert_array_equal(obs[k], o)
            # np.sin and math.sin may differ in the last bit (rewards are O(1)).
            assert reward[k] == pytest.approx(r, abs=1e-15) and terminated[k] == te
            assert info["is_balanced"][k] == i["is_balanced"]


# -- acrobot-mj balance ------------------------------------------------------------------------


def test_the_balance_command_records_what_replays_in_the_env(tmp_path, capsys) -> None:
    out = tmp_path / "b"
    assert main(["balance", "--hold", "5", "--no-video", "--out", str(out)]) == 0
    assert "balanced for 5.0 s" in capsys.readouterr().out
    record = json.loads((out / "balance.json").read_text())
    assert record["trajectory"]["source"] == "shipped (reserve)" and record["balanced"]
    # Replaying the recorded torques from the recorded start gives the recorded states.
    env = gym.make(Balance.env_id, continuous=True, max_episode_steps=len(record["torques"]))
    env.reset(seed=0)
    states = [env.unwrapped.state.tolist()]
    for torque in record["torques"]:
        env.step(np.array([torque], dtype=np.float32))
        states.append(env.unwrapped.state.tolist())
    assert states == record["states"]


def test_the_balance_command_refuses_bad_options(tmp_path, capsys) -> None:
    # A hold shorter than one physics step would run one step and record less (1e-300 s).
    for argv in (["--reserve", "1.5"], ["--hold", "-1"], ["--hold", "1e-300"]):
        with pytest.raises(SystemExit) as stop:
            main(["balance", "--no-video", "--out", str(tmp_path), *argv])
        assert stop.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert "reserve must be in (0, 1]" in err[0] and "hold must be in [0.05, 3600]" in err[1]
    assert "hold must be in [0.05, 3600]" in err[2] and len(err) == 3


def test_other_reserves_reuse_a_cached_trajectory_after_checking_it(tmp_path) -> None:
    # The reserve trajectory keeps |u| <= 0.8, so it is also one for a 0.9 N m reserve: cached,
    # it is reused (no optimisation), and a damaged cache is refused, naming the file.
    cache = tmp_path / "trajectory.json"
    Trajectory(RESERVE.states, RESERVE.torques, 0.05, RESERVE.method, 0.9).save(cache)
    trajectory, source = load_trajectory(0.9, cache)
    assert source == f"cached ({cache})" and trajectory.u_max == 0.9
    data = json.loads(cache.read_text())
    data["torques"][10] += 1e-3
    cache.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"trajectory\.json is not a usable trajectory"):
        load_trajectory(0.9, cache)
