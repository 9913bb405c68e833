"""The Gymnasium environment: API conformance, the height goal (docs/envs/acrobot.md),
determinism."""

from __future__ import annotations

import copy
import math
import pickle
import warnings

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import acrobot_mj
from acrobot_mj.envs.acrobot import AcrobotEnv
from acrobot_mj.physics import integrators
from acrobot_mj.physics.params import REPORT
from acrobot_mj.physics.xp import wrap_angle

HANGING = [-math.pi / 2, 0.0, 0.0, 0.0]
MAX_VEL1, MAX_VEL2 = REPORT.max_vel


@pytest.mark.parametrize(
    "kwargs",
    [{}, {"continuous": True}, {"frame_skip": 4}, {"integrator": "rk4", "start_noise": 0.1}],
)
def test_check_env_passes_without_warnings(kwargs) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(AcrobotEnv(**kwargs), skip_render_check=True)


def test_registered_with_time_limit() -> None:
    spec = gym.spec(acrobot_mj.ENV_ID)
    assert spec.max_episode_steps == 1000
    env = gym.make(acrobot_mj.ENV_ID, frame_skip=4)
    assert isinstance(env.unwrapped, AcrobotEnv) and env.unwrapped.frame_skip == 4
    assert isinstance(env.unwrapped.model, mujoco.MjModel)
    assert isinstance(env.unwrapped.data, mujoco.MjData)


def test_spaces_and_metadata() -> None:
    env = AcrobotEnv()
    assert env.action_space == gym.spaces.Discrete(3)
    assert env.observation_space.dtype == np.float64
    np.testing.assert_array_equal(
        env.observation_space.high, [math.pi, math.pi, 4 * math.pi, 9 * math.pi]
    )
    # 1 / 0.05 s and 1 / 0.2 s, to 1 ulp (0.05 is not exact in binary).
    assert env.metadata["render_fps"] == pytest.approx(20.0, rel=1e-15)
    assert AcrobotEnv(frame_skip=4).metadata["render_fps"] == pytest.approx(5.0, rel=1e-15)
    assert AcrobotEnv.metadata["render_fps"] == 20  # class default untouched by instances
    cont = AcrobotEnv(continuous=True)
    assert cont.action_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)


def test_reset_is_exactly_hanging_at_rest() -> None:
    env = AcrobotEnv()
    for seed in (None, 0, 123):
        env.step(2)
        obs, info = env.reset(seed=seed)
        assert obs.dtype == np.float64
        assert obs.tolist() == HANGING
        assert env.data.qpos.tolist() == HANGING[:2] and env.data.qvel.tolist() == [0.0, 0.0]
        assert env.data.time == 0.0 and env.data.ctrl[0] == 0.0
        assert info == {"tip_height": -2.0, "is_success": False}


def test_start_noise_option() -> None:
    env = AcrobotEnv(start_noise=0.1)
    obs, _ = env.reset(seed=1)
    assert np.all(np.abs(obs - HANGING) <= 0.1) and np.any(obs != HANGING)
    obs, _ = env.reset(seed=1, options={"start_noise": 0.0})
    assert obs.tolist() == HANGING
    plain = AcrobotEnv()
    obs, _ = plain.reset(seed=1, options={"start_noise": 0.1})
    np.testing.assert_array_equal(obs, env.reset(seed=1)[0])
    assert plain.reset()[0].tolist() == HANGING  # the option lasts one episode


def _rollout(env, seed: int, steps: int = 300) -> list:
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        out += [obs, reward, terminated, truncated, info]
        if terminated or truncated:
            obs, _ = env.reset()
    return out


def _identical(a: list, b: list) -> bool:
    return all(
        np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
        for x, y in zip(a, b, strict=True)
    )


def test_same_seed_same_rollout_bit_for_bit() -> None:
    a = _rollout(gym.make(acrobot_mj.ENV_ID, start_noise=0.1), seed=7)
    b = _rollout(gym.make(acrobot_mj.ENV_ID, start_noise=0.1), seed=7)
    c = _rollout(gym.make(acrobot_mj.ENV_ID, start_noise=0.1), seed=8)
    assert _identical(a, b)
    assert not _identical(a, c)


