"""Any acrobot (acrobot_mj.physics.models, acrobot_mj.envs.mjcf): the report's generated MJCF is
models/acrobot.xml, every shipped set's MuJoCo model follows its analytic model, the sets carry
their sources' numbers, and the env takes ``model=``."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import acrobot_mj
from acrobot_mj.envs.assets import load_acrobot, load_model, model_path
from acrobot_mj.envs.mjcf import acrobot_xml
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.models import (
    MODELS,
    AcrobotModel,
    capsule_inertia,
    model_from_dict,
    resolve,
)
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.report.crosscheck import cross_check


def _compiled(model: AcrobotModel) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(acrobot_xml(model))


def _fields(model: mujoco.MjModel) -> dict[str, object]:
    names = [n for n in dir(model) if not n.startswith("_")]
    values = {n: getattr(model, n) for n in names}
    kept = {n: v for n, v in values.items() if isinstance(v, (np.ndarray, int, float, str))}
    opt = model.opt
    kept.update({f"opt.{n}": getattr(opt, n) for n in dir(opt) if not n.startswith("_")})
    return {n: v for n, v in kept.items() if not callable(v)}


def test_report_mjcf_is_models_acrobot_xml() -> None:
    # Every compiled field (arrays, sizes, names, options) equal: the text differs only in its
    # comments and number spellings ("1" and "1.0").
    shipped = _fields(mujoco.MjModel.from_xml_path(str(model_path("acrobot.xml"))))
    generated = _fields(_compiled(MODELS["report"]))
    assert shipped.keys() == generated.keys()
    differ = [n for n in shipped if not np.array_equal(shipped[n], generated[n])]
    assert differ == []


def test_report_env_model_equals_the_default() -> None:
    default, generated = _fields(load_model()), _fields(load_acrobot(resolve("report")))
    assert [n for n in default if not np.array_equal(default[n], generated[n])] == []


def _mujoco_run(model: AcrobotModel, x0: np.ndarray, torques: np.ndarray) -> np.ndarray:
    m = _compiled(model)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = x0[:2], x0[2:]
    states = [x0]
    for tau in torques:
        d.ctrl[0] = tau
        mujoco.mj_step(m, d)
        d.qvel[:] = integrators.limit_velocities(*d.qvel, model.params.max_vel)
        states.append(np.concatenate([d.qpos, d.qvel]))
    return np.array(states)


def _derivative(model: AcrobotModel, x: np.ndarray, tau: float) -> np.ndarray:
    # The analytic terms with what the analytic step lacks: the driven joint and damping.
    p, q, dq = model.params, x[:2], x[2:]
    drive = np.zeros(2)
    drive[("shoulder", "elbow").index(model.actuated)] = tau
    force = drive - dynamics.bias_forces(q, dq, p) - np.asarray(model.damping) * dq
    return np.concatenate([dq, np.linalg.solve(dynamics.mass_matrix(q, p), force)])


def _rk4_run(model: AcrobotModel, x0: np.ndarray, torques: np.ndarray) -> np.ndarray:
    h, states = model.params.dt, [x0]
    for tau in torques:
        x = states[-1]
        k1 = _derivative(model, x, tau)
        k2 = _derivative(model, x + h / 2 * k1, tau)
        k3 = _derivative(model, x + h / 2 * k2, tau)
        k4 = _derivative(model, x + h * k3, tau)
        states.append(x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
    return np.array(states)


def _analytic_run(model: AcrobotModel, x0: np.ndarray, torques: np.ndarray) -> np.ndarray:
    if model.actuated == "elbow" and not any(model.damping):
        method = integrators.ENV_INTEGRATORS[model.integrator]
        return integrators.simulate(x0, torques, method, model.analytic)
    assert model.integrator == "rk4"  # the only such sets shipped
    return _rk4_run(model, x0, torques)


# 1,000 steps from hanging under random torques within the limit. MuJoCo and the analytic
# model compute the same formulas in another order: they differ by rounding (1e-16 relative),
# which these swings (far from the chaotic high-energy region) keep below 1e-12 over 1,000
# steps; 1e-10 leaves that margin while a modelling error (an inertia about the wrong point,
# a missing damping term) shows at 1e-3 or more.
@pytest.mark.parametrize("name", sorted(MODELS))
def test_each_set_follows_its_analytic_model(name: str) -> None:
    model = MODELS[name]
    torques = np.random.default_rng(0).uniform(-1, 1, 1000) * model.params.max_torque
    x0 = dynamics.HANGING
    gap = np.abs(_mujoco_run(model, x0, torques) - _analytic_run(model, x0, torques))
    assert gap.max() <= 1e-10, gap.max()


def test_the_analytic_model_refuses_what_it_cannot_represent() -> None:
    assert MODELS["ai_olympics"].analytic is MODELS["ai_olympics"].params
    with pytest.raises(ValueError, match="damping"):
        _ = MODELS["dm_control"].analytic
    with pytest.raises(ValueError, match="shoulder actuated"):
        _ = MODELS["ai_olympics_pendubot"].analytic


def test_sets_carry_their_sources_numbers() -> None:
    assert MODELS["report"].params == REPORT
    gym_set = MODELS["gymnasium"]
    assert gym_set.params == replace(REPORT, dt=0.2) and gym_set.integrator == "rk4"
    assert gym_set.params.max_vel == (4 * math.pi, 9 * math.pi)
    # dm_control: MuJoCo's own inertia of its capsules (the suite's geometry, mass 1 kg).
    dmc = _compiled(MODELS["dm_control"])
    capsule = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><joint type="hinge" axis="0 1 0"/><geom type="capsule" '
        'fromto="0 0 0 0 0 1" size="0.05" mass="1"/></body></worldbody></mujoco>'
    )
    assert capsule.body_inertia[1][0] == capsule_inertia(1.0, 0.05, 1.0)
    assert MODELS["dm_control"].params.I1 == capsule_inertia(1.0, 0.05, 1.0)
    assert np.all(dmc.dof_damping == 0.05)
    # AI Olympics design C.1 model 1.0: I about the joint axes is I + m r^2 about the centre.
    p = MODELS["ai_olympics"].params
    assert (round(p.m1, 4), round(p.m2, 4), p.l1, p.l2, round(p.lc2, 4)) == (
        0.5235,
        0.6256,
        0.2,
        0.3,
        0.2557,
    )
    assert round(p.I1 + p.m1 * p.lc1**2, 4) == 0.0319
    assert round(p.I2 + p.m2 * p.lc2**2, 4) == 0.0509
    assert (p.g, p.max_torque, p.dt) == (9.81, 6.0, 0.002)
    pendubot = _compiled(MODELS["ai_olympics_pendubot"])
    assert pendubot.actuator("shoulder_motor").trnid[0] == pendubot.joint("shoulder").id


def test_env_takes_a_model(tmp_path) -> None:
    env = gym.make("acrobot_mj/Acrobot-v0", model="ai_olympics", goal_height=0.2)
    env.reset(seed=0)
    assert env.unwrapped.dt == 0.002
    assert env.unwrapped.model.body("link2").mass[0] == MODELS["ai_olympics"].params.m2
    path = tmp_path / "heavy.toml"
    path.write_text('m2 = 2.0\ndamping = [0.0, 0.1]\nintegrator = "rk4"\n')
    heavy = resolve(path)
    assert heavy == AcrobotModel(replace(REPORT, m2=2.0), damping=(0.0, 0.1), integrator="rk4")
    env = gym.make("acrobot_mj/Acrobot-v0", model=path)
    assert env.unwrapped.model.body("link2").mass[0] == 2.0
    (tmp_path / "light.json").write_text(json.dumps({"m1": 0.5}))
    assert resolve(tmp_path / "light.json").params == AcrobotParams(m1=0.5)


@pytest.mark.parametrize(
    ("model", "error", "match"),
    [
        ("nope", ValueError, "ai_olympics"),
        (3, TypeError, "model must be"),
    ],
)
def test_env_refuses_bad_models(model, error, match) -> None:
    with pytest.raises(error, match=match):
        acrobot_mj.AcrobotEnv(model=model)


def test_model_files_refused_in_one_line(tmp_path) -> None:
    cases = {
        "unknown.toml": ("mass = 1.0\n", "unknown keys"),
        "negative.json": (json.dumps({"l1": -1}), "l1"),
        "pump.toml": ('actuated = "wrist"\n', "actuated"),
        "broken.json": ("{", "cannot read"),
    }
    for name, (text, match) in cases.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(ValueError, match=match):
            resolve(tmp_path / name)
    with pytest.raises(ValueError, match="model_path"):
        acrobot_mj.AcrobotEnv(model="report", model_path=model_path())


@pytest.mark.parametrize(
    ("values", "says"),
    [
        # MuJoCo zeroes a control past its mjMAXVAL (1e10): the acrobot hung still, exit 0.
        ({"max_torque": 2e10}, "max_torque must be in [1e-06, 1e+09] [N m], got 20000000000.0"),
        # MuJoCo refused it at the first step in two lines, naming neither file nor key.
        ({"m1": 1e-300}, "m1 must be in [1e-06, 1e+06] [kg], got 1e-300"),
        ({"I2": 1e-12, "m2": 1e-12}, "m2 must be in [1e-06, 1e+06] [kg]"),  # BADQACC once
        ({"l1": 1e300}, "l1 must be in [1e-06, 1e+06] [m], got 1e+300"),  # overflowed once
        ({"m1": 10**400}, "m1 must be in [1e-06, 1e+06] [kg], got an integer of 401 digits"),
        ({"damping": [10**400, 0]}, "damping must be two numbers in [0, 1e6], got (an integer"),
    ],
)
def test_a_model_file_out_of_range_is_refused_where_it_is_read(tmp_path, values, says) -> None:
    """Each value checked where the file is read, in one line naming the file and the key
    (each of these once failed later, or not at all)."""
    path = tmp_path / "mine.json"
    path.write_text(json.dumps(values))
    with pytest.raises(ValueError) as error:
        resolve(path)
    assert str(error.value).startswith(f"{path}: ") and says in str(error.value)
    assert "\n" not in str(error.value)


def test_a_model_file_is_refused_for_what_is_wrong_with_it(tmp_path) -> None:
    """A folder, a missing file, a symlink loop and an empty TOML each named as such (all once
    said "must be one of [...] or a .json or .toml file"; the empty TOML was the report's
    acrobot); an upper-case suffix and numpy's scalars are taken."""
    (tmp_path / "folder.json").mkdir()
    (tmp_path / "loop.json").symlink_to(tmp_path / "loop.json")
    (tmp_path / "empty.toml").write_text("")
    (tmp_path / "upper.JSON").write_text(json.dumps({"m1": 2.0}))
    for name, says in [
        ("folder.json", "is a folder"),
        ("missing.toml", "is not found"),
        ("loop.json", "symbolic links"),
        ("empty.toml", "not empty"),
    ]:
        with pytest.raises(ValueError, match=says):
            resolve(tmp_path / name)
    assert resolve(tmp_path / "upper.JSON").params.m1 == 2.0
    assert AcrobotParams(m1=np.float32(2.0)).m1 == 2.0
    for model in MODELS.values():  # to_dict's None (an infinite velocity limit) read back
        assert model_from_dict(model.to_dict()) == model


