"""The batched vector env against N single envs: identical numbers, through autoresets."""

from __future__ import annotations

import pickle

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from mujoco.batch import Batch

import acrobot_mj
from acrobot_mj.envs.batch import THREADED_FROM
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
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
                # tip heights: the rule compiled by numba in the vector env, run as Python in
                # the single one (math.sin): allowed 1 ulp apart.
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
        ({"autoreset_mode": "sometimes"}, ValueError, "autoreset_mode"),
        ({"frame_skip": 0}, ValueError, "frame_skip"),
        ({"render_mode": "human"}, ValueError, "render_mode"),
        ({"num_envs": 3, "render_envs": 4}, ValueError, "render_envs"),
        ({"render_envs": 0}, ValueError, "render_envs"),
        ({"nthread": -1}, ValueError, "nthread"),
        ({"nthread": "2"}, TypeError, "nthread"),
    ],
)
def test_bad_options_are_refused(kwargs, error, match) -> None:
    with pytest.raises(error, match=match):
        AcrobotVectorEnv(**kwargs)


def _run(vec: AcrobotVectorEnv, actions: np.ndarray, seed: int) -> list[list[np.ndarray]]:
    """Per step: the step's results, info's arrays, the unwrapped states and the batch's whole
    MuJoCo state rows. Every 100 steps all sub-envs are put at the velocity limits with angles
    near pi, so that the steps after them clip velocities and wrap angles."""
    vec.reset(seed=seed)
    records = []
    for t, action in enumerate(actions):
        if t % 100 == 50:
            vec.call("set_state", [3.1, -3.1], [MAX_VEL1, -MAX_VEL2])
        obs, reward, terminated, truncated, info = vec.step(action)
        infos = [info[key] for key in sorted(info)]
        states = np.array(vec.get_attr("state"))
        records.append([obs, reward, terminated, truncated, *infos, states, vec.batch.state.copy()])
    return records


def _assert_identical(a: list[list[np.ndarray]], b: list[list[np.ndarray]]) -> None:
    assert len(a) == len(b)
    for step_a, step_b in zip(a, b, strict=True):
        for x, y in zip(step_a, step_b, strict=True):
            np.testing.assert_array_equal(x, y)


def _actions(steps: int, n: int) -> np.ndarray:
    return np.random.default_rng(0).integers(0, 3, (steps, n))


KWARGS = {"max_episode_steps": 60, "start_noise": 0.1, "frame_skip": 2}


def test_threaded_and_single_thread_steps_are_bit_identical() -> None:
    # Threads only split the simulations between them: the same C code computes each one.
    n, actions = 16, _actions(1000, 16)
    threaded = AcrobotVectorEnv(num_envs=n, nthread=2, **KWARGS)
    assert threaded.nthread == 2
    one = _run(AcrobotVectorEnv(num_envs=n, nthread=1, **KWARGS), actions, seed=4)
    _assert_identical(one, _run(threaded, actions, seed=4))
    # The run went through autoresets, velocity clipping and angle wrapping.
    obs, truncated = np.array([r[0] for r in one]), np.array([r[3] for r in one])
    states = np.array([r[-2] for r in one])
    assert truncated.sum() >= 2 * n  # each truncation is followed by an autoreset
    assert (np.abs(obs[..., 2]) == MAX_VEL1).any() and (np.abs(obs[..., 3]) == MAX_VEL2).any()
    assert (np.abs(states[..., :2]) > np.pi).any()
    assert ((obs[..., :2] >= -np.pi) & (obs[..., :2] < np.pi)).all()


def test_a_few_sub_envs_and_many_give_the_same_numbers() -> None:
    # Sub-env i steps alike in a small batch and a larger one: every pass over the rows (the
    # step, the velocity limits, the observations, the task's rule) treats each row alone.
    few, many = 8, 16
    actions = _actions(400, many)
    small = _run(AcrobotVectorEnv(num_envs=few, **KWARGS), actions[:, :few], seed=2)
    large = _run(AcrobotVectorEnv(num_envs=many, **KWARGS), actions, seed=2)
    _assert_identical(small, [[x[:few] for x in step] for step in large])


def test_threads_follow_the_batch_size_unless_given() -> None:
    all_cpus = Batch(AcrobotVectorEnv().model, THREADED_FROM, nthread=0).nthread
    assert AcrobotVectorEnv(num_envs=THREADED_FROM - 1).nthread == 1
    assert AcrobotVectorEnv(num_envs=THREADED_FROM).nthread == all_cpus
    assert AcrobotVectorEnv(num_envs=THREADED_FROM, nthread=1).nthread == 1
    vec = AcrobotVectorEnv(num_envs=4, nthread=2)
    assert vec.nthread == 2
    assert pickle.loads(pickle.dumps(vec)).nthread == 2  # the copy keeps the user's choice


