"""The compiled row kernels (numba) against the numpy calls they replace: the same numbers bit
for bit, the same refusals, nothing written on a bad action."""

from __future__ import annotations

import numpy as np
import pytest

from acrobot_mj.envs import batch_physics
from acrobot_mj.envs.batch_physics import FEW, THREADED_FROM, checked_observation
from acrobot_mj.envs.env import HUGE, MAX_ANGLE
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2, TORQUES
from acrobot_mj.envs.tasks import ARRAY, get_task
from acrobot_mj.envs.vector import AcrobotVectorEnv
from tests.test_vector import KWARGS, _actions, _assert_identical, _run

kernels = pytest.importorskip("acrobot_mj.envs.row_kernels")  # the fast extra

#: Velocities at and around both limits, signed zeros, infinities and NaN [rad/s].
EDGES = np.array(
    [0.0, -0.0, MAX_VEL1, -MAX_VEL1, MAX_VEL2, -MAX_VEL2, np.nextafter(MAX_VEL1, np.inf),
     np.nextafter(-MAX_VEL2, -np.inf), 1e300, -np.inf, np.inf, np.nan, 3.0, -40.0]
)  # fmt: skip


def test_limit_rows_is_np_clip_on_a_strided_view() -> None:
    rng = np.random.default_rng(0)
    values = np.concatenate((EDGES, rng.uniform(-60.0, 60.0, 500)))
    rows = np.stack((values, rng.permutation(values)), axis=1)
    state = np.zeros((len(rows), 7))  # qvel inside wider rows, as in the batch's state
    state[:, 3:5] = rows
    kernels.limit_rows(state[:, 3:5], MAX_VEL1, MAX_VEL2)
    expected = np.stack(
        (np.clip(rows[:, 0], -MAX_VEL1, MAX_VEL1), np.clip(rows[:, 1], -MAX_VEL2, MAX_VEL2)), 1
    )
    # Bit for bit, NaN kept and -0.0 left as it is (array_equal would take -0.0 == 0.0).
    assert state[:, 3:5].tobytes() == expected.tobytes()
    assert not state[:, [0, 1, 2, 5, 6]].any()  # nothing outside the view written


def test_observe_rows_is_checked_observation() -> None:
    rng = np.random.default_rng(1)
    state = np.stack(
        [
            rng.uniform(-9.0, 9.0, 400),
            rng.uniform(-9.0, 9.0, 400),
            rng.uniform(-MAX_VEL1, MAX_VEL1, 400),
            rng.uniform(-MAX_VEL2, MAX_VEL2, 400),
        ],
        1,
    )  # fmt: skip  (angles beyond +-pi: wrapped)
    state[:4, 0] = [np.pi, -np.pi, np.nextafter(np.pi, 0.0), 3 * np.pi]  # the interval's ends
    obs = np.empty_like(state)
    assert kernels.observe_rows(state, obs, MAX_ANGLE, HUGE)
    assert obs.tobytes() == checked_observation(state.copy(), few=False).tobytes()
    for row, column, value in [(5, 2, np.nan), (9, 0, MAX_ANGLE), (0, 3, HUGE)]:
        bad = state.copy()
        bad[row, column] = value
        assert not kernels.observe_rows(bad, obs, MAX_ANGLE, HUGE)
        with pytest.raises(RuntimeError, match=rf"sub-envs \[{row}\]"):
            checked_observation(bad, few=False)


def test_discrete_torques_write_all_or_nothing() -> None:
    torques, ctrl = np.array(TORQUES), np.full((6, 1), 7.0)
    assert kernels.discrete_torques(np.array([0, 1, 2, 2, 1, 0]), torques, ctrl) == -1
    np.testing.assert_array_equal(ctrl[:, 0], [-1.0, 0.0, 1.0, 1.0, 0.0, -1.0])
    for bad, first in [([0, 1, 3, 2, -1, 0], 2), ([0, 0, 0, 0, 0, -1], 5)]:
        before = ctrl.copy()
        assert kernels.discrete_torques(np.array(bad), torques, ctrl) == first
        np.testing.assert_array_equal(ctrl, before)  # nothing written


def _numpy_and_compiled(monkeypatch, n: int, **kwargs) -> tuple[AcrobotVectorEnv, ...]:
    compiled = AcrobotVectorEnv(num_envs=n, **kwargs)
    monkeypatch.setattr(batch_physics, "COMPILED", False)
    numpy = AcrobotVectorEnv(num_envs=n, **kwargs)
    assert compiled.physics.kernels is kernels and numpy.physics.kernels is None
    return numpy, compiled