def test_a_diverging_simulation_is_one_line_from_the_cli(tmp_path, capsys, monkeypatch) -> None:
    """A model in range that Euler steps of 1 s throw past any angle (gravity 1e6 m/s^2, no
    velocity limit: None, as to_dict writes it): the env's one-line refusal, not a traceback
    (a diverging model was a BADQACC traceback)."""
    from acrobot_mj.cli import main

    monkeypatch.chdir(tmp_path)
    path = tmp_path / "wild.json"
    wild = {"g": 1e6, "dt": 1.0, "max_vel1": None, "max_vel2": None}  # MuJoCo warns: BADQACC
    path.write_text(json.dumps(wild))
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--model", str(path), "--steps", "50"])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and "non-finite state" in err and err.count("\n") == 1
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()  # MuJoCo's log: not in the user's folder


@pytest.mark.parametrize("name", ["gymnasium", "ai_olympics"])
def test_cross_check_takes_a_set(name: str) -> None:
    result = cross_check(n_states=50, n_trajectories=1, acrobot=name)
    relative = result["relative"]
    # Rounding only, as for the report's (tests/test_crosscheck.py gives the bounds' reasons).
    assert max(relative["mass_matrix"], relative["accelerations"]) <= 1e-10
    assert max(result["one_step"].values()) <= 1e-12
    # Gymnasium's 1,000 bang-bang decisions of 0.2 s are 200 s of chaotic swinging, where
    # rounding grows to O(1) (as in tests/test_crosscheck.py's high-energy runs): unbounded.
    if name != "gymnasium":
        assert max(result["trajectory_1000"].values()) <= 1e-10


