"""The protocol's entries, one declarative registry (:data:`ENTRIES`): each an :class:`Entry`
with its name, what it is, its factory (a controller built for a model from the model's
parameters alone), its options, and the model it is set for where it is set for one, with why.

Every entry is a :class:`~acrobot_mj.control.tracker.PlanTracker` along the model's planned
swing-up (:mod:`acrobot_mj.olympics.swing_ups`) on a state estimate
(:class:`~acrobot_mj.control.estimator.Observer`): ``funnel`` alone, ``replan`` with swing-ups
planned online from wherever it is, ``tree`` with a set of swing-ups planned offline (grown by
``scripts/grow_plans.py``), ``backward`` with swing-ups integrated backwards from
upright (:mod:`acrobot_mj.control.backward`) and energy removal planned on the model's steps
(:mod:`acrobot_mj.control.shooting`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from acrobot_mj.control.controller import Controller, EnergyRemoval, Fallbacks
from acrobot_mj.control.planned import PLANNED, shipped_name
from acrobot_mj.control.plans import PlanSet
from acrobot_mj.control.policies import EnergyPumping
from acrobot_mj.control.tracker import FunnelSettings, PlanningHook, PlanTracker, TrackerSettings
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.olympics.plants import Plant
from acrobot_mj.olympics.protocol import HEIGHT
from acrobot_mj.olympics.swing_ups import check_plannable
from acrobot_mj.settings import Settings, setting

#: The constrained LQR's horizon [steps] on ``ai_olympics``: 0.5 s, 2.3 time constants of the
#: slower unstable mode at upright (eigenvalue 4.65 /s). The QP's condition number stops it
#: near 361 steps, whose condensing took 248 s against 0.4 s for 250 (2 shared cores).
MPC_HORIZON = 250
#: Energy pumping's gain [N m / (J rad/s)] where no plan is followed.
PUMPING_GAIN = 50.0
#: The models on which the entries pump energy where no plan is followed; elsewhere they remove
#: it, so the arm falls to hanging, where the plan starts. On the report's acrobot, at 0.05 of
#: gravity's torque, pumping to upright's energy kept the arm whirling, its elbow spinning at
#: about 8 rad/s and never caught after a reset: global uptimes 0.091, 0.084, 0.113 on seeds
#: 0-2 against 0.252, 0.300, 0.196 removing energy.
PUMPING_ON = ("ai_olympics",)
#: A reset is an angle jump past this [rad] between two 0.002 s calls on ``ai_olympics``; at
#: the report's 0.05 s a step the arm at its velocity limit, 9 pi rad/s, turns 1.4 rad.
JUMPS = {"ai_olympics": 0.1, "report": 2.0}
#: The ``tree`` entry's plan sets on ``ai_olympics``: as grown (``scripts/grow_plans.py``) and
#: shortened (``scripts/shorten_plans.py``).
PLAN_SETS = {
    name: Path(__file__).resolve().parent / "trajectories" / f"ai_olympics_tree{suffix}.npz"
    for name, suffix in (("grown", ""), ("shortened", "_shortened"))
}
PLANS = PLAN_SETS["grown"]
#: ``tree``'s cost level below which a state is on a plan and follows it without a rollout:
#: from hanging at rest, the performance episode's start, the swing-up (0 there) rather than
#: a plan lower for fewer steps but rougher (performance 0.568 against 0.688, seed 0). On
#: seeds 200-219 the global mean moved from 0.709 to 0.706; at the entry level, 20, to 0.675.
ON_PLAN = 1.0
#: ``backward``'s plan points rolled out, entered as ``tree`` enters (the fewest steps low):
#: on seeds 61-66 of the scaled global test, 16 gave 0.593, 32 0.603, 64 0.603, entering by
#: state alone (its first version) 0.547.
BACKWARD_CANDIDATES = 32


@dataclass(frozen=True)
class FunnelOptions(Settings):
    """The ``funnel`` entry's options."""

    mpc: bool = setting(
        False,
        "balance with the constrained LQR (250 steps on ai_olympics, 40 elsewhere) instead of "
        "the saturated LQR",
    )

    what = "funnel entry"


