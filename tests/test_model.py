"""The MJCF model against AcrobotParams: the parameters live in two places, tied here."""

from __future__ import annotations

import math
import re

import mujoco
import numpy as np
import pytest

from acrobot_mj.envs.assets import REQUIRED_NAMES, load_model, model_path
from acrobot_mj.physics.params import AcrobotParams, describe

# Values are written in the XML as the same decimal literals as in params.py, so after parsing
# they are the same doubles; 1e-12 only absorbs the compiler's frame arithmetic (e.g. rotating
# inertias into the body frame), which is exact to a few ulps.
TOL = 1e-12


def _hinge_inertia(model: mujoco.MjModel, body: str) -> float:
    """Moment of inertia of ``body`` about the hinge direction through its centre of mass."""
    b = model.body(body)
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, b.iquat)
    rot = rot.reshape(3, 3)
    joint = model.joint(int(b.jntadr[0]))
    inertia_in_body = rot @ np.diag(b.inertia) @ rot.T
    axis = joint.axis / np.linalg.norm(joint.axis)
    return float(axis @ inertia_in_body @ axis)


@pytest.mark.parametrize("name", ["scene.xml", "acrobot.xml"])
def test_model_matches_params(name: str, params: AcrobotParams) -> None:
    model = load_model(model_path(name))
    link1, link2 = model.body("link1"), model.body("link2")
    shoulder, elbow = model.joint("shoulder"), model.joint("elbow")

    assert model.body_mass[link1.id] == pytest.approx(params.m1, abs=TOL)
    assert model.body_mass[link2.id] == pytest.approx(params.m2, abs=TOL)
    # Centres of mass on each link's axis (+x) at lc1, lc2 from the joint.
    np.testing.assert_allclose(link1.ipos, [params.lc1, 0, 0], atol=TOL)
    np.testing.assert_allclose(link2.ipos, [params.lc2, 0, 0], atol=TOL)
    assert _hinge_inertia(model, "link1") == pytest.approx(params.I1, abs=TOL)
    assert _hinge_inertia(model, "link2") == pytest.approx(params.I2, abs=TOL)
    # Link lengths: elbow at l1 along link 1, tip site at l2 along link 2.
    np.testing.assert_allclose(link2.pos, [params.l1, 0, 0], atol=TOL)
    np.testing.assert_allclose(model.site("tip").pos, [params.l2, 0, 0], atol=TOL)

    # Hinges about 0 -1 0 at the body origins: qpos = (q1, q2) of the report, CCW seen from -y.
    for joint in (shoulder, elbow):
        assert joint.type[0] == mujoco.mjtJoint.mjJNT_HINGE
        np.testing.assert_array_equal(joint.axis, [0, -1, 0])
        np.testing.assert_array_equal(joint.pos, [0, 0, 0])
        assert model.dof_damping[joint.dofadr[0]] == 0
        assert model.dof_frictionloss[joint.dofadr[0]] == 0
        assert model.dof_armature[joint.dofadr[0]] == 0
        assert model.jnt_stiffness[joint.id] == 0

    np.testing.assert_array_equal(model.opt.gravity, [0, 0, -params.g])
    assert model.opt.timestep == params.dt
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    for flag in (
        mujoco.mjtDisableBit.mjDSBL_CONSTRAINT,
        mujoco.mjtDisableBit.mjDSBL_CONTACT,
        mujoco.mjtDisableBit.mjDSBL_AUTORESET,
    ):
        assert model.opt.disableflags & flag, flag.name

    motor = model.actuator("elbow_motor")
    assert motor.trnid[0] == elbow.id
    np.testing.assert_array_equal(motor.gear, [1, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(motor.ctrlrange, [-params.max_torque, params.max_torque])
    assert motor.ctrllimited[0]
    assert model.nu == 1


def test_geoms_are_visual_only(model: mujoco.MjModel) -> None:
    # No geom can collide and none adds mass: only the explicit <inertial> elements count.
    assert np.all(model.geom_contype == 0) and np.all(model.geom_conaffinity == 0)
    assert model.body_mass.sum() == pytest.approx(2.0, abs=TOL)


def test_every_element_is_named(model: mujoco.MjModel) -> None:
    for obj, count in [
        (mujoco.mjtObj.mjOBJ_BODY, model.nbody),
        (mujoco.mjtObj.mjOBJ_JOINT, model.njnt),
        (mujoco.mjtObj.mjOBJ_GEOM, model.ngeom),
        (mujoco.mjtObj.mjOBJ_SITE, model.nsite),
        (mujoco.mjtObj.mjOBJ_CAMERA, model.ncam),
        (mujoco.mjtObj.mjOBJ_LIGHT, model.nlight),
        (mujoco.mjtObj.mjOBJ_ACTUATOR, model.nu),
        (mujoco.mjtObj.mjOBJ_KEY, model.nkey),
    ]:
        first = 1 if obj == mujoco.mjtObj.mjOBJ_BODY else 0  # body 0 is MuJoCo's world
        for i in range(first, count):
            assert mujoco.mj_id2name(model, obj, i), f"unnamed {obj.name} {i}"
    for obj, names in REQUIRED_NAMES.items():
        for name in names:
            assert mujoco.mj_name2id(model, obj, name) >= 0, name
    assert model.ncam >= 2


def test_keyframes(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    for key, q1, tip_z in [("hanging", -math.pi / 2, -2.0), ("upright", math.pi / 2, 2.0)]:
        mujoco.mj_resetDataKeyframe(model, data, model.key(key).id)
        np.testing.assert_array_equal(data.qpos, [q1, 0.0])
        np.testing.assert_array_equal(data.qvel, [0.0, 0.0])
        mujoco.mj_forward(model, data)
        # Both links vertical: the tip is l1 + l2 = 2 m below or above the pivot at the origin
        # (1e-12: cos(+-pi/2) is 6e-17, not 0, in floating point).
        np.testing.assert_allclose(data.site("tip").xpos, [0, 0, tip_z], atol=1e-12)
        # Zero-torque equilibria: no acceleration (1e-12: same cos(pi/2) rounding, times g).
        np.testing.assert_allclose(data.qacc, 0, atol=1e-12)


def test_goal_line_is_one_link_above_the_pivot(model: mujoco.MjModel, params) -> None:
    geom = model.geom("goal_line")
    assert geom.pos[2] == params.l1
    assert geom.contype[0] == 0 and geom.conaffinity[0] == 0


def test_header_cites_the_report_table() -> None:
    text = model_path("acrobot.xml").read_text()
    header = text[: text.index("<mujoco")]
    for needle in ["IND E 599", "l1, l2", "lc1, lc2", "m1, m2", "I1, I2", "9.8", "0.05 s", "rad"]:
        assert needle in header, needle


def test_params_carry_unit_and_source() -> None:
    table = describe()
    assert len(table.splitlines()) == 13
    assert re.search(r"^I1\s+1\s+kg m\^2", table, re.M)


@pytest.mark.parametrize("field", ["l1", "m2", "g", "dt"])
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_params_refuse_bad_values(field: str, bad: float) -> None:
    with pytest.raises(ValueError, match=field):
        AcrobotParams(**{field: bad})


def test_params_refuse_non_numbers() -> None:
    with pytest.raises(TypeError, match="l1"):
        AcrobotParams(l1="1.0")
