"""The analytic backend of the vector env against MuJoCo's: the same task, trajectories equal to
rounding through autoresets, the compiled step equal to the Python one bit for bit, threads
that change no number, pickling, rendering, and the models and options it refuses."""

from __future__ import annotations

import json
import math
import pickle
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import acrobot_mj
from acrobot_mj.compiled import compiled
from acrobot_mj.envs import batch
from acrobot_mj.envs.assets import models_dir
from acrobot_mj.envs.batch import ANALYTIC_THREADED_FROM as THREADED_FROM
from acrobot_mj.envs.batch import AnalyticPhysics, lumped_parameters
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.physics import xp
from acrobot_mj.physics.integrators import step, step_rows
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.physics.xp import wrap_angle

#: Largest gap allowed between the backends' observations, rewards and info numbers. The two
#: compute the same equations in different arithmetic (MuJoCo: kinematics through quaternions,
#: the composite rigid body mass matrix, recursive Newton-Euler and an LDL solve; the analytic
#: backend: the lumped closed form and Cramer's rule), so one physics step differs by rounding
#: (measured: at most 2.3e-14 over 20,000 random states and torques), and the acrobot's chaos
#: amplifies that by about 10x per 2 s of pumped swinging. Over the 1000 steps below, in
#: episodes of at most 100 decisions of 0.2 s, the largest gap measured was 1.9e-11 at N = 64
#: and 4.6e-11 at N = 256 (at N = 1: 6e-13; random actions alone stay near the bottom, not
#: chaotic: 1e-13): 1e-8 leaves two orders of margin
#: and still fails at once for a wrong parameter, sign or order of the step (those are 1e-4 and
#: more after one decision). Longer chaotic episodes drift further: 2.5e-8 by 150 decisions.
TOLERANCE = 1e-8
#: Height goal episodes (pumping reaches the goal: terminations) and balance episodes, each
#: truncated at 100 decisions of 0.2 s, so 1000 steps go through many autoresets.
CASES = {
    "height_goal": {"frame_skip": 4, "start_noise": 0.1, "max_episode_steps": 100},
    "balance": {
        "task": "balance",
        "frame_skip": 4,
        "start_noise": 0.1,
        "max_episode_steps": 100,
    },
}


def _angles_apart(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| with the angle columns' differences wrapped (an angle at -pi and one just below
    pi are a rounding apart)."""
    gap = np.abs(a - b)
    gap[..., :2] = np.abs((a[..., :2] - b[..., :2] + math.pi) % (2 * math.pi) - math.pi)
    return gap


def _actions(obs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Random actions for 30 % of the sub-envs each step, energy pumping (torque against the
    shoulder's velocity) for the rest: the swings reach the goal, clip and turn chaotic."""
    n = len(obs)
    return np.where(rng.random(n) < 0.3, rng.integers(0, 3, n), np.where(obs[:, 2] > 0, 0, 2))


def _compare(n: int, steps: int, **kwargs) -> dict[str, float]:
    """Step both backends ``steps`` times with the same actions and assert the same outcomes;
    returns the largest gap and the counts of terminations and truncations."""
    mujoco_env = AcrobotVectorEnv(num_envs=n, **kwargs)
    analytic = AcrobotVectorEnv(num_envs=n, backend="analytic", **kwargs)
    obs, info = mujoco_env.reset(seed=3)
    obs_a, info_a = analytic.reset(seed=3)
    np.testing.assert_array_equal(obs, obs_a)  # the same start: resets are the same code
    rng, worst, ends = np.random.default_rng(0), 0.0, {"terminated": 0, "truncated": 0}
    for _ in range(steps):
        actions = _actions(obs, rng)
        obs, reward, terminated, truncated, info = mujoco_env.step(actions)
        obs_a, reward_a, terminated_a, truncated_a, info_a = analytic.step(actions)
        worst = max(worst, _angles_apart(obs, obs_a).max(), np.abs(reward - reward_a).max())
        np.testing.assert_array_equal(terminated, terminated_a)
        np.testing.assert_array_equal(truncated, truncated_a)
        assert info.keys() == info_a.keys()
        for key, value in info.items():
            if value.dtype == bool:
                np.testing.assert_array_equal(value, info_a[key])
            else:
                worst = max(worst, np.abs(value - info_a[key]).max())
        ends["terminated"] += int(terminated.sum())
        ends["truncated"] += int(truncated.sum())
    assert worst <= TOLERANCE
    return {"worst": worst, **ends}


