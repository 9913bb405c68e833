"""The acrobot as a Gymnasium environment stepping MuJoCo, for any registered task."""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NoReturn

import gymnasium as gym
import mujoco
import numpy as np

from acrobot_mj.checks import check_bool, check_int
from acrobot_mj.compiled import jitable
from acrobot_mj.envs.assets import actuated_joint, link_lengths, load_model
from acrobot_mj.envs.gl import close_viewer, make_renderer, open_viewer
from acrobot_mj.envs.spaces import (
    INT_TYPES,
    RESET_OPTIONS,
    TorqueLimit,
    action_space,
    action_torque,
    cos_sin,
    observation_space,
    reset_noise,
    reset_state,
)
from acrobot_mj.envs.tasks import Task, TaskOptions, get_task
from acrobot_mj.physics.integrators import limit_velocities
from acrobot_mj.physics.models import ModelSpec, resolve
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.physics.xp import wrap

if sys.version_info >= (3, 11):
    from typing import Unpack
else:
    from typing_extensions import Unpack

INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4}

#: MuJoCo's mjMAXVAL: states beyond it are "huge" (its BADQPOS/BADQVEL warnings).
HUGE = 1e10
#: Larger angles [rad] are refused (set_state) or raise (step): a double resolves 1e-10 rad there.
MAX_ANGLE = 1e6


class Diverged(RuntimeError):
    """The simulation reached a non-finite state or angles beyond :data:`MAX_ANGLE`: a model
    too stiff for its time step, or an unstable one (a command reports it in one line)."""


MAX_FRAME_SKIP = 1000  # physics steps per action: 50 s
# Globals are cheaper than module attributes and negations on the hot path.
_mj_step = mujoco.mj_step
_PI, _MIN_PI = math.pi, -math.pi


@jitable
def sound(q1, q2, v1, v2, max_angle=MAX_ANGLE, huge=HUGE) -> bool:
    """Whether a state [rad, rad/s] may be observed: angles within +-``max_angle``, velocities
    finite and within +-``huge`` (False for NaN and infinities)."""
    return abs(q1) < max_angle and abs(q2) < max_angle and abs(v1) < huge and abs(v2) < huge


def observation(q1: float, q2: float, v1: float, v2: float) -> np.ndarray | None:
    """The observation ``(q1, q2, dq1, dq2)`` of a state, angles wrapped into ``[-pi, pi)``
    [rad, rad/s]; None if the state is not :func:`sound` (the env raises)."""
    if not sound(q1, q2, v1, v2):
        return None
    return np.array((wrap(q1), wrap(q2), v1, v2))


def drawn_start(task: Task, rest: np.ndarray, rng: np.random.Generator, noise: float) -> np.ndarray:
    """``rest`` ``(q1, q2, dq1, dq2)`` [rad, rad/s] plus ``task``'s start offsets drawn from
    ``rng`` at start noise ``noise``: a new array."""
    offsets = task.start_offsets(rng, noise)
    if offsets is None:
        return rest.copy()
    return np.concatenate((rest[:2] + offsets[0], rest[2:] + offsets[1]))


def start_state(
    task: Task, rest: np.ndarray, rng: np.random.Generator, options: Any
) -> tuple[np.ndarray, bool]:
    """The state a reset with ``options`` starts from, and whether ``options`` gave it
    (``"state"``); else :func:`drawn_start` at their ``"start_noise"`` (or the task's)."""
    start = reset_state(options)
    noise = reset_noise(options, task.start_noise, known=RESET_OPTIONS)
    if start is not None:
        return start, True
    return drawn_start(task, rest, rng, noise), False