@pytest.mark.parametrize("clone", [lambda e: pickle.loads(pickle.dumps(e)), copy.deepcopy])
def test_pickle_and_deepcopy_round_trip(clone) -> None:
    env = AcrobotEnv(frame_skip=2, start_noise=0.05)
    env.reset(seed=3)
    for action in (2, 2, 0):
        env.step(action)
    twin = clone(env)
    assert twin.model is not env.model and twin.data is not env.data
    np.testing.assert_array_equal(twin.state, env.state)
    for action in (0, 1, 2, 2, 0):  # the clone steps exactly like the original
        a, b = env.step(action), twin.step(action)
        assert _identical(list(a), list(b))
    # Its cached views point into its own data, not a copy: stepping moves twin.data.
    before = twin.data.qpos.copy()
    twin.step(2)
    assert not np.array_equal(before, twin.data.qpos)
    assert _identical(list(env.reset(seed=9)), list(twin.reset(seed=9)))


def test_reaching_the_goal_terminates_with_goal_reward() -> None:
    env = AcrobotEnv()
    env.reset()
    env.set_state([math.pi / 2 - 0.1, 0.0])  # tip at 2 cos(0.1) = 1.99 m, above the 1 m line
    _obs, reward, terminated, truncated, info = env.step(1)
    assert (reward, terminated, truncated, info["is_success"]) == (100.0, True, False, True)
    assert info["tip_height"] > 1.0
    env.reset()
    _, reward, terminated, _, info = env.step(1)
    assert (reward, terminated, info["is_success"]) == (-1.0, False, False)


def test_goal_threshold_is_strictly_above_goal_height() -> None:
    # A first run measures the tip height after one step from (0, pi/2) (tip near (1, 1));
    # with goal_height set to exactly that height the goal is not reached (strict >), with a
    # hair less it is, and the rewards follow the configured values.
    probe = AcrobotEnv()
    probe.reset()
    probe.set_state([0.0, math.pi / 2])
    tip = probe.step(1)[4]["tip_height"]
    for goal_height, expected in [(tip, False), (math.nextafter(tip, -math.inf), True)]:
        env = AcrobotEnv(goal_height=goal_height, step_reward=-2.0, goal_reward=7.0)
        env.reset()
        env.set_state([0.0, math.pi / 2])
        _, reward, terminated, _, info = env.step(1)
        assert info["tip_height"] == tip
        assert terminated is expected and info["is_success"] is expected
        assert reward == (7.0 if expected else -2.0)


def test_truncation_at_1000_steps_through_make() -> None:
    env = gym.make(acrobot_mj.ENV_ID)
    env.reset(seed=0)
    for step in range(1, 1001):
        _, reward, terminated, truncated, _ = env.step(1)  # no torque: stays hanging
        assert not terminated and reward == -1.0
        assert truncated == (step == 1000)


def test_velocities_are_clipped_after_every_physics_step() -> None:
    # Folded (q2 = pi) and spinning at both limits in opposite senses: the analytic model says
    # each of the three physics steps pushes both speeds past their limits.
    q, dq = [0.0, math.pi], [-MAX_VEL1, MAX_VEL2]
    x = np.array([*q, *dq])
    clipped_each_step = []
    for _ in range(3):
        unclipped = integrators.step_states(x, 1.0, limits=False)
        clipped_each_step.append(abs(unclipped[2]) > MAX_VEL1 and abs(unclipped[3]) > MAX_VEL2)
        x = integrators.step_states(x, 1.0)  # the same step, velocities then clipped
    assert all(clipped_each_step)

    env = AcrobotEnv(frame_skip=3)
    env.reset()
    env.set_state(q, dq)
    obs, *_ = env.step(2)
    assert obs[2] == -MAX_VEL1 and obs[3] == MAX_VEL2  # pinned at the limits, exactly
    # The positions integrate the clipped velocities of every physics step, as in the analytic
    # model (1e-12: one-step rounding, see test_crosscheck).
    np.testing.assert_allclose(env.state, x, atol=1e-12)


def test_angles_are_wrapped() -> None:
    env = AcrobotEnv()
    env.reset()
    env.set_state([3 * math.pi + 0.25, -5 * math.pi - 0.5])
    obs, *_ = env.step(1)
    assert np.all(obs[:2] >= -math.pi) and np.all(obs[:2] < math.pi)
    # Wrapping subtracts a multiple of 2 pi from angles of size ~20 rad: the result is exact
    # to a few ulps of 20 (~1e-14), so 1e-12 is the same angle and a wrong shift is off by O(1).
    assert math.cos(obs[0]) == pytest.approx(math.cos(env.state[0]), abs=1e-12)
    assert math.sin(obs[1]) == pytest.approx(math.sin(env.state[1]), abs=1e-12)
    # The edge cases of wrap_angle: the interval is half-open.
    assert wrap_angle(math.pi) == -math.pi
    assert wrap_angle(-math.pi) == -math.pi
    assert wrap_angle(-1e-17) < math.pi
    assert wrap_angle(2 * math.pi + 1.0) == pytest.approx(1.0, abs=1e-15)  # 2 ulps of 7.3