@pytest.mark.parametrize(
    ("case", "n", "nthread"),  # one thread, and numba's (the parallel kernel)
    [
        ("height_goal", 1, None),
        pytest.param("height_goal", 64, 2, marks=pytest.mark.slow),  # about 4 s
        ("balance", 1, None),
        ("balance", 32, 2),
    ],
)
def test_trajectories_match_mujoco_through_autoresets(case, n, nthread) -> None:
    result = _compare(n, 1000, nthread=nthread, **CASES[case])
    assert result["terminated"] + result["truncated"] >= 9 * n  # an autoreset after each
    if case == "height_goal" and n > 1:
        assert result["terminated"] >= n  # the goal reached, and reset
    assert result["worst"] > 0  # different arithmetic: a test of both, not of one twice


def test_fast_starts_through_the_velocity_limits_match_mujoco() -> None:
    # Random states at up to the velocity limits: MuJoCo moves the angles with the unclipped
    # velocity, then the env clips it; a kernel that clipped first would be 1e-3 off here.
    n, rng = 64, np.random.default_rng(4)
    envs = [AcrobotVectorEnv(num_envs=n, backend=b) for b in ("mujoco", "analytic")]
    starts = np.concatenate(
        [rng.uniform(-math.pi, math.pi, (n, 2)), rng.uniform(-1, 1, (n, 2)) * (MAX_VEL1, MAX_VEL2)],
        1,
    )
    for env in envs:
        env.reset(seed=0)
        env._qpos[...], env._qvel[...] = starts[:, :2], starts[:, 2:]
    clipped = 0
    for _ in range(20):
        actions = rng.integers(0, 3, n)
        (obs, reward, *_), (obs_a, reward_a, *_) = (env.step(actions) for env in envs)
        assert _angles_apart(obs, obs_a).max() <= TOLERANCE
        assert np.abs(reward - reward_a).max() <= TOLERANCE
        clipped += np.count_nonzero(np.abs(obs[:, 2:]) == (MAX_VEL1, MAX_VEL2))
    assert clipped > 20


def test_continuous_actions_match_mujoco() -> None:
    kwargs = {"continuous": True, "frame_skip": 4, "max_episode_steps": 100}
    envs = [AcrobotVectorEnv(num_envs=4, backend=b, **kwargs) for b in ("mujoco", "analytic")]
    results = [env.reset(seed=1) for env in envs]
    torques = np.random.default_rng(0).uniform(-1.0, 1.0, (300, 4, 1))
    for tau in torques:
        results = [env.step(tau) for env in envs]
        assert _angles_apart(results[0][0], results[1][0]).max() <= TOLERANCE


def test_the_compiled_step_is_the_python_step_bit_for_bit() -> None:
    # integrators.step compiled by numba (the backend's, the identified model's) against the
    # same source run as Python, one state at a time and over rows (step_rows, as the backend
    # steps).
    rng = np.random.default_rng(5)
    theta = lumped_parameters(AcrobotVectorEnv().model)
    limits = (MAX_VEL1, MAX_VEL2)
    jit = compiled(step)
    clipped = 0
    for _ in range(2000):
        x = (*rng.uniform(-4, 4, 2), *(rng.uniform(-1.2, 1.2, 2) * (MAX_VEL1, MAX_VEL2)))
        tau, substeps = float(rng.uniform(-1, 1)), int(rng.integers(1, 5))
        python = step(*x, tau, theta, 0.05, limits, substeps)
        assert jit(*x, tau, theta, 0.05, limits, substeps) == python
        clipped += abs(python[2]) == MAX_VEL1 or abs(python[3]) == MAX_VEL2
    assert clipped > 100  # the clipping was exercised
    nan = step(0.0, 0.0, math.nan, 0.0, 0.0, theta, 0.05, limits)
    assert math.isnan(jit(0.0, 0.0, math.nan, 0.0, 0.0, theta, 0.05, limits)[2])
    assert math.isnan(nan[2])
    states = np.concatenate(
        [rng.uniform(-4, 4, (500, 2)), rng.uniform(-1.2, 1.2, (500, 2)) * (MAX_VEL1, MAX_VEL2)], 1
    )
    states[7, 2] = math.nan
    torques, constants = rng.uniform(-1, 1, 500), np.array([*theta, 0.05, *limits])
    rows, python_rows = states.copy(), states.copy()
    compiled(step_rows)(rows, torques, constants, 3, 0)
    step_rows(python_rows, torques, constants, 3, 0)
    np.testing.assert_array_equal(rows, python_rows)
    assert math.isnan(rows[7, 2])


