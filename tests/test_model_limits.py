"""The envs take their torque and velocity limits, motor and integrator from the model's
parameter set; train --model stores the set in run.json and evaluate rebuilds it."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import acrobot_mj
from acrobot_mj.cli import main
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.envs.wrappers import CosSinObservation, EnergyShaping
from acrobot_mj.physics.models import MODELS
from acrobot_mj.physics.params import REPORT
from acrobot_mj.settings import SettingError
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.trainer import load_learner

OLYMPICS = MODELS["ai_olympics"].params


def test_the_ai_olympics_env_has_its_spaces_step_and_integrator() -> None:
    env = gym.make("acrobot_mj/Acrobot-v0", model="ai_olympics", continuous=True)
    acrobot = env.unwrapped
    assert env.action_space == gym.spaces.Box(-6.0, 6.0, (1,), np.float32)
    assert np.all(np.isinf(env.observation_space.high[2:]))
    assert np.all(np.isinf(env.observation_space.low[2:]))
    assert env.observation_space.high[:2].tolist() == [math.pi, math.pi]
    assert acrobot.dt == 0.002 and acrobot.integrator == "rk4"
    assert acrobot.model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert acrobot.params == OLYMPICS
    assert acrobot.task.goal_height == pytest.approx(0.2)  # l1, the report's rule
    env.reset(seed=0)
    env.step(np.array([6.0], dtype=np.float32))
    assert acrobot.data.ctrl[0] == 6.0
    env.step(np.array([-6.0]))
    with pytest.raises(ValueError, match=r"6.01 N m is outside the torque range \[-6, 6\] N m"):
        env.step(np.array([6.01]))
    assert gym.make("acrobot_mj/Acrobot-v0", model="ai_olympics").action_space == (
        gym.spaces.Discrete(3)
    )


def test_discrete_actions_are_the_models_torques() -> None:
    env = acrobot_mj.AcrobotEnv(model="ai_olympics")
    env.reset(seed=0)
    for action, torque in enumerate((-6.0, 0.0, 6.0)):
        env.step(action)
        assert env.data.ctrl[0] == torque
    with pytest.raises(ValueError, match=r"use 0 \(-6 N m\), 1 \(0 N m\) or 2 \(\+6 N m\)"):
        env.step(3)


def test_no_velocity_clipping_without_limits() -> None:
    fast = [10 * math.pi, -12 * math.pi]  # beyond 4 pi and 9 pi rad/s
    env = acrobot_mj.AcrobotEnv(model="ai_olympics")
    env.reset(seed=0)
    env.set_state([0.0, 0.0], fast)  # the report's limits would refuse it
    obs = env.step(1)[0]
    assert abs(obs[2]) > 9 * math.pi and abs(obs[3]) > 9 * math.pi
    assert obs[2:].tolist() == env.data.qvel.tolist()
    vec = AcrobotVectorEnv(2, model="ai_olympics")
    vec.reset(seed=0)
    vec.call("set_state", [0.0, 0.0], fast)
    obs = vec.step(np.array([1, 1]))[0]
    assert np.all(np.abs(obs[:, 2:]) > 9 * math.pi)
    assert np.all(np.isinf(vec.single_observation_space.high[2:]))


def test_the_vector_env_takes_the_models_torques() -> None:
    vec = AcrobotVectorEnv(2, model="ai_olympics", continuous=True)
    vec.reset(seed=0)
    vec.step(np.array([[6.0], [-6.0]]))
    assert vec.physics.ctrl[:, 0].tolist() == [6.0, -6.0]
    with pytest.raises(ValueError, match=r"outside \[-6, 6\] N m at sub-envs \[1\]"):
        vec.step(np.array([[6.0], [6.01]]))
    discrete = AcrobotVectorEnv(3, model="ai_olympics")
    discrete.reset(seed=0)
    discrete.step(np.array([0, 1, 2]))
    assert discrete.physics.ctrl[:, 0].tolist() == [-6.0, 0.0, 6.0]


def test_the_pendubots_motor_drives_the_shoulder() -> None:
    env = acrobot_mj.AcrobotEnv(model="ai_olympics_pendubot")
    env.reset(seed=0)
    env.step(2)
    assert env.data.qfrc_actuator.tolist() == [6.0, 0.0]
    with pytest.raises(ValueError, match="drives the elbow"):
        AcrobotVectorEnv(2, model="ai_olympics_pendubot", integrator="euler", backend="analytic")


def test_the_reports_env_keeps_its_limits() -> None:
    env = acrobot_mj.AcrobotEnv(continuous=True)
    assert env.params is REPORT and env.integrator == "euler"
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    assert env.observation_space.high.tolist() == [math.pi, math.pi, 4 * math.pi, 9 * math.pi]
    assert env.task.goal_height == 1.0
    with pytest.raises(ValueError, match="exceeds the velocity limits"):
        env.set_state([0.0, 0.0], [10 * math.pi, 0.0])


def test_the_wrappers_take_the_envs_limits_and_parameters() -> None:
    env = acrobot_mj.AcrobotEnv(model="ai_olympics")
    assert np.all(np.isinf(CosSinObservation(env).observation_space.high[4:]))
    assert EnergyShaping(env, 1.0).params == OLYMPICS
    assert EnergyShaping(acrobot_mj.AcrobotEnv(), 1.0).params is REPORT


def test_the_config_holds_the_model() -> None:
    assert TrainConfig().model is None and TrainConfig().integrator == "euler"
    assert TrainConfig(model="report") == TrainConfig()
    assert TrainConfig.from_dict({"task": "height_goal"}).model is None  # an old run's
    config = TrainConfig(model="ai_olympics")
    assert config.integrator == "rk4" and config.env_kwargs()["model"] == "ai_olympics"
    assert TrainConfig.from_dict(config.to_dict()) == config
    assert config.replace(model="dm_control").integrator == "rk4"
    assert config.replace(model=None).integrator == "euler"
    assert TrainConfig(model="ai_olympics", integrator="euler").integrator == "euler"
    assert "model" not in TrainConfig().env_kwargs()


@pytest.mark.parametrize(
    ("settings", "match"),
    [
        ({"model": "nope"}, "config model: model must be one of"),
        (
            {"model": "ai_olympics", "algorithm": "sarsa_lambda", "features": "tiles"},
            "tiles spans the velocity limits",
        ),
        ({"model": "dm_control", "identify_decisions": 10}, "identifies the report's acrobot"),
    ],
)
def test_what_a_learner_cannot_do_on_a_model_is_refused(settings, match) -> None:
    with pytest.raises(SettingError, match=match):
        TrainConfig(**settings)


def test_train_with_a_model_and_evaluate_rebuilds_it(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    argv = ["train", "--model", "ai_olympics", "--episodes", "3", "--max-episode-steps", "20"]
    assert main([*argv, "--out", str(out)]) == 0
    config = json.loads((out / "run.json").read_text())["config"]
    assert config["model"] == "ai_olympics" and config["integrator"] == "rk4"
    env = load_learner(out).env()
    assert env.unwrapped.params == OLYMPICS and env.unwrapped.dt == 0.002
    env.close()
    capsys.readouterr()
    assert main(["evaluate", str(out), "--episodes", "2"]) == 0
    assert "per-start minima exist for the report's acrobot only" in capsys.readouterr().out
    record = json.loads((out / "eval.json").read_text())
    assert record["config"]["model"] == "ai_olympics" and "minima" not in record
    assert record["physics"] == {"frame_skip": 1, "integrator": "rk4"}
    with pytest.raises(SystemExit) as exit_info:
        main(["evaluate", str(out), "--episodes", "2", "--minima"])
    assert exit_info.value.code == 2
    assert "report's acrobot only" in capsys.readouterr().err


def test_an_unknown_model_is_a_one_line_error(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["train", "--model", "nope", "--episodes", "1", "--out", str(tmp_path / "run")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "model must be one of" in err and "'nope'" in err
    assert not (tmp_path / "run").exists()