@dataclass(frozen=True)
class TreeOptions(Settings):
    """The ``tree`` entry's options."""

    candidates: int = setting(
        16,
        "the N plan points of least cost rolled out on the model, one of those that reach "
        "upright entered (0: no rollout, the point of least cost below the entry level)",
        "points",
        low=0,
        metavar="N",
    )
    pause: int = setting(
        1,
        "calls without a search for an entry after one found none (the fallback acts), so "
        "that few calls search",
        "calls",
        low=0,
    )
    below: float | None = setting(
        HEIGHT,
        "of the N points whose rollout reaches upright, enter the one whose tip spends the "
        "fewest steps at or below this fraction of the arm's reach (0.9: the protocol's up); "
        "none: the first in order of cost",
        low=-1.0,
        high=1.0,
    )
    plans: str = setting(
        "shortened",
        "the plan set: as grown (scripts/grow_plans.py) or each plan re-solved to spend less "
        "time below the protocol's height (scripts/shorten_plans.py)",
        choices=tuple(PLAN_SETS),
    )

    what = "tree entry"


@dataclass(frozen=True)
class NoOptions(Settings):
    """An entry without options."""

    what = "entry"


@dataclass(frozen=True)
class Entry:
    """An entry: its ``name``, what it ``describes``, its ``factory`` (a
    :class:`~acrobot_mj.olympics.plants.Plant` and the options to a controller), its
    ``options`` (a :class:`~acrobot_mj.settings.Settings`), ``only``, the acrobot it is set for
    (None: every one with a planned swing-up), with ``why``, whether it can be built on a
    ``learnt`` model, and whether it is ``realtime`` (False: the simulation waits for it)."""

    name: str
    describes: str
    factory: Callable[[Plant, Any], Controller]
    options: type[Settings] = NoOptions
    only: str | None = None
    why: str = ""
    learnt: bool = False
    realtime: bool = True

    def check(self, model: str, learnt: bool = False) -> None:
        """Refuse, in one line, an acrobot ``model`` the entry cannot work on, from its
        equations or (``learnt``) from a learnt model of it."""
        if learnt and not self.learnt:
            raise ValueError(f"the {self.name} entry is built on the equations, not a learnt model")
        name = shipped_name(model)
        if self.only is not None and name != self.only:
            raise ValueError(f"the {self.name} entry is for {self.only}, not {model!r}: {self.why}")
        if not learnt:
            check_plannable(model)

    def build(self, plant: Plant, options: Mapping[str, Any] | None = None) -> Controller:
        """The entry's controller on ``plant`` with ``options`` (by name)."""
        self.check(plant.model or plant.name, plant.learnt)
        return self.factory(plant, self.options.from_dict(dict(options or {})))


def fallback(plant: Plant) -> Controller | None:
    """Where no plan is followed: energy pumping on :data:`PUMPING_ON` (the equations'
    energy), else removal."""
    if plant.name not in PUMPING_ON or plant.learnt:
        return None
    return EnergyPumping(plant.swing_up.params, PUMPING_GAIN)


def _funnel(plant: Plant, options: FunnelOptions) -> Controller:
    chosen = plant.levels
    if options.mpc:  # elsewhere the default horizon: 40 steps, as `balance --feedback`
        horizon = MPC_HORIZON if plant.name == "ai_olympics" else FunnelSettings().horizon
        chosen = chosen.replace(horizon=horizon)
    tracker = PlanTracker(
        [plant.swing_up], chosen, fallback=fallback(plant), linear=plant.linear, step=plant.step
    )
    return plant.estimated(tracker)


def _replan(plant: Plant, options: NoOptions) -> Controller:
    from acrobot_mj.control.replan import Planner, replanner  # CasADi: the control extra

    swing_up = plant.swing_up
    planner = replanner(Planner(swing_up.params, swing_up.method))
    settings = TrackerSettings(jump=JUMPS[plant.name])
    tracker = PlanTracker(
        [swing_up], plant.levels, settings, fallback=fallback(plant), planner=planner
    )
    return plant.estimated(tracker)


