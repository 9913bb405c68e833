"""The ``tree`` entry's plan set (:mod:`acrobot_mj.control.plans`) and its tracker: the shipped
set's plans reach upright on the model, the tracker enters a plan from its start and swings up
on the analytic model without planning, and a missing or corrupt set is refused in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.control.planned import planned_swing_up
from acrobot_mj.control.plans import PlanSet, warm_torques
from acrobot_mj.control.replan import END_TOLERANCE
from acrobot_mj.control.tracker import PlanTracker, TrackerSettings
from acrobot_mj.olympics import entries
from acrobot_mj.olympics.plants import equations
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import state_error
from acrobot_mj.physics.models import MODELS

OLYMPICS = MODELS["ai_olympics"]
P = OLYMPICS.params
SHIPPED = planned_swing_up("ai_olympics")


def _library() -> PlanSet:
    return PlanSet.load(entries.PLANS)


def _tree(count: int) -> PlanTracker:
    """The entry's tracker (no estimator) on the grown set's first ``count`` plans, entered by
    state alone (no rollout)."""
    library = _library()
    return entries.tree(
        equations("ai_olympics"),
        PlanSet(library.starts[:count], library.held[:count], library.hold),
        options=entries.TreeOptions(candidates=0, pause=0, below=None, plans="grown"),
    )


def test_the_shipped_library_is_small_and_every_plan_ends_upright() -> None:
    library = _library()
    assert len(library) >= 10
    assert entries.PLANS.stat().st_size < 1_000_000  # shipped with the package: under 1 MB
    plans = library.plans(P, SHIPPED.method)
    for plan in plans:
        # 1e-12: the torques were clipped to the limit before they were stored.
        assert np.abs(plan.torques).max() <= P.max_torque + 1e-12
        # END_TOLERANCE (0.05 rad, rad/s): the planner kept only plans whose rollout on the
        # model ends this close to upright at rest, and this is the same rollout.
        assert np.abs(state_error(plan.states[-1])).max() <= END_TOLERANCE


def test_it_enters_a_plan_at_its_start_and_swings_up_on_the_analytic_model() -> None:
    """Three of the library's plans, each from its own start: the controller follows a plan
    from the first call (the start is a plan point of cost 0) and balances upright at the end,
    on the noise-free model the plans were made on."""
    tree = _tree(3)
    assert len(tree.plans) == 4  # the three and the funnel's own swing-up
    for start in _library().starts[:3]:
        tree.reset()
        x = start.copy()
        u = tree.act(x, 0.0)
        assert tree.mode == "plan"  # entered at once, no fallback
        for _ in range(integrators.steps_in(1.5 + 0.5, P.dt)):  # the plan and 0.5 s more
            x = integrators.step_states(x, u, P, method=SHIPPED.method)
            u = tree.act(x, 0.0)
        # 0.01 rad, rad/s: balancing upright on the noise-free model (as the funnel's test).
        assert np.abs(state_error(x)).max() < 0.01


@pytest.mark.slow  # about 15 s: a whole 60 s episode at 500 Hz
def test_a_whole_global_episode_keeps_the_arm_up_half_the_time() -> None:
    """The entry as ``acrobot-mj olympics tree --scores global --seed 3`` runs it: resets,
    the estimator and the library together."""
    from acrobot_mj.olympics.episodes import global_episode
    from acrobot_mj.olympics.protocol import GLOBAL
    from acrobot_mj.olympics.scores import uptime
    from acrobot_mj.olympics.sources import Source

    recording, draws = global_episode(Source("tree"), "ai_olympics", 3)
    assert len(draws["reset_times"]) == GLOBAL.resets
    score = uptime(recording, P.l1, P.l2, GLOBAL.t_final, GLOBAL.height)["score"]
    # Half the episode up. Seed 3's score differs by a tenth between two machines (the recorded
    # tree-held-out and tree-held-out-second-machine): rounding moves a global score between
    # machines (the throws amplify it), so the leaderboard's best (leaderboard.GLOBAL) is no
    # bound for one seed here.
    assert score > 0.5


def test_the_shortened_set_starts_alike_and_is_low_no_longer_than_the_grown() -> None:
    """Each plan of the shortened set (``scripts/shorten_plans.py``) starts where the grown
    one's does, ends upright and spends no more steps with the tip at or below 0.9 of the
    reach than the grown plan; most spend fewer."""
    grown, shortened = (PlanSet.load(entries.PLAN_SETS[n]) for n in ("grown", "shortened"))
    np.testing.assert_array_equal(shortened.starts, grown.starts)
    assert entries.PLAN_SETS["shortened"].stat().st_size < 1_000_000
    low = 0.9 * (P.l1 + P.l2)
    fewer = 0
    for old, new in zip(grown.plans(P, "rk4"), shortened.plans(P, "rk4"), strict=True):
        # END_TOLERANCE, as the grown set's: the planner keeps only plans that end this close.
        assert np.abs(state_error(new.states[-1])).max() <= END_TOLERANCE
        before = (dynamics.tip_height(old.states, P) <= low).sum()
        after = (dynamics.tip_height(new.states, P) <= low).sum()
        assert after <= before
        fewer += after < before
    assert fewer > 0.8 * len(grown)  # measured: 59 of 68


def test_the_search_finds_the_point_itself() -> None:
    tree = _tree(2)
    plan = tree.plans[2]
    i, k, level = tree.nearest(plan.states[100] + np.array([2 * np.pi, -2 * np.pi, 0.0, 0.0]))
    assert (i, k) == (2, 100)  # a point of the stride (5), whole turns away
    assert level < 1e-9  # its own point: cost 0 but for the turns' rounding


def test_a_library_grows_and_round_trips(tmp_path: Path) -> None:
    library = _library()
    one = PlanSet(library.starts[:1], library.held[:1], library.hold)
    plan = library.plans(P, "rk4")[1]
    two = one.with_plan(plan)
    assert len(two) == 2
    np.testing.assert_array_equal(two.held[1], library.held[1])
    path = tmp_path / "lib.npz"
    two.save(path)
    again = PlanSet.load(path)
    np.testing.assert_array_equal(again.starts, two.starts)
    np.testing.assert_array_equal(again.held, two.held)
    assert len(warm_torques(plan, 5, 200)) == 200  # padded with zeros past the plan


def test_bad_input_is_refused_in_one_line(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no plan set") as missing:
        PlanSet.load(tmp_path / "none.npz")
    assert "\n" not in str(missing.value)
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(b"PK\x03\x04 not a zip file")
    with pytest.raises(ValueError, match="unreadable") as error:
        PlanSet.load(corrupt)
    assert "\n" not in str(error.value)
    wrong = tmp_path / "wrong.npz"
    np.savez(wrong, starts=np.zeros((2, 3)), held=np.zeros((2, 5)), hold=5)
    with pytest.raises(ValueError, match=r"unreadable.*starts"):
        PlanSet.load(wrong)
    with pytest.raises(ValueError, match="exceeds"):
        PlanSet(np.zeros((1, 4)), np.full((1, 3), 100.0), 5).plans(P, "rk4")
    with pytest.raises(
        ValueError, match="config stride must be a whole number of steps >= 1, got 0"
    ):
        TrackerSettings(stride=0)
    with pytest.raises(ValueError, match="the tree entry is for ai_olympics, not 'report'"):
        entries.ENTRIES["tree"].check("report")
    tree = _tree(1)
    with pytest.raises(ValueError, match="4 finite numbers"):
        tree.act(np.array([0.0, np.nan, 0.0, 0.0]), 0.0)
    with pytest.raises(ValueError, match="model parameters"):
        PlanTracker([SHIPPED, planned_swing_up("report")])


def test_the_compiled_rollout_answers_as_the_rollout_in_python() -> None:
    """``rollout`` on the model's own step is one compiled kernel; on any other step function
    (a learnt model's) the same rollout runs in Python, numpy's products included. Both must
    give the same answer at every start, the steps low counted (below 0.9 of the reach) and
    cut at a most: 400 starts near the swing-up's points, at errors of every cost between
    entry and far beyond track, so that both outcomes occur."""
    plan = planned_swing_up("ai_olympics")
    p, levels = plan.params, equations("ai_olympics").levels
    settings = TrackerSettings(below=0.9)
    compiled_one = PlanTracker([plan], levels, settings)

    def python_step(x: np.ndarray, u: float) -> np.ndarray:  # not a partial: the Python loop
        return integrators.step_states(x, u, p=p, method=plan.method)

    python_one = PlanTracker([plan], levels, settings, step=python_step)
    assert compiled_one._constants() is not None and python_one._constants() is None
    rng = np.random.default_rng(5)
    answers, lows = [], []
    for _ in range(400):
        k = int(rng.integers(0, plan.steps - 1))
        x = plan.states[k] + rng.normal(0.0, 10.0 ** rng.uniform(-3, 0), 4)
        low = compiled_one.rollout(x, 0, k)
        assert low == python_one.rollout(x, 0, k), (k, x.tolist())
        answers.append(low >= 0)
        assert compiled_one.reaches(x, 0, k) == (low >= 0)
        if low > 0:  # one step fewer allowed: refused, by both
            assert compiled_one.rollout(x, 0, k, low - 1) == python_one.rollout(x, 0, k, low - 1)
            assert compiled_one.rollout(x, 0, k, low - 1) == -1
            lows.append(low)
    assert 50 < sum(answers) < 350, sum(answers)  # both answers, many times
    # Counted, and not all alike: the swing-up is low for its first 1.4 s (about 700 steps).
    assert len(set(lows)) > 20 and max(lows) > 300


def test_an_entry_is_the_first_of_the_candidates_whose_rollout_reaches_upright() -> None:
    """With one candidate the rule is the funnel's: the point of least cost, entered below
    ``entry``, or below ``track`` where its rollout reaches upright. With 32 and no ``below``,
    the first point in order of cost whose rollout reaches; else the least, where below
    ``entry``. Checked at 300 states near the library's points against the rule written out
    here."""
    plant = equations("ai_olympics")
    first = entries.TreeOptions(pause=0, below=None, plans="grown")
    one = entries.tree(plant, PlanSet.load(entries.PLANS), None, first.replace(candidates=1))
    many = entries.tree(plant, PlanSet.load(entries.PLANS), None, first.replace(candidates=32))
    assert one.settings.rollout and (one.settings.candidates, many.settings.candidates) == (1, 32)
    levels, rng, moved = plant.levels, np.random.default_rng(8), 0
    for _ in range(300):
        i = int(rng.integers(len(one.plans)))
        plan = one.plans[i]
        x = plan.states[int(rng.integers(plan.steps))] + rng.normal(0.0, 0.05, 4)
        costs = one._levels(x)
        ranked = np.argsort(costs, kind="stable")
        best = one.which[ranked[0]]
        reached = [
            b for b in ranked[:32] if costs[b] < levels.track and one.reaches(x, *one.which[b])
        ]
        first = one.entry(x)
        old = costs[ranked[0]] < levels.entry or (
            costs[ranked[0]] < levels.track and one.reaches(x, *best)
        )
        assert first == (*best, bool(old))
        want = (
            (*one.which[reached[0]], True) if reached else (*best, costs[ranked[0]] < levels.entry)
        )
        assert many.entry(x) == tuple(int(v) if not isinstance(v, bool) else v for v in want)
        moved += bool(reached) and reached[0] != ranked[0]
    assert moved > 10  # the candidates changed the entry at many states


def test_by_default_it_enters_the_candidate_whose_rollout_is_low_the_fewest_steps() -> None:
    """The entry's default (16 candidates, ``below`` 0.9): on a plan (cost below
    :data:`~acrobot_mj.olympics.entries.ON_PLAN`), the point of least cost; else of the
    candidates whose rollout reaches upright, the one whose rollout has the tip at or below
    0.9 of the reach the fewest steps, the cheaper of equals; checked at 200 states near the
    shortened set's points against the rule written out here."""
    plant = equations("ai_olympics")
    options = entries.TreeOptions()
    defaults = (options.candidates, options.pause, options.below, options.plans)
    assert defaults == (16, 1, 0.9, "shortened")
    tracker = entries.tree(plant, PlanSet.load(entries.PLAN_SETS["shortened"]), None, options)
    rng, chosen_later = np.random.default_rng(9), 0
    for _ in range(200):
        plan = tracker.plans[int(rng.integers(len(tracker.plans)))]
        x = plan.states[int(rng.integers(plan.steps))] + rng.normal(0.0, 0.05, 4)
        costs = tracker._levels(x)
        ranked = [b for b in np.argsort(costs, kind="stable")[:16] if costs[b] < plant.levels.track]
        lows = [tracker.rollout(x, *tracker.which[b]) for b in ranked]
        reached = [(low, n) for n, low in enumerate(lows) if low >= 0]
        i, k, entered = tracker.entry(x)
        if costs[ranked[0]] < entries.ON_PLAN:  # on a plan: followed as it is
            assert entered and (i, k) == tuple(tracker.which[ranked[0]])
        elif reached:
            fewest = min(reached)  # the fewest steps low, then the earlier in order of cost
            assert entered and (i, k) == tuple(tracker.which[ranked[fewest[1]]])
            chosen_later += fewest[1] > 0
    assert chosen_later > 10  # not the first that reaches at many states


def test_after_a_search_that_finds_no_entry_it_pauses_the_calls_asked() -> None:
    """``pause=3``: of 8 calls where nothing can be entered (hanging, the shoulder at 25
    rad/s: no rollout of 32 reaches upright, the least cost is past ``entry``), the 1st and
    5th search; a reset ends the pause."""
    plant = equations("ai_olympics")
    options = entries.TreeOptions(candidates=32, pause=3)
    tracker = entries.tree(plant, PlanSet.load(entries.PLAN_SETS["shortened"]), None, options)
    searched: list[int] = []
    search = tracker.entry

    def counted(x: np.ndarray) -> tuple[int, int, bool]:
        searched.append(call)
        return search(x)

    tracker.entry = counted  # type: ignore[method-assign]
    x = np.array([-np.pi / 2, 0.0, 25.0, 0.0])
    assert not search(x)[2]  # nothing to enter here
    for call in range(8):
        tracker.act(x, call * 0.002)
        assert tracker.mode == "fallback"
    assert searched == [0, 4]
    call = 8
    tracker.act(x + np.array([1.0, 0.0, 0.0, 0.0]), 0.016)  # an angle jump: a reset
    assert searched == [0, 4, 8]