def test_the_compiled_observation_is_the_shared_one_bit_for_bit() -> None:
    wrap_jit = compiled(xp.wrap)
    rng = np.random.default_rng(6)
    angles = np.concatenate(
        [
            rng.uniform(-4, 4, 4000),
            rng.uniform(-1e6, 1e6, 4000),
            [
                math.pi,
                -math.pi,
                np.nextafter(math.pi, 0),
                np.nextafter(-math.pi, -4),
                3 * math.pi,
                -3 * math.pi,
                0.0,
                -0.0,
                1e6 - 1,
                2 * math.pi,
            ],
        ]
    )
    wrapped = wrap_angle(angles)
    jit_wrapped = np.array([wrap_jit(float(a)) for a in angles])
    np.testing.assert_array_equal(jit_wrapped, wrapped)
    assert np.array_equal(np.signbit(jit_wrapped), np.signbit(wrapped))
    physics = AnalyticPhysics(AcrobotVectorEnv().model, 500)
    physics.qpos[...] = rng.uniform(-20, 20, (500, 2))
    physics.qvel[...] = rng.uniform(-30, 30, (500, 2))
    expected = physics.state.copy()  # numpy's wrapping of the angles
    expected[:, :2] = wrap_angle(expected[:, :2])
    np.testing.assert_array_equal(physics.observe(), expected)


def test_threads_change_no_number_and_follow_the_size() -> None:
    kwargs = {"backend": "analytic", **CASES["height_goal"]}
    runs = []
    for nthread in (1, 2):
        env = AcrobotVectorEnv(num_envs=64, nthread=nthread, **kwargs)
        obs, _ = env.reset(seed=9)
        rng, rows = np.random.default_rng(0), []
        for _ in range(300):
            obs = env.step(_actions(obs, rng))[0]
            rows.append(obs)
        runs.append(np.array(rows))
    np.testing.assert_array_equal(runs[0], runs[1])
    model = env.model
    every = AnalyticPhysics(model, THREADED_FROM, 0).nthread  # numba's threads
    assert env.nthread == min(2, every)
    assert AnalyticPhysics(model, THREADED_FROM - 1).nthread == 1
    assert AnalyticPhysics(model, THREADED_FROM).nthread == every
    assert AnalyticPhysics(model, 3, 64).nthread <= 3  # at most one per acrobot


def test_make_vec_pickling_and_rendering() -> None:
    vec = gym.make_vec(
        acrobot_mj.ENV_ID,
        num_envs=3,
        backend="analytic",
        render_mode="rgb_array",
        width=32,
        height=24,
        **CASES["height_goal"],
    )
    env = vec.unwrapped
    assert isinstance(env, AcrobotVectorEnv) and env.backend == "analytic" and env.batch is None
    obs, _ = vec.reset(seed=2)
    rng = np.random.default_rng(1)
    for _ in range(40):
        obs = vec.step(_actions(obs, rng))[0]
    twin = pickle.loads(pickle.dumps(vec))
    for _ in range(150):  # through autoresets: the copy's generators and counters too
        actions = _actions(obs, rng)
        a, b = vec.step(actions), twin.step(actions)
        for x, y in zip(a[:4], b[:4], strict=True):
            np.testing.assert_array_equal(x, y)
        obs = a[0]
    # The frame of a MuJoCo vector env put in the same state is the same picture.
    reference = AcrobotVectorEnv(num_envs=3, render_mode="rgb_array", width=32, height=24)
    reference.call("set_state", env.get_attr("state")[0][:2], env.get_attr("state")[0][2:])
    np.testing.assert_array_equal(env.render()[0], reference.render()[0])  # sub-env 0


def test_a_pickle_from_before_the_backends_is_refused_in_one_line() -> None:
    vec = AcrobotVectorEnv(num_envs=2)
    vec.reset(seed=1)
    state = vec.__getstate__()
    del state["backend"]  # as pickled by a version without backends
    old = AcrobotVectorEnv.__new__(AcrobotVectorEnv)
    with pytest.raises(ValueError, match=r"pickled by acrobot_mj before 0\.4\.0") as error:
        old.__setstate__(state)
    assert "\n" not in str(error.value)


def test_a_bad_state_is_refused_naming_the_sub_env() -> None:
    n = 3
    vec = AcrobotVectorEnv(num_envs=n, backend="analytic")
    vec.reset(seed=0)
    vec._qvel[1, 0] = math.nan  # NaN stays NaN through the kernel's clipping
    with pytest.raises(RuntimeError, match=r"sub-envs \[1\] reached a non-finite"):
        vec.step(np.ones(n, dtype=np.int64))
    assert math.isnan(vec.get_attr("state")[1][2])


def _model_file(tmp_path, *edits: tuple[str, str]) -> str:
    """The packaged scene with each edit's old text replaced by its new one in acrobot.xml."""
    robot = (models_dir() / "acrobot.xml").read_text()
    for old, new in edits:
        assert old in robot
        robot = robot.replace(old, new, 1)
    (tmp_path / "acrobot.xml").write_text(robot)
    (tmp_path / "scene.xml").write_text((models_dir() / "scene.xml").read_text())
    return str(tmp_path / "scene.xml")