def tree(
    plant: Plant,
    plans: PlanSet,
    planner: PlanningHook | None = None,
    options: TreeOptions = TreeOptions(),
) -> PlanTracker:
    """The ``tree`` entry's tracker on ``plant`` over its swing-up and ``plans``, unestimated;
    ``planner`` (offline) adds plans to it; ``options.candidates`` points tried by rollout."""
    swing_up = plant.swing_up
    every = [swing_up, *plans.plans(swing_up.params, swing_up.method)]
    tried = options.candidates
    settings = TrackerSettings(
        stride=5,
        rollout=tried > 0,
        candidates=max(tried, 1),
        pause=options.pause,
        on=ON_PLAN,
        below=options.below,
        jump=JUMPS[plant.name],
    )
    return PlanTracker(
        every, plant.levels, settings, fallback=fallback(plant), planner=planner, keep=True
    )


def backward(plant: Plant, plans: list[Trajectory] | None = None) -> PlanTracker:
    """The ``backward`` entry's tracker on ``plant``, unestimated: its swing-up and ``plans``
    (None: :func:`~acrobot_mj.control.backward.backward_library`'s), entered as ``tree``
    enters its set; above upright's energy, energy removal planned on the model's steps
    (:class:`~acrobot_mj.control.shooting.EnergyShooting`), below it the funnel's."""
    from acrobot_mj.control.backward import BackwardSettings, backward_library
    from acrobot_mj.control.shooting import EnergyShooting

    swing_up = plant.swing_up
    p, method = swing_up.params, swing_up.method
    plans = backward_library(p, method, BackwardSettings()) if plans is None else plans
    chosen = plant.levels
    removal = Fallbacks([EnergyShooting(p, method), EnergyRemoval(chosen.damping, p.max_torque)])
    settings = TrackerSettings(
        stride=5, candidates=BACKWARD_CANDIDATES, on=ON_PLAN, below=HEIGHT, jump=JUMPS[plant.name]
    )
    return PlanTracker([swing_up, *plans], chosen, settings, fallback=removal)


#: The entries by name.
ENTRIES = {
    entry.name: entry
    for entry in (
        Entry(
            "funnel",
            "TVLQR along the planned swing-up entered by state, LQR at upright, on a state "
            "estimate; energy pumping elsewhere on ai_olympics, removal on other acrobots",
            _funnel,
            FunnelOptions,
            learnt=True,
        ),
        Entry(
            "replan",
            "funnel with swing-ups planned online from wherever it is (IPOPT; not real-time)",
            _replan,
            only="ai_olympics",
            why="its planner's and replanning's settings are that robot's",
            realtime=False,
        ),
        Entry(
            "tree",
            "funnel with a set of swing-ups planned offline, entered by rollout (real-time)",
            lambda plant, options: plant.estimated(
                tree(plant, PlanSet.load(PLAN_SETS[options.plans]), None, options)
            ),
            TreeOptions,
            only="ai_olympics",
            why="its plan set and settings are that robot's",
        ),
        Entry(
            "backward",
            "funnel with swing-ups integrated backwards from upright and energy removal "
            "planned on the model's steps",
            lambda plant, options: plant.estimated(backward(plant)),
            only="report",
            why="its plans' torques and its reset test are for that acrobot's steps",
        ),
    )
}


def support_table() -> str:
    """A Markdown table of each entry on each shipped acrobot: ``runs``, or why not in short
    (the refusal itself is one line naming the model); then why each set for one acrobot is."""
    from acrobot_mj.physics.models import MODELS

    rows = ["| entry | " + " | ".join(f"`{m}`" for m in MODELS) + " |"]
    rows.append("|---" * (len(MODELS) + 1) + "|")
    for name, entry in ENTRIES.items():
        cells = []
        for model in MODELS:
            if model not in PLANNED:
                cells.append("no planned swing-up")
            elif entry.only is not None and model != entry.only:
                cells.append(f"for `{entry.only}` only")
            else:
                cells.append("runs")
        rows.append(f"| `{name}` | " + " | ".join(cells) + " |")
    why = [f"- `{e.name}`: {e.why}." for e in ENTRIES.values() if e.only is not None]
    return "\n".join(rows) + "\n\n" + "\n".join(why) + "\n"
