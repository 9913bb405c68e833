"""The physics of many acrobots: their MuJoCo states in one ``mujoco.batch.Batch``, stepped on
as many threads as pay off for the batch's size, with the task's velocity limits after every
physics step.

Threads cost a wake-up and a join on every ``Batch.step`` call: tens of microseconds, more on a
loaded machine, where a thread may wait for a core. One acrobot's ``mj_step`` costs about
1.3 us, so a batch of fewer than :data:`THREADED_FROM` simulations runs faster on the calling
thread alone (measured: ``benchmarks/suite.py``, and docs/speed.md). Every simulation is
computed by the same C code whatever thread runs it, so the thread count changes no number.

Between steps, batches of more than :data:`FEW` simulations limit velocities and build their
observations in compiled passes (:mod:`~acrobot_mj.envs.row_kernels`) when numba is installed
(the ``fast`` extra), else in numpy's calls: the same numbers either way. The time between
``Batch.step`` calls counts more than it measures alone: after a step the caches are cold, and
the same Python runs 1.6 to 2.3 times slower (measured: docs/speed.md).
"""

from __future__ import annotations

import importlib.util
import math
from types import ModuleType

import numpy as np
from mujoco import MjData, MjModel
from mujoco.batch import Batch

from acrobot_mj.checks import check_int
from acrobot_mj.envs.env import HUGE, MAX_ANGLE
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.physics.angles import wrap_angle

#: Batches of at least this many simulations step on all CPUs (unless told otherwise); smaller
#: ones on one thread.
THREADED_FROM = 256
#: Batches of at most this many simulations test their velocities and states in Python (a few
#: comparisons cost less than a numpy call); larger ones in numpy. The numbers are the same.
FEW = 8
#: Whether batches of more than :data:`FEW` simulations use the compiled row kernels where numba
#: is installed, read when a batch is built (both backends; off, numpy's calls: the tests
#: compare the two).
COMPILED = True
_PI, _MIN_PI = math.pi, -math.pi
#: Weights of ``|q1|, |q2|, |dq1|, |dq2|`` in the observation's quick test: powers of two, so
#: exact; a weighted maximum below pi means every angle in (-pi, pi) (wrapping changes nothing),
#: every velocity below pi * 2**31 < HUGE, and no NaN (NaN * w is NaN, and fails the test).
_QUICK = np.array([1.0, 1.0, 2.0**-31, 2.0**-31])


def batch_threads(num_envs: int, nthread: int | None) -> int:
    """``Batch``'s ``nthread`` for ``num_envs`` simulations: ``nthread`` as given (0: all CPUs),
    or with ``None`` one thread below :data:`THREADED_FROM` simulations and all CPUs from it."""
    if nthread is not None:
        return check_int("nthread", nthread, 0)
    return 1 if num_envs < THREADED_FROM else 0


def row_kernels(num_envs: int) -> ModuleType | None:
    """:mod:`~acrobot_mj.envs.row_kernels` for a batch of ``num_envs`` simulations, or None:
    for at most :data:`FEW` (Python's tests cost less), without numba (or with one that fails
    to load), or with :data:`COMPILED` off."""
    if num_envs <= FEW or not COMPILED or importlib.util.find_spec("numba") is None:
        return None
    try:
        from acrobot_mj.envs import row_kernels as kernels
    except (ImportError, RuntimeError):  # a numba that does not load (built for another numpy)
        return None  # numpy's calls: the same numbers
    return kernels


