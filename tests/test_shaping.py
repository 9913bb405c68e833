"""Potential-based energy shaping: the potential's golden values, the telescoping sum that makes
it policy-invariant, unshaped returns in the records, and bad input."""

import functools
import math

import gymnasium as gym
import numpy as np
import pytest

import acrobot_mj
from acrobot_mj.control.policies import pump_policy
from acrobot_mj.envs.wrappers import EnergyShaping
from acrobot_mj.physics.dynamics import potential_energy, total_energy
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.learners import make_env
from acrobot_mj.train.lockstep import can_lockstep, train_lockstep
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.trainer import train


@functools.cache
def _unit_shaping(params: AcrobotParams) -> EnergyShaping:
    return EnergyShaping(gym.make(acrobot_mj.ENV_ID), 1.0, params=params)


def energy_potential(obs, params: AcrobotParams = REPORT) -> float:
    """The normalised energy of ``obs``, 0 hanging at rest and 1 upright: the wrapper's
    potential at scale 1."""
    return _unit_shaping(params).potential(obs)


def total_energy_potential(obs, params: AcrobotParams = REPORT) -> float:
    """The same from numpy's total_energy and potential_energy (the definition the shaped
    presets' runs and golden values were made with)."""
    obs = np.asarray(obs, dtype=np.float64)
    hanging = float(potential_energy(np.array([-math.pi / 2, 0.0]), params))
    upright = float(potential_energy(np.array([math.pi / 2, 0.0]), params))
    return (float(total_energy(obs[:2], obs[2:], params)) - hanging) / (upright - hanging)


# Golden values from the definition alone (no dynamics code): at rest the energy is potential
# only, V = g ((m1 lc1 + m2 l1) sin q1 + m2 lc2 sin(q1 + q2)) = g (1.5 sin q1 + 0.5 sin(q1 + q2)),
# so hanging is -2 g, upright +2 g, both links horizontal 0: potentials 0, 1 and 1/2.
# Link 1 horizontal with link 2 hanging: V = -0.5 g, potential (2 - 0.5) / 4 = 0.375.
GOLDEN = [
    ((-math.pi / 2, 0.0), 0.0),
    ((math.pi / 2, 0.0), 1.0),
    ((0.0, 0.0), 0.5),
    ((0.0, -math.pi / 2), 0.375),
]
# Sums of ~100 terms of size <= 10: a few ulps each, far below 1e-9.
SUM_TOL = 1e-9


@pytest.mark.parametrize(("q", "expected"), GOLDEN)
def test_potential_golden_values_at_rest(q, expected):
    assert energy_potential([*q, 0.0, 0.0]) == pytest.approx(expected, abs=1e-12)


def test_potential_counts_kinetic_energy():
    # Hanging, link 1 turning at 1 rad/s with link 2 locked to it: T = (I1 + I2 + m1 lc1^2
    # + m2 (l1^2 + lc2^2 + 2 l1 lc2)) / 2 = (1 + 1 + 0.25 + 1 + 0.25 + 1) / 2 = 2.25 J, over
    # E_up - E_hang = 4 g with the report's g = 9.8 m/s^2. Rounding only: 1e-12 relative.
    value = energy_potential([-math.pi / 2, 0.0, 1.0, 0.0])
    assert value == pytest.approx(2.25 / (4 * 9.8), rel=1e-12)


def _episode(env, actions, seed=0):
    obs, _ = env.reset(seed=seed, options={"start_noise": 0.1})
    first = obs
    shaped, unshaped = [], []
    for a in actions:
        obs, r, terminated, truncated, info = env.step(a)
        shaped.append(r)
        unshaped.append(info["unshaped_reward"])
        if terminated or truncated:
            return first, obs, shaped, unshaped, terminated
    return first, obs, shaped, unshaped, False


def test_shaping_telescopes_on_truncation():
    scale = 10.0
    env = EnergyShaping(
        gym.make(acrobot_mj.ENV_ID, frame_skip=4, max_episode_steps=40), scale, gamma=1.0
    )
    rng = np.random.default_rng(3)
    first, last, shaped, unshaped, terminated = _episode(env, rng.integers(0, 3, 40))
    assert not terminated and len(shaped) == 40
    expected = scale * (energy_potential(last) - energy_potential(first))
    assert sum(shaped) - sum(unshaped) == pytest.approx(expected, abs=SUM_TOL)


