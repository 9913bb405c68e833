"""Every constant and rule of the AI Olympics protocol pinned by a fast test whose expected value
is the protocol's own definition (dfki-ric-underactuated-lab/double_pendulum: the leaderboards'
``leaderboard/acrobot/simulation_v2``, ``robustness_v2`` and ``simulation_v3`` scripts, and
``src/python/double_pendulum/analysis/benchmark.py``), so that a one-line change of any of
them fails here: the up test's strict inequality, the delay's mode, the overall robustness as a
mean, each category's conditions, and the robustness run's episodes, order and pool."""

# ruff: noqa: NPY002  # the April 2025 global test draws from numpy's legacy global generator

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from acrobot_mj.control.controller import Controller
from acrobot_mj.olympics import run as olympics_run
from acrobot_mj.olympics import scores
from acrobot_mj.olympics.episodes import Conditions
from acrobot_mj.olympics.protocol import (
    CATEGORY_KEYS,
    DT,
    GLOBAL,
    HEIGHT,
    PERFORMANCE,
    ROBUSTNESS,
    Perturbations,
)
from acrobot_mj.olympics.run import OlympicsRun
from acrobot_mj.olympics.scaling import ORIGINAL
from acrobot_mj.physics.models import MODELS

MODEL = MODELS["ai_olympics"]


def test_the_tip_must_be_strictly_above_the_line() -> None:
    """``is_up``: height > 0.9 (l1 + l2), strictly (benchmark_scores' ``>``). Upright at rest
    with l1 + l2 = 1 puts the tip at exactly 1.0 (cos pi = -1 exactly): at a line of 1.0 it
    is not up; at 0.999 it is."""
    upright = np.array([[math.pi, 0.0, 0.0, 0.0]])  # the protocol's convention
    assert scores.tip_heights(upright, 0.5, 0.5)[0] == 1.0
    assert not scores.is_up(upright, 0.5, 0.5, height=1.0)[0]
    assert scores.is_up(upright, 0.5, 0.5, height=0.999)[0]
    assert HEIGHT == 0.9 and PERFORMANCE.height == GLOBAL.height == 0.9


def test_the_overall_robustness_is_the_mean_of_unequal_categories() -> None:
    """1/6 of each of six different scores (not their max, min or median)."""
    categories = ROBUSTNESS.categories(MODEL)
    values = dict(zip(CATEGORY_KEYS, (0.1, 0.2, 0.3, 0.4, 0.5, 0.9), strict=True))
    overall = scores.overall_robustness(values, categories)
    assert overall == pytest.approx(2.4 / 6, rel=1e-15)


def test_each_category_meets_the_protocols_conditions() -> None:
    """robustness_v2: model errors through the plant's parameters; velocity noise on both
    velocities; torque noise on the motor; the motor's responsiveness; a delay of the whole
    measured state (``delay_mode="posvel"``); the pulses (drawn, not a level)."""
    conditions = olympics_run._level_conditions
    by_key = {c.key: c for c in ROBUSTNESS.categories(MODEL)}
    assert conditions(by_key["model"], "m2", 0.7) == Conditions(model_error={"m2": 0.7})
    noise = conditions(by_key["measurement_noise"], "sigma", 0.3)
    assert noise == Conditions(sensor={"sigma": (0.0, 0.0, 0.3, 0.3)})
    assert conditions(by_key["u_noise"], "sigma", 0.2) == Conditions(motor={"sigma": 0.2})
    response = conditions(by_key["u_responsiveness"], "response", 0.4)
    assert response == Conditions(motor={"response": 0.4})
    delay = conditions(by_key["delay"], "delay", 0.01)
    assert delay == Conditions(sensor={"delay": 0.01, "mode": "posvel"})
    with pytest.raises(ValueError, match="no conditions"):
        conditions(by_key["perturbation"], "pulses", 0.0)


