"""Model errors: the AI Olympics robustness protocol's ten model parameters changed on the
MuJoCo model an env steps, while its controller keeps the nominal model (dfki-ric-
underactuated-lab/double_pendulum, leaderboard/acrobot/robustness_v2/sim_parameters.py and
src/python/double_pendulum/analysis/benchmark.py; the plant, model/plant.py). The parameters
are in the protocol's terms (docs/envs/disturbances.md): inertias about the joint axes,
``m r`` products, viscous ``b`` and Coulomb-like ``cf`` friction ``F = b dq + cf arctan(100
dq)`` (subtracted), the motor's inertia ``Ir`` behind gear ratio ``gr``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

from acrobot_mj.checks import check_float
from acrobot_mj.envs.links import acrobot_under, read_link, write_link
from acrobot_mj.physics.models import JOINTS, ModelSpec, joint_inertias, resolve

#: The protocol's parameters in its order: motor inertia [kg m^2], m1 r1 [kg m], I1 about the
#: shoulder [kg m^2], b1 [N m s/rad], cf1 [N m], then link 2's and m2 [kg].
PROTOCOL_PARAMETERS = ("Ir", "m1r1", "I1", "b1", "cf1", "m2r2", "m2", "I2", "b2", "cf2")
#: The protocol's gear ratio (model_parameters.yml of design C.1).
GEAR_RATIO = 6.0


def nominal(model: ModelSpec = "ai_olympics", gear_ratio: float = GEAR_RATIO) -> dict[str, float]:
    """A parameter set's values of :data:`PROTOCOL_PARAMETERS` in the protocol's terms: inertias
    about the joints ``I + m r^2``, ``Ir`` the elbow's motor inertia over ``gear_ratio^2``, ``b``
    the damping and ``cf`` the Coulomb friction of each joint."""
    m = resolve(model)
    p = m.params
    values = {"Ir": m.motor_inertia[1] / gear_ratio**2}
    about_joints = joint_inertias(m)
    for k, (mass, lc) in enumerate(((p.m1, p.lc1), (p.m2, p.lc2))):
        j = str(k + 1)
        values |= {f"m{j}r{j}": mass * lc, f"I{j}": about_joints[k]}
        values |= {f"b{j}": m.damping[k], f"cf{j}": m.friction[k]}
    values["m2"] = p.m2
    return {name: float(values[name]) for name in PROTOCOL_PARAMETERS}


def check_parameters(values: Mapping[str, float]) -> dict[str, float]:
    """``values`` as floats, refusing an unknown name or a value out of range in one line."""
    if not isinstance(values, Mapping):
        raise TypeError(f"model errors must be a mapping of names to values, got {values!r}")
    unknown = sorted(set(values) - set(PROTOCOL_PARAMETERS))
    if unknown:
        raise ValueError(f"unknown model parameters {unknown}; known: {list(PROTOCOL_PARAMETERS)}")
    checked = {}
    for name, value in values.items():
        low = -1e3 if name[:1] in "bc" else 0.0  # friction may be negative (the protocol's)
        checked[name] = check_float(name, value, low, 1e3)
        if name != "Ir" and name[:1] in "mI" and checked[name] <= 0.0:
            raise ValueError(f"{name} must be > 0, got {value:g}")
    return checked


class ModelError(gym.Wrapper):
    """The env's MuJoCo model with :data:`PROTOCOL_PARAMETERS` ``values`` (any of them; the rest
    keep theirs), set at construction and put back by ``close``:

    - ``Ir``: MuJoCo's armature, ``gr^2 Ir + Ir`` on the shoulder and ``gr^2 Ir`` on the
      elbow (the plant's diagonal); the plant's coupling ``M12 = M21 -= gr Ir`` as the force
      ``gr Ir (ddq2, ddq1)`` [N m] in ``qfrc_applied`` from the accelerations of the physics
      step before (MuJoCo's ``qacc``; 0 after a reset), held over the decision
      (docs/envs/disturbances.md measures it).
    - ``m2``: the mass, its centre of mass and inertia about the joint kept; ``m1r1``,
      ``m2r2``: the centre of mass at ``value / m`` (after ``m2``), the inertia about the joint
      kept; ``I1``, ``I2``: the inertia about the joint. MuJoCo holds inertias about the
      centre of mass, ``I - m r^2``, which may be negative here (MuJoCo takes it at run time).
    - ``b1``, ``b2``: MuJoCo's ``dof_damping`` (negative ones too), exact under RK4 (MuJoCo
      evaluates it at each stage, as the plant does); implicit under MuJoCo's Euler.
    - ``cf1``, ``cf2``: ``-cf arctan(100 dq)`` [N m] in ``qfrc_applied`` from the state at the
      start of each decision (held over its physics steps; exact to the plant's RK4 only to
      first order).

    This wrapper's part of ``qfrc_applied`` is kept apart from other writers'.
    """

    def __init__(
        self, env: gym.Env, values: Mapping[str, float], gear_ratio: float = GEAR_RATIO
    ) -> None:
        super().__init__(env)
        self.values = check_parameters(values)
        if check_float("gear_ratio", gear_ratio, 0.0, 1e4) <= 0.0:
            raise ValueError(f"gear_ratio must be > 0, got {gear_ratio:g}")
        acrobot = acrobot_under(env, "ModelError")
        self._model, self._data = acrobot.model, acrobot.data
        m = self._model
        self._saved = {
            name: getattr(m, name).copy()
            for name in ("body_mass", "body_ipos", "body_inertia", "dof_damping", "dof_armature")
        }
        self._cf = np.array([self.values.get("cf1", 0.0), self.values.get("cf2", 0.0)])
        self._coupling = gear_ratio * self.values.get("Ir", 0.0)
        self._forced = bool(self._cf.any() or self._coupling)  # a force in qfrc_applied
        self._mine = np.zeros(2)
        apply(m, self.values, gear_ratio)

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        self._set(np.zeros(2))
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        if self._forced:
            friction = -self._cf * np.arctan(100.0 * self._data.qvel)
            self._set(friction + self._coupling * self._data.qacc[::-1])
        return self.env.step(action)

    def _set(self, force: np.ndarray) -> None:
        """Make this wrapper's part of ``qfrc_applied`` [N m] ``force``."""
        self._data.qfrc_applied -= self._mine
        self._data.qfrc_applied += force
        self._mine = force

    def close(self) -> None:
        for name, saved in self._saved.items():
            getattr(self._model, name)[:] = saved
        self._set(np.zeros(2))
        super().close()


def apply(model: mujoco.MjModel, values: Mapping[str, float], gear_ratio: float) -> None:
    """Write ``values`` (:data:`PROTOCOL_PARAMETERS`, checked) into ``model`` but the ``cf`` ones
    (no MuJoCo field holds them)."""
    if "Ir" in values:
        ir = values["Ir"]
        model.dof_armature[model.joint("shoulder").dofadr[0]] = gear_ratio**2 * ir + ir
        model.dof_armature[model.joint("elbow").dofadr[0]] = gear_ratio**2 * ir
    for k in (1, 2):
        mass, r, inertia = read_link(model, k)
        about_joint = inertia + mass * r**2
        mass = values.get(f"m{k}", mass) if k == 2 else mass
        r = values[f"m{k}r{k}"] / mass if f"m{k}r{k}" in values else r
        about_joint = values.get(f"I{k}", about_joint)
        write_link(model, k, mass, r, about_joint - mass * r**2)
        if f"b{k}" in values:
            model.dof_damping[model.joint(JOINTS[k - 1]).dofadr[0]] = values[f"b{k}"]


def measured(env: gym.Env, gear_ratio: float = GEAR_RATIO) -> dict[str, float]:
    """The values of :data:`PROTOCOL_PARAMETERS` but ``cf`` (no MuJoCo field holds them) that
    ``env``'s MuJoCo model has, in the protocol's terms."""
    model = env.unwrapped.model  # type: ignore[attr-defined]
    values = {"Ir": float(model.dof_armature[model.joint("elbow").dofadr[0]]) / gear_ratio**2}
    for k in (1, 2):
        mass, r, inertia = read_link(model, k)
        values[f"m{k}r{k}"] = mass * r
        values[f"I{k}"] = inertia + mass * r**2
        values[f"b{k}"] = float(model.dof_damping[model.joint(JOINTS[k - 1]).dofadr[0]])
        if k == 2:
            values["m2"] = mass
    return {name: values[name] for name in PROTOCOL_PARAMETERS if name in values}