@pytest.mark.parametrize(
    ("field", "value", "sub_env"), [("qvel", np.nan, 1), ("qpos", 2e6, 2), ("qpos", np.inf, 0)]
)
def test_a_bad_state_is_refused_naming_the_sub_env(field, value, sub_env) -> None:
    n = 3
    vec = AcrobotVectorEnv(num_envs=n)
    vec.reset(seed=0)
    vec.batch.bind(field)[sub_env, 0] = value
    with pytest.raises(RuntimeError, match=rf"sub-envs \[{sub_env}\] reached a non-finite"):
        vec.step(np.ones(n, dtype=np.int64))


def _steps(env, n: int, steps: int):
    """``steps`` steps of pumping (even sub-envs: they terminate) and a fixed torque (odd ones:
    truncated at the limit); deterministic, so that both autoreset modes act alike."""
    obs, _ = env.reset(seed=3)
    out = []
    for _ in range(steps):
        actions = np.array([(0 if obs[k, 2] > 0 else 2) if k % 2 == 0 else 2 for k in range(n)])
        obs, reward, terminated, truncated, info = env.step(actions)
        out.append((obs, reward, terminated, truncated, info))
    return out


@pytest.mark.parametrize("env_id", [acrobot_mj.ENV_ID, "acrobot_mj/AcrobotBalance-v0"])
def test_same_step_autoreset_is_sync_vector_envs(env_id) -> None:
    # Observations, rewards, flags and infos bit for bit; final_obs (an object array, None where
    # no episode ended) and final_info with their masks. tip_height is numba's sin in the batch
    # and Python's in the single env: 1 ulp apart at most.
    n, kwargs = 4, {"frame_skip": 4, "start_noise": 0.1, "max_episode_steps": 60}
    ours = gym.make_vec(env_id, num_envs=n, autoreset_mode="same_step", **kwargs)
    same = {"autoreset_mode": AutoresetMode.SAME_STEP}
    theirs = gym.make_vec(env_id, n, vectorization_mode="sync", vector_kwargs=same, **kwargs)
    assert ours.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    ended = 0
    for mine, sync in zip(_steps(ours, n, 200), _steps(theirs, n, 200), strict=True):
        for a, b in zip(mine[:4], sync[:4], strict=True):
            np.testing.assert_array_equal(a, b)
        info, expected = mine[4], sync[4]
        assert set(info) == set(expected)
        if "final_obs" in expected:
            ended += int(expected["_final_obs"].sum())
            np.testing.assert_array_equal(info["_final_obs"], expected["_final_obs"])
            assert info["final_obs"].dtype == object
            for a, b in zip(info["final_obs"], expected["final_obs"], strict=True):
                assert (a is None and b is None) or np.array_equal(a, b)
            assert set(info["final_info"]) == set(expected["final_info"])
            for key, value in expected["final_info"].items():
                assert info["final_info"][key].dtype == value.dtype, key
                np.testing.assert_allclose(info["final_info"][key], value, rtol=0, atol=1e-15)
        for key, value in expected.items():
            if key not in ("final_obs", "final_info"):
                np.testing.assert_allclose(info[key], value, rtol=0, atol=1e-15, err_msg=key)
    assert ended >= 6  # episodes ended, terminated and truncated, some sub-envs alone


@pytest.mark.parametrize("backend", ["mujoco", "analytic"])
def test_same_step_autoreset_runs_the_episodes_of_next_step(backend) -> None:
    # Each sub-env's episodes are the same in both modes: next-step's reset step is same-step's
    # final_obs moved to its own step.
    n = 4
    kwargs = {"frame_skip": 4, "max_episode_steps": 50, "backend": backend}
    same = _steps(AcrobotVectorEnv(n, autoreset_mode="same_step", **kwargs), n, 300)
    nxt = _steps(AcrobotVectorEnv(n, autoreset_mode="next_step", **kwargs), n, 300)
    for k in range(n):
        a, b = [], [step[0][k].tolist() for step in nxt]
        for obs, _, terminated, truncated, info in same:
            ended = terminated[k] or truncated[k]
            a.append((info["final_obs"][k] if ended else obs[k]).tolist())
            if ended:
                a.append(obs[k].tolist())  # the reset's
        assert a[: len(b) - 10] == b[: len(b) - 10]  # the same states, in the same order
        assert sum(t[k] or u[k] for _, _, t, u, _ in same) >= 3
