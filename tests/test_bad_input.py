"""Bad input gets a clear error that names the problem; nothing is silently clipped."""

from __future__ import annotations

import enum
import math
import shutil

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import acrobot_mj
from acrobot_mj.envs.acrobot import AcrobotEnv
from acrobot_mj.envs.assets import load_model, models_dir


@pytest.fixture
def env() -> AcrobotEnv:
    env = AcrobotEnv()
    env.reset(seed=0)
    return env


@pytest.mark.parametrize(
    ("action", "error", "match"),
    [
        (3, ValueError, "outside Discrete"),
        (-1, ValueError, "outside Discrete"),
        (np.int64(7), ValueError, "outside Discrete"),
        (1.5, TypeError, "must be an integer"),
        (1.0, TypeError, "must be an integer"),
        (math.nan, TypeError, "must be an integer"),
        (True, TypeError, "must be an integer"),
        ("1", TypeError, "must be an integer"),
        (None, TypeError, "must be an integer"),
        (np.array([1]), TypeError, "must be an integer"),
        (np.array(1.0), TypeError, "must be an integer"),
    ],
)
def test_discrete_actions_outside_the_space(env, action, error, match) -> None:
    before = env.state
    with pytest.raises(error, match=match):
        env.step(action)
    np.testing.assert_array_equal(env.state, before)  # nothing was stepped


class Torque(enum.IntEnum):
    NEGATIVE = 0
    POSITIVE = 2


@pytest.mark.parametrize(
    "action",
    [0, 1, 2, np.int64(2), np.int32(0), np.longlong(1), np.uint8(2), np.array(1), Torque.POSITIVE],
)
def test_discrete_actions_inside_the_space(env, action) -> None:
    # Everything Gymnasium's Discrete(3).contains accepts is stepped with its torque.
    assert env.action_space.contains(action)
    env.step(action)
    assert env.data.ctrl[0] == [-1.0, 0.0, 1.0][int(action)]


@pytest.mark.parametrize(
    ("action", "error", "match"),
    [
        (np.array([1.5]), ValueError, "outside the torque range"),
        (np.array([-1.0001]), ValueError, "outside the torque range"),
        (np.array([np.nan]), ValueError, "outside the torque range"),
        (np.array([np.inf]), ValueError, "outside the torque range"),
        (np.array([0.1, 0.2]), ValueError, "shape"),
        (np.array(0.5), ValueError, "shape"),
        (0.5, ValueError, "shape"),
        (1, ValueError, "shape"),  # a Discrete action given to the continuous env
        (np.int64(2), ValueError, "shape"),
        ("a", TypeError, "float array"),
        (None, TypeError, "float array"),
    ],
)
def test_continuous_actions_outside_the_space(action, error, match) -> None:
    env = AcrobotEnv(continuous=True)
    env.reset()
    with pytest.raises(error, match=match):
        env.step(action)
    assert env.data.ctrl[0] == 0.0


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"frame_skip": 0}, ValueError, "frame_skip"),
        ({"frame_skip": -2}, ValueError, "frame_skip"),
        ({"frame_skip": 1.5}, TypeError, "frame_skip"),
        ({"integrator": "implicit"}, ValueError, "integrator"),
        ({"integrator": ["euler"]}, ValueError, "integrator"),
        ({"model_path": 123}, TypeError, "model_path"),
        ({"goal_height": 2.0}, ValueError, "goal_height"),
        ({"goal_height": -2.0}, ValueError, "goal_height"),
        ({"step_reward": math.nan}, ValueError, "step_reward"),
        ({"goal_reward": "big"}, TypeError, "goal_reward"),
        ({"goal_height": 2.5}, ValueError, "goal_height"),
        ({"goal_height": math.inf}, ValueError, "goal_height"),
        ({"start_noise": -0.1}, ValueError, "start_noise"),
        ({"start_noise": 2.0}, ValueError, "start_noise"),
        ({"continuous": 1}, TypeError, "continuous"),
        ({"render_mode": "ansi"}, ValueError, "render_mode"),
        ({"width": 0}, ValueError, "width"),
        ({"height": 10_000}, ValueError, "height"),
        ({"camera": "top"}, ValueError, "camera"),
        ({"frameskip": 4}, TypeError, "frameskip"),
    ],
)
def test_invalid_options(kwargs, error, match) -> None:
    with pytest.raises(error, match=match):
        AcrobotEnv(**kwargs)


def test_unknown_keyword_through_make() -> None:
    with pytest.raises(TypeError, match="colour"):
        gym.make(acrobot_mj.ENV_ID, colour="red")


@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"noise": 0.1}, ValueError, "unknown reset options"),
        (["start_noise"], TypeError, "must be a dict"),
        ("start_noise", TypeError, "must be a dict"),
        ({"start_noise": -1.0}, ValueError, "start_noise"),
        ({"start_noise": math.nan}, ValueError, "start_noise"),
    ],
)
def test_invalid_reset_options(env, options, error, match) -> None:
    with pytest.raises(error, match=match):
        env.reset(options=options)


def test_missing_model_file(tmp_path) -> None:
    missing = tmp_path / "nowhere.xml"
    with pytest.raises(FileNotFoundError, match=r"nowhere\.xml"):
        AcrobotEnv(model_path=missing)


