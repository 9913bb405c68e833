"""The vector env's Gymnasium API beyond reset and step: sub-env attributes against
SyncVectorEnv over single envs, rendering, pickling, make_vec's wrappers and the specs."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import imageio.v3 as iio
import numpy as np
import pytest

import acrobot_mj
from acrobot_mj.control.trajopt import shipped
from acrobot_mj.envs.control_loop import balance_env, closed_loop
from acrobot_mj.envs.tasks import Balance, HeightGoal
from acrobot_mj.envs.vector import PER_ENV, SHARED, AcrobotVectorEnv

KWARGS = {"frame_skip": 4, "start_noise": 0.1}


def _pair(n: int = 3, **kwargs):
    """The batched env and SyncVectorEnv over n single envs, same options, both reset(seed=5)."""
    options = {**KWARGS, **kwargs}
    vec = gym.make_vec(acrobot_mj.ENV_ID, num_envs=n, **options)
    sync = gym.make_vec(acrobot_mj.ENV_ID, num_envs=n, vectorization_mode="sync", **options)
    assert isinstance(vec, AcrobotVectorEnv) and isinstance(sync, gym.vector.SyncVectorEnv)
    obs, _ = vec.reset(seed=5)
    np.testing.assert_array_equal(obs, sync.reset(seed=5)[0])
    return vec, sync


def _settings(task) -> dict:
    return {key: value for key, value in vars(task).items() if not key.startswith("_")}


def _assert_same(name: str, ours: tuple, theirs: tuple) -> None:
    assert isinstance(ours, tuple) and len(ours) == len(theirs), name
    for a, b in zip(ours, theirs, strict=True):
        if name == "state":
            np.testing.assert_array_equal(a, b)
        elif name == "np_random":
            assert a.bit_generator.state == b.bit_generator.state
        elif name == "task":  # the same settings (a private cache, the compiled rule, aside)
            assert type(a) is type(b) and _settings(a) == _settings(b)
        elif name == "model":  # one shared MjModel (SyncVectorEnv: one per sub-env)
            assert a is ours[0] and a.opt.timestep == b.opt.timestep
            assert a.opt.integrator == b.opt.integrator and a.nq == b.nq
        else:
            assert a == b, name


def test_get_attr_and_call_match_sync_vector_env() -> None:
    vec, sync = _pair()
    for _ in range(20):
        actions = np.array([2, 0, 1])
        vec.step(actions)
        sync.step(actions)
    for name in (*PER_ENV, *SHARED):
        _assert_same(name, vec.get_attr(name), sync.get_attr(name))
        _assert_same(name, vec.call(name), sync.call(name))  # an attribute: its values
    assert vec.get_attr("np_random_seed") == (5, 6, 7)
    assert vec.np_random_seed == sync.np_random_seed
    _assert_same("np_random", vec.np_random, sync.np_random)


@pytest.mark.parametrize("shared", [False, True])
def test_set_attr_np_random_and_call_set_state_match_sync_vector_env(shared: bool) -> None:
    vec, sync = _pair()
    for env in (vec, sync):
        # One generator for all (they draw from it in turn) or one each; same seeds in both.
        rngs = np.random.default_rng(9) if shared else [np.random.default_rng(k) for k in range(3)]
        env.set_attr("np_random", rngs)
    assert vec.get_attr("np_random_seed") == sync.get_attr("np_random_seed") == (-1, -1, -1)
    np.testing.assert_array_equal(vec.reset()[0], sync.reset()[0])  # noise from the new ones
    q, dq = (0.3, -0.2), (1.0, 2.0)
    assert vec.call("set_state", q, dq) == sync.call("set_state", q, dq) == (None,) * 3
    _assert_same("state", vec.get_attr("state"), sync.get_attr("state"))
    np.testing.assert_array_equal(vec.get_attr("state")[2], [*q, *dq])
    for _ in range(10):
        ours, theirs = vec.step(np.array([0, 1, 2])), sync.step(np.array([0, 1, 2]))
        for a, b in zip(ours[:4], theirs[:4], strict=True):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    ("method", "args", "error", "match"),
    [
        ("get_attr", ("nope",), AttributeError, "no attribute 'nope'; per sub-env"),
        ("call", ("nope",), AttributeError, "no attribute 'nope'"),
        ("set_attr", ("frame_skip", 2), AttributeError, "shared by all 3 sub-envs"),
        ("set_attr", ("model", None), AttributeError, "shared by all"),
        ("set_attr", ("state", np.zeros(4)), AttributeError, "read-only.*set_state"),
        ("set_attr", ("np_random_seed", 1), AttributeError, "read-only"),
        ("set_attr", ("nope", 1), AttributeError, "no attribute of the sub-envs; settable"),
        ("set_attr", ("np_random", [np.random.default_rng()]), ValueError, "Got `1` values"),
        ("set_attr", ("np_random", 3), TypeError, "numpy Generators"),
        ("call", ("set_state", (0.0, 0.0, 0.0)), ValueError, "shape"),
        ("call", ("set_state", (0.0, 0.0), (99.0, 0.0)), ValueError, "velocity limits"),
    ],
)
def test_bad_names_and_values_are_refused(method, args, error, match) -> None:
    vec = AcrobotVectorEnv(num_envs=3)
    vec.reset(seed=0)
    before = vec.get_attr("state")
    with pytest.raises(error, match=match) as raised:
        getattr(vec, method)(*args)
    assert "\n" not in str(raised.value)  # one line
    _assert_same("state", vec.get_attr("state"), before)  # nothing changed
    assert vec.get_attr("frame_skip") == (1, 1, 1)


def test_render_is_the_single_envs_frame() -> None:
    size = {"width": 96, "height": 64}
    vec = AcrobotVectorEnv(num_envs=3, render_mode="rgb_array", render_envs=1, **KWARGS, **size)
    singles = [
        gym.make(acrobot_mj.ENV_ID, render_mode="rgb_array", **KWARGS, **size) for _ in range(3)
    ]
    vec.reset(seed=3)
    for k, env in enumerate(singles):
        env.reset(seed=3 + k)
    for _ in range(15):
        vec.step(np.array([2, 0, 1]))
        for k, env in enumerate(singles):
            env.step([2, 0, 1][k])
    expected = [env.render() for env in singles]
    frame = vec.render()
    assert frame.shape == (64, 96, 3) and frame.dtype == np.uint8
    assert frame.std() > 10  # a picture, not a blank buffer
    np.testing.assert_array_equal(frame, expected[0])  # same state, same renderer: exact
    every = vec.call("render")
    for k in range(3):
        np.testing.assert_array_equal(every[k], expected[k])
    assert not np.array_equal(every[0], every[1])  # different states, different frames
    twin = pickle.loads(pickle.dumps(vec))  # after rendering: the copy makes its own renderer
    np.testing.assert_array_equal(twin.render(), frame)


def test_render_grid_and_every_frame() -> None:
    vec = AcrobotVectorEnv(num_envs=3, render_mode="rgb_array", width=32, height=24, render_envs=3)
    vec.reset(seed=0, options={"start_noise": 0.5})
    frames = vec.call("render")
    grid = vec.render()
    assert grid.shape == (48, 64, 3)  # ceil(sqrt(3)) = 2 columns, 2 rows
    np.testing.assert_array_equal(grid[:24, :32], frames[0])
    np.testing.assert_array_equal(grid[:24, 32:], frames[1])
    np.testing.assert_array_equal(grid[24:, :32], frames[2])
    assert not grid[24:, 32:].any()  # no fourth sub-env: black
    vec.render_envs = None  # the default: every frame, as SyncVectorEnv's
    assert isinstance(vec.render(), tuple) and len(vec.render()) == 3
    default = AcrobotVectorEnv(num_envs=3, render_mode="rgb_array", width=32, height=24)
    default.reset(seed=0, options={"start_noise": 0.5})
    for mine, sync in zip(default.render(), frames, strict=True):
        np.testing.assert_array_equal(mine, sync)
    with pytest.warns(UserWarning, match="render_mode=None"):  # as the single env
        assert AcrobotVectorEnv(num_envs=2).render() is None
    with pytest.warns(UserWarning, match="render_mode=None"):  # as SyncVectorEnv's
        assert AcrobotVectorEnv(num_envs=2).call("render") == (None, None)


def test_gymnasium_vector_record_video_records_every_sub_env(tmp_path) -> None:
    pytest.importorskip("moviepy")  # the wrapper with its defaults, the env with its own
    vec = gym.make_vec(
        acrobot_mj.ENV_ID,
        num_envs=2,
        render_mode="rgb_array",
        width=32,
        height=32,
        max_episode_steps=5,
    )
    folder = tmp_path / "videos"
    env = gym.wrappers.vector.RecordVideo(vec, str(folder), episode_trigger=lambda e: e == 0)
    env.reset(seed=0)
    for _ in range(6):
        env.step(np.array([2, 0]))
    env.close()
    (video,) = folder.glob("*.mp4")
    # The reset's frame and five steps', both sub-envs side by side (32 x 32 each).
    assert iio.imread(video).shape == (6, 32, 64, 3)


def _policy(k: int, obs: np.ndarray, rng: np.random.Generator) -> int:
    # Even sub-envs pump energy (they terminate at the goal), odd ones act at random (they run
    # into the time limit).
    return (0 if obs[2] > 0 else 2) if k % 2 == 0 else int(rng.integers(3))


def _run(env, obs: np.ndarray, steps: int, rng: np.random.Generator) -> list:
    out = []
    for _ in range(steps):
        actions = np.array([_policy(k, obs[k], rng) for k in range(env.num_envs)])
        obs, reward, terminated, truncated, info = env.step(actions)
        out.append((obs, reward, terminated, truncated, info))
    return out


@pytest.mark.parametrize("duplicate", [pickle.loads, copy.deepcopy])
def test_pickle_round_trip_then_identical_steps(duplicate) -> None:
    vec = AcrobotVectorEnv(num_envs=4, max_episode_steps=80, **KWARGS)
    obs, _ = vec.reset(seed=21)
    rng = np.random.default_rng(1)
    while True:  # to a step where some sub-envs, not all, await their autoreset
        ((obs, *_),) = _run(vec, obs, 1, rng)
        if vec._pending.any() and not vec._pending.all():
            break
    blob = pickle.dumps(vec) if duplicate is pickle.loads else vec
    twin = duplicate(blob)
    assert twin.batch is not vec.batch
    np.testing.assert_array_equal(twin.batch.state, vec.batch.state)
    np.testing.assert_array_equal(twin._elapsed, vec._elapsed)
    np.testing.assert_array_equal(twin._pending, vec._pending)
    assert twin.np_random_seed == vec.np_random_seed
    assert twin.unwrapped.spec == vec.unwrapped.spec
    seed = rng.integers(2**32)
    a = _run(vec, obs, 300, np.random.default_rng(seed))
    b = _run(twin, obs, 300, np.random.default_rng(seed))
    for ours, theirs in zip(a, b, strict=True):
        for x, y in zip(ours[:4], theirs[:4], strict=True):
            np.testing.assert_array_equal(x, y)
        assert ours[4].keys() == theirs[4].keys()
        for key in ours[4]:
            np.testing.assert_array_equal(ours[4][key], theirs[4][key])
    ends = sum(int(step[2].sum() + step[3].sum()) for step in a)
    assert ends >= 6  # through autoresets, both kinds (pumping ones terminate)
    assert sum(int(step[2].sum()) for step in a) >= 2
    np.testing.assert_array_equal(vec.reset()[0], twin.reset()[0])  # same generators


def test_make_vec_wrappers() -> None:
    wrap = [lambda env: gym.wrappers.TransformReward(env, lambda r: 2.0 * r)]
    # Gymnasium refuses single-env wrappers for a vector entry point...
    with pytest.raises(gym.error.Error, match="Cannot use `vector_entry_point` vectorization"):
        gym.make_vec(acrobot_mj.ENV_ID, num_envs=2, wrappers=wrap)
    # ... and applies them in its own sync (or async) vector env over single envs.
    sync = gym.make_vec(acrobot_mj.ENV_ID, num_envs=2, vectorization_mode="sync", wrappers=wrap)
    sync.reset(seed=0)
    assert sync.step(np.array([0, 2]))[1].tolist() == [-2.0, -2.0]
    # Vector wrappers wrap the batched env.
    vec = gym.wrappers.vector.RecordEpisodeStatistics(
        gym.make_vec(acrobot_mj.ENV_ID, num_envs=2, max_episode_steps=10)
    )
    vec.reset(seed=0)
    for _ in range(10):
        *_, info = vec.step(np.array([0, 2]))
    assert info["episode"]["l"].tolist() == [10, 10]
    assert info["episode"]["r"].tolist() == [-10.0, -10.0]


def test_reward_threshold_on_the_specs() -> None:
    assert gym.spec(acrobot_mj.ENV_ID).reward_threshold == HeightGoal.reward_threshold == -300.0
    assert gym.spec(Balance.env_id).reward_threshold == Balance.reward_threshold == 1200.0
    assert gym.make(acrobot_mj.ENV_ID).spec.reward_threshold == -300.0
    # The docstring's bang-bang law reaches the goal on step 300 (returns 101 - 300 = -199):
    # solved by the threshold; the best known minimum (249 steps) returns -148.
    env = gym.make(acrobot_mj.ENV_ID)
    obs, _ = env.reset(seed=0)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(0 if obs[2] > 0 else 2)
        total, done = total + reward, terminated or truncated
    assert total == -199.0 and total >= env.spec.reward_threshold
    assert 101 - HeightGoal.MIN_DECISIONS[1] == -148


@pytest.mark.parametrize(
    ("name", "discrete", "solved"),
    [
        ("reserve", False, True),
        ("reserve", True, True),
        pytest.param("min_time", True, False, marks=pytest.mark.slow),  # plans a swing-up
    ],
)
def test_the_balance_threshold_separates_balancing_from_falling(name, discrete, solved) -> None:
    # The shipped controllers over one registered episode (2000 steps): those that swing up and
    # balance return about 1610, the minimum-time swing-up with {-1, 0, +1} torques falls (592).
    trajectory, rewards = shipped(name), []
    env = balance_env(trajectory, discrete, hold=(2000 - trajectory.steps) * trajectory.dt)
    env = gym.wrappers.TransformReward(env, lambda r: rewards.append(r) or r)
    result = closed_loop(trajectory, discrete=discrete, env=env)
    assert len(rewards) == gym.spec(Balance.env_id).max_episode_steps == 2000
    assert result["balanced"] is solved
    assert (sum(rewards) >= Balance.reward_threshold) is solved


@pytest.mark.parametrize("backend", ["mujoco", "analytic"])
def test_the_vector_env_refuses_to_step_before_reset_as_the_single_env(backend) -> None:
    # It returned observations from an unseeded start, different on every run.
    vec = gym.make_vec("acrobot_mj/AcrobotRLContinuous-v0", num_envs=2, backend=backend)
    actions = np.zeros((2, 1), dtype=np.float32)
    with pytest.raises(gym.error.ResetNeeded, match=r"before calling env.reset\(\)"):
        vec.step(actions)
    vec.reset(seed=0, options={"reset_mask": np.array([True, False])})
    with pytest.raises(gym.error.ResetNeeded, match=r"sub-envs \[1\]"):
        vec.step(actions)
    vec.reset(seed=0)
    assert vec.step(actions)[0].shape == (2, 6)
    single = gym.make("acrobot_mj/AcrobotRLContinuous-v0")
    with pytest.raises(gym.error.ResetNeeded):
        single.step(actions[0])
