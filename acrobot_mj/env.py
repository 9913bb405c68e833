"""The acrobot swing-up task as a Gymnasium environment stepping MuJoCo."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from acrobot_mj.assets import load_model
from acrobot_mj.params import AcrobotParams
from acrobot_mj.render import make_renderer

_REPORT = AcrobotParams()
#: Velocity limits [rad/s] (the report, after Sutton and Barto), applied after every physics step.
MAX_VEL1 = _REPORT.max_vel1
MAX_VEL2 = _REPORT.max_vel2
#: Torque [N m] of each discrete action.
TORQUES = (-1.0, 0.0, 1.0)
INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4}
RESET_OPTIONS = ("start_noise",)

_TWO_PI = 2.0 * math.pi
_mj_step = mujoco.mj_step  # a global name lookup is cheaper than a module attribute
#: MuJoCo's mjMAXVAL: states beyond it are "huge" (its BADQPOS/BADQVEL warnings).
_HUGE = 1e10
#: set_state refuses larger angles [rad]: at 1e6 rad a double resolves 1e-10 rad, no finer.
_MAX_ANGLE = 1e6
_INT_TYPES = (int, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64)
_TORQUE_OF = {i: t for i, t in enumerate(TORQUES)}
_BAD_STATE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


def wrap_angle(angle: float) -> float:
    """Wrap an angle [rad] into ``[-pi, pi)`` (the env applies it only to angles outside)."""
    wrapped = (angle + math.pi) % _TWO_PI - math.pi
    return wrapped - _TWO_PI if wrapped >= math.pi else wrapped


def _check_int(name: str, value: Any, minimum: int, maximum: int | None = None) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    if value < minimum or (maximum is not None and value > maximum):
        bound = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ValueError(f"{name} must be {bound}, got {value}")
    return int(value)


def _check_float(
    name: str, value: Any, minimum: float = -math.inf, maximum: float = math.inf
) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {value!r} ({type(value).__name__})")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    if not minimum <= value <= maximum:
        raise ValueError(f"{name} must be in [{minimum:g}, {maximum:g}], got {value:g}")
    return value


class AcrobotEnv(gym.Env[np.ndarray, Any]):
    r"""The acrobot swing-up of the IND E 599 report, simulated by MuJoCo.

    Two links hang from a passive shoulder on a bar; a motor at the elbow (the gymnast's hips)
    applies a torque. The agent must swing the tip of link 2 above a line one link length over the
    bar (Sutton and Barto's height goal). Physics and conventions: ``models/acrobot.xml`` and
    ``DESIGN.md``; parameters: :class:`acrobot_mj.params.AcrobotParams` (l1 = l2 = 1 m,
    lc1 = lc2 = 0.5 m, m1 = m2 = 1 kg, I1 = I2 = 1 kg m^2 about each centre of mass, g = 9.8).

    ## Action Space
    ``Discrete(3)``: the elbow torque, held for ``frame_skip`` physics steps.

    | Num | Action                 | Unit |
    |-----|------------------------|------|
    | 0   | torque -1 on the elbow | N m  |
    | 1   | torque 0               | N m  |
    | 2   | torque +1 on the elbow | N m  |

    With ``continuous=True`` it is ``Box(-1, 1, (1,), float32)``: the torque in N m. Actions
    outside the space (3, -1, 1.5, NaN, a wrong type or shape) raise an error; nothing is clipped.

    ## Observation Space
    ``Box((4,), float64)``: angles in the report's convention (from the horizontal,
    counter-clockwise positive, q2 relative to link 1), wrapped into [-pi, pi).

    | Num | Observation                        | Min    | Max    | Unit  |
    |-----|------------------------------------|--------|--------|-------|
    | 0   | q1, angle of link 1 from +x        | -pi    | pi     | rad   |
    | 1   | q2, angle of link 2 from link 1    | -pi    | pi     | rad   |
    | 2   | dq1, shoulder angular velocity     | -4 pi  | 4 pi   | rad/s |
    | 3   | dq2, elbow angular velocity        | -9 pi  | 9 pi   | rad/s |

    Velocities are clipped to these limits after every physics step (the report's task).
    Gymnasium's ``Acrobot-v1`` uses ``theta1 = q1 + pi/2``, ``theta2 = q2`` and the same torque
    sign, and observes cos and sin of the angles instead.

    ## Rewards
    ``step_reward`` (-1) on every step and ``goal_reward`` (+100) instead on the step that reaches
    the goal (the report).

    ## Starting State
    Hanging at rest, exactly ``(-pi/2, 0, 0, 0)`` (the ``hanging`` keyframe). With
    ``start_noise = s > 0`` each angle and velocity gets ``U(-s, s)`` added (from ``np_random``).

    ## Episode End
    - Termination: the tip is more than ``goal_height`` above the pivot, ``l1 sin(q1) +
      l2 sin(q1 + q2) > goal_height`` (checked after each action's last physics step).
    - Truncation: 1000 actions, by the ``TimeLimit`` that ``gymnasium.make`` adds.

    ``info`` holds ``tip_height`` [m above the pivot] and ``is_success`` (the goal was reached).

    ## Arguments
    | Argument      | Default   | Meaning                                                         |
    |---------------|-----------|-----------------------------------------------------------------|
    | frame_skip    | 1         | physics steps (0.05 s each) per action; 4 gives 0.2 s decisions  |
    | integrator    | "euler"   | MuJoCo's semi-implicit ``"euler"`` or ``"rk4"``                 |
    | step_reward   | -1.0      | reward of a step that does not reach the goal                   |
    | goal_reward   | 100.0     | reward of the step that reaches the goal                        |
    | goal_height   | 1.0       | tip height above the pivot that ends the episode [m], < l1 + l2 |
    | start_noise   | 0.0       | half-width of the uniform start noise [rad, rad/s], in [0, 1]   |
    | continuous    | False     | ``Box(-1, 1, (1,))`` torques instead of ``Discrete(3)``         |
    | render_mode   | None      | ``"rgb_array"``: ``render()`` returns frames (EGL or OSMesa)   |
    | width, height | 480, 480  | frame size [pixels], at most the model's offscreen buffer       |
    | camera        | "side"    | name of a camera in the model (``"side"`` or ``"wide"``)        |
    | model_path    | None      | an MJCF file to use instead of the packaged ``scene.xml``       |

    ``reset(options={"start_noise": s})`` overrides ``start_noise`` for that episode only.
    ``env.unwrapped.model`` and ``env.unwrapped.data`` are the live ``MjModel`` and ``MjData``.
    ``render_fps`` in ``metadata`` is ``1 / (timestep * frame_skip)``, real time.

    ## Example
    Golden values computed independently by the analytic model (``acrobot_mj.integrators``,
    semi-implicit Euler with the same clipping): ten +1 N m steps from rest, rounded to 1e-9,
    then the bang-bang law ``tau = -sign(dq1)`` reaching the goal on step 300 with +100:

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

    ## Version History
    - v0: first version: the report's task on MuJoCo (semi-implicit Euler, 0.05 s steps),
      with offscreen ``rgb_array`` rendering.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        frame_skip: int = 1,
        integrator: str = "euler",
        step_reward: float = -1.0,
        goal_reward: float = 100.0,
        goal_height: float = 1.0,
        start_noise: float = 0.0,
        continuous: bool = False,
        render_mode: str | None = None,
        width: int = 480,
        height: int = 480,
        camera: str = "side",
        model_path: str | Path | None = None,
    ) -> None:
        self._frame_skip = _check_int("frame_skip", frame_skip, 1)
        self._substeps = range(self._frame_skip)
        if not isinstance(integrator, str) or integrator not in INTEGRATORS:
            raise ValueError(f"integrator must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
        self._integrator = integrator
        self.step_reward = _check_float("step_reward", step_reward)
        self.goal_reward = _check_float("goal_reward", goal_reward)
        self.start_noise = _check_float("start_noise", start_noise, 0.0, 1.0)
        if not isinstance(continuous, bool):
            raise TypeError(f"continuous must be True or False, got {continuous!r}")
        self._continuous = continuous
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )

        if model_path is not None and not isinstance(model_path, (str, os.PathLike)):
            raise TypeError(f"model_path must be a path to an MJCF file, got {model_path!r}")
        self.model = load_model(model_path)
        self.model.opt.integrator = INTEGRATORS[integrator]
        # Whatever the file says: a NaN state must stay visible (step raises), not be reset away.
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        self.data = mujoco.MjData(self.model)
        self._ids()
        self._l1, self._l2 = self._link_lengths()
        reach = self._l1 + self._l2
        self.goal_height = _check_float("goal_height", goal_height, -reach, reach)
        if abs(self.goal_height) == reach:
            raise ValueError(
                f"goal_height must be strictly inside (-{reach:g}, {reach:g}) m: "
                f"at {self.goal_height:g} m the goal is never or always reached"
            )

        offwidth, offheight = self.model.vis.global_.offwidth, self.model.vis.global_.offheight
        self.width = _check_int("width", width, 1, offwidth)
        self.height = _check_int("height", height, 1, offheight)
        if (
            not isinstance(camera, str)
            or mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera) < 0
        ):
            names = [self.model.camera(i).name for i in range(self.model.ncam)]
            raise ValueError(
                f"camera must be the name of one of the model's cameras {names}, got {camera!r}"
            )
        self.camera = camera
        self.render_mode = render_mode
        self._renderer = None  # created by the first render() call, released by close()

        self.metadata = {**self.metadata, "render_fps": 1.0 / self.dt}
        if continuous:
            self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        else:
            self.action_space = spaces.Discrete(len(TORQUES))
        # Fast path of step() for integer actions; empty for continuous actions.
        self._torque_of = {} if continuous else _TORQUE_OF
        high = np.array([math.pi, math.pi, MAX_VEL1, MAX_VEL2])
        self.observation_space = spaces.Box(-high, high, dtype=np.float64)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._hanging)

    # -- set-up ----------------------------------------------------------------------------

    def _ids(self) -> None:
        """Resolve names to ids and cache views into ``data`` (redone after unpickling)."""
        m, d = self.model, self.data
        self._hanging = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "hanging")
        joints = [m.joint(name) for name in ("shoulder", "elbow")]
        qadr = [int(j.qposadr[0]) for j in joints]
        dadr = [int(j.dofadr[0]) for j in joints]
        if qadr != [0, 1] or dadr != [0, 1]:
            raise ValueError(f"expected joints shoulder, elbow at qpos 0, 1; got {qadr}")
        self._qpos, self._qvel = d.qpos, d.qvel
        self._ctrl = d.ctrl[m.actuator("elbow_motor").id : m.actuator("elbow_motor").id + 1]

    def _link_lengths(self) -> tuple[float, float]:
        """l1, l2 [m] measured on the model: shoulder to elbow, elbow to the ``tip`` site."""
        m = self.model
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        shoulder, elbow = d.xanchor[m.joint("shoulder").id], d.xanchor[m.joint("elbow").id]
        tip = d.site_xpos[m.site("tip").id]
        return float(np.linalg.norm(elbow - shoulder)), float(np.linalg.norm(tip - elbow))

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for key in ("_qpos", "_qvel", "_ctrl"):
            state.pop(key)
        state["_renderer"] = None  # a GL context cannot be copied; the copy makes its own
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._ids()

    # -- the task --------------------------------------------------------------------------

    # Read-only: the spaces, metadata and model are built from them at construction.
    frame_skip = property(lambda self: self._frame_skip, doc="Physics steps per action.")
    integrator = property(lambda self: self._integrator, doc='"euler" or "rk4".')
    continuous = property(lambda self: self._continuous, doc="Box actions instead of Discrete.")

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
        if np.any(np.abs(q) > _MAX_ANGLE):
            raise ValueError(
                f"angles q={q} rad are beyond +-{_MAX_ANGLE:g} rad, where they lose "
                "precision; wrap them into [-pi, pi) first"
            )
        if abs(dq[0]) > MAX_VEL1 or abs(dq[1]) > MAX_VEL2:
            raise ValueError(
                f"dq={dq} exceeds the velocity limits ({MAX_VEL1:.4g}, {MAX_VEL2:.4g}) rad/s"
            )
        self._qpos[:] = q
        self._qvel[:] = dq

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        noise = self.start_noise
        if options is not None and not isinstance(options, Mapping):
            raise TypeError(f"reset options must be a dict, got {options!r}")
        if options:
            unknown = sorted(set(options) - set(RESET_OPTIONS))
            if unknown:
                raise ValueError(f"unknown reset options {unknown}; known: {list(RESET_OPTIONS)}")
            if "start_noise" in options:
                noise = _check_float("start_noise", options["start_noise"], 0.0, 1.0)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._hanging)
        if noise > 0.0:
            self._qpos += self.np_random.uniform(-noise, noise, 2)
            self._qvel += self.np_random.uniform(-noise, noise, 2)
        obs, tip, _ = self._observe()
        return obs, {"tip_height": tip, "is_success": False}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        # The hot path: names resolved to ids once, views into data cached, the observation
        # the only allocation, and _observe() inlined (a call costs a tenth of the step).
        torque = self._torque_of.get(action) if action.__class__ in _INT_TYPES else None
        self._ctrl[0] = self._torque(action) if torque is None else torque
        m, d, qvel = self.model, self.data, self._qvel
        for _ in self._substeps:
            _mj_step(m, d)
            # Velocity limits of the task, after every physics step.
            v1, v2 = qvel.tolist()
            if v1 > MAX_VEL1 or v1 < -MAX_VEL1:
                v1 = qvel[0] = MAX_VEL1 if v1 > 0 else -MAX_VEL1
            if v2 > MAX_VEL2 or v2 < -MAX_VEL2:
                v2 = qvel[1] = MAX_VEL2 if v2 > 0 else -MAX_VEL2
        q1, q2 = self._qpos.tolist()
        tip = self._l1 * math.sin(q1) + self._l2 * math.sin(q1 + q2)
        # Angles in [-pi, pi) are observed exactly as they are; others are wrapped.
        w1 = q1 if -math.pi <= q1 < math.pi else wrap_angle(q1)
        w2 = q2 if -math.pi <= q2 < math.pi else wrap_angle(q2)
        obs = np.array((w1, w2, v1, v2))
        # False for NaN, infinities and MuJoCo's "huge" values alike (one comparison); the env
        # disables MuJoCo's autoreset, so a bad state cannot hide.
        if not abs(q1) + abs(q2) + abs(v1) + abs(v2) < _HUGE:
            self._raise_bad_state()
        terminated = tip > self.goal_height
        reward = self.goal_reward if terminated else self.step_reward
        return obs, reward, terminated, False, {"tip_height": tip, "is_success": terminated}

    def _observe(self) -> tuple[np.ndarray, float, bool]:
        """Observation, tip height [m] and whether the state is finite."""
        q1, q2 = self._qpos.tolist()
        v1, v2 = self._qvel.tolist()
        tip = self._l1 * math.sin(q1) + self._l2 * math.sin(q1 + q2)
        # Angles in [-pi, pi) are observed exactly as they are; others are wrapped.
        w1 = q1 if -math.pi <= q1 < math.pi else wrap_angle(q1)
        w2 = q2 if -math.pi <= q2 < math.pi else wrap_angle(q2)
        obs = np.array((w1, w2, v1, v2))
        # False for NaN, infinities and MuJoCo's "huge" values alike (one comparison).
        return obs, tip, abs(q1) + abs(q2) + abs(v1) + abs(v2) < _HUGE

    def _raise_bad_state(self) -> None:
        reported = [
            f"{w.name.removeprefix('mjWARN_')} (last at index {self.data.warning[w].lastinfo})"
            for w in _BAD_STATE_WARNINGS
            if self.data.warning[w].number
        ]
        raise RuntimeError(
            "the simulation reached a non-finite or huge state"
            + (f"; MuJoCo reported {', '.join(reported)}" if reported else "")
            + f"; state now {self.state.tolist()}. Call reset() before stepping again."
        )

    def _torque(self, action: Any) -> float:
        """The elbow torque [N m] of ``action``; raises on anything outside the action space."""
        if not self._continuous:
            if action.__class__ in _INT_TYPES:
                torque = _TORQUE_OF.get(action)
                if torque is not None:
                    return torque
                raise ValueError(
                    f"action {action} is outside Discrete(3): use 0 (-1 N m), "
                    "1 (0 N m) or 2 (+1 N m)"
                )
            if isinstance(action, (int, np.integer)) and not isinstance(action, (bool, np.bool_)):
                return self._torque(int(action))  # e.g. np.longlong or an IntEnum member
            if isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu":
                return self._torque(action.item())
            raise TypeError(
                f"action must be an integer 0, 1 or 2, got {action!r} ({type(action).__name__})"
            )
        array = np.asarray(action)
        if array.dtype.kind not in "fiu":
            raise TypeError(f"action must be a float array of shape (1,), got {action!r}")
        if array.shape != (1,):
            raise ValueError(f"action must have shape (1,), got shape {array.shape}: {action!r}")
        torque = float(array[0])
        if not -1.0 <= torque <= 1.0:  # also refuses NaN
            raise ValueError(f"action {torque} N m is outside the torque range [-1, 1] N m")
        return torque

    def render(self) -> np.ndarray | None:
        """The current frame, ``uint8`` of shape ``(height, width, 3)``, from ``camera``.

        The renderer is created on the first call through :func:`acrobot_mj.render.make_renderer`
        (headless EGL or OSMesa; a clear error if neither works) and released by :meth:`close`.
        """
        if self.render_mode is None:
            gym.logger.warn("render() called with render_mode=None: nothing is rendered")
            return None
        if self._renderer is None:
            self._renderer = make_renderer(self.model, self.width, self.height)
        # Positions of bodies, cameras and lights for the current state (mj_step leaves them
        # at the start of the last step).
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        self._renderer.update_scene(self.data, camera=self.camera)
        return self._renderer.render()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
