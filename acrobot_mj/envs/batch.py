"""The physics of a vector env's acrobots: MuJoCo's C batch (:class:`BatchPhysics`, the
reference) or the analytic model compiled by numba (:class:`AnalyticPhysics`), with live
``(N, ...)`` views ``qpos``, ``qvel``, ``ctrl`` and the velocity limits after every physics step.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from mujoco import MjData, MjModel
from mujoco.batch import Batch

from acrobot_mj.checks import check_int
from acrobot_mj.compiled import available_threads, compiled, jitable, set_threads
from acrobot_mj.envs.acrobot import HUGE, MAX_ANGLE, Diverged, sound
from acrobot_mj.envs.assets import actuated_joint
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.physics import xp
from acrobot_mj.physics.dynamics import forward_dynamics
from acrobot_mj.physics.integrators import UNLIMITED, Stepping, limit_velocities, step_rows
from acrobot_mj.physics.params import REPORT, AcrobotParams

#: Sizes from which threads pay: waking them costs tens of microseconds per step (MuJoCo's).
THREADED_FROM, ANALYTIC_THREADED_FROM = 256, 65536
#: Largest relative gap between MuJoCo's accelerations and the lumped model's it accepts.
DYNAMICS_TOLERANCE = 1e-9


@jitable
def limit_rows(qvel, lim1, lim2) -> None:
    """The velocity limits on ``qvel`` ``(N, 2)``, in place (rows inside are not written)."""
    for i in range(qvel.shape[0]):
        v1, v2 = qvel[i, 0], qvel[i, 1]
        if not (-lim1 <= v1 <= lim1 and -lim2 <= v2 <= lim2):  # or NaN (written back unchanged)
            qvel[i, 0], qvel[i, 1] = limit_velocities(v1, v2, (lim1, lim2))


@jitable
def observe_rows(qpos, qvel, obs, max_angle, huge) -> bool:
    """Each row's observation (angles wrapped) into ``obs``; False if a row is not
    :func:`~acrobot_mj.envs.acrobot.sound` with limits ``max_angle`` and ``huge``."""
    ok = True
    for i in range(qpos.shape[0]):
        q1, q2, v1, v2 = qpos[i, 0], qpos[i, 1], qvel[i, 0], qvel[i, 1]
        if not sound(q1, q2, v1, v2, max_angle, huge):
            ok = False
        obs[i, 0], obs[i, 1], obs[i, 2], obs[i, 3] = xp.wrap(q1), xp.wrap(q2), v1, v2
    return ok


def observe(qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
    """Every row's observation; raises naming the sub-envs with a bad state."""
    obs = np.empty((len(qpos), 4))
    if compiled(observe_rows)(qpos, qvel, obs, MAX_ANGLE, HUGE):
        return obs
    bad = [i for i, row in enumerate(np.concatenate((qpos, qvel), 1)) if not sound(*row)]
    raise Diverged(
        f"sub-envs {bad} reached a non-finite state or angles "
        f"beyond +-{MAX_ANGLE:g} rad; reset them before stepping again"
    )


def threads(num_envs: int, nthread: int | None, threaded_from: int, available: int) -> int:
    """Threads for ``num_envs`` simulations: ``nthread`` (0: all ``available``; None: one below
    ``threaded_from``, all from there), at most one per simulation."""
    if nthread is None:
        nthread = 1 if num_envs < threaded_from else 0
    nthread = check_int("nthread", nthread, 0)
    return max(1, min(nthread or available, available, num_envs))


class BatchPhysics:
    """``num_envs`` simulations of ``model`` in one ``mujoco.batch.Batch`` (``batch``), their
    velocities clipped to ``max_vel`` [rad/s] (inf: not clipped)."""

    def __init__(
        self,
        model: MjModel,
        num_envs: int,
        nthread: int | None = None,
        max_vel: tuple[float, float] = REPORT.max_vel,
    ) -> None:
        n = 1 if num_envs < THREADED_FROM else 0
        self.batch = Batch(model, num_envs, nthread=n if nthread is None else nthread)
        self.qpos, self.qvel = self.batch.bind("qpos"), self.batch.bind("qvel")
        self.ctrl = self.batch.bind("ctrl")
        self.columns = (self.qpos[:, 0], self.qpos[:, 1], self.qvel[:, 0], self.qvel[:, 1])
        self._limit = compiled(limit_rows)
        self.max_vel = max_vel
        self._limits = None if max_vel == UNLIMITED else max_vel  # None: nothing to clip

    @property
    def nthread(self) -> int:
        return self.batch.nthread

    def step(self, substeps: int) -> None:
        limits = self._limits
        for _ in range(substeps):
            self.batch.step()
            if limits is not None:
                self._limit(self.qvel, *limits)

    def observe(self) -> np.ndarray:
        return observe(self.qpos, self.qvel)

    def snapshot(self) -> np.ndarray:
        """A copy of every simulation's whole MuJoCo state."""
        return self.batch.state.copy()

    def restore(self, rows: np.ndarray) -> None:
        self.batch.state[...] = rows

    def get_data(self, i: int, data: MjData) -> None:
        self.batch.get_data(i, data)


