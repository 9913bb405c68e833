"""The AI Olympics disturbances as wrappers (Sensor, Motor, ModelError), each against a hand
computation of the protocol's rule, on the report's env (discrete and continuous) and the
ai_olympics set; and their bad input refused in one line."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import acrobot_mj  # noqa: F401 (registers the ids)
from acrobot_mj.cli import main
from acrobot_mj.envs.model_error import PROTOCOL_PARAMETERS, ModelError, measured, nominal
from acrobot_mj.envs.motor import Motor
from acrobot_mj.envs.sensor import Sensor
from acrobot_mj.olympics.protocol import Perturbations
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING, bias_forces, mass_matrix
from acrobot_mj.physics.models import MODELS
from acrobot_mj.physics.xp import ARRAY, wrap
from acrobot_mj.train.evaluate import evaluate
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.trainer import train

ID = "acrobot_mj/Acrobot-v0"


def olympics() -> gym.Env:
    return gym.make(ID, model="ai_olympics", continuous=True, goal_height=0.45, integrator="rk4")


def run(env: gym.Env, actions, seed: int = 0) -> tuple[list, list]:
    """Observations (reset's first) and true states of ``actions`` from hanging."""
    obs, _ = env.reset(seed=seed)
    observations, states = [obs], [env.unwrapped.state]
    for action in actions:
        obs, *_ = env.step(action)
        observations.append(obs)
        states.append(env.unwrapped.state)
    return observations, states


def swing(n: int, continuous: bool) -> list:
    rng = np.random.default_rng(1)
    if continuous:
        return [rng.uniform(-1, 1, 1).astype(np.float32) for _ in range(n)]
    return [int(a) for a in rng.integers(0, 3, n)]


@pytest.mark.parametrize("continuous", [False, True])
def test_sensor_off_is_the_env(continuous: bool) -> None:
    actions = swing(30, continuous)
    plain, _ = run(gym.make(ID, continuous=continuous), actions)
    sensed, _ = run(Sensor(gym.make(ID, continuous=continuous)), actions)
    assert all(np.array_equal(a, b) for a, b in zip(plain, sensed, strict=True))


@pytest.mark.parametrize("continuous", [False, True])
def test_delay_of_three_decisions(continuous: bool) -> None:
    env = gym.make(ID, continuous=continuous)
    dt = env.unwrapped.dt
    sensor = Sensor(env, delay=3.5 * dt)
    assert sensor.n == 4
    observations, states = run(sensor, swing(20, continuous))
    for k, obs in enumerate(observations):
        back = states[max(k - 3, 0)]  # the oldest while fewer than 3 have passed
        assert np.array_equal(obs, [wrap(back[0]), wrap(back[1]), back[2], back[3]])
    assert np.array_equal(sensor.measured[-1], states[-4])


def test_velocity_delay_keeps_angles_current() -> None:
    env = gym.make(ID)
    sensor = Sensor(env, delay=2.5 * env.unwrapped.dt, mode="vel")
    _, states = run(sensor, swing(10, False))
    for k in range(3, len(states)):
        assert np.array_equal(sensor.measured[k][:2], states[k][:2])
        assert np.array_equal(sensor.measured[k][2:], states[k - 2][2:])


def test_protocol_delay_rule_rounds_down() -> None:
    # Python's float division, as the protocol's: 0.006 / 0.002 = 3.0000000000000004.
    assert Sensor(olympics(), delay=0.006).n == int(0.006 / 0.002) + 1 == 4
    assert Sensor(olympics(), delay=0.004).n == int(0.004 / 0.002) + 1 == 3
    assert Sensor(olympics(), delay=0.0039).n == 2


def test_noise_is_seeded_and_has_its_sigma() -> None:
    sigma = [0.0, 0.1, 0.2, 0.5]
    first = Sensor(gym.make(ID), sigma=sigma)
    run(first, [1] * 2000, seed=3)
    second = Sensor(gym.make(ID), sigma=sigma, rng=np.random.default_rng(7))
    run(second, [1] * 2000, seed=3)
    again = Sensor(gym.make(ID), sigma=sigma)
    run(again, [1] * 2000, seed=3)
    assert np.array_equal(first.measured, again.measured)
    assert not np.array_equal(first.measured, second.measured)
    _, states = run(gym.make(ID), [1] * 2000, seed=3)
    errors = first.measured - np.array(states)
    n = len(errors)
    assert np.all(errors[:, 0] == 0.0)
    for j in (1, 2, 3):
        std = errors[:, j].std()
        assert abs(std - sigma[j]) < 4 * sigma[j] / math.sqrt(2 * (n - 1))


def test_cos_sin_from_the_noisy_state() -> None:
    sensor = Sensor(gym.make(ID, observation="cos_sin"), sigma=0.3, rng=2)
    obs, _ = sensor.reset(seed=0)
    q1, q2, v1, v2 = sensor.measured[0]
    expected = np.array([np.cos(q1), np.sin(q1), np.cos(q2), np.sin(q2), v1, v2], np.float32)
    assert np.array_equal(obs, expected)


def test_response_of_one_half() -> None:
    motor = Motor(olympics(), response=0.5)
    run(motor, [np.array([1.0], np.float32)] * 3)  # a 1 N m step: 0.5, 0.75, 0.875
    assert motor.applied[:, 1].tolist() == [0.5, 0.75, 0.875]
    assert motor.applied[:, 0].tolist() == [0.0, 0.0, 0.0]


def test_response_on_a_two_newton_metre_step() -> None:
    motor = Motor(olympics(), response=0.5)
    run(motor, [np.array([2.0], np.float32)] * 3)
    assert motor.applied[:, 1].tolist() == [1.0, 1.5, 1.75]


@pytest.mark.parametrize("continuous", [False, True])
def test_response_on_the_report_env(continuous: bool) -> None:
    motor = Motor(gym.make(ID, continuous=continuous), response=0.25)
    run(motor, [np.array([-1.0], np.float32) if continuous else 0] * 3)
    assert motor.applied[:, 1].tolist() == [-0.25, -0.4375, -0.578125]


def test_applied_torque_reaches_mujoco() -> None:
    """What MuJoCo integrates is the applied torque: the motor's run equals the plain env
    driven by the applied torques."""
    actions = swing(50, True)
    motor = Motor(olympics(), response=0.3, sigma=0.2, rng=4)
    _, states = run(motor, actions)
    plain = olympics()
    plain.reset(seed=0)
    data = plain.unwrapped.data
    for k, nu in enumerate(motor.applied):
        data.qfrc_applied[1] = nu[1] - float(actions[k][0])
        plain.step(actions[k])
        assert np.array_equal(plain.unwrapped.state, states[k + 1])


def test_pulses_exceed_the_clipped_torque() -> None:
    pulses = np.zeros((2, 10))
    pulses[:, 2] = [3.0, 4.0]
    env = gym.make(ID, continuous=True)  # the report's limit: 1 N m
    motor = Motor(env, sigma=5.0, pulses=pulses, rng=0)
    run(motor, [np.array([1.0], np.float32)] * 5)
    assert np.all(np.abs(motor.applied[[0, 1, 3, 4], 1]) <= 1.0)
    assert motor.applied[2, 1] == pytest.approx(4.0 + np.clip(motor.applied[2, 1] - 4.0, -1, 1))
    assert abs(motor.applied[2, 1]) > 1.0
    assert motor.applied[:, 0].tolist() == [0.0, 0.0, 3.0, 0.0, 0.0]  # drawn, never acting
    assert np.all(env.unwrapped.data.qfrc_applied[0] == 0.0)


def test_pulse_array_is_the_protocols_formula() -> None:
    drawn = Perturbations().draw(np.random.default_rng(5), 10.0)
    pulses, mu, sigma, amplitude = drawn.torques(10.0), drawn.mu, drawn.sigma, drawn.amplitude
    rng = np.random.default_rng(5)
    wiggle = (10.0 - 7 * 1.0) / 6
    centres = [1.0 + rng.random() * wiggle]
    for _ in range(5):
        centres.append(centres[-1] + 1.0 + rng.random() * wiggle)
    rng.shuffle(centres)
    assert np.array_equal(mu, np.reshape(centres, (2, 3)))
    assert np.array_equal(sigma, 0.05 + rng.random((2, 3)) * 0.05)
    amp = rng.uniform(-4.5, 4.5, size=(2, 3))
    assert np.array_equal(amplitude, amp + 0.5 * np.sign(amp))
    assert np.all((np.abs(amplitude) >= 0.5) & (np.abs(amplitude) <= 5.0))
    t = np.arange(0, 10.0, 0.002)
    assert pulses.shape == (2, 5000)
    for j in range(2):
        expected = sum(
            amplitude[j, i] * np.exp(-((t - mu[j, i]) ** 2) / (2 * sigma[j, i] ** 2))
            for i in range(3)
        )
        assert np.allclose(pulses[j], expected, rtol=0, atol=1e-12)


def test_motor_noise_is_seeded_and_has_its_sigma() -> None:
    def applied(rng) -> np.ndarray:
        motor = Motor(olympics(), sigma=0.5, rng=rng)
        run(motor, [np.array([0.0], np.float32)] * 2000)
        return motor.applied

    first, again = applied(11), applied(11)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, applied(12))
    assert np.all(first[:, 0] == 0.0)
    n = len(first)
    assert abs(first[:, 1].std() - 0.5) < 4 * 0.5 / math.sqrt(2 * (n - 1))


