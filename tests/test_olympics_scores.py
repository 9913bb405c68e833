"""The AI Olympics protocol's scores (acrobot_mj.olympics) on hand-made trajectories whose
scores are worked out by hand, its levels and draws, and olympics.json written and read."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from acrobot_mj.olympics import scores
from acrobot_mj.olympics.protocol import (
    CATEGORY_KEYS,
    CRITERIA,
    GLOBAL,
    PERFORMANCE,
    ROBUSTNESS,
    Perturbations,
    Robustness,
    episode_times,
    from_protocol,
    get_par_list,
    step_count,
    to_protocol,
)
from acrobot_mj.olympics.report import (
    RECORD_FILE,
    EpisodeRecord,
    Olympics,
    read_olympics,
    write_olympics,
)
from acrobot_mj.olympics.scores import Recording
from acrobot_mj.physics.models import MODELS, joint_inertias

MODEL = MODELS["ai_olympics"]
L1, L2 = MODEL.params.l1, MODEL.params.l2
UP = (math.pi / 2, 0.0, 0.0, 0.0)  # our convention: upright at rest
DOWN = (-math.pi / 2, 0.0, 0.0, 0.0)  # hanging at rest


def episode(up_rows: np.ndarray | slice, t_final: float = 10.0) -> Recording:
    """A performance-length episode hanging at rest but for ``up_rows`` (upright), no torque."""
    T = episode_times(t_final)
    X = np.tile(DOWN, (len(T), 1))
    X[up_rows] = UP
    return Recording(T, X, np.zeros(len(T) - 1))


def test_the_loop_counts_the_steps_and_sums_the_times() -> None:
    T = episode_times(10.0)
    assert PERFORMANCE.steps == step_count(10.0) == len(T) - 1 == 5000
    assert T[-2] < 10.0 <= T[-1] and T[1] == 0.002 and T[3] == 0.002 + 0.002 + 0.002
    assert GLOBAL.steps == 30000
    with pytest.raises(ValueError, match="t_final"):
        episode_times(math.inf)


def test_one_conversion_between_the_conventions() -> None:
    assert np.array_equal(to_protocol(np.array(DOWN)), [0.0, 0.0, 0.0, 0.0])
    assert np.allclose(to_protocol(np.array(UP)), [math.pi, 0, 0, 0])
    x = np.array([[0.3, -1.2, 2.0, -3.0]])
    assert np.allclose(from_protocol(to_protocol(x)), x)
    assert joint_inertias(MODEL) == (0.031887199591513114, 0.05086984812807257)


def test_up_from_the_first_sample_swings_up_at_the_second() -> None:
    run = scores.performance(episode(slice(None)), L1, L2)
    T = episode_times(10.0)
    # The loop runs from row N-2 down to row 1 and stops there: the time is T[1], not T[0].
    assert run["swingup_time"] == T[1] == 0.002 and run["success"] is True
    assert run["energy"] == run["tau_cost"] == run["tau_smoothness"] == 0.0
    assert run["velocity_cost"] == 0.0
    assert run["score"] == pytest.approx(1 - math.tanh(math.pi * 0.002 / 20) / 5, rel=1e-15)


def test_up_only_at_the_end_is_a_failure() -> None:
    T = episode_times(10.0)
    n = len(T) - 1
    for rows in (slice(n - 1, None), slice(n, None)):  # the last CSV row, the final state
        run = scores.performance(episode(rows), L1, L2)
        assert run["swingup_time"] == T[n - 1] and run["success"] is False
        assert run["score"] == 0.0


def test_a_fall_before_the_end_is_a_failure_but_the_last_row_is_never_looked_at() -> None:
    n = PERFORMANCE.steps
    fell = scores.performance(episode(slice(100, n - 2)), L1, L2)  # down from row N-2
    assert fell["success"] is False and fell["score"] == 0.0
    late = scores.performance(episode(slice(100, n - 1)), L1, L2)  # down only in row N-1
    assert late["success"] is True and late["swingup_time"] == episode_times(10.0)[100]


def test_constant_torque_and_velocities_cost_what_they_should() -> None:
    T = episode_times(10.0)
    n = len(T) - 1
    X = np.tile(UP, (n + 1, 1))
    X[:, 1] = 0.001 * np.arange(n + 1)  # the elbow turns 1 mrad a step
    X[:, 2:] = (0.5, -2.0)
    run = scores.performance(Recording(T, X, np.full(n, 2.0)), L1, L2)
    # Over the N rows, sums run over i < N-1: N-1 = 4999 steps ending at T[N-1].
    assert run["energy"] == pytest.approx(4999 * 0.001 * 2.0, rel=1e-12)
    assert run["tau_cost"] == pytest.approx(4.0 * T[n - 1], rel=1e-12)
    assert run["velocity_cost"] == pytest.approx((0.25 + 4.0) * T[n - 1], rel=1e-12)
    assert run["tau_smoothness"] == 0.0
    # Alternating +-a: 4999 changes, 2500 of -2a and 2499 of +2a.
    U = np.where(np.arange(n) % 2 == 0, 1.5, -1.5)
    alternating = scores.performance(Recording(T, X, U), L1, L2)
    expected = 3.0 * math.sqrt(1 - 1 / 4999**2)
    assert alternating["tau_smoothness"] == pytest.approx(expected, rel=1e-12)


def test_the_v2_score_of_known_criteria() -> None:
    zero = {c.name: 0.0 for c in CRITERIA}
    assert scores.score_v2(zero, True) == 1.0
    assert scores.score_v2({**zero, "swingup_time": 20.0}, True) == pytest.approx(
        1 - math.tanh(math.pi) / 5, rel=1e-15
    )
    at_norm = {c.name: c.norm for c in CRITERIA}
    assert scores.score_v2(at_norm, True) == pytest.approx(1 - math.tanh(math.pi), rel=1e-15)
    assert scores.score_v2({**zero, "swingup_time": None}, False) == 0.0
    assert [c.name for c in CRITERIA] == [
        "swingup_time",
        "energy",
        "tau_cost",
        "tau_smoothness",
        "velocity_cost",
    ]


@pytest.mark.parametrize(
    ("offset", "success"),
    [
        ((0.0, 0.0, 0.0, 0.0), True),
        ((0.34, 0.0, 0.0, 0.0), True),
        ((-0.34, 0.0, 0.0, 0.0), True),
        ((0.36, 0.0, 0.0, 0.0), False),
        ((-0.36, 0.0, 0.0, 0.0), False),
        ((2 * math.pi + 0.34, 0.0, 0.0, 0.0), True),  # theta1 wraps into [0, 2 pi)
        ((-2 * math.pi - 0.34, 0.0, 0.0, 0.0), True),
        ((0.0, 0.34, 0.0, 0.0), True),
        ((0.0, -0.36, 0.0, 0.0), False),
        ((0.0, 2 * math.pi - 0.34, 0.0, 0.0), True),  # theta2 wraps into [-pi, pi)
        ((0.0, 2 * math.pi + 0.36, 0.0, 0.0), False),
        ((0.0, 0.0, 0.99, -0.99), True),
        ((0.0, 0.0, 1.01, 0.0), False),
        ((0.0, 0.0, 0.0, -1.01), False),
        ((2 * math.pi, 0.0, 2 * math.pi, 0.0), False),  # velocities are not wrapped
    ],
)
def test_the_final_state_within_the_epsilons(offset, success) -> None:
    assert scores.final_success(np.add(UP, offset)) is success


def noise_successes(passing: int) -> list[list[list[bool]]]:
    """21 levels: the first ``passing`` succeed 6 times in 10, the others 5 times."""
    return [[[k < (6 if level < passing else 5) for k in range(10)] for level in range(21)]]


def test_a_noise_level_passes_on_a_majority_of_its_episodes() -> None:
    categories = {c.key: c for c in ROBUSTNESS.categories(MODEL)}
    for key in ("measurement_noise", "u_noise"):
        category = categories[key]
        assert category.majority and category.repetitions == 10
        assert scores.category_score(category, noise_successes(21)) == 1.0
        assert scores.category_score(category, noise_successes(0)) == 0.0
        assert scores.category_score(category, noise_successes(10)) == 10 / 21
        assert scores.level_fractions(category, noise_successes(1))[0][:2] == [0.6, 0.5]
    with pytest.raises(ValueError, match="21 levels of 10 episodes"):
        scores.category_score(categories["u_noise"], [[[True] * 10] * 20])


def test_the_other_categories_score_the_fraction_of_their_episodes() -> None:
    categories = {c.key: c for c in ROBUSTNESS.categories(MODEL)}
    model = [[[level % 2 == 0] for level in range(21)] for _ in range(10)]  # 11 of 21 each
    assert scores.category_score(categories["model"], model) == 110 / 210
    assert scores.category_score(categories["delay"], [[[True]] * 7 + [[False]] * 14]) == 1 / 3
    pulses = [[[k < 20 for k in range(50)]]]
    assert scores.category_score(categories["perturbation"], pulses) == 0.4
    overall = scores.overall_robustness(
        dict.fromkeys(CATEGORY_KEYS, 0.5), tuple(categories.values())
    )
    assert overall == pytest.approx(0.5, rel=1e-15)
    with pytest.raises(ValueError, match="missing"):
        scores.overall_robustness({"model": 1.0}, tuple(categories.values()))


def test_the_levels_are_the_protocols() -> None:
    categories = ROBUSTNESS.categories(MODEL)
    assert tuple(c.key for c in categories) == CATEGORY_KEYS
    assert [c.episodes for c in categories] == [210, 210, 210, 21, 21, 50]
    assert ROBUSTNESS.episodes(MODEL) == 722  # their sum: what the bench projects
    sweeps = {s.parameter: s.levels for s in categories[0].sweeps}
    assert list(sweeps) == ["Ir", "m1r1", "I1", "b1", "cf1", "m2r2", "m2", "I2", "b2", "cf2"]
    m1, r1 = MODEL.params.m1, MODEL.params.lc1
    assert sweeps["m1r1"] == tuple(np.linspace(0.75, 1.25, 21) * (m1 * r1))
    assert sweeps["I2"] == tuple(np.linspace(0.75, 1.25, 21) * 0.05086984812807257)
    assert sweeps["b1"] == tuple(np.linspace(-0.1, 0.1, 21))
    assert categories[1].sweeps[0].levels == tuple(np.linspace(0.0, 0.5, 21))
    assert categories[3].sweeps[0].levels == tuple(np.linspace(0.1, 2.0, 21))
    assert len(get_par_list(2.0, 0.75, 1.25, 20)) == 21  # made odd
    assert list(get_par_list(0.0, 0.75, 1.25, 3)) == [0.0, 0.0, 0.0]
    assert ROBUSTNESS.epsilon == (0.35, 0.35, 1.0, 1.0)


def test_the_draws_are_seeded_and_within_the_protocols_ranges() -> None:
    drawn = ROBUSTNESS.perturbations.draw(np.random.default_rng(3), 10.0)
    again = ROBUSTNESS.perturbations.draw(np.random.default_rng(3), 10.0)
    assert np.array_equal(drawn.mu, again.mu) and drawn.mu.shape == (2, 3)
    assert np.all(np.diff(np.sort(drawn.mu.ravel())) >= 1.0) and drawn.mu.max() < 10.0
    assert np.all((drawn.sigma >= 0.05) & (drawn.sigma <= 0.1))
    assert np.all((np.abs(drawn.amplitude) >= 0.5) & (np.abs(drawn.amplitude) <= 5.0))
    torques = drawn.torques(10.0)
    assert torques.shape == (2, 5000)
    k = round(drawn.mu[1, 0] / 0.002)
    assert torques[1, k] == pytest.approx(drawn.amplitude[1, 0], abs=0.01)
    targets, resets = GLOBAL.draw(3)
    assert targets.shape == (151, 4) and np.all(targets[:, 2:] == 0.0)
    assert np.all(np.abs(targets[:, :2]) <= math.pi)
    nominal = np.linspace(60 / 16, 60 - 60 / 16, 15)
    assert np.all(np.abs(resets - nominal) <= 1.0)


def test_uptime_of_an_episode_up_half_the_time() -> None:
    T = episode_times(GLOBAL.t_final)
    half = episode(slice(15000, None), GLOBAL.t_final)
    run = scores.uptime(half, L1, L2, GLOBAL.t_final)
    # Rows 15000 .. N-1 count T[i] - T[i-1]: T[N-1] - T[14999].
    assert run["uptime"] == pytest.approx(T[29999] - T[14999], rel=1e-12)
    assert run["uptime"] == pytest.approx(30.0, rel=1e-9)
    assert run["score"] == pytest.approx(0.5, rel=1e-9)
    assert scores.uptime(episode(slice(None), 1.0), L1, L2, 1.0)["uptime"] == pytest.approx(
        episode_times(1.0)[-2]
    )


def test_a_trajectory_of_the_wrong_shape_is_refused() -> None:
    T = episode_times(1.0)
    X = np.zeros((len(T), 4))
    with pytest.raises(ValueError, match="U must be elbow torques"):
        Recording(T, X, np.zeros(len(T)))
    with pytest.raises(ValueError, match="X must be states"):
        Recording(T, X[1:], np.zeros(len(T) - 1))
    with pytest.raises(ValueError, match="finite"):
        Recording(T, X, np.full(len(T) - 1, np.nan))


def small_results() -> Olympics:
    """Every part, on small categories and a one-second global episode."""
    small = Robustness(levels=3, noise_repetitions=2, perturbations=Perturbations(episodes=2))
    categories = small.categories(MODEL)
    rng = np.random.default_rng(0)

    def record(k: int) -> EpisodeRecord:
        return EpisodeRecord(UP, rng.normal(size=10), k % 3 != 0, {"level": float(k)})

    episodes = {
        c.key: [
            [[record(k + r) for r in range(c.repetitions)] for k in range(len(s.levels))]
            for s in c.sweeps
        ]
        for c in categories
    }
    torque = np.sin(np.arange(PERFORMANCE.steps))
    performance = episode(slice(None))
    performance = Recording(performance.T, performance.X, torque)
    return Olympics(
        model={"name": "ai_olympics"},
        lengths=(L1, L2),
        seeds={"perturbation": 0},
        performance=performance,
        categories=categories,
        episodes=episodes,
        global_episodes=(episode(slice(200, None), 1.0),),
        global_seeds=(0,),
        global_draws={"reset_times": [0.5]},
    )


def test_the_record_is_written_read_and_drawn(tmp_path) -> None:
    results = small_results()
    path = write_olympics(tmp_path, results)
    assert path == tmp_path / RECORD_FILE
    for name in ("performance", "global", *(f"robustness_{k}" for k in CATEGORY_KEYS)):
        assert (tmp_path / f"{name}.png").stat().st_size > 0
    record = read_olympics(tmp_path)
    assert record["performance"]["success"] is True
    assert (
        record["performance"]["score"] == scores.performance(results.performance, L1, L2)["score"]
    )
    torques = record["performance"]["episode"]["torques"]
    assert np.allclose(torques, results.performance.U, atol=1e-6)
    model = record["robustness"]["categories"][0]
    assert model["key"] == "model" and len(model["sweeps"]) == 10
    assert model["sweeps"][0]["fractions"] == [0.0, 1.0, 1.0]
    assert 0.0 <= record["robustness"]["overall"] <= 1.0
    assert record["global"]["uptime"] == pytest.approx(episode_times(1.0)[-2] - 0.398)
    assert record["global"]["episode"]["disturbance"] == {"reset_times": [0.5]}


def test_a_replaced_record_leaves_no_figure_of_a_score_it_lacks(tmp_path) -> None:
    """``--force`` with fewer scores once left performance.png beside a record without a
    performance score; figures that are not the record's are left alone."""
    write_olympics(tmp_path, small_results())
    (tmp_path / "notes.png").write_bytes(b"mine")
    only_global = replace(small_results(), performance=None, categories=(), episodes={})
    write_olympics(tmp_path, only_global)
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["global.png", "notes.png"]
    assert set(read_olympics(tmp_path)) >= {"global"}


