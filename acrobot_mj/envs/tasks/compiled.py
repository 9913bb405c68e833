"""Compiled row forms of the built-in tasks' outcomes (numba, the ``fast`` extra; imported only
when a vector env of more than :data:`~acrobot_mj.envs.batch_physics.FEW` sub-envs asks for one,
through :meth:`~acrobot_mj.envs.tasks.base.Task.rows_outcome`).

Each kernel is the task's :meth:`~acrobot_mj.envs.tasks.base.Task.outcome` rule, one row at a
time, in the same operations in the same order (``math.sin`` is the C library's ``sin``, as
numpy's is here; no fast-math, so no fused multiply-adds): the numbers are the same bit for bit
as ``outcome(ARRAY)``'s (``tests/test_row_kernels.py`` compares them). One pass over the rows
replaces the rule's seven to twelve numpy calls (about 1 us each up to a few hundred rows,
measured: docs/speed.md).
"""

from __future__ import annotations

import math

from acrobot_mj.envs.row_kernels import wrap_jit

try:
    from numba import njit
except ImportError as error:  # pragma: no cover  (the fast extra is missing)
    raise ImportError("the compiled outcomes need numba: pip install acrobot-mj[fast]") from error


@njit(cache=True)
def height_goal_rows(  # pragma: no cover  (compiled)
    q1, q2, l1, l2, height, goal_reward, step_reward, reward, reached, success, tip
):
    """The height goal's rule: ``tip = l1 sin q1 + l2 sin(q1 + q2)`` [m], ``reached = tip >
    height`` (also the success) and the reward, written into ``reward``, ``reached``,
    ``success`` and ``tip`` row by row."""
    for i in range(q1.shape[0]):
        h = l1 * math.sin(q1[i]) + l2 * math.sin(q1[i] + q2[i])
        tip[i] = h
        reached[i] = success[i] = h > height
        reward[i] = goal_reward if h > height else step_reward


@njit(cache=True)
def balance_rows(  # pragma: no cover  (compiled)
    q1, q2, tolerance, up, reward, error, balanced, success
):
    """The balance task's rule: ``reward = (1 + sin q1)(1 + cos q2) / 4``, the larger wrapped
    angle error from upright [rad] (``np.maximum``'s: NaN wins) and ``error < tolerance`` (also
    the success), written into ``reward``, ``error``, ``balanced`` and ``success`` row by row."""
    for i in range(q1.shape[0]):
        a, b = q1[i], q2[i]
        reward[i] = (1.0 + math.sin(a)) * (1.0 + math.cos(b)) / 4.0
        e1, e2 = abs(wrap_jit(a - up)), abs(wrap_jit(b))
        e = e1 if (e1 >= e2 or e1 != e1) else e2
        error[i] = e
        balanced[i] = success[i] = e < tolerance