class BatchPhysics:
    """``num_envs`` simulations of ``model`` in one ``Batch`` (``batch``) on
    :func:`batch_threads` threads, with live ``(num_envs, ...)`` views ``qpos``, ``qvel`` and
    ``ctrl`` into its state rows."""

    def __init__(self, model: MjModel, num_envs: int, nthread: int | None = None) -> None:
        self.batch = Batch(model, num_envs, nthread=batch_threads(num_envs, nthread))
        self.qpos, self.qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self.ctrl = self.batch.bind("ctrl")
        self.few = num_envs <= FEW
        #: Live views of the columns ``q1, q2, dq1, dq2``, as the task's outcome takes them.
        self.columns = (self.qpos[:, 0], self.qpos[:, 1], self.qvel[:, 0], self.qvel[:, 1])
        self._rows = state_rows(self.qpos, self.qvel)
        #: The compiled row kernels (:func:`row_kernels`), or None.
        self.kernels = row_kernels(num_envs)

    @property
    def nthread(self) -> int:
        """Threads the batch steps on (at most one per simulation)."""
        return self.batch.nthread

    def step(self, substeps: int) -> None:
        """``substeps`` physics steps of every simulation, each followed by the velocity limits
        (``np.clip``, NaN kept). A few simulations are tested in Python first and left alone
        when inside the limits, as the single env does; each velocity column is clipped on its
        own (a 1-D pass is several times faster than one over the strided ``(N, 2)`` view), or
        all in one compiled pass (:attr:`kernels`)."""
        qvel, step, kernels = self.qvel, self.batch.step, self.kernels
        dq1, dq2 = self.columns[2:]
        for _ in range(substeps):
            step()
            if kernels is not None:
                kernels.limit_rows(qvel, MAX_VEL1, MAX_VEL2)
                continue
            if self.few:
                for v1, v2 in qvel.tolist():
                    if not (-MAX_VEL1 <= v1 <= MAX_VEL1 and -MAX_VEL2 <= v2 <= MAX_VEL2):
                        break  # outside, or NaN
                else:
                    continue
            np.clip(dq1, -MAX_VEL1, MAX_VEL1, out=dq1)
            np.clip(dq2, -MAX_VEL2, MAX_VEL2, out=dq2)

    def observe(self) -> np.ndarray:
        """Every simulation's observation ``(q1, q2, dq1, dq2)``, angles wrapped into [-pi, pi)
        (as they are when inside); raises on a non-finite state or angles beyond
        ``MAX_ANGLE``, naming the simulations, as the single env does (one compiled pass with
        :attr:`kernels`)."""
        q, v = self.qpos, self.qvel
        if self.kernels is not None:
            rows = np.concatenate((q, v), axis=1) if self._rows is None else self._rows
            obs = np.empty((len(q), 4))
            if self.kernels.observe_rows(rows, obs, MAX_ANGLE, HUGE):
                return obs
            return checked_observation(np.array(rows), few=False)  # raises
        # One copy of the (N, 4) rows where qvel follows qpos in each state row (the batch's
        # layout), else two.
        obs = np.concatenate((q, v), axis=1) if self._rows is None else self._rows.copy()
        return checked_observation(obs, self.few)

    def snapshot(self) -> np.ndarray:
        """A copy of every simulation's whole MuJoCo state row (time, qpos, qvel, ctrl, warm
        start, ...)."""
        return self.batch.state.copy()

    def restore(self, rows: np.ndarray) -> None:
        """Put back the state rows of a :meth:`snapshot`."""
        self.batch.state[...] = rows

    def get_data(self, i: int, data: MjData) -> None:
        """Copy simulation ``i``'s state into ``data`` (of the same model)."""
        self.batch.get_data(i, data)


def checked_observation(obs: np.ndarray, few: bool) -> np.ndarray:
    """The observations of the rows ``obs`` (``(N, 4)``: ``q1, q2, dq1, dq2``, changed in
    place), angles wrapped into [-pi, pi) (as they are when inside); raises on a non-finite
    state or angles beyond ``MAX_ANGLE``, naming the rows, as the single env does. ``few``: test
    the rows in Python (cheaper than numpy's calls on a few rows; the same result)."""
    if few:  # the usual case, every angle inside [-pi, pi): nothing to wrap or raise
        usual = True
        for q1, q2, v1, v2 in obs.tolist():  # a loop: cheaper than all() over a generator
            inside = _MIN_PI <= q1 < _PI and _MIN_PI <= q2 < _PI
            if not (inside and abs(v1) < HUGE and abs(v2) < HUGE):  # NaN fails every test
                usual = False
                break
    else:
        usual = (np.abs(obs) * _QUICK).max() < _PI  # one reduction
    if usual:
        return obs
    q, v = obs[:, :2], obs[:, 2:]
    # As the single env: NaN fails the test too; the row test names the bad sub-envs.
    if not (np.abs(q).max() < MAX_ANGLE and np.abs(v).max() < HUGE):
        bad = ~((np.abs(q) < MAX_ANGLE).all(1) & (np.abs(v) < HUGE).all(1))
        raise RuntimeError(
            f"sub-envs {np.flatnonzero(bad).tolist()} reached a non-finite state or angles "
            f"beyond +-{MAX_ANGLE:g} rad; reset them before stepping again"
        )
    obs[:, :2] = wrap_angle(q)
    return obs


def state_rows(qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray | None:
    """A read-only ``(N, 4)`` view of ``q1, q2, dq1, dq2`` over the batch's state rows, if each
    row holds qvel right after qpos (as MuJoCo's state does), else None."""
    address = qpos.__array_interface__["data"][0]
    after = qvel.__array_interface__["data"][0] - address == qpos.shape[1] * qpos.itemsize
    if not (after and qvel.strides == qpos.strides and qpos.shape == qvel.shape):
        return None
    return np.lib.stride_tricks.as_strided(qpos, (len(qpos), 4), qpos.strides, writeable=False)
