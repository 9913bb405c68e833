"""Swing-ups planned online (:mod:`acrobot_mj.control.replan`): the planner's plans on the
analytic model, the controller's input checks, its equality with the funnel from hanging, and
one stretch of the global policy's episode."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.control.estimator import Estimated
from acrobot_mj.control.planned import planned_swing_up
from acrobot_mj.control.replan import END_TOLERANCE, Planner, replanner, upright_targets
from acrobot_mj.control.tracker import PlanTracker, TrackerSettings
from acrobot_mj.olympics import entries
from acrobot_mj.olympics.plants import equations
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT, state_error
from acrobot_mj.physics.models import MODELS

pytest.importorskip("casadi", reason="the planner needs the control extra")

OLYMPICS = MODELS["ai_olympics"]
P = OLYMPICS.params


def _check_plan(plan, x0: np.ndarray) -> None:
    """A plan starts at ``x0``, keeps the torque limit, is the model's own rollout and ends at
    upright at rest."""
    assert np.abs(plan.states[0] - x0).max() == 0.0  # the rollout starts where it was asked
    # 1e-12: the clip to the limit is exact; only rounding in the comparison remains.
    assert np.abs(plan.torques).max() <= P.max_torque + 1e-12
    # 1e-9 (trajopt.TOLERANCE): the states are the model's rollout of the torques.
    assert plan.residual() <= 1e-9
    # END_TOLERANCE (0.05 rad, rad/s): IPOPT's tolerance of 1e-6 and the rollout's drift away
    # from an unstable end; the LQR at upright catches far more.
    assert np.abs(state_error(plan.states[-1])).max() <= END_TOLERANCE


def test_upright_targets_are_upright_and_near() -> None:
    x = np.array([2.0, -5.0, 1.0, 1.0])
    found = upright_targets(x)
    assert len(found) == 3
    for target in found:
        assert np.abs(state_error(target)).max() < 1e-12  # each is upright at rest
    # The nearest: each angle within pi of the state's.
    assert np.abs(found[0][:2] - x[:2]).max() <= np.pi
    assert len({tuple(t) for t in found}) == 3
    assert len(upright_targets(x, 1)) == 1
    with pytest.raises(ValueError, match="count"):
        upright_targets(x, 4)


def test_a_short_plan_along_the_planned_swing_up_reaches_upright() -> None:
    """0.5 s (50 torques held 5 steps) from the shipped swing-up's state 0.5 s before its end,
    IPOPT warm-started from its torques: fast, and the same NLP as the entry's."""
    shipped = planned_swing_up("ai_olympics")
    start = shipped.steps - 250
    planner = Planner(P, "rk4", decisions=50, hold=5)
    x0 = shipped.states[start]
    found = planner.solve(x0, UPRIGHT, warm=shipped.torques[start::5])
    assert found is not None
    plan, objective = found
    assert plan.steps == 250
    # The objective recomputed from the plan rolled out by numpy: the tip's mean squared drop
    # below its top over the decisions' ends, plus effort times the held torques' mean square.
    # The NLP's states equal the rollout's to IPOPT's constraint tolerance (1e-8 and less), so
    # 1e-6 relative would catch a wrong term or weight.
    q = plan.states[5::5]  # the state after each decision
    tip = P.l1 * np.sin(q[:, 0]) + P.l2 * np.sin(q[:, 0] + q[:, 1])
    held = plan.torques[::5]
    expected = np.mean((P.l1 + P.l2 - tip) ** 2) + planner.effort * np.mean(held**2)
    assert objective == pytest.approx(expected, rel=1e-6)
    _check_plan(plan, x0)


@pytest.mark.slow
def test_the_planner_swings_up_from_rest_anywhere() -> None:
    """The entry's planner (150 torques held 5 steps: 1.5 s) from three random rests, each to
    its best of three targets."""
    planner = Planner(P, "rk4")
    rng = np.random.default_rng(0)
    for _ in range(3):
        x0 = np.r_[rng.uniform(-np.pi, np.pi, 2), 0.0, 0.0]
        plan = planner.plan(x0)
        assert plan is not None
        assert plan.steps == 750
        _check_plan(plan, x0)