def test_reset_seed_reseeds_the_wrappers() -> None:
    motor = Sensor(Motor(olympics(), sigma=0.5), sigma=0.1)
    runs = []
    for _ in range(2):
        run(motor, [np.array([0.0], np.float32)] * 20, seed=9)
        runs.append((motor.measured, motor.env.applied))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert np.array_equal(runs[0][1], runs[1][1])


def lumped(m2_scale: float) -> tuple:
    p = MODELS["ai_olympics"].params
    m2 = p.m2 * m2_scale
    i2 = p.I2 + p.m2 * p.lc2**2 - m2 * p.lc2**2  # I2 about the joint kept
    a = p.m1 * p.lc1**2 + m2 * (p.l1**2 + p.lc2**2) + p.I1 + i2
    b, c = m2 * p.l1 * p.lc2, m2 * p.lc2**2 + i2
    return (a, b, c, (p.m1 * p.lc1 + m2 * p.l1) * p.g, m2 * p.lc2 * p.g)


def test_m2_error_follows_the_analytic_model() -> None:
    base = nominal("ai_olympics")
    env = ModelError(olympics(), {"m2": 1.25 * base["m2"]})
    body = env.unwrapped.model.body("link2")
    assert body.mass[0] == 1.25 * base["m2"]
    assert measured(env)["I2"] == pytest.approx(base["I2"], rel=1e-14)
    assert measured(env)["m2r2"] == pytest.approx(1.25 * base["m2r2"], rel=1e-14)
    actions = swing(100, True)
    _, states = run(env, actions)
    theta, dt = lumped(1.25), MODELS["ai_olympics"].params.dt
    x = np.array(HANGING, dtype=np.float64)
    for k, action in enumerate(actions):
        x = np.array(
            integrators.step(*x, float(action[0]), theta, dt, (math.inf,) * 2, 1, 1, ARRAY)
        )
        assert np.abs(x - states[k + 1]).max() <= 1e-10
    env.close()
    assert env.unwrapped.model.body("link2").mass[0] == base["m2"]


