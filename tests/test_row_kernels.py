"""The compiled row kernels (numba) against the same Python source run uncompiled: the same
numbers bit for bit, the same refusals, nothing written on a bad action; and the tasks' rules
compiled over rows (``Task.outcomes``) against the rule run row by row in Python."""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from types import FunctionType

import numpy as np
import pytest

import acrobot_mj.compiled
from acrobot_mj.compiled import compiled
from acrobot_mj.envs import batch, tasks
from acrobot_mj.envs.acrobot import HUGE, MAX_ANGLE
from acrobot_mj.envs.batch import THREADED_FROM
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2, TORQUES, discrete_torques
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.physics.integrators import step_rows
from acrobot_mj.physics.xp import wrap_angle
from tests.test_vector import KWARGS, _actions, _assert_identical, _run

#: Velocities at and around both limits, signed zeros, infinities and NaN [rad/s].
EDGES = np.array(
    [
        0.0,
        -0.0,
        MAX_VEL1,
        -MAX_VEL1,
        MAX_VEL2,
        -MAX_VEL2,
        np.nextafter(MAX_VEL1, np.inf),
        np.nextafter(-MAX_VEL2, -np.inf),
        1e300,
        -np.inf,
        np.inf,
        np.nan,
        3.0,
        -40.0,
    ]
)