def test_a_foreign_or_corrupt_record_is_one_line(tmp_path) -> None:
    path = write_olympics(tmp_path, small_results())
    text = path.read_text()
    cases = {
        "not a readable": text[: len(text) // 2],
        "not an olympics record": json.dumps({"kind": "run"}),
        "edited or cut short": text.replace('"success": true', '"success": false', 1),
    }
    for words, body in cases.items():
        path.write_text(body)
        with pytest.raises(ValueError, match=words) as error:
            read_olympics(path)
        assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    ("p", "dof", "table"),
    # Student's t quantiles from a printed table (NIST/SEMATECH e-Handbook, 1.3.6.7.2).
    [
        (0.975, 1, 12.706),
        (0.975, 2, 4.303),
        (0.975, 7, 2.365),
        (0.975, 29, 2.045),
        (0.95, 10, 1.812),
    ],
)
def test_the_t_quantile_is_the_tables(p, dof, table) -> None:
    assert scores.t_quantile(p, dof) == pytest.approx(table, abs=5e-4)  # the table's 3 decimals


def test_the_t_quantile_refuses_what_it_cannot_give() -> None:
    with pytest.raises(ValueError, match="dof >= 1"):
        scores.t_quantile(0.975, 0)
    with pytest.raises(ValueError, match=r"0\.5 <= p < 1"):
        scores.t_quantile(1.0, 3)
    assert scores.mean_interval([0.4])["interval"] is None  # one seed: no spread to measure