def test_the_protocols_constants() -> None:
    """Each number as the protocol's scripts set it: 2 ms steps; performance 10 s at 6 N m;
    robustness 10 s, 21 levels, 10 noise repetitions, motor inertia 1e-4, damping and friction
    spans 0.1 and 0.2, velocity noise to 0.5 rad/s, torque noise to 1.1 N m, delay to 0.04 s,
    responsiveness 0.1 to 2, 50 pulse episodes of 3 pulses a joint 1 s apart (widths 0.05 to
    0.1 s, amplitudes 0.5 to 5 N m), final state within (0.35, 0.35, 1, 1); global 60 s, 15
    resets within 1 s of even spacing, each 0.2 s of a PID (10, 0.1, 1 at 1 ms) at 6 N m a joint.
    """
    assert DT == 0.002 and PERFORMANCE.dt == ROBUSTNESS.dt == GLOBAL.dt == DT
    assert (PERFORMANCE.t_final, PERFORMANCE.torque_limit) == (10.0, 6.0)
    assert [c.norm for c in PERFORMANCE.criteria] == [20.0, 60.0, 20.0, 0.1, 400.0]
    r = ROBUSTNESS
    assert (r.t_final, r.torque_limit, r.levels, r.noise_repetitions) == (10.0, 6.0, 21, 10)
    assert (r.motor_inertia, r.damping, r.friction) == (1e-4, 0.1, 0.2)
    assert (r.velocity_noise, r.torque_noise, r.delay, r.response) == (0.5, 1.1, 0.04, (0.1, 2.0))
    assert r.epsilon == (0.35, 0.35, 1.0, 1.0)
    assert r.perturbations == Perturbations(50, 3, 1.0, (0.05, 0.1), (0.5, 5.0))
    g = GLOBAL
    assert (g.t_final, g.resets, g.jitter, g.reset_length) == (60.0, 15, 1.0, 0.2)
    assert (g.kp, g.ki, g.kd, g.pid_dt, g.torque_limit) == (10.0, 0.1, 1.0, 0.001, (6.0, 6.0))


class Still(Controller):
    """No torque: every robustness episode hangs (and fails), fast to simulate."""

    def act(self, x: np.ndarray, t: float) -> float:
        return 0.0


def tiny_rules():
    """The protocol's rules with robustness episodes of 10 steps, 3 levels, 2 repetitions and 2
    pulse episodes of one pulse a joint: every category, a few seconds of episodes."""
    robustness = replace(
        ROBUSTNESS,
        t_final=0.02,
        levels=3,
        noise_repetitions=2,
        perturbations=Perturbations(episodes=2, per_joint=1, min_gap=0.005, sigma=(0.001, 0.002)),
    )
    return replace(ORIGINAL, robustness=robustness)


def test_the_robustness_run_makes_each_episode_once_in_order_on_any_pool() -> None:
    """_calls: one call per category, sweep, level and repetition, seeded apart; _grouped puts
    each record back at its category, sweep and level (its disturbance names the level); the
    pool's records are the loop's, to the bit."""
    rules = tiny_rules()
    alone = OlympicsRun(Still(), parts=("robustness",), protocol=rules).run()
    pooled = OlympicsRun(Still(), parts=("robustness",), jobs=2, protocol=rules).run()
    categories = rules.robustness.categories(MODEL)
    assert [c.episodes for c in categories] == [30, 6, 6, 3, 3, 2]
    for category in categories:
        grouped, again = alone.episodes[category.key], pooled.episodes[category.key]
        for sweep, levels, levels_again in zip(category.sweeps, grouped, again, strict=True):
            for value, records, records_again in zip(
                sweep.levels, levels, levels_again, strict=True
            ):
                assert len(records) == category.repetitions
                for record, record_again in zip(records, records_again, strict=True):
                    assert record.to_dict() == record_again.to_dict()
                    if category.key != "perturbation":
                        assert record.disturbance == {sweep.parameter: value}
    calls = [
        c
        for category in categories
        for c in olympics_run._calls(Still(), "ai_olympics", category, 0, rules.robustness)
    ]
    assert len(calls) == 50 and len({c[3] for c in calls}) == 50  # every episode its own seed