def test_bad_input_is_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="decisions"):
        Planner(P, decisions=1)
    with pytest.raises(ValueError, match="integrator"):
        Planner(P, "euler")
    planner = Planner(P, decisions=10)
    with pytest.raises(ValueError, match="targets"):
        replanner(planner, targets=0)
    with pytest.raises(ValueError, match=r"config window must be in \[0, inf\], got -1"):
        TrackerSettings(window=-1.0)
    with pytest.raises(ValueError, match="start"):
        planner.plan(np.array([0.0, np.nan, 0.0, 0.0]))
    controller = PlanTracker([planned_swing_up("ai_olympics")], planner=replanner(planner))
    with pytest.raises(ValueError, match="4 finite numbers"):
        controller.act(np.array([0.0, 0.0, 0.0]), 0.0)
    with pytest.raises(ValueError, match="4 finite numbers"):
        controller.act(np.array([0.0, np.inf, 0.0, 0.0]), 0.0)


def test_from_hanging_it_is_the_funnel_entry() -> None:
    """From hanging at rest both entries follow the shipped swing-up: the same torques, to the
    last bit, over the swing-up and 0.5 s of balance, and no plan."""
    funnel = entries.ENTRIES["funnel"].build(equations("ai_olympics"))
    replan = entries.ENTRIES["replan"].build(equations("ai_olympics"))
    assert isinstance(replan, Estimated) and isinstance(replan.controller, PlanTracker)
    funnel.reset()
    replan.reset()
    x = HANGING.copy()
    for k in range(integrators.steps_in(planned_swing_up("ai_olympics").seconds + 0.5, P.dt)):
        u = funnel.act(x, k * P.dt)
        assert replan.act(x, k * P.dt) == u
        x = integrators.step_states(x, u, P, method="rk4")
    assert replan.controller.planned == [] and replan.controller.failed == 0
    assert np.abs(state_error(x)).max() < 0.01  # balancing upright: 0.01 of the noise-free model


@pytest.mark.slow
def test_a_global_stretch_swings_up_after_a_reset() -> None:
    """One reset of the protocol (at 1.5 s, to the arm folded sideways at rest) in 5 s of the
    global episode: the entry is up before it, plans after it and is up again at the end."""
    from acrobot_mj.olympics.episodes import global_run
    from acrobot_mj.olympics.protocol import GLOBAL
    from acrobot_mj.olympics.scores import uptime

    controller = entries.ENTRIES["replan"].build(equations("ai_olympics"))
    assert isinstance(controller, Estimated) and isinstance(controller.controller, PlanTracker)
    targets = np.array([[1.0, 2.0, 0.0, 0.0]])  # protocol angles: theta1, theta2
    recording = global_run(
        controller, "ai_olympics", targets, np.array([1.5]), replace(GLOBAL, t_final=5.0)
    )
    assert controller.controller.planned  # it planned after the reset, and found a plan
    tip = P.l1 * np.sin(recording.X[:, 0]) + P.l2 * np.sin(recording.X[:, 0] + recording.X[:, 1])
    assert tip[-1] > 0.9 * (P.l1 + P.l2)  # the protocol's "up"
    # The plan ends upright 1.5 s after the reset's end (1.7 s): 1.8 s up from 3.2 s to 5 s at
    # least; 1.5 s leaves room for a tracking loss near the end of the plan.
    assert uptime(recording, P.l1, P.l2, 5.0)["uptime"] > 1.5


def test_a_plan_re_solved_for_time_below_the_height_is_low_for_less_time() -> None:
    """``scripts/shorten_plans.py`` (the :class:`TimeBelow` objective) on the grown set's
    plan 0, warm-started from its torques, to its own end: the tip at or below 0.9 of the
    reach for fewer steps (measured 200 against 245), and the shipped shortened set's torques
    to IPOPT's rounding."""
    import importlib.util

    from acrobot_mj.control.plans import PlanSet

    spec = importlib.util.spec_from_file_location(
        "shorten_plans", Path(__file__).parents[1] / "scripts" / "shorten_plans.py"
    )
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    grown = PlanSet.load(entries.PLAN_SETS["grown"])
    held, before, after = script.shorten(grown.starts[0], grown.held[0], grown.hold)
    assert after < before  # seconds below
    assert (before, after) == pytest.approx((244 * P.dt, 199 * P.dt), abs=1e-9)  # past the start
    shipped = PlanSet.load(entries.PLAN_SETS["shortened"]).held[0]
    # 1e-9 N m: the same solve on this machine gives the shipped file's torques to the bit;
    # another BLAS may round IPOPT's steps differently.
    np.testing.assert_allclose(held, shipped, atol=1e-9)
    with pytest.raises(ValueError, match="iterations must be >= 1, got 0"):
        Planner(P, iterations=0)