def test_shaping_telescopes_to_minus_start_potential_at_the_goal():
    # An episode that reaches the goal: the package's pumping rule swings up within 1000.
    scale = 10.0
    env = EnergyShaping(gym.make(acrobot_mj.ENV_ID, frame_skip=4), scale)
    obs, _ = env.reset(seed=0)
    first, shaped, unshaped = obs, [], []
    for _ in range(1000):
        obs, r, terminated, truncated, info = env.step(pump_policy(obs))
        shaped.append(r)
        unshaped.append(info["unshaped_reward"])
        if terminated or truncated:
            break
    assert terminated, "the pumping rule should reach the goal"
    # phi(terminal) = 0: the terms sum to -phi(s0) whatever the policy did.
    assert sum(shaped) - sum(unshaped) == pytest.approx(
        -scale * energy_potential(first), abs=SUM_TOL
    )


def test_shaping_rewards_adding_energy():
    env = EnergyShaping(gym.make(acrobot_mj.ENV_ID, frame_skip=4), 10.0)
    env.reset(seed=0)  # hanging at rest: any torque adds energy
    _, reward, _, _, info = env.step(2)
    assert info["unshaped_reward"] == -1.0
    assert reward > -1.0


def test_records_report_unshaped_returns():
    config = PRESETS["book"].replace(episodes=3, energy_shaping=10.0, max_episode_steps=50)
    record = train(config, seed=0)
    # Book reward: -1 per step, the last included, so the task's return is minus the length.
    assert record["episode_returns"] == [-float(n) for n in record["episode_lengths"]]
    assert record["greedy_from_rest"]["return"] == -record["greedy_from_rest"]["length"]


def test_shaping_changes_learning_but_not_unshaped_env():
    base = PRESETS["book"].replace(episodes=2)
    plain = train(base, seed=1)
    shaped = train(base.replace(energy_shaping=10.0), seed=1)
    assert plain["episode_lengths"] != shaped["episode_lengths"]
    assert not isinstance(make_env(base), EnergyShaping)
    assert isinstance(make_env(base.replace(energy_shaping=10.0)), EnergyShaping)


def test_tabular_sarsa_with_shaping_is_not_run_in_lockstep():
    config = TrainConfig().replace(episodes=2, energy_shaping=1.0)
    assert not can_lockstep(config) and can_lockstep(TrainConfig())
    with pytest.raises(ValueError, match="energy shaping"):
        train_lockstep(config, [0, 1])


@pytest.mark.parametrize("scale", [0.0, -1.0, math.nan, math.inf, "10"])
def test_wrapper_refuses_bad_scales(scale):
    with pytest.raises(ValueError, match="scale"):
        EnergyShaping(gym.make(acrobot_mj.ENV_ID), scale)


def test_wrapper_refuses_bad_gamma_and_step_before_reset():
    with pytest.raises(ValueError, match="gamma"):
        EnergyShaping(gym.make(acrobot_mj.ENV_ID), 1.0, gamma=1.5)
    env = EnergyShaping(gym.make(acrobot_mj.ENV_ID), 1.0)
    with pytest.raises(RuntimeError, match="before reset"):
        env.step(1)


@pytest.mark.parametrize("value", [-1.0, math.nan])
def test_config_refuses_bad_energy_shaping(value):
    with pytest.raises((ValueError, TypeError), match="energy_shaping"):
        TrainConfig().replace(energy_shaping=value)


def test_the_wrappers_potential_is_the_normalised_total_energy_bit_for_bit():
    # EnergyShaping.potential works on Python floats (energies()); the numbers must not move
    # from numpy's total_energy, normalised, which the shaped presets' runs were made with.
    rng = np.random.default_rng(7)
    for params in (AcrobotParams(), AcrobotParams(m2=1.3, lc2=0.4)):
        shaping = EnergyShaping(make_env(PRESETS["book"]), 40.0, params=params)
        for obs in rng.uniform([-4, -4, -13, -29], [4, 4, 13, 29], (2000, 4)):
            for given in (obs, obs.astype(np.float32), obs.tolist()):
                expected = 40.0 * total_energy_potential(given, params)
                assert shaping.potential(given) == expected


def test_replacing_the_wrappers_params_moves_its_potential():
    params = AcrobotParams(m2=1.3, lc2=0.4)
    shaping = EnergyShaping(make_env(PRESETS["book"]), 40.0, params=params)
    obs = np.array([0.3, -1.2, 2.0, -5.0])
    shaping.params = AcrobotParams()  # replaced: the rest energies follow
    assert shaping.potential(obs) == 40.0 * total_energy_potential(obs)