def _same_bytes(a: list[list[np.ndarray]], b: list[list[np.ndarray]]) -> None:
    _assert_identical(a, b)  # shapes and values, then the bits (-0.0 is not 0.0 here)
    for step_a, step_b in zip(a, b, strict=True):
        assert [np.asarray(x).tobytes() for x in step_a] == [
            np.asarray(y).tobytes() for y in step_b
        ]


# The height goal low enough that random actions reach it within 60 steps (terminations), and
# the balance task (no termination, wrapped angle errors).
TASK_OPTIONS = [{}, {"goal_height": -1.5}, {"task": "balance", "tolerance": 2.0}]


@pytest.mark.parametrize("n", [FEW + 1, THREADED_FROM])  # one thread, and the batch's threads
@pytest.mark.parametrize("options", TASK_OPTIONS)
def test_the_vector_env_steps_alike_with_and_without_the_kernels(monkeypatch, n, options) -> None:
    # Through autoresets, velocity limits (set_state puts sub-envs at them) and angle wrapping,
    # with the task's compiled outcome against outcome(ARRAY).
    numpy, compiled = _numpy_and_compiled(monkeypatch, n, **KWARGS, **options)
    assert "compiled_outcome" in compiled._outcome.__qualname__  # the task's compiled rule
    assert "compiled_outcome" not in numpy._outcome.__qualname__
    actions = _actions(300, n)
    reference = _run(numpy, actions, seed=5)
    _same_bytes(reference, _run(compiled, actions, seed=5))
    obs = np.array([r[0] for r in reference])
    assert (np.abs(obs[..., 2]) == MAX_VEL1).any() and (np.abs(obs[..., 3]) == MAX_VEL2).any()
    assert np.array([r[3] for r in reference]).sum() >= n  # truncations, then autoresets
    if "goal_height" in options:
        assert np.array([r[2] for r in reference]).sum() >= n  # terminations too


@pytest.mark.parametrize(
    "name, options",
    [("height_goal", {}), ("height_goal", {"goal_height": -0.3, "goal_reward": 7.5,
     "step_reward": -0.25}), ("balance", {}), ("balance", {"tolerance": 1.0})],
)  # fmt: skip
def test_the_compiled_outcomes_are_the_array_rule_bit_for_bit(name, options) -> None:
    task = get_task(name)((1.0, 1.0), **options)
    rng = np.random.default_rng(7)
    states = rng.uniform(-9.0, 9.0, (4, 3000))  # angles beyond +-pi: wrapped errors
    states[0, :6] = [np.pi, -np.pi, np.pi / 2, -np.pi / 2, 3 * np.pi, np.nextafter(np.pi, 0)]
    # NaN or inf in one operand: as numpy's (where both are NaN or inf, a NaN's sign bit can
    # differ; the envs raise on such states before the outcome runs)
    states[1, :6] = [0.0, -0.0, np.pi, -np.pi, np.nan, np.inf]
    states[:2, 6] = [np.pi / 2, 0.0]  # upright: balanced
    rows = np.zeros((3000, 7))  # strided columns, as the batch's views
    rows[:, 1:5] = states.T
    columns = tuple(rows[:, k] for k in range(1, 5))
    with np.errstate(invalid="ignore"):
        expected = task.outcome(ARRAY)(*columns)
    got = task.compiled_outcome()(*columns)
    for x, y in zip(got[:2], expected[:2], strict=True):
        assert np.broadcast_to(x, (3000,)).tobytes() == np.broadcast_to(y, (3000,)).tobytes()
    assert got[2].keys() == expected[2].keys()
    for key in expected[2]:
        assert got[2][key].tobytes() == expected[2][key].tobytes(), key
    # New arrays, none shared: the vector env hands them on without copies.
    arrays = [got[0], got[1], *got[2].values()]
    assert all(a.shape == (3000,) and a.flags.owndata for a in arrays)
    assert not any(np.shares_memory(a, b) for i, a in enumerate(arrays) for b in arrays[:i])
    assert 0 < np.count_nonzero(expected[2]["is_success"]) < 3000  # both outcomes occur


def test_rows_outcome_falls_back_to_the_array_rule(monkeypatch) -> None:
    task = get_task("height_goal")((1.0, 1.0))
    assert "compiled_outcome" in task.rows_outcome(True)[0].__qualname__
    assert "compiled_outcome" not in task.rows_outcome(False)[0].__qualname__
    monkeypatch.setattr(type(task), "compiled_outcome", lambda self: None)  # a task without one
    assert "compiled_outcome" not in task.rows_outcome(True)[0].__qualname__

    def broken(self):
        raise ImportError("numba: built for another numpy")

    monkeypatch.setattr(type(task), "compiled_outcome", broken)
    assert "compiled_outcome" not in task.rows_outcome(True)[0].__qualname__