def test_the_parameters_come_from_the_model(tmp_path) -> None:
    lumped = lumped_parameters(AcrobotVectorEnv().model)
    assert lumped == pytest.approx((3.5, 0.5, 1.25, 14.7, 4.9), abs=1e-12)  # the report's
    link2 = '<inertial pos="0.5 0 0" mass="1" diaginertia="0.001 1 1"/>\n        <geom name="link2"'
    heavy = link2.replace('mass="1" diaginertia="0.001 1 1"', 'mass="2" diaginertia="1 1.5 1.5"')
    heavier = _model_file(tmp_path, (link2, heavy))
    model = AcrobotVectorEnv(model_path=heavier).model
    assert lumped_parameters(model) == pytest.approx((5.25, 1.0, 2.0, 24.5, 9.8), abs=1e-12)
    result = _compare(2, 200, model_path=heavier, frame_skip=4, max_episode_steps=100)
    assert result["terminated"] + result["truncated"] >= 2


@pytest.mark.parametrize(
    ("kwargs", "edit", "match"),
    [
        ({"backend": "numpy"}, None, r"backend must be one of \['mujoco', 'analytic'\]"),
        ({"backend": "analytic", "integrator": "rk4"}, None, "semi-implicit Euler only"),
        ({"backend": "analytic"}, ('damping="0"', 'damping="0.1"'), r"damping \[0.1, 0.1\]"),
        ({"backend": "analytic"}, ('armature="0"', 'armature="0.2"'), "armature"),
        (
            {"backend": "analytic"},
            [
                ('<flag constraint="disable"', "<flag"),
                ('name="shoulder"/>', 'name="shoulder" range="-3 3"/>'),
            ],
            "joint limits, equality constraints or contacts",
        ),
        # A centre of mass off the link's line: a dynamics the lumped form has no term for.
        (
            {"backend": "analytic"},
            ('pos="0.5 0 0" mass="1"', 'pos="0.5 0 0.2" mass="1"'),
            "dynamics differ from the lumped acrobot's",
        ),
    ],
)
def test_what_the_analytic_model_cannot_represent_is_refused(tmp_path, kwargs, edit, match):
    if edit is not None:
        edits = edit if isinstance(edit, list) else [edit]
        kwargs = {**kwargs, "model_path": _model_file(tmp_path, *edits)}
    with pytest.raises(ValueError, match=match):
        AcrobotVectorEnv(num_envs=2, **kwargs)


def test_numba_is_imported_only_when_a_kernel_is_compiled_and_can_be_missing() -> None:
    # numba is a dependency, loaded when the first kernel is compiled; where it cannot load, the
    # kernels run as the same Python source, after one line on stderr: the same numbers.
    code = (
        "import sys; import acrobot_mj.envs.vector as v; assert 'numba' not in sys.modules\n"
        "sys.modules['numba'] = None  # as if numba could not load\n"
        "import json, numpy as np\n"
        "env = v.AcrobotVectorEnv(num_envs=2, backend='analytic', **{kwargs!r})\n"
        "obs, _ = env.reset(seed=0)\n"
        "for _ in range(20):\n    obs = env.step(np.array([0, 2]))[0]\n"
        "print(json.dumps(obs.tolist()))\n"
    ).format(kwargs=CASES["height_goal"])
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stderr.startswith("acrobot-mj: numba cannot load")
    assert out.stderr.count("\n") == 1  # one line
    env = AcrobotVectorEnv(num_envs=2, backend="analytic", **CASES["height_goal"])
    obs, _ = env.reset(seed=0)
    for _ in range(20):
        obs = env.step(np.array([0, 2]))[0]
    assert json.loads(out.stdout) == obs.tolist()  # the compiled kernels' numbers, bit for bit


def test_the_dynamics_check_refuses_wrong_parameters(monkeypatch) -> None:
    model = AcrobotVectorEnv().model
    right = batch.physical_parameters(model)
    assert lumped_parameters(model) == right.lumped  # the model's parameters pass the check
    # Parameters read wrongly from the model (I2 off by 1e-6): the check against MuJoCo's
    # accelerations refuses them.
    monkeypatch.setattr(batch, "physical_parameters", lambda model: AcrobotParams(I2=1.0 + 1e-6))
    with pytest.raises(ValueError, match="dynamics differ"):
        lumped_parameters(model)


def _step_threaded(n: int) -> None:
    env = AcrobotVectorEnv(num_envs=n, backend="analytic", nthread=2)
    env.reset(seed=1)
    for _ in range(5):
        env.step(np.ones(n, dtype=np.int64))


def test_a_process_forked_after_the_threaded_kernels_can_run_them() -> None:
    # Under GNU OpenMP (numba's default layer where libgomp is found) a child forked after the
    # parent ran a parallel kernel aborts when it runs one; the backend picks a fork-safe layer.
    import multiprocessing

    _step_threaded(64)
    child = multiprocessing.get_context("fork").Process(target=_step_threaded, args=(64,))
    child.start()
    child.join(60)
    assert child.exitcode == 0
