"""Model-based learning: the dynamics identified from env transitions, an env over the model that
follows MuJoCo, and training in it that costs the env only the data and the greedy run."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from acrobot_mj.envs.identified import IdentifiedEnv
from acrobot_mj.identify.lumped import identify
from acrobot_mj.physics.integrators import Stepping, step_states
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.train import model_based
from acrobot_mj.train.evaluate import evaluate
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.lockstep import can_lockstep
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.trainer import train

#: The lumped parameters of the report's acrobot, by hand: a = 0.25 + (1 + 0.25) + 1 + 1,
#: b = 1 * 1 * 0.5, c = 0.25 + 1, d = (0.5 + 1) * 9.8, e = 0.5 * 9.8.
TRUTH = (3.5, 0.5, 1.25, 14.7, 4.9)
#: The env's step as the learner is told it: 0.05 s, 4 steps per decision, the velocity limits.
BOOK_STEP = Stepping(substeps=4)
SMALL = PRESETS["tuned"].replace(population=2, max_decisions=6000, identify_decisions=300)


@pytest.fixture(scope="module")
def data():
    return model_based.collect(gym.make("acrobot_mj/Acrobot-v0", frame_skip=4), 300, 0, 0.05)


def advance(x, tau, theta, told):
    """One decision of the lumped model ``theta`` from state ``x`` with torque ``tau``."""
    return told.advance(theta, np.asarray(x, dtype=float)[None], [tau])[0]


def test_the_truth_by_hand_and_the_lumped_step_is_the_models() -> None:
    np.testing.assert_allclose(AcrobotParams().lumped, TRUTH, rtol=1e-15)
    x = np.array([-1.2, 0.7, 1.5, -3.0])
    for tau in (-1.0, 0.0, 1.0):
        np.testing.assert_allclose(
            advance(x, tau, TRUTH, BOOK_STEP), step_states(x, tau, substeps=4), atol=1e-13
        )


def test_identification_recovers_the_parameters_from_env_transitions(data) -> None:
    theta, rms = identify(data, BOOK_STEP)
    # MuJoCo's Euler step and the lumped model agree to rounding, so the fit is exact up to it.
    assert rms < 1e-12
    np.testing.assert_allclose(theta, TRUTH, rtol=1e-9)


@pytest.mark.parametrize(
    ("which", "steps", "atol"), [("truth", 500, 1e-12), ("identified", 300, 1e-9)]
)
def test_the_model_env_follows_mujoco(data, which, steps, atol) -> None:
    real = gym.make("acrobot_mj/Acrobot-v0", frame_skip=4)
    theta = TRUTH if which == "truth" else identify(data, model_based.stepping(real))[0]
    model = IdentifiedEnv(theta, real.unwrapped.task)
    rng = np.random.default_rng(5)
    a, _ = real.reset(seed=9, options={"start_noise": 0.05})
    b, _ = model.reset(seed=9, options={"start_noise": 0.05})
    np.testing.assert_array_equal(a, b)  # the same start draws, from the task
    for t in range(steps):
        action = int(rng.integers(3))
        ra, rb = real.step(action), model.step(action)
        # Rounding differences (and the fit's 1e-9 relative error) grow along a chaotic
        # trajectory: on this one, with the true parameters, 9e-14 by step 500 but 3e-9 by
        # step 940 (hence 1e-12 over 500 steps); with the identified ones 3e-8 by step 960
        # (hence 1e-9 over 300).
        np.testing.assert_allclose(ra[0], rb[0], rtol=0, atol=atol, err_msg=f"step {t}")
        assert ra[1:4] == rb[1:4]
        if ra[2] or ra[3]:
            break
    assert t == steps - 1 or ra[2]


def test_the_model_env_follows_mujoco_through_the_velocity_limits() -> None:
    # Starts at the limits, with the torque pushing past them: MuJoCo's Euler step moves the
    # angles with the new velocity, then the env clips it. A model that clipped first would be
    # off by up to 1 rad within these decisions (measured: 1.03); the same order agrees to
    # rounding (1e-12: a few decisions of fast, not yet chaotic, motion).
    real = gym.make("acrobot_mj/Acrobot-v0", frame_skip=4)
    model = IdentifiedEnv(TRUTH, real.unwrapped.task)
    clipped = 0
    for start in ([-1.5, 0.3, 4 * np.pi, 9 * np.pi], [0.2, -2.0, -4 * np.pi + 0.01, -9 * np.pi]):
        a, _ = real.reset(options={"state": start})
        b, _ = model.reset(options={"state": start})
        for action in (2, 2, 0, 0, 1, 2):
            a, b = real.step(action)[0], model.step(action)[0]
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)
            clipped += int(np.isclose(abs(a[2]), 4 * np.pi) or np.isclose(abs(a[3]), 9 * np.pi))
    assert clipped >= 2  # decisions that end at a limit (more bind inside decisions)


def test_a_model_that_breaks_down_stops_with_an_error_not_nan_observations() -> None:
    # Finite parameters whose mass matrix overflows: det = inf - inf is NaN from the first step.
    # The step keeps the NaN (its limits do not clip it into a number), the env refuses it.
    task = gym.make("acrobot_mj/Acrobot-v0").unwrapped.task
    model = IdentifiedEnv((3.5, 1e308, 1.25, 14.7, 4.9), task)
    model.reset()
    with pytest.raises(RuntimeError, match="the model reached a non-finite state"):
        model.step(1)


def test_the_wrong_structure_or_no_data_fails_clearly(data) -> None:
    with pytest.raises(ValueError, match="at least 3 transitions, some with torque"):
        identify([], BOOK_STEP)
    with pytest.raises(ValueError, match="some with torque"):
        identify([(x, 0.0, x2) for x, _, x2 in data], BOOK_STEP)
    # Data from an acrobot with joint damping (0.3 N m s): no lumped model fits it.
    damped = []
    for x, tau, _ in data:
        y = np.array(x, dtype=float)
        for _ in range(4):
            y = np.array(advance(y, tau - 0.3 * y[3], TRUTH, Stepping(substeps=1)))
        damped.append((x, tau, y.tolist()))
    assert identify(damped, BOOK_STEP)[1] > 1e-4
    with pytest.raises(ValueError, match="the identified model does not fit"):
        model_based.check_identified(identify(damped, BOOK_STEP)[1])


def test_training_in_the_model_costs_the_env_only_data_and_greedy_run(tmp_path) -> None:
    record = train(SMALL, seed=3, out_dir=tmp_path)
    model = record["model"]
    assert model["data_decisions"] == 300 and model["rms"] < 1e-12
    np.testing.assert_allclose(model["theta"], TRUTH, rtol=1e-9)
    assert record["steps"] == 6000  # simulated: 3000 per learner
    assert record["decisions_total"] == 300 + record["greedy_from_rest"]["length"]
    pop = record["population"]
    assert pop["scores"][pop["kept"]] == min(pop["scores"]) and "identified model" in pop["rule"]
    # The shaping is applied once, and the record keeps the task's own returns: -1 a decision
    # (the goal's too). Shaped twice, the learners' env reported the inner wrapper's shaped
    # rewards as the unshaped ones (returns like -565.0118).
    assert record["episode_returns"] == [-float(n) for n in record["episode_lengths"]]
    # Evaluation is in the env, from the run's checkpoint; the rest episode is the record's.
    evaluation = evaluate(tmp_path, HeldOut(episodes=3))
    assert evaluation["rest"]["length"] == record["greedy_from_rest"]["length"]
    # Deterministic and resumable: the same data, the same model, the same run.
    again = train(SMALL, seed=3, out_dir=tmp_path, options=RunOptions(resume=True))
    for key in ("episode_lengths", "greedy_from_rest", "model", "population"):
        assert again[key] == record[key], key
    assert json.loads((tmp_path / "run.json").read_text())["model"] == model


def test_model_based_settings_are_checked() -> None:
    with pytest.raises(ValueError, match=r"identify_decisions must be in \[0, 1000000000\]"):
        PRESETS["book"].replace(identify_decisions=-1)
    assert not can_lockstep(PRESETS["report"].replace(identify_decisions=10))
    with pytest.raises(ValueError, match="give no env"):
        train(SMALL, seed=0, env=gym.make("acrobot_mj/Acrobot-v0", frame_skip=4))