def test_nominal_values_in_the_protocols_terms() -> None:
    # design C.1 model 1.0 (model_parameters.yml): I about the joints, m r products.
    values = nominal("ai_olympics")
    assert list(values) == list(PROTOCOL_PARAMETERS)
    assert values["I1"] == pytest.approx(0.031887199591513114, rel=1e-14)
    assert values["I2"] == pytest.approx(0.05086984812807257, rel=1e-14)
    assert values["m1r1"] == pytest.approx(0.5234602302310271 * 0.2, rel=1e-14)
    assert values["m2r2"] == pytest.approx(0.6255677234174437 * 0.25569305436052964, rel=1e-14)
    assert values["Ir"] == values["b1"] == values["cf2"] == 0.0
    assert measured(olympics()) == pytest.approx({k: v for k, v in values.items() if "cf" not in k})


def test_motor_inertia_friction_and_restore() -> None:
    env = olympics()
    model = env.unwrapped.model
    errors = ModelError(env, {"Ir": 1e-4, "b1": -0.1, "b2": 0.05, "m1r1": 1.25 * nominal()["m1r1"]})
    assert model.dof_armature.tolist() == pytest.approx([37e-4, 36e-4], rel=1e-15)
    assert model.dof_damping.tolist() == [-0.1, 0.05]
    assert model.body("link1").inertia[1] < 0  # I1 about the joint kept: 0.0319 < m1 r1^2
    assert measured(env)["I1"] == pytest.approx(nominal()["I1"], rel=1e-12)
    run(errors, swing(50, True))
    assert np.all(np.isfinite(env.unwrapped.state))
    errors.close()
    assert model.dof_armature.tolist() == [0.0, 0.0]
    assert measured(env) == pytest.approx({k: v for k, v in nominal().items() if "cf" not in k})