def make_task(
    task: str | type[Task], links: tuple[float, float], options: Mapping[str, Any]
) -> Task:
    """The task ``task`` (a registered name or a Task class) on links ``(l1, l2)`` [m], with its
    keyword ``options`` (an unknown one raises)."""
    cls = task if isinstance(task, type) and issubclass(task, Task) else get_task(task)
    unknown = sorted(set(options) - {"start_noise", *cls.options})
    if unknown:
        raise TypeError(
            f"unknown arguments {unknown} for task {cls.name!r}; its options: "
            f"{sorted({'start_noise', *cls.options})}"
        )
    return cls(links, **options)


class EnvOptions(TaskOptions, total=False):
    """:class:`AcrobotEnv`'s keyword arguments but ``render_mode``: the task's options and the
    env's own, which :class:`~acrobot_mj.envs.vector.AcrobotVectorEnv` passes on to it."""

    frame_skip: int
    integrator: str
    task: str | type[Task]
    continuous: bool
    observation: str
    width: int
    height: int
    camera: str
    model_path: str | Path | None
    model: ModelSpec


def check_copy(what: str, state: dict[str, Any], keys: tuple[str, ...]) -> None:
    """Refuse the pickled state of a ``what`` without ``keys``, which every copy from 0.4.0 on
    holds: one pickled by an older acrobot_mj."""
    missing = [key for key in keys if key not in state]
    if missing:
        raise ValueError(
            f"this {what} was pickled by acrobot_mj before 0.4.0 (it lacks {missing}), which "
            "this version does not unpickle: make it again"
        )


