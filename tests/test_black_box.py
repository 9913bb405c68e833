"""The black-box learner: the generic library model (exact on data in its span, the same in numpy
and CasADi, Jacobians that match finite differences), the goal from a learnt reward, the
exploration's seeding, and the preset trained end to end, on the package's env and on one whose
masses and inertias it was never told."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.control.controller import EnergyRemoval
from acrobot_mj.control.lqr import LQR, step_jacobians
from acrobot_mj.control.tracker import PlanTracker
from acrobot_mj.control.trajopt import shipped
from acrobot_mj.envs.links import model_parameters, set_model_parameters
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.identify.library import LibraryModel, best_angles
from acrobot_mj.identify.terms import DENOMINATOR_TERMS, features
from acrobot_mj.physics.dynamics import UPRIGHT
from acrobot_mj.train.black_box import (
    BlackBoxConfig,
    BlackBoxLearner,
    black_box_env,
    check_fit,
    explore,
    fit_model,
)
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.run import Run
from acrobot_mj.train.trainer import load_learner

RNG = np.random.default_rng(7)
STATES = np.column_stack([RNG.uniform(-np.pi, np.pi, (400, 2)), RNG.uniform(-5, 5, (400, 2))])
ACTIONS = RNG.uniform(-1, 1, 400)


def a_model(harmonics: int = 2, form: str = "map") -> LibraryModel:
    weights = np.zeros((len(features(np.zeros(4), 0.0, harmonics)), 4))
    weights[RNG.choice(len(weights), 12, replace=False)] = RNG.normal(0, 0.01, (12, 4))
    if form == "rational":  # denominators of 1 + 0.3 of two angle products (never near 0)
        bottoms = np.zeros((DENOMINATOR_TERMS, 4))
        bottoms[[3, 7]] = 0.3
        return LibraryModel(harmonics, weights, denominators=bottoms)
    # An ODE's weights are rates: the same numbers over 0.01 s substeps.
    return (
        LibraryModel(harmonics, weights / 0.01, 3, 0.01)
        if form == "ode"
        else LibraryModel(harmonics, weights)
    )


def field(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """A pendulum-like vector field written by hand, not through features(): 1, 1, 3 and 3
    library terms of harmonics <= 2."""
    q1, q2, v1, v2 = x.T
    return np.column_stack(
        [
            v1,
            v2,
            3.0 * np.cos(q1) * u - 0.2 * np.sin(2 * q2) * v1 * v2 - 9.0 * np.sin(q1),
            0.5 * np.cos(q1) * np.sin(q2) * v2 - 4.0 * np.sin(q1 + q2),
        ]
    )


def rk4(x: np.ndarray, u: np.ndarray, h: float, n: int) -> np.ndarray:
    """``n`` classical RK4 steps of ``h`` [s] of :func:`field`, written out again here."""
    for _ in range(n):
        k1 = field(x, u)
        k2 = field(x + h / 2 * k1, u)
        k3 = field(x + h / 2 * k2, u)
        k4 = field(x + h * k3, u)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


# -- the library model ------------------------------------------------------------------------


def test_the_fit_recovers_a_sparse_law_in_its_span() -> None:
    # Increments written by hand, not through features(): three terms of q1, q2 and v1 v2 u.
    q1, q2, v1, v2 = STATES.T
    delta = np.zeros((400, 4))
    delta[:, 2] = 0.3 * np.cos(q1) * ACTIONS - 0.02 * np.sin(2 * q2) * v1 * v2 + 0.1
    delta[:, 3] = 0.05 * np.cos(q1) * np.sin(q2) * v2
    model = LibraryModel.fit(STATES, ACTIONS, STATES + delta, harmonics=2)
    # Exact data: the refit on the kept terms solves to rounding (1e-12 of increments ~0.3).
    assert np.abs(model.step(STATES, ACTIONS) - STATES - delta).max() < 1e-12
    # The threshold dropped every other term: 3, 1 and no term in the three columns.
    assert np.count_nonzero(model.weights, axis=0).tolist() == [0, 0, 3, 1]


def test_the_ode_fit_recovers_a_field_integrated_by_rk4_where_the_map_cannot() -> None:
    after = rk4(STATES, ACTIONS, 0.02, 3)  # three RK4 steps of 0.02 s make one decision
    ode = LibraryModel.fit(STATES, ACTIONS, after, harmonics=2, ode=(3, 0.02))
    # Data in its span: the fixed point converges to rounding (measured 7e-15 on states ~5).
    assert np.abs(ode.step(STATES, ACTIONS) - after).max() < 1e-11
    assert np.count_nonzero(ode.weights, axis=0).tolist() == [1, 1, 3, 3]
    assert ode.form == "ode"
    # Three RK4 steps are no sum of library terms: the map misses by 0.014 (measured), and
    # keeps most terms.
    mapped = LibraryModel.fit(STATES, ACTIONS, after, harmonics=2)
    assert np.abs(mapped.step(STATES, ACTIONS) - after).max() > 1e-3
    assert mapped.form == "map" and mapped.terms > 100


@pytest.mark.slow
def test_the_ode_fit_recovers_a_rational_field() -> None:
    # A field divided by 1 + 0.4 cos 2 q2, as a mass matrix's determinant divides an arm's.
    def divided(x: np.ndarray, u: np.ndarray, h: float, n: int) -> np.ndarray:
        for _ in range(n):
            stage, ks = x, []
            for advance in (0.5, 0.5, 1.0, 0.0):
                k = field(stage, u)
                k[:, 2:] /= (1.0 + 0.4 * np.cos(2.0 * stage[:, 1]))[:, None]
                ks.append(k)
                stage = x + h * advance * k
            x = x + h / 6 * (ks[0] + 2 * ks[1] + 2 * ks[2] + ks[3])
        return x

    rng = np.random.default_rng(3)  # 1,500 transitions: 400 leave the fit on a wrong valley
    states = np.column_stack([rng.uniform(-np.pi, np.pi, (1500, 2)), rng.uniform(-5, 5, (1500, 2))])
    actions = rng.uniform(-1, 1, 1500)
    after = divided(states, actions, 0.02, 3)
    ode = LibraryModel.fit(states, actions, after, harmonics=2, ode=(3, 0.02))
    # The ridge biases the fit by about 6e-7 (measured); the polynomial start misses by 1e-2.
    assert np.abs(ode.step(states, actions) - after).max() < 1e-5
    assert np.count_nonzero(ode.weights, axis=0).tolist() == [1, 1, 3, 3]
    # The velocities' denominators are 1 + 0.4 cos 2 q2; the angles' stay 1 (the ridge).
    q2 = np.linspace(-np.pi, np.pi, 7)
    grid = np.column_stack([np.zeros(7), q2, np.zeros((7, 2))])
    from acrobot_mj.identify.terms import denominator_design

    bottom = 1.0 + denominator_design(grid) @ ode.bottoms
    assert np.abs(bottom[:, 2:] - (1.0 + 0.4 * np.cos(2 * q2))[:, None]).max() < 1e-5
    assert np.abs(bottom[:, :2] - 1.0).max() < 1e-9


def test_the_rational_map_fit_recovers_a_divided_map_the_map_cannot() -> None:
    # One explicit step of the field, its velocities divided by 1 + 0.4 cos 2 q2, written by
    # hand: in the rational map's span, not in the map's (1 / (1 + 0.4 cos 2 q2) has every
    # harmonic).
    bottom = 1.0 + 0.4 * np.cos(2.0 * STATES[:, 1])
    after = STATES + 0.05 * field(STATES, ACTIONS) / np.column_stack(
        [np.ones((400, 2)), bottom, bottom]
    )
    rational = LibraryModel.fit_rational(STATES, ACTIONS, after, harmonics=2)
    plain = LibraryModel.fit(STATES, ACTIONS, after, harmonics=2)
    # Exact data in its span: rounding only (measured about 1e-15); the map misses by 1e-3.
    assert (
        rational.form == "rational" and np.abs(rational.step(STATES, ACTIONS) - after).max() < 1e-10
    )
    assert np.abs(plain.step(STATES, ACTIONS) - after).max() > 1e-4


def test_the_rational_map_is_exact_on_the_reports_acrobot_from_1000_decisions() -> None:
    # The report's step is semi-implicit Euler: its increments are the inverse mass matrix
    # times polynomial terms, so rational in the library with the determinant a - b cos^2 q2
    # as denominator. 1,000 decisions fit it to rounding (measured 1e-15 held out; the map's
    # error from as many is about 2e-3).
    config = BlackBoxConfig(decisions=1000, form="rational")
    env = black_box_env(config)
    data = explore(env, config, 0)
    train, held = ({k: v[s] for k, v in data.items()} for s in (slice(900), slice(900, None)))
    model = fit_model(train, held, config, env)
    errors = model.errors(held["states"], held["actions"], held["next_states"])["max"]
    assert model.form == "rational" and max(errors) < 1e-12


def test_the_plan_takes_one_rk4_step_per_decision_of_the_same_field() -> None:
    fine = LibraryModel.fit(STATES, ACTIONS, rk4(STATES, ACTIONS, 0.02, 3), 2, ode=(3, 0.02))
    coarse = fine.coarse()
    assert (coarse.substeps, coarse.h) == (1, pytest.approx(0.06))
    assert coarse.weights is fine.weights and a_model().coarse().form == "map"
    # One RK4 step of 0.06 s against three of 0.02 s, rates up to about 15: apart by 2.5e-5
    # (measured; RK4's error goes as h^5), which the funnel's feedback corrects.
    miss = np.abs(coarse.step(STATES, ACTIONS) - fine.step(STATES, ACTIONS)).max()
    assert 0.0 < miss < 1e-3


@pytest.mark.slow
def test_the_learner_keeps_the_form_that_predicts_held_out_data_better() -> None:
    from types import SimpleNamespace

    from acrobot_mj.train.black_box import fit_model

    # What fit_model reads of an env: a decision of 3 physics steps of 0.02 s.
    env = SimpleNamespace(unwrapped=SimpleNamespace(frame_skip=3, dt=0.06))
    after = rk4(STATES, ACTIONS, 0.02, 3)
    data = {"states": STATES, "actions": ACTIONS, "next_states": after}
    train, held = ({k: v[s] for k, v in data.items()} for s in (slice(300), slice(300, None)))
    config = BlackBoxConfig(harmonics=2)
    assert fit_model(train, held, config, env).form == "ode"  # type: ignore[arg-type]
    assert fit_model(train, held, BlackBoxConfig(harmonics=2, form="map"), env).form == "map"  # type: ignore[arg-type]
    # Data of a map: the map predicts it to rounding, the ODE cannot.
    mapped = {**data, "next_states": a_model().step(STATES, ACTIONS)}
    train, held = ({k: v[s] for k, v in mapped.items()} for s in (slice(300), slice(300, None)))
    assert fit_model(train, held, config, env).form == "map"  # type: ignore[arg-type]


@pytest.mark.parametrize("form", ["map", "ode", "rational"])
def test_numpy_and_casadi_give_the_same_step_and_jacobians_match_differences(form) -> None:
    model = a_model(form=form)
    rows = model.step(STATES[:5], ACTIONS[:5])  # numpy's rows (one state: CasADi's, for an ODE)
    for x, u, row in zip(STATES[:5], ACTIONS[:5], rows, strict=True):
        symbolic = np.array(model.function(x, u, 0.0)).ravel()
        assert np.abs(symbolic - row).max() < 1e-12  # one sum, another order
        assert np.abs(model.step(x, u) - row).max() < 1e-12
        a, b = model.jacobians(x, u)
        eps = 1e-6  # central differences: truncation ~1e-12, rounding ~1e-10
        for j in range(4):
            dx = np.eye(4)[j] * eps
            column = (model.step(x + dx, u) - model.step(x - dx, u)) / (2 * eps)
            assert np.abs(column - a[:, j]).max() < 1e-7
        column = (model.step(x, u + eps) - model.step(x, u - eps)) / (2 * eps)
        assert np.abs(column - b[:, 0]).max() < 1e-7


@pytest.mark.parametrize("form", ["map", "ode", "rational"])
def test_a_saved_model_predicts_the_same_and_a_bad_one_is_refused(form) -> None:
    model = a_model(form=form)
    again = LibraryModel.from_dict(json.loads(json.dumps(model.to_dict())))
    assert np.array_equal(again.step(STATES, ACTIONS), model.step(STATES, ACTIONS))
    assert again.terms == 12 == model.terms and again.form == model.form == form
    # A record written before the ODE form is a map.
    assert "substeps" not in a_model().to_dict()
    with pytest.raises(ValueError, match="needs substeps > 0 and h > 0 s"):
        LibraryModel(2, np.zeros((250, 4)), 3, 0.0)
    with pytest.raises(ValueError, match=r"needs finite weights of shape \(250, 4\)"):
        LibraryModel(2, np.zeros((249, 4)))
    with pytest.raises(ValueError, match="cannot fit 250 library terms"):
        LibraryModel.fit(STATES[:100], ACTIONS[:100], STATES[:100], harmonics=2)
    with pytest.raises(ValueError, match="cannot fit 274 library terms"):  # 250 + 24 below
        LibraryModel.fit_rational(STATES[:260], ACTIONS[:260], STATES[:260], harmonics=2)
    with pytest.raises(ValueError, match=r"denominators need shape \(24, 4\)"):
        LibraryModel(2, np.zeros((250, 4)), denominators=np.zeros((23, 4)))


def test_a_model_with_no_rest_point_says_so() -> None:
    weights = np.zeros((len(features(np.zeros(4), 0.0, 1)), 4))
    weights[0, 2] = 0.1  # a constant push on dq1: nothing stays at rest
    with pytest.raises(ValueError, match="holds no state at rest near"):
        LibraryModel(1, weights).equilibrium(np.array([1.0, 0.0]))


def test_the_goal_is_where_the_learnt_reward_is_highest() -> None:
    q1, q2 = STATES[:, 0], STATES[:, 1]
    reward = (1 + np.sin(q1)) * (1 + np.cos(q2)) / 4  # the balance task's, in its span
    angles, rms = best_angles(STATES, reward, harmonics=2)
    assert rms < 1e-12 and np.abs(angles - UPRIGHT[:2]).max() < 1e-12  # pi/2 is on the grid


def test_the_learnt_jacobians_drive_the_same_lqr_and_funnel() -> None:
    # The analytic Jacobians passed as a "learnt" model give the LQR of the equations exactly.
    plain, told = LQR(), LQR(linear=lambda x, u: step_jacobians(x, u))
    assert np.abs(plain.gain - told.gain).max() < 1e-12  # the same Jacobians: rounding only
    reserve = shipped("reserve")
    funnel = PlanTracker(
        [reserve],
        linear=lambda x, u: step_jacobians(x, u, p=reserve.params),
        fallback=EnergyRemoval(damping=0.0, limit=1.0),
    )
    # Its LQR sits at the swing-up's end, (pi/2, 2 pi): the same Jacobians up to rounding in
    # the angle, which the Riccati recursion along 476 steps carries to far below 1e-9.
    gains, exact = funnel.tracking[0][1], PlanTracker([reserve]).tracking[0][1]
    assert np.allclose(gains, exact, rtol=0, atol=1e-9)
    far = np.array([0.0, 2.0, 5.0, -8.0])  # no funnel point near: the law given for elsewhere
    assert funnel.act(far, 0.0) == 0.0 and funnel.mode == "fallback"


# -- exploration -------------------------------------------------------------------------------


def test_exploration_is_seeded_and_refuses_discrete_actions() -> None:
    config = BlackBoxConfig(decisions=300, episode_decisions=50)
    first, again, other = (explore(black_box_env(), config, s) for s in (0, 0, 1))
    assert all(np.array_equal(first[k], again[k]) for k in first)
    assert not np.array_equal(first["states"], other["states"])
    assert first["actions"].shape == (300,) and np.abs(first["actions"]).max() <= 1.0
    # 6 episodes from rest with both angles anywhere.
    assert np.count_nonzero(np.all(first["states"][:, 2:] == 0.0, axis=1)) == 6
    with pytest.raises(ValueError, match="needs a Box action"):
        explore(gym.make(Balance.env_id), config, 0)


@pytest.mark.parametrize(
    ("settings", "words"),
    [
        ({"decisions": 50}, "decisions"),
        ({"harmonics": 0}, "harmonics"),
        ({"reserve": 0.0}, "reserve"),
        ({"horizons": (400, 300, 10)}, "horizons"),
    ],
)
def test_bad_settings_are_refused(settings, words) -> None:
    with pytest.raises(ValueError, match=words):
        BlackBoxConfig(**settings)


def test_a_rational_fit_needs_transitions_for_its_denominators_too() -> None:
    check_fit(BlackBoxConfig(decisions=927, form="rational"))  # 834 fitted: 810 + 24 terms
    with pytest.raises(
        ValueError, match=r">= 927 with 4 harmonics and form rational \(the fit's 834 terms"
    ):
        check_fit(BlackBoxConfig(decisions=926, form="rational"))
    with pytest.raises(ValueError, match="form"):
        BlackBoxConfig(form="polynomial")


def test_the_cli_refuses_settings_of_other_learners(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit):
        main(["train", "--preset", "black_box", "--alpha", "0.1", "--out", str(tmp_path / "x")])
    assert "--alpha: not a setting of the black_box preset" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["train", "--preset", "book", "--decisions", "10", "--out", str(tmp_path / "y")])
    assert "--decisions: only the black_box preset takes it" in capsys.readouterr().err


# -- trained end to end (about a minute each) --------------------------------------------------


@pytest.mark.slow
def test_the_preset_trains_balances_held_out_starts_and_replays(tmp_path, capsys) -> None:
    from tests.test_disturbances import replays

    out = tmp_path / "box"
    assert main(["train", "--preset", "black_box", "--out", str(out)]) == 0
    assert "random decisions" in capsys.readouterr().out
    record = json.loads((out / "run.json").read_text())
    # Measured: a 39-term model, held-out errors about 1e-4 rad/s; a 24 s plan; from rest
    # balanced after 23.7 s. 1e-3 leaves room for other machines' rounding in the fit.
    assert max(record["model"]["held_out_errors"]["rms"]) < 1e-3
    assert record["greedy_from_rest"]["balanced_at_end"]
    assert record["data"] == {"decisions": 20000, "simulated_seconds": 1000.0, "held_out": 2000}
    protocol = HeldOut(episodes=3, seed=0, start_noise=0.01, seconds=100.0)
    from acrobot_mj.train.evaluate import evaluate

    evaluated = evaluate(out, protocol)
    # The aim was 1 of 3; measured: 100 of 100 held-out starts within 24 s.
    assert evaluated["balanced_at_end"] == [True] * 3
    assert max(evaluated["first_balance_seconds"]) <= 40.0
    replays(evaluated, Balance)
    assert isinstance(load_learner(out), BlackBoxLearner)
    (out / "model.json").write_text('{"format": "something else"}')
    with pytest.raises(ValueError, match=r"model\.json is not a usable black-box model"):
        load_learner(out)


@pytest.mark.slow
def test_it_learns_an_acrobot_whose_parameters_it_was_never_told() -> None:
    env = black_box_env()
    nominal = model_parameters(env)
    scales = {"m1": 1.2, "m2": 0.85, "I1": 0.9, "I2": 1.1}  # masses [kg], inertias [kg m^2]
    set_model_parameters(env, {k: v * scales[k] for k, v in nominal.items()})
    # As a rational map from 400 decisions: exact for any rigid arm the env steps by
    # semi-implicit Euler (the default preset's whole run is the test above).
    learner = BlackBoxLearner(BlackBoxConfig(decisions=400, harmonics=2, form="rational"), 0, env)
    record = learner.learn(Run(None))
    assert record["greedy_from_rest"]["balanced_at_end"]
    # It learnt this acrobot, not the package's: on the nominal env the same model's
    # predictions miss by far more than its held-out error.
    data = explore(black_box_env(), BlackBoxConfig(decisions=500), 9)
    assert learner.model is not None
    miss = learner.model.errors(data["states"], data["actions"], data["next_states"])["rms"]
    assert min(miss[2:]) > 100 * max(record["model"]["held_out_errors"]["rms"])


# -- other acrobots ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "skip", "seconds"),
    [
        ("report", 1, 0.05),
        ("gymnasium", 1, 0.2),  # one step is already longer than 0.05 s
        ("dm_control", 5, 0.05),
        ("ai_olympics", 25, 0.05),
        ("ai_olympics_pendubot", 25, 0.05),
    ],
)
def test_each_shipped_acrobot_is_seen_through_its_own_spaces_and_a_frame_skip(
    name, skip, seconds
) -> None:
    from acrobot_mj.physics.models import MODELS
    from acrobot_mj.train.black_box import decision_seconds, frame_skip, limits_of

    model = MODELS[name]
    assert frame_skip(model.params.dt, 0.05) == skip
    env = black_box_env(BlackBoxConfig(model=name))
    # 25 steps of 0.002 s add up to 0.05 s only to rounding.
    assert decision_seconds(env) == pytest.approx(seconds, abs=1e-12)
    assert limits_of(env).max_torque == model.params.max_torque
    assert env.unwrapped.params == model.params  # type: ignore[attr-defined]


def test_the_report_is_the_default_model_and_a_bad_model_is_refused(tmp_path, capsys) -> None:
    assert BlackBoxConfig(model="report") == BlackBoxConfig()
    assert BlackBoxConfig.from_dict(BlackBoxConfig().to_dict()).model is None
    with pytest.raises(ValueError, match="config model: model must be one of"):
        BlackBoxConfig(model="nope")
    with pytest.raises(ValueError, match="config decision_period must be"):
        BlackBoxConfig(decision_period=0.0)
    with pytest.raises(SystemExit):
        main(["train", "--preset", "black_box", "--model", "nope", "--out", str(tmp_path / "x")])
    assert "model must be one of" in capsys.readouterr().err


def test_the_balance_and_black_box_presets_share_one_horizons_flag() -> None:
    from acrobot_mj.cli import build_parser
    from acrobot_mj.cli.learning import config_of

    parser = build_parser()
    for preset in ("black_box", "balance"):
        args = parser.parse_args(["train", "--preset", preset, "--horizons", "20:200:20"])
        assert config_of(args).horizons == (20, 200, 20)  # type: ignore[union-attr]


def test_the_plan_horizons_are_the_same_seconds_at_any_decision() -> None:
    from acrobot_mj.train.black_box import plan_horizons

    assert plan_horizons((440, 800, 40), 0.05) == list(range(440, 800, 40))  # the report's
    assert plan_horizons((440, 800, 40), 0.2) == list(range(110, 200, 10))  # 22 to 39.5 s
    assert plan_horizons((1, 4, 1), 0.2) == [1]  # rounded up to one decision, each once


def test_a_failed_horizon_is_tried_again_from_the_nearest_path_led_by_a_wait(monkeypatch) -> None:
    # A stand-in optimiser records each solve: every path from tiny actions misses, the 10-step
    # one by 0.5 rad towards the goal itself; the 20-step plan comes from that path led by a wait
    # (as dm_control's did: tiny actions at 12 s ended 0.82 rad away, the continuation found it).
    from acrobot_mj.physics.params import AcrobotParams
    from acrobot_mj.train import black_box

    calls: list[tuple[int, bool, float]] = []

    class Stand:
        def __init__(self, *args: object) -> None:
            pass

        def tiny_torques(self, horizon: int):
            return np.zeros((horizon + 1, 4)), np.full(horizon, 0.01)

        def reach(self, target: np.ndarray, warm):
            horizon, waited = len(warm[1]), not warm[1][0]
            calls.append((horizon, waited, float(target[1])))
            states = np.repeat(target[None], horizon + 1, axis=0)
            if waited:
                return (states, warm[1]), (states, warm[1])
            states[-1, 0] += 0.5 if (horizon, target[1]) == (10, goal[1]) else 2.0
            return (states, warm[1]), None

        def trajectory(self, path):
            return path

    monkeypatch.setattr(black_box, "Optimiser", Stand)
    goal = np.array([np.pi / 2, 0.0, 0.0, 0.0])
    config, limits = BlackBoxConfig(horizons=(10, 30, 10)), AcrobotParams(dt=0.05)
    plan = black_box.swing_up(a_model(), np.zeros(4), goal, config, limits)
    turns = [0.0, 2 * np.pi, -2 * np.pi]
    assert calls == [(10, False, t) for t in turns] + [(20, False, t) for t in turns] + [
        (20, True, 0.0)
    ]
    assert not plan[1][:10].any() and (plan[1][10:] == 0.01).all()  # waits 10, then the path


def test_a_model_with_no_velocity_limits_is_saved_and_read_again(tmp_path) -> None:
    # dm_control's and RealAIGym's acrobots bound no velocity: JSON holds no infinity.
    from acrobot_mj.control.trajopt import Trajectory
    from acrobot_mj.physics.models import MODELS

    p = MODELS["dm_control"].params
    plan = Trajectory(np.zeros((3, 4)), np.zeros(2), p.dt, "learned", 1.6, p)
    config = BlackBoxConfig(model="dm_control")
    # A damped, driven, stable toy (features' order: angle products times 1, v1, v2, u, ...).
    weights = np.zeros((250, 4))
    weights[1, 0] = weights[2, 1] = 0.05  # q' = q + 0.05 v - 0.01 sin q
    weights[100, 0] = weights[20, 1] = -0.01
    weights[1, 2] = weights[2, 3] = -0.1  # v' = 0.9 v + (0.1, 0.2) u
    weights[3, 2], weights[3, 3] = 0.1, 0.2
    BlackBoxLearner(config, 0, built=(LibraryModel(2, weights), plan)).save(tmp_path)
    (tmp_path / "run.json").write_text(
        json.dumps({"kind": "black_box", "config": config.to_dict(), "seed": 0})
    )
    again = BlackBoxLearner.load(tmp_path)
    assert again.trajectory is not None and again.trajectory.params == p
    assert again.config.model == "dm_control"