def test_a_subclass_with_its_own_rule_is_not_given_its_parents_compiled_one() -> None:
    # A user's variant of the height goal that rewards the tip's height: the built-in compiled
    # height goal would give it -1 and +100 instead, silently.
    height_goal = get_task("height_goal")

    class Variant(height_goal):
        def outcome(self, xp):
            rule = super().outcome(xp)

            def outcome(q1, q2, dq1, dq2):
                _, reached, info = rule(q1, q2, dq1, dq2)
                return info["tip_height"], reached, info

            return outcome

    class Recompiled(Variant):  # one that compiles its rule again is given it
        def compiled_outcome(self):
            return height_goal.compiled_outcome(self)

    assert "compiled_outcome" not in Variant((1.0, 1.0)).rows_outcome(True)[0].__qualname__
    assert "compiled_outcome" in Recompiled((1.0, 1.0)).rows_outcome(True)[0].__qualname__
    env = AcrobotVectorEnv(num_envs=FEW + 1, task=Variant)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(np.ones(FEW + 1, dtype=np.int64))
    assert reward.tobytes() == info["tip_height"].tobytes()  # the variant's rule, not -1


def test_other_ways_out_of_the_compiled_rule_give_the_tasks_own() -> None:
    height_goal = get_task("height_goal")

    class NoCompiled(height_goal):  # a subclass that opts out
        compiled_outcome = None

    class GoalPerEnv(height_goal):  # its own numbers, not floats: one goal per sub-env
        def __init__(self, links, **options):
            super().__init__(links, **options)
            self.goal_height = np.array([1.0] + [-2.5] * FEW)  # [m]

    instance = height_goal((1.0, 1.0))
    instance.outcome = lambda xp: height_goal.outcome(instance, xp)  # an instance's own rule
    for task in (NoCompiled((1.0, 1.0)), GoalPerEnv((1.0, 1.0)), instance):
        assert task.rows_outcome(True)[1] is False
    env = AcrobotVectorEnv(num_envs=FEW + 1, task=GoalPerEnv)
    env.reset(seed=0)
    terminated = env.step(np.ones(FEW + 1, dtype=np.int64))[2]
    # Near hanging the tip is about 2 m below the pivot: above -2.5 m, not above 1 m.
    assert terminated.tolist() == [False] + [True] * FEW


# The first two reach the kernel (int64 of the batch's shape) and are refused there; the others
# (another dtype, shape or kind) take numpy's path with the kernels present.
@pytest.mark.parametrize(
    "actions",
    [np.array([0, 1, 3] * 5), np.array([-1] + [0] * 14), np.zeros(15, dtype=np.int32) + 5,
     np.zeros(14, dtype=np.int64), np.zeros(15)],
)  # fmt: skip
def test_bad_actions_get_the_same_error_and_write_nothing(monkeypatch, actions) -> None:
    envs = _numpy_and_compiled(monkeypatch, 15)
    messages = []
    for env in envs:
        env.reset(seed=0)
        env.step(np.full(15, 2))
        before = env.batch.state.copy()
        with pytest.raises(ValueError) as error:
            env.step(actions)
        messages.append(str(error.value))
        assert env.batch.state.tobytes() == before.tobytes()  # no control written
    assert messages[0] == messages[1]


def test_the_analytic_backend_takes_its_torques_alike(monkeypatch) -> None:
    # The analytic backend shares the torque kernel (its own step limits the velocities).
    pytest.importorskip("acrobot_mj.envs.analytic_kernel")
    numpy, compiled = _numpy_and_compiled(monkeypatch, FEW + 4, backend="analytic")
    actions = _actions(200, FEW + 4)
    for env in (numpy, compiled):
        env.reset(seed=3)
    for a in actions:
        for x, y in zip(numpy.step(a)[:4], compiled.step(a)[:4], strict=True):
            assert x.tobytes() == y.tobytes()
    assert numpy.physics.snapshot().tobytes() == compiled.physics.snapshot().tobytes()


def test_a_numba_that_fails_to_load_leaves_numpys_calls(monkeypatch) -> None:
    # Installed but broken (built for another numpy, say): the env still works, unchanged.
    import builtins

    real = builtins.__import__

    def broken(name, *args, **kwargs):
        if name == "acrobot_mj.envs" and "row_kernels" in (args[2] or ()):
            raise ImportError("numba: built for another numpy")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", broken)
    env = AcrobotVectorEnv(num_envs=FEW + 3)
    assert env.physics.kernels is None
    env.reset(seed=0)
    assert env.step(np.ones(FEW + 3, dtype=np.int64))[0].shape == (FEW + 3, 4)