def test_cross_check_refuses_what_the_analytic_model_lacks() -> None:
    with pytest.raises(ValueError, match="damping"):
        cross_check(n_states=5, n_trajectories=1, acrobot="dm_control")


def test_cli_demo_and_params_take_a_model(tmp_path, capsys) -> None:
    from acrobot_mj.cli import main

    out = tmp_path / "demo.json"
    assert main(["demo", "--model", "gymnasium", "--steps", "5", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["config"]["model"] == "gymnasium"
    assert "0.2 s per action" in capsys.readouterr().out
    assert main(["params", "--model", "ai_olympics"]) == 0
    assert "0.002" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--model", "nope"])
    assert exit_info.value.code == 2
    assert "--model" in capsys.readouterr().err


def test_vector_env_takes_a_model() -> None:
    from acrobot_mj.envs.vector import AcrobotVectorEnv

    kwargs = {"model": "ai_olympics", "integrator": "euler", "goal_height": 0.2}
    analytic = AcrobotVectorEnv(3, backend="analytic", **kwargs)
    simulated = gym.make_vec("acrobot_mj/Acrobot-v0", 3, **kwargs)
    a, _ = analytic.reset(seed=1)
    b, _ = simulated.reset(seed=1)
    for _ in range(200):
        a = analytic.step(np.array([2, 0, 2]))[0]
        b = simulated.step(np.array([2, 0, 2]))[0]
    # Rounding only over 200 steps of 2 ms (see the 1,000-step test above).
    assert np.abs(a - b).max() <= 1e-10
    with pytest.raises(ValueError, match="damping"):
        AcrobotVectorEnv(2, model="dm_control", backend="analytic")