def test_frame_skip_repeats_the_action() -> None:
    one, four = AcrobotEnv(), AcrobotEnv(frame_skip=4)
    one.reset()
    four.reset()
    for _ in range(4):
        one.step(2)
    four.step(2)
    np.testing.assert_array_equal(one.state, four.state)
    assert four.dt == pytest.approx(0.2, rel=1e-15)  # 0.05 * 4 in doubles: 1 ulp


def test_rk4_option_steps_mujoco_rk4() -> None:
    env = AcrobotEnv(integrator="rk4")
    assert env.model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    env.reset()
    obs, *_ = env.step(2)
    expected = integrators.step_states(HANGING, 1.0, method="rk4", limits=False)
    np.testing.assert_allclose(obs, expected, atol=1e-12)  # one-step rounding, see crosscheck


def test_continuous_actions_apply_the_torque() -> None:
    env = AcrobotEnv(continuous=True)
    env.reset()
    obs, *_ = env.step(np.array([0.25], dtype=np.float32))
    assert env.data.ctrl[0] == 0.25
    expected = integrators.step_states(HANGING, 0.25, limits=False)
    np.testing.assert_allclose(obs, expected, atol=1e-12)


def test_options_are_read_only_after_construction() -> None:
    env = AcrobotEnv()
    for name, value in [("continuous", True), ("frame_skip", 4), ("integrator", "rk4")]:
        with pytest.raises(AttributeError):
            setattr(env, name, value)


def test_models_are_independent_per_instance() -> None:
    a, b = AcrobotEnv(integrator="rk4"), AcrobotEnv()
    assert a.model.opt.integrator != b.model.opt.integrator


RL_IDS = {
    "acrobot_mj/AcrobotRL-v0": ("height_goal", False, 0.0),
    "acrobot_mj/AcrobotRLContinuous-v0": ("height_goal", True, 0.0),
    "acrobot_mj/AcrobotBalanceRL-v0": ("balance", False, 300.0),
    "acrobot_mj/AcrobotBalanceRLContinuous-v0": ("balance", True, 300.0),
}


@pytest.mark.parametrize("env_id", sorted(RL_IDS))
def test_the_rl_ready_ids_have_gymnasiums_acrobot_defaults(env_id) -> None:
    # Acrobot-v1's: 0.2 s decisions, 500 of them, float32 (cos q1, sin q1, cos q2, sin q2, dq1,
    # dq2), rest plus U(-0.1, 0.1) on each coordinate drawn from the seed.
    task, continuous, threshold = RL_IDS[env_id]
    env = gym.make(env_id)
    assert env.spec.max_episode_steps == 500 and env.spec.reward_threshold == threshold
    assert env.unwrapped.task.name == task and env.unwrapped.continuous is continuous
    assert env.unwrapped.dt == pytest.approx(0.2)
    assert env.observation_space.dtype == np.float32 and env.observation_space.shape == (6,)
    obs, _ = env.reset(seed=7)
    q1, q2, dq1, dq2 = env.unwrapped.state
    assert obs.dtype == np.float32 and obs in env.observation_space
    # Computed here from the state, independently of the env's conversion.
    expected = [math.cos(q1), math.sin(q1), math.cos(q2), math.sin(q2), dq1, dq2]
    np.testing.assert_array_equal(obs, np.array(expected, dtype=np.float32))
    offsets = env.unwrapped.state - np.array([-math.pi / 2, 0.0, 0.0, 0.0])
    assert np.all(np.abs(offsets) <= 0.1) and np.any(offsets != 0.0)
    assert not np.array_equal(env.reset(seed=8)[0], obs)  # another seed, another start
    np.testing.assert_array_equal(env.reset(seed=7)[0], obs)
    action = np.array([0.5], dtype=np.float32) if continuous else 2
    obs, *_ = env.step(action)
    assert obs.dtype == np.float32 and obs in env.observation_space
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the checker has nothing to say
        check_env(gym.make(env_id).unwrapped, skip_render_check=True)  # all modes: test_window