def test_coulomb_friction_is_an_applied_force() -> None:
    env = ModelError(olympics(), {"cf1": 0.2, "cf2": -0.1})
    env.reset(seed=0, options={"state": np.array([0.0, 0.0, 1.0, -2.0])})
    env.step(np.array([0.0], np.float32))
    expected = [-0.2 * np.arctan(100.0), 0.1 * np.arctan(-200.0)]
    assert env.unwrapped.data.qfrc_applied.tolist() == expected


def test_writers_compose() -> None:
    env = Motor(ModelError(olympics(), {"cf2": 0.1}), sigma=0.0, pulses=np.full((2, 5), 0.5))
    env.reset(seed=0, options={"state": np.array([0.0, 0.0, 0.0, 1.0])})
    env.step(np.array([0.0], np.float32))
    assert env.unwrapped.data.qfrc_applied[1] == pytest.approx(0.5 - 0.1 * np.arctan(100.0))


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda env: Sensor(env, sigma=-0.1), "sigma"),
        (lambda env: Sensor(env, sigma=[0.1, 0.1]), "sigma"),
        (lambda env: Sensor(env, delay=-0.01), "delay"),
        (lambda env: Sensor(env, mode="pos"), "mode"),
        (lambda env: Motor(env, response=0.0), "response"),
        (lambda env: Motor(env, response=-1.0), "response"),
        (lambda env: Motor(env, sigma=-1.0), "sigma"),
        (lambda env: Motor(env, pulses=np.zeros(5)), "pulses"),
        (lambda env: ModelError(env, {"m3": 1.0}), "unknown model parameters"),
        (lambda env: ModelError(env, {"I1": -1.0}), "I1"),
        (lambda env: Sensor(env, rng=-1), "seed"),
    ],
)
def test_bad_input_is_one_line(make, match) -> None:
    with pytest.raises((ValueError, TypeError), match=match) as error:
        make(gym.make(ID))
    assert "\n" not in str(error.value)


def test_bad_pulse_settings() -> None:
    with pytest.raises(ValueError, match="do not fit"):
        Perturbations().draw(np.random.default_rng(0), 5.0)
    with pytest.raises(ValueError, match="sigma"):
        Perturbations(sigma=(0.0, 0.1))


# -- the held-out evaluation under them ------------------------------------------------------

NOISY = {"velocity_noise": 0.5, "delay": 0.1, "torque_noise": 0.3, "torque_response": 0.5}


def test_evaluate_under_the_protocols_disturbances(tmp_path, capsys) -> None:
    run_dir = tmp_path / "book"
    train(PRESETS["book"].replace(episodes=2, max_episode_steps=100), seed=0, out_dir=run_dir)
    plain = evaluate(run_dir, {"episodes": 2}, minima="none")
    noisy = evaluate(run_dir, {"episodes": 2, **NOISY}, minima="none")
    again = evaluate(run_dir, {"episodes": 2, **NOISY}, minima="none")
    assert noisy["protocol"] == {"episodes": 2, "start_noise": 0.05, "seed": 0, **NOISY}
    assert "velocity_noise" not in plain["protocol"]
    assert noisy["rest"] == plain["rest"]  # the episode from rest is undisturbed, as with pushes
    assert noisy["start_states"] == plain["start_states"]
    assert noisy["torques"] == again["torques"] and noisy["actions"] == again["actions"]
    applied = {t for episode in noisy["torques"] for t in episode}
    assert not applied <= {-1.0, 0.0, 1.0}  # the motor's torques, not the commanded ones
    code = main(["evaluate", str(run_dir), "--episodes", "2", "--torque-response", "0.5"])
    assert code == 0 and "held-out starts" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("settings", "words"),
    [
        ({"velocity_noise": -0.1}, "velocity_noise"),
        ({"delay": -0.01}, "delay"),
        ({"torque_noise": -1.0}, "torque_noise"),
        ({"torque_response": 0.0}, "torque_response"),
        ({"torque_response": 2.5}, "torque_response"),
    ],
)
def test_bad_evaluation_disturbances_are_refused_by_name(settings, words) -> None:
    with pytest.raises(ValueError, match=words) as error:
        HeldOut(**settings)
    assert "\n" not in str(error.value)