class AnalyticPhysics:
    """``num_envs`` acrobots of ``model``'s lumped dynamics in one ``(num_envs, 4)`` ``state``,
    stepped by :func:`~acrobot_mj.physics.integrators.step_rows` compiled, their velocities
    clipped to ``max_vel`` [rad/s] (inf: not clipped)."""

    def __init__(
        self,
        model: MjModel,
        num_envs: int,
        nthread: int | None = None,
        max_vel: tuple[float, float] = REPORT.max_vel,
    ) -> None:
        self.model, self.max_vel = model, max_vel
        stepping = Stepping(model.opt.timestep, max_vel=max_vel)
        self.constants = stepping.constants(lumped_parameters(model))
        self.state, self.ctrl = np.zeros((num_envs, 4)), np.zeros((num_envs, 1))
        self.qpos, self.qvel = self.state[:, :2], self.state[:, 2:]
        self.columns = tuple(self.state[:, k] for k in range(4))
        self.nthread = threads(num_envs, nthread, ANALYTIC_THREADED_FROM, available_threads())
        self._step = compiled(step_rows, parallel=self.nthread > 1)

    def step(self, substeps: int) -> None:
        if self.nthread > 1:
            set_threads(self.nthread)
        self._step(self.state, self.ctrl[:, 0], self.constants, substeps, 0)

    def observe(self) -> np.ndarray:
        return observe(self.qpos, self.qvel)

    def snapshot(self) -> np.ndarray:
        """A copy of every state and control, ``(num_envs, 5)``."""
        return np.concatenate((self.state, self.ctrl), axis=1)

    def restore(self, rows: np.ndarray) -> None:
        self.state[...], self.ctrl[...] = rows[:, :4], rows[:, 4:]

    def get_data(self, i: int, data: MjData) -> None:
        """Acrobot ``i``'s state and control in ``data``, forwarded (to render it)."""
        data.qpos[:], data.qvel[:], data.ctrl[:] = self.qpos[i], self.qvel[i], self.ctrl[i]
        mujoco.mj_forward(self.model, data)


def lumped_parameters(model: MjModel) -> tuple[float, ...]:
    """The lumped parameters of ``model``; ``ValueError`` for one they cannot represent (damping,
    armature, friction loss, stiffness, a driven shoulder, not Euler, limits, equalities,
    contacts, or accelerations off MuJoCo's by more than :data:`DYNAMICS_TOLERANCE` at random
    states)."""
    for field, values in (
        ("damping", model.dof_damping),
        ("armature", model.dof_armature),
        ("frictionloss", model.dof_frictionloss),
        ("stiffness", model.jnt_stiffness),
    ):
        if np.any(values != 0):
            raise ValueError(
                f"the model's joints have {field} {values.tolist()}, which the "
                "analytic backend does not model; use backend='mujoco'"
            )
    if actuated_joint(model) != "elbow":
        raise ValueError(
            "the analytic backend drives the elbow; this model drives the "
            f"{actuated_joint(model)}; use backend='mujoco'"
        )
    integrator = mujoco.mjtIntegrator(model.opt.integrator)
    if integrator != mujoco.mjtIntegrator.mjINT_EULER:
        name = integrator.name.removeprefix("mjINT_").lower()
        raise ValueError(
            f"the analytic backend steps MuJoCo's semi-implicit Euler only, not "
            f"integrator {name!r}; use backend='mujoco'"
        )
    flags, bits = model.opt.disableflags, mujoco.mjtDisableBit
    colliding = model.geom_contype | model.geom_conaffinity
    contacts = not flags & bits.mjDSBL_CONTACT and np.any(colliding)
    if not flags & bits.mjDSBL_CONSTRAINT and (np.any(model.jnt_limited) or model.neq or contacts):
        raise ValueError(
            "the model has joint limits, equality constraints or contacts, which "
            "the analytic backend does not model; use backend='mujoco'"
        )
    params = physical_parameters(model)
    rng, data, worst = np.random.default_rng(0), MjData(model), 0.0
    for _ in range(32):
        data.qpos[:] = rng.uniform(-math.pi, math.pi, 2)
        data.qvel[:] = rng.uniform(-1.0, 1.0, 2) * (MAX_VEL1, MAX_VEL2)  # the report's, any model
        data.ctrl[:] = rng.uniform(-1.0, 1.0)
        mujoco.mj_forward(model, data)
        analytic = forward_dynamics(data.qpos, data.qvel, data.ctrl[0], params)
        gap = np.max(np.abs(analytic - data.qacc)) / max(1.0, np.max(np.abs(data.qacc)))
        worst = max(worst, float(gap))
    if not worst <= DYNAMICS_TOLERANCE:
        raise ValueError(
            f"the model's dynamics differ from the lumped acrobot's (relative gap "
            f"{worst:.3g} in the accelerations): the analytic backend cannot "
            "represent it; use backend='mujoco'"
        )
    return params.lumped


def physical_parameters(model: MjModel) -> AcrobotParams:
    """The model's links as :class:`~acrobot_mj.physics.params.AcrobotParams`, read by name at
    ``qpos = 0``."""
    data = MjData(model)
    mujoco.mj_kinematics(model, data)
    shoulder, elbow = model.joint("shoulder").id, model.joint("elbow").id
    values = {"l1": float(np.linalg.norm(data.xanchor[elbow] - data.xanchor[shoulder]))}
    for k, (body, joint) in enumerate(
        ((model.body("link1").id, shoulder), (model.body("link2").id, elbow)), 1
    ):
        frame = data.ximat[body].reshape(3, 3)  # principal axes of inertia, in the world
        axis = data.xaxis[joint]
        values[f"m{k}"] = float(model.body_mass[body])
        values[f"lc{k}"] = float(np.linalg.norm(data.xipos[body] - data.xanchor[joint]))
        values[f"I{k}"] = float(axis @ frame @ np.diag(model.body_inertia[body]) @ frame.T @ axis)
    try:
        return AcrobotParams(**values, g=float(np.linalg.norm(model.opt.gravity)))
    except ValueError as error:
        raise ValueError(f"the analytic backend cannot represent this model: {error}") from None