def test_the_rl_ready_vector_env_is_its_single_envs() -> None:
    vec = gym.make_vec("acrobot_mj/AcrobotRL-v0", num_envs=3)
    sync = gym.make_vec("acrobot_mj/AcrobotRL-v0", num_envs=3, vectorization_mode="sync")
    assert vec.single_observation_space == sync.single_observation_space
    np.testing.assert_array_equal(vec.reset(seed=2)[0], sync.reset(seed=2)[0])
    for t in range(120):  # pumping: through the goal and autoresets
        actions = np.array([0 if t % 7 else 2, 2, 1])
        for a, b in zip(vec.step(actions)[:4], sync.step(actions)[:4], strict=True):
            np.testing.assert_array_equal(a, b)


def test_the_rl_ready_thresholds_separate_pumping_from_random_torques() -> None:
    # Pumping (tau = -sign(dq1) on the cos/sin observation) reaches the height goal in about
    # 100 decisions; random torques never do in 500.
    env = gym.make("acrobot_mj/AcrobotRL-v0")
    rng, returns = np.random.default_rng(0), {"pump": [], "random": []}
    for kind in returns:
        for seed in range(5):
            obs, _ = env.reset(seed=seed)
            total, done = 0.0, False
            while not done:
                action = (0 if obs[4] > 0 else 2) if kind == "pump" else int(rng.integers(3))
                obs, reward, terminated, truncated, _ = env.step(action)
                total, done = total + reward, terminated or truncated
            returns[kind].append(total)
    assert np.mean(returns["pump"]) >= env.spec.reward_threshold > np.mean(returns["random"])


def test_an_unknown_observation_kind_is_refused() -> None:
    with pytest.raises(ValueError, match="observation must be one of"):
        AcrobotEnv(observation="pixels")


def test_the_cos_sin_wrapper_observes_as_the_rl_ids() -> None:
    from acrobot_mj.envs.wrappers import CosSinObservation

    kwargs = {"frame_skip": 4, "start_noise": 0.1}
    wrapped = CosSinObservation(gym.make(acrobot_mj.ENV_ID, **kwargs))
    native = gym.make(acrobot_mj.ENV_ID, observation="cos_sin", **kwargs)
    assert wrapped.observation_space == native.observation_space
    np.testing.assert_array_equal(wrapped.reset(seed=4)[0], native.reset(seed=4)[0])
    for _ in range(30):
        np.testing.assert_array_equal(wrapped.step(2)[0], native.step(2)[0])
    with pytest.raises(ValueError, match="expected"):
        CosSinObservation(native)  # already 6 numbers


def test_a_copy_from_before_the_window_and_cos_sin_is_refused_in_one_line() -> None:
    # A pickled env of 0.3.0 holds none of the attributes 0.4.0 added for the viewer window and
    # the cos/sin observations: it is refused, naming the version that wrote it.
    env = AcrobotEnv()
    env.reset(seed=0)
    state = pickle.loads(pickle.dumps(env.__getstate__()))  # its own MjData
    for key in ("_human", "_viewer", "_shown_at", "_cos_sin", "_observation"):
        del state[key]
    old = object.__new__(AcrobotEnv)
    with pytest.raises(ValueError, match=r"pickled by acrobot_mj before 0\.4\.0") as error:
        old.__setstate__(state)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    "state",
    [
        (0.0, 0.0, math.inf, 0.0),
        (0.0, 0.0, 0.0, -math.inf),
        (0.0, 0.0, math.nan, 0.0),
        (2e6, 0.0, 0.0, 0.0),
        (0.0, math.nan, 0.0, 0.0),
    ],
)
def test_every_env_refuses_to_observe_a_non_finite_state_by_one_rule(state) -> None:
    # The single and identified envs let infinite velocities through (v == v), the vector env
    # did not (|v| < 1e10): a Gymnasium user expects finite observations, so none is observed.
    from acrobot_mj.compiled import compiled
    from acrobot_mj.envs.acrobot import observation, sound
    from acrobot_mj.envs.batch import observe
    from acrobot_mj.envs.identified import IdentifiedEnv

    assert not sound(*state) and observation(*state) is None
    assert not compiled(sound)(*state)
    rows = np.array([state, (4.0, -4.0, 1.0, 1.0)])
    with pytest.raises(RuntimeError, match=r"sub-envs \[0\]"):
        observe(rows[:, :2], rows[:, 2:])
    model = IdentifiedEnv(REPORT.lumped, AcrobotEnv().task)
    model._x = state
    with pytest.raises(RuntimeError, match="non-finite state"):
        model._observe()
    assert observation(4.0, -4.0, 1.0, 1.0).tolist() == [
        4.0 - 2 * math.pi,
        2 * math.pi - 4.0,
        1.0,
        1.0,
    ]
