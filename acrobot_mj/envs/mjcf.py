"""The MJCF of any acrobot, generated from its :class:`~acrobot_mj.physics.models.AcrobotModel`
with the names and conventions of ``models/acrobot.xml`` (which is the report's, generated:
``tests/test_models.py`` compares the compiled models)."""

from __future__ import annotations

from acrobot_mj.physics.models import AcrobotModel


def _n(value: float) -> str:
    return repr(float(value))


def _joint(name: str, model: AcrobotModel, k: int) -> str:
    damping, friction, inertia = model.damping[k], model.friction[k], model.motor_inertia[k]
    return (
        f'<joint name="{name}" damping="{_n(damping)}" frictionloss="{_n(friction)}" '
        f'armature="{_n(inertia)}"/>'
    )


def _inertial(lc: float, mass: float, inertia: float) -> str:
    # I about the hinge direction (y) through the centre of mass; the axial moment (x), a
    # thousandth of it, never enters planar motion.
    return (
        f'<inertial pos="{_n(lc)} 0 0" mass="{_n(mass)}" '
        f'diaginertia="{_n(inertia / 1000)} {_n(inertia)} {_n(inertia)}"/>'
    )


def acrobot_xml(model: AcrobotModel) -> str:
    """The MJCF text of ``model``: bodies ``link1``, ``link2``, hinges ``shoulder``, ``elbow``
    about ``0 -1 0`` (q of the report), the motor ``<joint>_motor`` on the actuated joint
    (gear 1, ``|tau| <= max_torque`` [N m]), the site ``tip``, keyframes ``hanging`` and
    ``upright``. Geoms are visual, sized to the mean link length."""
    p, s = model.params, (model.params.l1 + model.params.l2) / 2
    integrator = {"euler": "Euler", "rk4": "RK4"}[model.integrator]
    return f"""<mujoco model="acrobot">
  <compiler angle="radian" autolimits="true" inertiafromgeom="false"/>
  <option timestep="{_n(p.dt)}" integrator="{integrator}" gravity="0 0 {_n(-p.g)}">
    <flag constraint="disable" contact="disable" autoreset="disable"/>
  </option>
  <default>
    <default class="acrobot">
      <joint type="hinge" axis="0 -1 0" damping="0" frictionloss="0" armature="0" stiffness="0"/>
      <geom type="capsule" contype="0" conaffinity="0" group="1" material="link"/>
      <site group="3" size="{_n(0.02 * s)}" rgba="1 0.3 0.1 1"/>
    </default>
  </default>
  <asset>
    <material name="link" rgba="0.85 0.45 0.1 1"/>
    <material name="link2" rgba="0.15 0.45 0.85 1"/>
    <material name="hub" rgba="0.2 0.2 0.2 1"/>
  </asset>
  <worldbody>
    <body name="link1" pos="0 0 0" childclass="acrobot">
      {_joint("shoulder", model, 0)}
      {_inertial(p.lc1, p.m1, p.I1)}
      <geom name="link1" fromto="0 0 0 {_n(p.l1)} 0 0" size="{_n(0.06 * s)}"/>
      <geom name="shoulder_hub" type="cylinder" fromto="0 {_n(-0.07 * s)} 0 0 {_n(0.07 * s)} 0"
            size="{_n(0.08 * s)}" material="hub"/>
      <body name="link2" pos="{_n(p.l1)} 0 0">
        {_joint("elbow", model, 1)}
        {_inertial(p.lc2, p.m2, p.I2)}
        <geom name="link2" fromto="0 0 0 {_n(p.l2)} 0 0" size="{_n(0.055 * s)}" material="link2"/>
        <geom name="elbow_hub" type="cylinder" fromto="0 {_n(-0.065 * s)} 0 0 {_n(0.065 * s)} 0"
              size="{_n(0.07 * s)}" material="hub"/>
        <site name="tip" pos="{_n(p.l2)} 0 0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="{model.actuated}_motor" joint="{model.actuated}" gear="1"
           ctrlrange="{_n(-p.max_torque)} {_n(p.max_torque)}"/>
  </actuator>
  <keyframe>
    <key name="hanging" qpos="-1.5707963267948966 0" qvel="0 0" ctrl="0"/>
    <key name="upright" qpos="1.5707963267948966 0" qvel="0 0" ctrl="0"/>
  </keyframe>
</mujoco>
"""