@contextmanager
def uncompiled() -> Iterator[None]:
    """Inside, every kernel is its Python source (``compiled(f)`` returns ``f``, as where numba
    cannot load) and the tasks' rules over rows are built again, uncompiled."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(acrobot_mj.compiled, "_NUMBA", False)  # numba "cannot load": no message
        patch.setattr(acrobot_mj.compiled, "_COMPILED", {})
        patch.setattr(tasks, "_ROWS", {})
        yield


def _is_python(env: AcrobotVectorEnv) -> bool:
    """Whether ``env`` (reset once) steps on the kernels' Python source, not numba's."""
    python_kernel = step_rows if env.backend == "analytic" else batch.limit_rows
    kernel = env.physics._step if env.backend == "analytic" else env.physics._limit
    return isinstance(env.task._compiled_rows, FunctionType) and kernel is python_kernel


@pytest.mark.parametrize("limit_rows", [compiled(batch.limit_rows), batch.limit_rows])
def test_limit_rows_is_np_clip_on_a_strided_view(limit_rows) -> None:
    rng = np.random.default_rng(0)
    values = np.concatenate((EDGES, rng.uniform(-60.0, 60.0, 500)))
    rows = np.stack((values, rng.permutation(values)), axis=1)
    state = np.zeros((len(rows), 7))  # qvel inside wider rows, as in the batch's state
    state[:, 3:5] = rows
    limit_rows(state[:, 3:5], MAX_VEL1, MAX_VEL2)
    expected = np.stack(
        (np.clip(rows[:, 0], -MAX_VEL1, MAX_VEL1), np.clip(rows[:, 1], -MAX_VEL2, MAX_VEL2)), 1
    )
    # Bit for bit, NaN kept and -0.0 left as it is (array_equal would take -0.0 == 0.0).
    assert state[:, 3:5].tobytes() == expected.tobytes()
    assert not state[:, [0, 1, 2, 5, 6]].any()  # nothing outside the view written


def test_observe_rows_compiled_is_observe_rows_in_python() -> None:
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
    qpos, qvel = state[:, :2], state[:, 2:]  # strided views, as the batch's
    obs, python = np.empty_like(state), np.empty_like(state)
    assert compiled(batch.observe_rows)(qpos, qvel, obs, MAX_ANGLE, HUGE)
    assert batch.observe_rows(qpos, qvel, python, MAX_ANGLE, HUGE)
    assert obs.tobytes() == python.tobytes()
    expected = state.copy()  # numpy's wrapping of the angles
    expected[:, :2] = wrap_angle(expected[:, :2])
    assert obs.tobytes() == expected.tobytes()
    for row, column, value in [(5, 2, np.nan), (9, 0, MAX_ANGLE), (0, 3, HUGE)]:
        bad = state.copy()
        bad[row, column] = value
        assert not compiled(batch.observe_rows)(bad[:, :2], bad[:, 2:], obs, MAX_ANGLE, HUGE)
        assert not batch.observe_rows(bad[:, :2], bad[:, 2:], python, MAX_ANGLE, HUGE)
        with pytest.raises(RuntimeError, match=rf"sub-envs \[{row}\]"):
            batch.observe(bad[:, :2], bad[:, 2:])


@pytest.mark.parametrize("kernel", [compiled(discrete_torques), discrete_torques])
def test_discrete_torques_write_all_or_nothing(kernel) -> None:
    torques, ctrl = np.array(TORQUES), np.full((6, 1), 7.0)
    assert kernel(np.array([0, 1, 2, 2, 1, 0]), torques, ctrl) == -1
    np.testing.assert_array_equal(ctrl[:, 0], [-1.0, 0.0, 1.0, 1.0, 0.0, -1.0])
    for bad, first in [([0, 1, 3, 2, -1, 0], 2), ([0, 0, 0, 0, 0, -1], 5)]:
        before = ctrl.copy()
        assert kernel(np.array(bad), torques, ctrl) == first
        np.testing.assert_array_equal(ctrl, before)  # nothing written


def _same_bytes(a: list[list[np.ndarray]], b: list[list[np.ndarray]]) -> None:
    _assert_identical(a, b)  # shapes and values, then the bits (-0.0 is not 0.0 here)
    for step_a, step_b in zip(a, b, strict=True):
        assert [np.asarray(x).tobytes() for x in step_a] == [
            np.asarray(y).tobytes() for y in step_b
        ]


# The height goal low enough that random actions reach it within 60 steps (terminations), and
# the balance task (no termination, wrapped angle errors).
TASK_OPTIONS = [{}, {"goal_height": -1.5}, {"task": "balance", "tolerance": 2.0}]


@pytest.mark.parametrize(
    "n", [9, pytest.param(THREADED_FROM, marks=pytest.mark.slow)]
)  # one thread, and the batch's threads
@pytest.mark.parametrize("options", TASK_OPTIONS)
def test_the_vector_env_steps_alike_compiled_and_in_python(n, options) -> None:
    # Through autoresets, velocity limits (set_state puts sub-envs at them) and angle wrapping,
    # with the task's rule compiled over rows against the same rule run in Python.
    actions = _actions(300, n)
    fast = AcrobotVectorEnv(num_envs=n, **KWARGS, **options)
    fast.reset(seed=5)
    assert not _is_python(fast)  # numba's kernels and the task's compiled rule
    reference = _run(fast, actions, seed=5)
    with uncompiled():
        python = AcrobotVectorEnv(num_envs=n, **KWARGS, **options)
        python.reset(seed=5)
        assert _is_python(python)
        _same_bytes(reference, _run(python, actions, seed=5))
    obs = np.array([r[0] for r in reference])
    assert (np.abs(obs[..., 2]) == MAX_VEL1).any() and (np.abs(obs[..., 3]) == MAX_VEL2).any()
    assert np.array([r[3] for r in reference]).sum() >= n  # truncations, then autoresets
    if "goal_height" in options:
        assert np.array([r[2] for r in reference]).sum() >= n  # terminations too


def _rule_by_rows(task, columns) -> tuple:
    """``task.rule()`` run in Python row by row, as ``outcomes`` returns it (None where the
    Python rule raises: ``math.sin`` refuses infinities where numba's gives NaN)."""
    rule, n = task.rule(), len(columns[0])
    reward, flags = np.empty(n), np.empty((2, n), bool)
    values = np.empty((len(task.info_keys), n))
    refused = []
    for i, row in enumerate(zip(*(c.tolist() for c in columns), strict=True)):
        try:
            r, t, s, v = rule(*row)
        except ValueError:  # math domain error
            refused.append(i)
            continue
        reward[i], flags[0, i], flags[1, i], values[:, i] = r, t, s, v
    info = {key: values[j] for j, key in enumerate(task.info_keys)}
    info.update(dict.fromkeys(task.success_keys, flags[1]))
    return reward, flags[0], info, refused


@pytest.mark.parametrize(
    "name, options",
    [
        ("height_goal", {}),
        ("height_goal", {"goal_height": -0.3, "goal_reward": 7.5, "step_reward": -0.25}),
        ("balance", {}),
        ("balance", {"tolerance": 1.0}),
    ],
)
def test_the_compiled_outcomes_are_the_python_rule_bit_for_bit(name, options) -> None:
    task = get_task(name)((1.0, 1.0), **options)
    rng = np.random.default_rng(7)
    states = rng.uniform(-9.0, 9.0, (4, 3000))  # angles beyond +-pi: wrapped errors
    states[0, :6] = [np.pi, -np.pi, np.pi / 2, -np.pi / 2, 3 * np.pi, np.nextafter(np.pi, 0)]
    # NaN or inf in one operand (the envs raise on such states before the rule runs)
    states[1, :6] = [0.0, -0.0, np.pi, -np.pi, np.nan, np.inf]
    states[:2, 6] = [np.pi / 2, 0.0]  # upright: balanced
    rows = np.zeros((3000, 7))  # strided columns, as the batch's views
    rows[:, 1:5] = states.T
    columns = tuple(rows[:, k] for k in range(1, 5))
    before = rows.copy()
    got = task.outcomes(*columns)
    assert rows.tobytes() == before.tobytes()  # the state is only read
    *expected, refused = _rule_by_rows(task, columns)
    # Python's math.sin and cos refuse an infinite angle (the height goal's sines, the balance
    # reward's); every other row, NaN included, is compared.
    assert refused == [5]
    keep = np.ones(3000, bool)
    keep[refused] = False
    for x, y in zip(got[:2], expected[:2], strict=True):
        assert x.shape == (3000,) and x[keep].tobytes() == y[keep].tobytes()
    assert got[2].keys() == expected[2].keys()
    for key in expected[2]:
        assert got[2][key][keep].tobytes() == expected[2][key][keep].tobytes(), key
    # The infinite angle gives NaN numbers and no success, compiled.
    assert all(math.isnan(got[2][key][5]) for key in task.info_keys)
    assert not any(got[2][key][5] for key in task.success_keys)
    # New arrays, none sharing memory with another or with the state: the vector env hands
    # them on without copies.
    arrays = [got[0], got[1], *got[2].values()]
    assert all(a.shape == (3000,) for a in arrays)
    assert not any(np.shares_memory(a, b) for i, a in enumerate(arrays) for b in arrays[:i])
    assert not any(np.shares_memory(a, rows) for a in arrays)
    assert 0 < np.count_nonzero(expected[2]["is_success"]) < 3000  # both outcomes occur


def test_a_subclass_with_its_own_rule_is_not_given_its_parents_compiled_one() -> None:
    # A user's variant of the height goal that rewards the tip's height: the built-in compiled
    # height goal would give it -1 and +100 instead, silently.
    height_goal = get_task("height_goal")

    class Variant(height_goal):
        def rule(self):
            l1, l2, height = self.l1, self.l2, self.goal_height

            def rule(q1, q2, dq1, dq2):
                tip = l1 * math.sin(q1) + l2 * math.sin(q1 + q2)
                return tip, tip > height, tip > height, (tip,)

            return rule

    n = 9
    plain = AcrobotVectorEnv(num_envs=n)  # the parent's rule compiled first, same settings
    plain.reset(seed=0)
    assert plain.step(np.ones(n, dtype=np.int64))[1].tolist() == [-1.0] * n
    env = AcrobotVectorEnv(num_envs=n, task=Variant)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(np.ones(n, dtype=np.int64))
    assert reward.tobytes() == info["tip_height"].tobytes()  # the variant's rule, not -1


# The first two reach the kernel (integers of the batch's shape) and are refused there; the
# others (another shape or kind) are refused before it, the third after it has checked them.
@pytest.mark.parametrize(
    "actions",
    [
        np.array([0, 1, 3] * 5),
        np.array([-1] + [0] * 14),
        np.zeros(15, dtype=np.int32) + 5,
        np.zeros(14, dtype=np.int64),
        np.zeros(15),
    ],
)
def test_bad_actions_get_the_same_error_and_write_nothing(actions) -> None:
    messages = []
    for python in (False, True):
        with uncompiled() if python else nullcontext():
            env = AcrobotVectorEnv(num_envs=15)
            env.reset(seed=0)
            assert _is_python(env) is python
            env.step(np.full(15, 2))
            before = env.batch.state.copy()
            with pytest.raises(ValueError) as error:
                env.step(actions)
            messages.append(str(error.value))
            assert env.batch.state.tobytes() == before.tobytes()  # no control written
    assert messages[0] == messages[1]


def test_the_analytic_backend_steps_alike_compiled_and_in_python() -> None:
    # The analytic backend shares the torque kernel and the observation; its own step (the
    # physics step over rows) limits the velocities.
    n = 12
    actions = _actions(200, n)
    runs = []
    for python in (False, True):
        with uncompiled() if python else nullcontext():
            env = AcrobotVectorEnv(num_envs=n, backend="analytic")
            env.reset(seed=3)
            assert _is_python(env) is python
            runs.append([[x.tobytes() for x in env.step(a)[:4]] for a in actions])
            runs[-1].append(env.physics.snapshot().tobytes())
    assert runs[0] == runs[1]


def test_a_numba_that_fails_to_load_leaves_the_python_kernels(monkeypatch, capsys) -> None:
    # Installed but broken (built for another numpy, say): the env still works, unchanged,
    # after one line on stderr.
    import builtins

    real = builtins.__import__

    def broken(name, *args, **kwargs):
        if name == "numba" or name.startswith("numba."):
            raise ImportError("numba: built for another numpy")
        return real(name, *args, **kwargs)

    reference = AcrobotVectorEnv(num_envs=11)
    reference.reset(seed=0)
    expected = reference.step(np.ones(11, dtype=np.int64))[0]
    with uncompiled():
        monkeypatch.setattr(acrobot_mj.compiled, "_NUMBA", None)  # not tried yet
        monkeypatch.setattr(builtins, "__import__", broken)
        env = AcrobotVectorEnv(num_envs=11)
        env.reset(seed=0)
        assert _is_python(env)
        obs = env.step(np.ones(11, dtype=np.int64))[0]
        monkeypatch.undo()
    assert obs.tobytes() == expected.tobytes()
    err = capsys.readouterr().err
    assert err.startswith("acrobot-mj: numba cannot load (ImportError: numba: built for")
    assert err.count("\n") == 1