# -- against the protocol's plant (model/plant.py: friction and motor inertia inside its RK4) --

GR = 6.0


def plant_derivative(x: np.ndarray, tau: float, values: dict[str, float]) -> np.ndarray:
    p, ir = MODELS["ai_olympics"].params, values.get("Ir", 0.0)
    q, dq = x[:2], x[2:]
    m = mass_matrix(q, p) + [[GR**2 * ir + ir, -GR * ir], [-GR * ir, GR**2 * ir]]
    b = np.array([values.get("b1", 0.0), values.get("b2", 0.0)])
    cf = np.array([values.get("cf1", 0.0), values.get("cf2", 0.0)])
    force = np.array([0.0, tau]) - bias_forces(q, dq, p) - b * dq - cf * np.arctan(100 * dq)
    return np.concatenate([dq, np.linalg.solve(m, force)])


def plant_run(torques: np.ndarray, values: dict[str, float], dt: float = 0.002) -> np.ndarray:
    x, states = np.array(HANGING, dtype=np.float64), [np.array(HANGING, dtype=np.float64)]
    for u in torques:
        k1 = plant_derivative(x, u, values)
        k2 = plant_derivative(x + dt / 2 * k1, u, values)
        k3 = plant_derivative(x + dt / 2 * k2, u, values)
        k4 = plant_derivative(x + dt * k3, u, values)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        states.append(x)
    return np.array(states)


# 0.2 s of a 1.2 Hz torque of 0.8 N m from hanging: each change moves the state by more than
# 1 (rad, rad/s); b through dof_damping is exact, Ir with its coupling from the last step's
# accelerations within 2e-3 (6e-2 without it), cf held over each step within 0.12.
@pytest.mark.parametrize(
    ("values", "gap"),
    [
        ({"b1": 0.1, "b2": -0.1}, 1e-10),
        ({"Ir": 1e-4}, 5e-3),
        ({"cf1": 0.2, "cf2": -0.2}, 0.2),
    ],
)
def test_model_errors_follow_the_protocols_plant(values, gap) -> None:
    t = np.arange(100) * 0.002
    torques = np.float32(0.8 * np.sin(2 * np.pi * 1.2 * t))
    _, states = run(ModelError(olympics(), values), [np.array([u]) for u in torques])
    expected = plant_run(torques.astype(float), values)
    assert np.abs(np.array(states) - expected).max() <= gap
    assert np.abs(expected - plant_run(torques.astype(float), {})).max() > 1.0


def test_zero_motor_inertia_is_a_level() -> None:
    """The protocol's first motor-inertia level is 0 kg m^2 (linspace(0, 1e-4)): accepted."""
    from acrobot_mj.envs.model_error import check_parameters

    assert check_parameters({"Ir": 0.0}) == {"Ir": 0.0}
    with pytest.raises(ValueError, match="m2 must be > 0"):
        check_parameters({"m2": 0.0})


def _pushed(env: gym.Env) -> gym.Env:
    from acrobot_mj.envs.disturbances import Pushed

    pushed = Pushed(env)
    pushed.begin([2, 6], 0.5, np.random.default_rng(3))
    return pushed


def _every_wrapper() -> dict[str, Any]:
    from acrobot_mj.envs.wrappers import CosSinObservation, EnergyShaping, ReportObservation

    return {
        "Motor": lambda env: Motor(env, response=0.3, sigma=0.2, pulses=np.ones((2, 3)), rng=1),
        "Sensor": lambda env: Sensor(env, delay=0.1, sigma=0.1, rng=2),
        "ModelError": lambda env: ModelError(env, {"Ir": 1e-4, "m2": 0.7, "cf1": 0.05, "b2": 0.1}),
        "Pushed": _pushed,
        "EnergyShaping": lambda env: EnergyShaping(env, scale=10.0, gamma=0.99),
        "CosSinObservation": CosSinObservation,
        "ReportObservation": lambda env: ReportObservation(CosSinObservation(env)),
    }


