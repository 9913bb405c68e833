"""The batched vector env against N single envs: identical numbers, through autoresets."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import acrobot_mj
from acrobot_mj.envs.vector import AcrobotVectorEnv


def test_make_vec_returns_the_batched_env() -> None:
    env = gym.make_vec(acrobot_mj.ENV_ID, num_envs=8, frame_skip=4)
    assert isinstance(env.unwrapped, AcrobotVectorEnv)
    assert isinstance(env.unwrapped.model, mujoco.MjModel)
    assert env.unwrapped.max_episode_steps == 1000  # from the registration
    assert env.action_space == gym.spaces.MultiDiscrete([3] * 8)
    assert env.observation_space.shape == (8, 4)
    assert env.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert env.metadata["render_fps"] == pytest.approx(5.0)


def _policy(k: int, obs: np.ndarray, rng: np.random.Generator) -> int:
    # Even sub-envs pump energy (they reach the goal and terminate), odd ones act at random
    # (they run into the time limit): both kinds of episode end are exercised.
    return (0 if obs[2] > 0 else 2) if k % 2 == 0 else int(rng.integers(3))


@pytest.mark.parametrize(
    "kwargs", [{}, {"frame_skip": 4, "start_noise": 0.1}, {"integrator": "rk4", "goal_reward": 5.0}]
)
def test_identical_to_single_envs_through_autoresets(kwargs) -> None:
    n, steps = 4, 1500
    vec = gym.make_vec(acrobot_mj.ENV_ID, num_envs=n, max_episode_steps=400, **kwargs)
    singles = [gym.make(acrobot_mj.ENV_ID, max_episode_steps=400, **kwargs) for _ in range(n)]
    obs, _ = vec.reset(seed=11)
    single_obs = [env.reset(seed=11 + k)[0] for k, env in enumerate(singles)]
    np.testing.assert_array_equal(obs, single_obs)
    rng, pending, ends = np.random.default_rng(0), [False] * n, {"term": 0, "trunc": 0}
    for _ in range(steps):
        actions = np.array([_policy(k, single_obs[k], rng) for k in range(n)])
        obs, reward, terminated, truncated, info = vec.step(actions)
        for k, env in enumerate(singles):
            if pending[k]:  # Gymnasium's next-step autoreset, done by hand
                single_obs[k], _ = env.reset()
                expected = (0.0, False, False)
                pending[k] = False
            else:
                single_obs[k], r, te, tr, single_info = env.step(int(actions[k]))
                expected = (r, te, tr)
                pending[k] = te or tr
                ends["term"] += te
                ends["trunc"] += tr
                # tip heights: np.sin in the vector env, math.sin in the single one (1 ulp).
                assert info["tip_height"][k] == pytest.approx(single_info["tip_height"], abs=1e-15)
            np.testing.assert_array_equal(obs[k], single_obs[k])
            assert (reward[k], terminated[k], truncated[k]) == expected
    assert ends["term"] >= 4 and ends["trunc"] >= 2


def test_disabled_autoreset_with_reset_mask_and_seeds() -> None:
    vec = AcrobotVectorEnv(num_envs=3, autoreset_mode="disabled", start_noise=0.05)
    vec.reset(seed=[1, 2, 3])
    for _ in range(5):
        vec.step(np.array([2, 0, 1]))
    before = vec._qpos.copy()
    obs, _ = vec.reset(seed=[None, 7, None], options={"reset_mask": np.array([False, True, False])})
    np.testing.assert_array_equal(vec._qpos[[0, 2]], before[[0, 2]])  # untouched
    single = gym.make(acrobot_mj.ENV_ID, start_noise=0.05)
    np.testing.assert_array_equal(obs[1], single.reset(seed=7)[0])


@pytest.mark.parametrize(
    ("actions", "match"),
    [
        (np.array([0, 1]), "shape"),
        (np.array([0, 1, 3]), "outside Discrete"),
        (np.array([0, -1, 2]), "outside Discrete"),
        (np.array([0.0, 1.0, 2.0]), "integers"),
        ([[0], [1], [2]], "shape"),
    ],
)
def test_bad_discrete_actions_are_refused(actions, match) -> None:
    vec = AcrobotVectorEnv(num_envs=3)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=match):
        vec.step(actions)


@pytest.mark.parametrize(
    ("actions", "match"),
    [
        (np.zeros(3), "shape"),
        (np.array([[0.5], [1.5], [0.0]]), r"outside \[-1, 1\]"),
        (np.array([[np.nan], [0.0], [0.0]]), r"outside \[-1, 1\]"),
    ],
)
def test_bad_continuous_actions_are_refused(actions, match) -> None:
    vec = AcrobotVectorEnv(num_envs=3, continuous=True)
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=match):
        vec.step(actions)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"num_envs": 0}, ValueError, "num_envs"),
        ({"autoreset_mode": "same_step"}, ValueError, "autoreset_mode"),
        ({"frame_skip": 0}, ValueError, "frame_skip"),
        ({"render_mode": "human"}, ValueError, "render_mode"),
        ({"num_envs": 3, "render_envs": 4}, ValueError, "render_envs"),
        ({"render_envs": 0}, ValueError, "render_envs"),
    ],
)
def test_bad_options_are_refused(kwargs, error, match) -> None:
    with pytest.raises(error, match=match):
        AcrobotVectorEnv(**kwargs)
