"""The physics of many acrobots without MuJoCo's step: the cross-checked Lagrangian model in
lumped form, compiled with numba, over plain numpy state arrays.

:class:`AnalyticPhysics` has :class:`~acrobot_mj.envs.batch_physics.BatchPhysics`'s interface
(``qpos``, ``qvel``, ``ctrl``, ``columns``, ``step``, ``observe``, ``nthread``), so the vector
env runs either (``backend="analytic"``). Its step is
:func:`~acrobot_mj.control.identification.lumped_step`: MuJoCo's semi-implicit Euler in MuJoCo's
order (``v' = v + h a``, then ``q' = q + h v'``, then the task's velocity limits, as the env
applies them after each ``mj_step``). The lumped parameters are derived from the loaded
``MjModel`` (:func:`lumped_parameters`), and a model the lumped equations cannot represent is
refused, so the two backends simulate the same acrobot: to rounding, which the acrobot's chaos
amplifies (``tests/test_analytic.py`` measures how far).

The kernel (:mod:`acrobot_mj.envs.analytic_kernel`) imports numba, the ``fast`` extra, only
when an :class:`AnalyticPhysics` is built.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from mujoco import MjData, MjModel

from acrobot_mj.checks import check_int
from acrobot_mj.control.identification import lumped
from acrobot_mj.envs import batch_physics
from acrobot_mj.envs.batch_physics import FEW, checked_observation
from acrobot_mj.envs.env import HUGE, MAX_ANGLE
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.physics.dynamics import forward_dynamics
from acrobot_mj.physics.params import AcrobotParams

#: Batches of at least this many acrobots step on all of numba's threads (unless told
#: otherwise); smaller ones on the calling thread. The numbers are the same either way. Measured
#: on 2 cores (4 physics steps per call): idle, 2 threads took 10.3 us against 13.8 us serial
#: at N = 64, 29 against 52 us at 256 and 102 against 208 us at 1024; but with another process
#: busy on one core, a parallel call waits for its descheduled thread, and 2 threads ran 10 to
#: 30 times slower than one at N = 256 to 4096, 0.5x at 16384 and 0.85x at 65536. One thread
#: loses at most 2x on an idle machine; threads lose 10x on a loaded one: below 65536, one.
THREADED_FROM = 65536
#: Largest relative gap between MuJoCo's accelerations and the lumped model's at random states
#: for a model to be accepted (rounding is about 1e-15; a wrong parameter is far above).
DYNAMICS_TOLERANCE = 1e-9
_INTEGRATOR_NAMES = {int(mujoco.mjtIntegrator.mjINT_EULER): "euler",
                     int(mujoco.mjtIntegrator.mjINT_RK4): "rk4"}  # fmt: skip


def refuse_unrepresentable(model: MjModel) -> None:
    """Raise ``ValueError`` naming what of ``model`` the lumped model leaves out: another
    integrator than Euler, joint damping, armature, friction loss, stiffness, or active
    joint limits, equality constraints or contacts."""
    name = _INTEGRATOR_NAMES.get(int(model.opt.integrator), str(model.opt.integrator))
    if name != "euler":
        raise ValueError(
            f"the analytic backend steps MuJoCo's semi-implicit Euler only, not integrator "
            f"{name!r}; use backend='mujoco'"
        )
    for field, values in (
        ("damping", model.dof_damping),
        ("armature", model.dof_armature),
        ("frictionloss", model.dof_frictionloss),
        ("stiffness", model.jnt_stiffness),
    ):
        if np.any(values != 0):
            raise ValueError(
                f"the model's joints have {field} {values.tolist()}, which the analytic "
                "backend does not model; use backend='mujoco'"
            )
    flags, bits = model.opt.disableflags, mujoco.mjtDisableBit
    contacts = not flags & bits.mjDSBL_CONTACT and np.any(
        model.geom_contype | model.geom_conaffinity
    )
    if not flags & bits.mjDSBL_CONSTRAINT and (np.any(model.jnt_limited) or model.neq or contacts):
        raise ValueError(
            "the model has joint limits, equality constraints or contacts, which the analytic "
            "backend does not model; use backend='mujoco'"
        )


def physical_parameters(model: MjModel) -> AcrobotParams:
    """The model's links as :class:`AcrobotParams`, read by name at ``qpos = 0``: masses [kg],
    ``l1`` (shoulder to elbow) and each link's joint to centre of mass [m], inertia about the
    hinge axis through the centre of mass [kg m^2], and ``|gravity|`` [m/s^2]."""
    data = MjData(model)
    data.qpos[:] = 0.0
    mujoco.mj_kinematics(model, data)
    shoulder, elbow = model.joint("shoulder").id, model.joint("elbow").id
    values = {"l1": float(np.linalg.norm(data.xanchor[elbow] - data.xanchor[shoulder]))}
    links = ((model.body("link1").id, shoulder), (model.body("link2").id, elbow))
    for k, (body, joint) in enumerate(links, 1):
        frame = data.ximat[body].reshape(3, 3)  # the inertia's principal axes, in the world
        inertia = frame @ np.diag(model.body_inertia[body]) @ frame.T
        axis = data.xaxis[joint]
        values[f"m{k}"] = float(model.body_mass[body])
        values[f"lc{k}"] = float(np.linalg.norm(data.xipos[body] - data.xanchor[joint]))
        values[f"I{k}"] = float(axis @ inertia @ axis)
    try:
        return AcrobotParams(**values, g=float(np.linalg.norm(model.opt.gravity)))
    except ValueError as error:
        raise ValueError(f"the analytic backend cannot represent this model: {error}") from None


def check_dynamics(model: MjModel, params: AcrobotParams, states: int = 32) -> None:
    """Raise ``ValueError`` unless MuJoCo's accelerations (``mj_forward``) match the analytic
    model's with ``params`` within :data:`DYNAMICS_TOLERANCE` (relative) at ``states`` random
    states and torques in [-1, 1] N m: whatever else the model holds (gear, gravity's
    direction, axes, offsets, passive or fluid forces) shows up here."""
    rng = np.random.default_rng(0)
    data = MjData(model)
    worst = 0.0
    for _ in range(states):
        data.qpos[:] = rng.uniform(-math.pi, math.pi, 2)
        data.qvel[:] = rng.uniform(-1.0, 1.0, 2) * (MAX_VEL1, MAX_VEL2)
        data.ctrl[:] = rng.uniform(-1.0, 1.0)
        mujoco.mj_forward(model, data)
        analytic = forward_dynamics(data.qpos, data.qvel, data.ctrl[0], params)
        gap = np.max(np.abs(analytic - data.qacc)) / max(1.0, np.max(np.abs(data.qacc)))
        worst = max(worst, float(gap))
    if not worst <= DYNAMICS_TOLERANCE:
        raise ValueError(
            f"the model's dynamics differ from the lumped acrobot's (relative gap {worst:.3g} "
            f"in the accelerations): the analytic backend cannot represent it; use "
            "backend='mujoco'"
        )


def lumped_parameters(model: MjModel) -> tuple[float, float, float, float, float]:
    """The lumped parameters ``(a, b, c, d, e)`` [kg m^2 (a, b, c), N m (d, e)] of ``model``,
    or ``ValueError`` for a model they cannot represent (:func:`refuse_unrepresentable`,
    :func:`check_dynamics`)."""
    refuse_unrepresentable(model)
    params = physical_parameters(model)
    check_dynamics(model, params)
    return lumped(params)


def analytic_threads(num_envs: int, nthread: int | None, available: int) -> int:
    """Threads for ``num_envs`` acrobots: ``nthread`` as given (0: all ``available``), or with
    ``None`` one below :data:`THREADED_FROM` and all from it; never more than ``available``
    or one per acrobot."""
    if nthread is None:
        nthread = 1 if num_envs < THREADED_FROM else 0
    nthread = check_int("nthread", nthread, 0)
    return max(1, min(nthread or available, available, num_envs))


class AnalyticPhysics:
    """``num_envs`` acrobots of ``model``'s lumped dynamics (:func:`lumped_parameters`, fixed
    at construction) in one ``(num_envs, 4)`` array ``state`` of rows ``(q1, q2, dq1, dq2)``
    [rad, rad/s], with live views ``qpos``, ``qvel`` and a ``(num_envs, 1)`` array ``ctrl``
    [N m], stepped by the compiled kernel on :func:`analytic_threads` threads."""

    def __init__(self, model: MjModel, num_envs: int, nthread: int | None = None) -> None:
        from acrobot_mj.envs import analytic_kernel as kernel  # numba: the fast extra
        from acrobot_mj.envs import row_kernels

        self.model = model
        #: What the kernel takes: ``a, b, c`` [kg m^2], ``d, e`` [N m], ``dt`` [s] and the
        #: velocity limits [rad/s].
        self.theta = np.array((*lumped_parameters(model), model.opt.timestep, MAX_VEL1, MAX_VEL2))
        self.state, self.ctrl = np.zeros((num_envs, 4)), np.zeros((num_envs, 1))
        self.qpos, self.qvel = self.state[:, :2], self.state[:, 2:]
        #: Live views of the columns ``q1, q2, dq1, dq2``, as the task's outcome takes them.
        self.columns = tuple(self.state[:, k] for k in range(4))
        self.few = num_envs <= FEW
        self._nthread = analytic_threads(num_envs, nthread, kernel.available_threads())
        self._tau = self.ctrl[:, 0]
        self._kernel = kernel.step_rows if self._nthread == 1 else kernel.step_rows_parallel
        self._set_threads = kernel.set_threads
        self._observe = row_kernels.observe_rows
        #: The compiled passes the vector env shares (the discrete actions' torques).
        self.kernels = batch_physics.row_kernels(num_envs)

    @property
    def nthread(self) -> int:
        """Threads the kernel steps on (at most one per acrobot)."""
        return self._nthread

    def step(self, substeps: int) -> None:
        """``substeps`` physics steps of every acrobot, in place (``lumped_step``, compiled)."""
        if self._nthread > 1:
            self._set_threads(self._nthread)
        self._kernel(self.state, self._tau, self.theta, substeps)

    def observe(self) -> np.ndarray:
        """Every acrobot's observation, angles wrapped (``wrap_angle``'s numbers, compiled: one
        pass over the rows); on a bad state, raises naming the sub-envs, as the MuJoCo backend
        (:func:`~acrobot_mj.envs.batch_physics.checked_observation`)."""
        obs = np.empty_like(self.state)
        if self._observe(self.state, obs, MAX_ANGLE, HUGE):
            return obs
        return checked_observation(self.state.copy(), self.few)  # raises

    def snapshot(self) -> np.ndarray:
        """A copy of every acrobot's state and control, ``(num_envs, 5)``."""
        return np.concatenate((self.state, self.ctrl), axis=1)

    def restore(self, rows: np.ndarray) -> None:
        """Put back the states and controls of a :meth:`snapshot`."""
        self.state[...] = rows[:, :4]
        self.ctrl[...] = rows[:, 4:]

    def get_data(self, i: int, data: MjData) -> None:
        """Put acrobot ``i``'s state and control into ``data`` (of ``model``), then
        ``mj_forward``, so it renders as the MuJoCo backend's would."""
        data.qpos[:], data.qvel[:], data.ctrl[:] = self.qpos[i], self.qvel[i], self.ctrl[i]
        mujoco.mj_forward(self.model, data)