@pytest.mark.parametrize("name", sorted(_every_wrapper()))
@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_a_copied_or_unpickled_wrapper_still_disturbs(name: str, how: str) -> None:
    """A copy steps exactly as the original (a Motor once held a view of the original env's
    ``qfrc_applied``, so its copy ran undisturbed): observations and states to the bit."""
    import copy
    import pickle

    wrap_with = _every_wrapper()[name]
    make = lambda: wrap_with(gym.make(ID, continuous=True, max_episode_steps=50))  # noqa: E731
    actions = [np.array([u], dtype=np.float32) for u in (1.0, -1.0, 0.5, 1.0, 0.0, -0.5, 1.0, 1.0)]
    original = run(make(), actions)
    fresh = make()
    copied = copy.deepcopy(fresh) if how == "deepcopy" else pickle.loads(pickle.dumps(fresh))
    again = run(copied, actions)
    undisturbed = run(gym.make(ID, continuous=True, max_episode_steps=50), actions)
    for got, want in zip(again, original, strict=True):
        assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))
    if name in ("Motor", "ModelError", "Pushed"):  # a dynamics wrapper changes the states
        assert not np.array_equal(again[1][-1], undisturbed[1][-1])


@pytest.mark.parametrize(
    ("make", "says"),
    [
        (lambda env: Sensor(env, sigma=None), "sigma must be one number or 4 of them, got None"),
        (lambda env: Sensor(env, delay=10**400), "delay must be finite, got an integer of 401"),
        (lambda env: Motor(env, sigma=10**400), "sigma must be finite, got an integer of 401"),
    ],
)
def test_a_none_or_a_huge_integer_is_one_line(make, says: str) -> None:
    """None once read as NaN ("got nan"); a 400-digit integer raised OverflowError."""
    with pytest.raises(ValueError) as error:
        make(gym.make(ID, continuous=True))
    assert says in str(error.value)


def test_a_huge_integer_setting_is_one_line() -> None:
    from acrobot_mj.settings import SettingError
    from acrobot_mj.train.feedback_run import FeedbackConfig

    with pytest.raises(SettingError, match="reserve must be finite, got an integer of 401 digits"):
        FeedbackConfig(reserve=10**400)


@pytest.mark.parametrize("wrapper", ["Motor", "Sensor", "ModelError", "Pushed"])
def test_a_wrapper_of_gymnasiums_own_acrobot_is_refused_in_one_line(wrapper: str) -> None:
    """Acrobot-v1 has no MuJoCo model: once an AttributeError deep in the constructor."""
    with pytest.raises(TypeError, match=f"{wrapper} wraps an acrobot-mj env"):
        _every_wrapper()[wrapper](gym.make("Acrobot-v1"))


def test_the_motor_drives_the_pendubots_shoulder() -> None:
    """The pendubot's one motor is on the shoulder (once KeyError 'elbow_motor'): a slow
    response there changes the trajectory, and the elbow's limit is 0."""
    make = lambda: gym.make(ID, model="ai_olympics_pendubot", continuous=True)  # noqa: E731
    motor = Motor(make(), response=0.3)
    assert motor.dof == 0 and motor.limit.tolist() == [6.0, 0.0]
    actions = [np.array([3.0], dtype=np.float32)] * 5
    slow, plain = run(motor, actions)[1][-1], run(make(), actions)[1][-1]
    assert not np.array_equal(slow, plain)


def test_a_second_model_error_after_one_that_zeroed_an_inertia() -> None:
    """The first sets link 2's inertia about its centre of mass to 0 (I2 about the joint =
    m2 r2^2); the second once divided by it. Now it sets it."""
    values = nominal("ai_olympics")
    first = ModelError(olympics(), {"I2": values["m2r2"] ** 2 / values["m2"]})
    assert first.unwrapped.model.body("link2").inertia[1] == pytest.approx(0.0, abs=1e-15)
    second = ModelError(first, {"I2": values["I2"]})
    assert measured(second)["I2"] == pytest.approx(values["I2"], rel=1e-12)