class AcrobotEnv(gym.Env[np.ndarray, Any]):
    r"""The acrobot of the IND E 599 report simulated by MuJoCo, with a ``task`` on top
    (:mod:`acrobot_mj.envs.tasks`: rewards, episode end, ``info``).

    Actions: ``Discrete(3)``, motor torques -1, 0, +1 N m (``-max_torque, 0, +max_torque`` of
    the model) held for ``frame_skip`` physics steps of 0.05 s (the model's ``dt``), or with
    ``continuous=True`` ``Box(-max_torque, max_torque, (1,))`` [N m]; anything else raises.
    The motor drives the elbow (a pendubot's the shoulder). Observations ``(q1, q2, dq1, dq2)``:
    q1 from the horizontal, q2 relative to link 1, wrapped into [-pi, pi) [rad]; velocities
    [rad/s] clipped to ``(4 pi, 9 pi)`` (the model's ``max_vel1, max_vel2``; inf: no clipping
    and no bound) after every physics step; with ``observation="cos_sin"`` float32 ``(cos q1,
    sin q1, cos q2, sin q2, dq1, dq2)`` as Gymnasium's ``Acrobot-v1``. ``model_path``: an MJCF
    file instead of ``scene.xml`` (the report's limits); ``model``: a parameter set by name
    (:data:`~acrobot_mj.physics.models.MODELS`), a JSON or TOML file of one, or an
    ``AcrobotModel`` or ``AcrobotParams``, its MJCF generated; ``params`` is the set's
    parameters; ``integrator``: ``"euler"`` or ``"rk4"``, default the model's (``"euler"`` for
    an MJCF file). ``reset`` takes ``options={"start_noise": s}`` or ``{"state": x}``.

    Ten +1 N m steps from rest (the analytic model's numbers), then the bang-bang law
    ``tau = -sign(dq1)`` reaching the goal on step 300:

    >>> import gymnasium as gym
    >>> import acrobot_mj
    >>> env = gym.make("acrobot_mj/Acrobot-v0")
    >>> obs, info = env.reset(seed=0)
    >>> obs.tolist(), info
    ([-1.5707963267948966, 0.0, 0.0, 0.0], {'tip_height': -2.0, 'is_success': False})
    >>> for _ in range(10):
    ...     obs, reward, terminated, truncated, info = env.step(2)
    >>> [round(x, 9) for x in obs.tolist()], reward, terminated, truncated
    ([-1.647489786, 0.204950005, -0.229681209, 0.640375848], -1.0, False, False)
    >>> obs, info = env.reset()
    >>> for step in range(1, 1001):
    ...     obs, reward, terminated, truncated, info = env.step(0 if obs[2] > 0 else 2)
    ...     if terminated or truncated:
    ...         break
    >>> step, reward, terminated, round(info["tip_height"], 9)
    (300, 100.0, True, 1.044545016)
    """

    metadata = {"render_modes": ["human", "rgb_array", "depth_array"], "render_fps": 20}

    def __init__(
        self,
        frame_skip: int = 1,
        integrator: str | None = None,
        *,
        task: str | type[Task] = "height_goal",
        continuous: bool = False,
        observation: str = "state",
        render_mode: str | None = None,
        width: int = 480,
        height: int = 480,
        camera: str = "side",
        model_path: str | Path | None = None,
        model: ModelSpec = None,
        **task_options: Unpack[TaskOptions],
    ) -> None:
        self._frame_skip = check_int("frame_skip", frame_skip, 1, MAX_FRAME_SKIP)
        self._substeps = range(self._frame_skip)
        self._continuous = check_bool("continuous", continuous)
        modes = self.metadata["render_modes"]
        if render_mode is not None and render_mode not in modes:
            raise ValueError(f"render_mode must be None or one of {modes}, got {render_mode!r}")
        self._load(model_path, model, integrator)
        self.task = make_task(task, link_lengths(self.model), task_options)
        key = self.task.start_keyframe
        self._start_key = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, key)
        if self._start_key < 0:
            raise ValueError(f"the model has no keyframe {key!r}")
        self._bind()
        offscreen = self.model.vis.global_
        self.width = check_int("width", width, 1, offscreen.offwidth)
        self.height = check_int("height", height, 1, offscreen.offheight)
        if (
            not isinstance(camera, str)
            or mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera) < 0
        ):
            names = [self.model.camera(i).name for i in range(self.model.ncam)]
            raise ValueError(
                f"camera must be the name of one of the model's cameras {names}, got {camera!r}"
            )
        self.camera, self.render_mode = camera, render_mode
        self._renderer: Any = None  # created by the first render(), released by close()
        self._viewer: Any = None  # render_mode="human"'s window, opened by _show()
        self._human, self._shown_at = render_mode == "human", 0.0
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.dt}
        self.action_space = action_space(continuous, self._torques)
        # raises on an unknown kind
        self.observation_space = observation_space(observation, self.params.max_vel)
        self._observation, self._cos_sin = observation, observation == "cos_sin"
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._start_key)

    def _load(
        self, model_path: str | Path | None, model: ModelSpec, integrator: str | None
    ) -> None:
        """``model`` (or the MJCF file ``model_path``) as ``model``, ``data`` and ``params``,
        stepped by ``integrator`` (None: the model's; a file's: ``"euler"``)."""
        if integrator is not None and (
            not isinstance(integrator, str) or integrator not in INTEGRATORS
        ):
            raise ValueError(f"integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
        if model_path is not None and not isinstance(model_path, (str, os.PathLike)):
            raise TypeError(f"model_path must be a path to an MJCF file, got {model_path!r}")
        acrobot = None if model is None else resolve(model)
        #: The parameter set: its torque and velocity limits bound the spaces.
        self.params: AcrobotParams = REPORT if acrobot is None else acrobot.params
        self.model = load_model(model_path, acrobot)
        self._integrator = integrator or ("euler" if acrobot is None else acrobot.integrator)
        self.model.opt.integrator = INTEGRATORS[self._integrator]
        # Whatever the file says: a NaN state must stay visible (step raises), not be reset away.
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        self.data = mujoco.MjData(self.model)

    def _bind(self) -> None:  # views into data and the task's rule, redone by unpickling
        m, d = self.model, self.data
        qadr = [int(m.joint(name).qposadr[0]) for name in ("shoulder", "elbow")]
        dadr = [int(m.joint(name).dofadr[0]) for name in ("shoulder", "elbow")]
        if qadr != [0, 1] or dadr != [0, 1]:
            raise ValueError(
                f"expected joints shoulder, elbow at qpos 0, 1 and dofs 0, 1; got {qadr}, {dadr}"
            )
        self._qpos, self._qvel = d.qpos, d.qvel
        motor = m.actuator(f"{actuated_joint(m)}_motor").id
        self._ctrl = d.ctrl[motor : motor + 1]
        self._rule, self._info = self.task.rule(), self.task.info()
        # the limits as step() reads them: torques, and (-max, max) of each velocity
        self._torques = TorqueLimit(self.params.max_torque)
        self._torque_of: dict[Any, float] = {} if self._continuous else self._torques.of
        max1, max2 = self._max_vel = self.params.max_vel
        self._bounds = (-max1, max1, -max2, max2)

    def __getstate__(self) -> dict[str, Any]:
        views = (
            *("_qpos", "_qvel", "_ctrl", "_rule", "_info"),
            *("_torques", "_torque_of", "_max_vel", "_bounds"),
        )
        state = {key: value for key, value in self.__dict__.items() if key not in views}
        return {**state, "_renderer": None, "_viewer": None}  # GL contexts cannot be copied

    def __setstate__(self, state: dict[str, Any]) -> None:
        added = ("_human", "_viewer", "_shown_at", "_cos_sin", "_observation")  # in 0.4.0
        check_copy("AcrobotEnv", state, added)
        self.__dict__.update({"params": REPORT, **state})  # 0.4.0's: the report's limits
        self._bind()

    # Read-only: the spaces, metadata and model are built from them.
    frame_skip = property(lambda self: self._frame_skip, doc="Physics steps per action.")
    integrator = property(lambda self: self._integrator, doc='"euler" or "rk4".')
    continuous = property(lambda self: self._continuous, doc="Box actions instead of Discrete.")
    observation = property(lambda self: self._observation, doc='"state" or "cos_sin".')
    start_noise = property(lambda self: self.task.start_noise, doc="The task's start noise.")
    torque_limit = property(lambda self: self._torques, doc="The actions' torques (TorqueLimit).")

    @property
    def dt(self) -> float:
        """Time between actions [s]: ``timestep * frame_skip``."""
        return self.model.opt.timestep * self._frame_skip

    @property
    def state(self) -> np.ndarray:
        """The unwrapped state ``(q1, q2, dq1, dq2)`` [rad, rad/s], a copy."""
        return np.concatenate([self._qpos, self._qvel])

    def set_state(self, q: Any, dq: Any = (0.0, 0.0)) -> None:
        """Put the acrobot at angles ``q`` [rad] with velocities ``dq`` [rad/s] (validated)."""
        q, dq = np.asarray(q, dtype=np.float64), np.asarray(dq, dtype=np.float64)
        if q.shape != (2,) or dq.shape != (2,):
            raise ValueError(f"q and dq must have shape (2,), got {q.shape} and {dq.shape}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(dq))):
            raise ValueError(f"state must be finite, got q={q}, dq={dq}")
        if np.any(np.abs(q) > MAX_ANGLE):
            raise ValueError(
                f"angles q={q} rad are beyond +-{MAX_ANGLE:g} rad, where they lose "
                "precision; wrap them into [-pi, pi) first"
            )
        max1, max2 = self._max_vel
        if abs(dq[0]) > max1 or abs(dq[1]) > max2:
            raise ValueError(f"dq={dq} exceeds the velocity limits ({max1:.4g}, {max2:.4g}) rad/s")
        self._qpos[:], self._qvel[:] = q, dq

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._start_key)
        start, given = start_state(self.task, self.state, self.np_random, options)
        if given:
            self.set_state(start[:2], start[2:])  # validated
        else:
            self._qpos[:], self._qvel[:] = start[:2], start[2:]
        q1, q2 = self._qpos.tolist()
        v1, v2 = self._qvel.tolist()
        values = self._rule(q1, q2, v1, v2)[3]
        obs = self._observe(q1, q2, v1, v2)
        if self._human:
            self._show()
        return (cos_sin(obs) if self._cos_sin else obs), self._info(values, False)  # no success

    def step(self, action: Any) -> tuple[np.ndarray, Any, Any, bool, dict[str, Any]]:
        torque = self._torque_of.get(action) if action.__class__ in INT_TYPES else None
        if torque is None:
            torque = action_torque(action, self._continuous, self._torques)
        self._ctrl[0] = torque
        m, d, qvel = self.model, self.data, self._qvel
        low1, high1, low2, high2 = self._bounds
        for _ in self._substeps:
            _mj_step(m, d)
            v1, v2 = qvel.tolist()
            if not (low1 <= v1 <= high1 and low2 <= v2 <= high2):  # or NaN
                v1, v2 = qvel[0], qvel[1] = limit_velocities(v1, v2, self._max_vel)
        q1, q2 = self._qpos.tolist()
        # Angles in [-pi, pi) and velocities within the limits (not NaN) are observed as they
        # are; anything else takes the one rule (MuJoCo's autoreset is off).
        if _MIN_PI <= q1 < _PI and _MIN_PI <= q2 < _PI and v1 == v1 and v2 == v2:
            obs = np.array((q1, q2, v1, v2))
        else:
            obs = self._observe(q1, q2, v1, v2)
        reward, terminated, success, values = self._rule(q1, q2, v1, v2)
        if self._cos_sin:
            obs = cos_sin(obs)
        if self._human:
            self._show()
        return obs, reward, terminated, False, self._info(values, success)

    def _observe(self, q1: float, q2: float, v1: float, v2: float) -> np.ndarray:
        obs = observation(q1, q2, v1, v2)
        if obs is None:
            self._raise_bad_state()
        return obs

    def _raise_bad_state(self) -> NoReturn:
        kinds = mujoco.mjtWarning
        reported = [
            f"{w.name.removeprefix('mjWARN_')} (last at index {self.data.warning[w].lastinfo})"
            for w in (kinds.mjWARN_BADQPOS, kinds.mjWARN_BADQVEL, kinds.mjWARN_BADQACC)
            if self.data.warning[w].number
        ]
        raise Diverged(
            f"the simulation reached a non-finite state or angles beyond +-{MAX_ANGLE:g} rad"
            + (f"; MuJoCo reported {', '.join(reported)}" if reported else "")
            + f"; state now {self.state.tolist()}. Call reset() before stepping again."
        )

    def render(self) -> np.ndarray | None:
        """The current frame from ``camera``: ``"rgb_array"`` ``uint8`` ``(height, width, 3)``,
        ``"depth_array"`` float32 ``(height, width)`` distances [m] (headless GL:
        :func:`acrobot_mj.envs.gl.make_renderer`); ``"human"`` shows it in MuJoCo's viewer
        window (as every reset and step does) and returns None."""
        if self.render_mode is None:
            gym.logger.warn("render() called with render_mode=None: nothing is rendered")
            return None
        if self._human:
            self._show()
            return None
        if self._renderer is None:
            self._renderer = make_renderer(self.model, self.width, self.height)
            if self.render_mode == "depth_array":
                self._renderer.enable_depth_rendering()
        # mj_step leaves positions, cameras and lights at the start of the last step.
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        self._renderer.update_scene(self.data, camera=self.camera)
        return self._renderer.render()

    def _show(self) -> None:
        """The state in the viewer window, at most ``render_fps`` frames a second of wall time;
        nothing once the user has closed the window."""
        if self._viewer is None:
            self._viewer = open_viewer(self.model, self.data, self.camera)
        elif not self._viewer.is_running():
            return
        wait = self._shown_at + self.dt - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        mujoco.mj_kinematics(self.model, self.data)  # the positions after the last step
        self._viewer.sync()
        self._shown_at = time.perf_counter()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if self._viewer is not None:
            close_viewer(self._viewer)
            self._viewer = None