def test_malformed_model_file(tmp_path) -> None:
    bad = tmp_path / "broken.xml"
    bad.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(ValueError, match=r"broken\.xml"):
        load_model(bad)


def test_model_that_is_not_an_acrobot(tmp_path) -> None:
    other = tmp_path / "pendulum.xml"
    other.write_text(
        "<mujoco><worldbody><body><joint name='hinge'/><geom size='0.1'/></body></worldbody>"
        "</mujoco>"
    )
    with pytest.raises(ValueError, match=r"lacks body 'link1'.*joint 'shoulder'"):
        AcrobotEnv(model_path=other)


@pytest.mark.parametrize(
    ("q", "dq", "match"),
    [
        ([math.nan, 0.0], [0.0, 0.0], "finite"),
        ([0.0, 0.0], [0.0, math.inf], "finite"),
        ([0.0], [0.0, 0.0], "shape"),
        ([0.0, 0.0], [100.0, 0.0], "velocity limits"),
        ([1e300, 0.0], [0.0, 0.0], "lose precision"),
    ],
)
def test_set_state_refuses_bad_states(env, q, dq, match) -> None:
    with pytest.raises(ValueError, match=match):
        env.set_state(q, dq)


@pytest.mark.parametrize("autoreset_in_file", [False, True])
def test_nan_state_in_data_is_reported_not_hidden(tmp_path, monkeypatch, autoreset_in_file):
    # Writing NaN into MjData directly bypasses set_state. MuJoCo would reset its data with a
    # warning and carry on from qpos0; the env turns autoreset off (also for a model file that
    # leaves it on) and raises instead. Straight after reset is the hardest case to notice.
    path = None
    if autoreset_in_file:
        shutil.copytree(models_dir(), tmp_path / "models")
        robot = tmp_path / "models" / "acrobot.xml"
        robot.write_text(robot.read_text().replace('autoreset="disable"', ""))
        path = tmp_path / "models" / "scene.xml"
        assert not load_model(path).opt.disableflags & mujoco.mjtDisableBit.mjDSBL_AUTORESET
    env = AcrobotEnv(model_path=path)
    env.reset(seed=0)
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warnings to MUJOCO_LOG.TXT in the cwd
    env.data.qvel[0] = math.nan
    with pytest.raises(RuntimeError, match=r"non-finite.*BADQVEL"):
        env.step(1)


@pytest.mark.parametrize("angle", [1e300, 1e9, -2e6])
def test_huge_state_in_data_is_reported(env, tmp_path, monkeypatch, angle) -> None:
    # Finite but beyond MuJoCo's mjMAXVAL (1e10, where MuJoCo warns BADQPOS), or beyond the
    # 1e6 rad where angles lose precision (1e9 rad used to pass, reported as the goal): the
    # numbers are meaningless, so the env raises as for NaN.
    monkeypatch.chdir(tmp_path)
    env.data.qpos[0] = angle
    with pytest.raises(RuntimeError, match=r"non-finite state or angles beyond \+-1e\+06 rad"):
        env.step(1)


@pytest.mark.parametrize(
    ("tiles", "match"),
    [
        ({"angle_tiles": 100_000}, r"tile coding of 48 tilings and 8,180,045,400,176 features"),
        ({"velocity_tiles": 1_000_000}, r"and 470,001,210,000,848 features"),
        ({"tilings": 100_000_000}, r"tile coding of 100,000,036 tilings"),  # grew to 24 GB
    ],
)
def test_sizes_beyond_memory_are_refused_before_allocation(tiles, match) -> None:
    from acrobot_mj.agents.features import TilesConfig

    space = gym.make(acrobot_mj.ENV_ID).observation_space
    with pytest.raises(ValueError, match=match + r".* needs [0-9,.]+ GiB of memory; this"):
        TilesConfig(**tiles).build(space)


def test_learners_check_their_tables_against_free_memory(monkeypatch) -> None:
    # The learners' own arrays, with the machine's free memory set small: refused before
    # np.zeros, naming what and how much (225 cells x 3 actions, 16 bytes each, is 10,800 B).
    from acrobot_mj import checks
    from acrobot_mj.agents.features import StateGrid, book_tile_coder
    from acrobot_mj.agents.sarsa import Sarsa, SarsaConfig, SarsaGroup
    from acrobot_mj.agents.sarsa_lambda import SarsaLambda

    space = gym.make(acrobot_mj.ENV_ID).observation_space
    coder = book_tile_coder(space)
    monkeypatch.setattr(checks, "memory_available", lambda: 10_799)
    with pytest.raises(
        ValueError,
        match=r"a Q table of 675 values needs 10.5 KiB of memory; this machine has 10.5 KiB",
    ):
        Sarsa(StateGrid())
    with pytest.raises(ValueError, match=r"2 Q tables of 675 values"):
        SarsaGroup(StateGrid(), SarsaConfig(), [0, 1])
    with pytest.raises(ValueError, match=r"Sarsa\(lambda\) with 97,044 weights needs 2.2 MiB"):
        SarsaLambda(coder)
    monkeypatch.setattr(checks, "memory_available", lambda: 10_800)
    Sarsa(StateGrid())  # exactly enough