def test_an_episode_cut_short_has_no_swing_up_time() -> None:
    """benchmark.py's 0.99: rows that end before 0.99 t_final are a failure (inf), up or not;
    rows to 0.995 t_final are scored."""
    up = np.ones(1000, dtype=bool)
    assert scores.swingup_time(np.linspace(0.0, 9.5, 1000), up, 10.0) == math.inf
    assert scores.swingup_time(np.linspace(0.0, 9.95, 1000), up, 10.0) < math.inf


def their_draw(version: str, seed: int, n: int = 15, t_max: float = 60.0):
    """The global test's draws in double_pendulum's own lines
    (src/python/double_pendulum/controller/global_policy_testing_controller.py,
    ``GlobalPolicyTestingControllerV2.__init__``): commit 9bb3a032, which the ICRA 2025
    simulation leaderboard ran (April 2025), and ff81de3d (current), on numpy's global
    generator seeded as ``np.random.seed(seed)`` (9bb3a032) or a seeded Generator (here)."""
    if version == "icra2025":
        np.random.seed(seed)
        random_states = np.random.uniform(0.0, 2 * np.pi, (n, 4))
        random_states -= np.pi
        random_states.T[2:] *= 4.0
        avg_time_between_reset = t_max / float(n + 1)
        reset_times = np.arange(avg_time_between_reset, t_max, avg_time_between_reset) + 2.0 * (
            np.random.rand(n) - 0.5
        )
        return random_states, reset_times
    rng = np.random.default_rng(seed)
    random_states = rng.uniform(0.0, 2 * np.pi, (10 * n + 1, 4))
    random_states -= np.pi
    random_states.T[2:] *= 0.0
    avg_time_between_reset = t_max / float(n + 1)
    reset_times = np.linspace(avg_time_between_reset, t_max - avg_time_between_reset, n) + 2.0 * (
        rng.random(n) - 0.5
    )
    return random_states, reset_times


@pytest.mark.parametrize("version", ["current", "icra2025"])
@pytest.mark.parametrize("seed", [0, 333, 777])
def test_the_global_draws_are_the_protocols_to_the_bit(version, seed) -> None:
    state = np.random.get_state()
    try:
        targets, times = their_draw(version, seed)
    finally:
        np.random.set_state(state)
    ours = replace(GLOBAL, version=version).draw(seed)
    assert np.array_equal(ours[0], targets) and np.array_equal(ours[1], times)


def test_the_leaderboards_draw_is_replayed() -> None:
    # Seed 333's first reset times, as the leaderboard's stored acrobot plots show them
    # (mcpilco's and prx's, within 0.18 s of a plot's pixels): 3.40 s, 6.86 s, 11.08 s.
    targets, times = replace(GLOBAL, version="icra2025", replay="mcpilco").draw(5)
    assert times[:3] == pytest.approx([3.4035, 6.8570, 11.0847], abs=1e-4)
    assert targets.shape == (15, 4)
    state = np.random.get_state()
    try:
        np.random.seed(333)
        np.random.random_sample(1_146_567)  # what the entries before AR-EAPO drew
        expected = np.arange(3.75, 60.0, 3.75)[:15]
        np.random.uniform(size=60)
        expected = expected + 2.0 * (np.random.rand(15) - 0.5)
    finally:
        np.random.set_state(state)
    replayed = replace(GLOBAL, version="icra2025", replay="AR-EAPO").draw(0)[1]
    assert np.array_equal(replayed, expected)
    with pytest.raises(ValueError, match="one of \\['current', 'icra2025'\\], got 'april'"):
        replace(GLOBAL, version="april")
    with pytest.raises(ValueError, match="replay is a draw of the icra2025 version"):
        replace(GLOBAL, replay="AR-EAPO")  # the current version
