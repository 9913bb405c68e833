"""The swing-up planned for each shipped acrobot that has one (:data:`PLANNED`, stored in
``trajectories/``), and the funnel levels chosen for a tracker along it (:data:`LEVELS`):
what a :class:`~acrobot_mj.control.tracker.PlanTracker` follows on that acrobot, whether it is
named or read from a file with the same parameters."""

from __future__ import annotations

import math
from dataclasses import astuple

from acrobot_mj.control.tracker import FunnelSettings
from acrobot_mj.control.trajopt import Trajectory, shipped
from acrobot_mj.physics.models import MODELS, AcrobotModel, ModelSpec, resolve

#: The planned swing-up of each shipped acrobot that has one: the report's ``reserve`` plan
#: (476 steps of 0.05 s within 0.8 N m), ``ai_olympics``'s plan for the AI Olympics'
#: performance criteria (:func:`~acrobot_mj.olympics.swing_ups.performance_swing_up`).
PLANNED = {"report": "reserve", "ai_olympics": "ai_olympics"}
#: The funnel's cost levels at 500 decisions a second (the LQR's costs grow with the rate):
#: chosen on the AI Olympics' global episodes of seeds 0 to 2 (uptime 0.42 against 0.28 with
#: FunnelSettings' levels times 25); its robustness and performance seeds were not used.
LEVELS = {"ai_olympics": FunnelSettings(upright=30_000.0, track=20_000.0, entry=2_000.0, horizon=0)}


def shipped_name(model: ModelSpec) -> str | None:
    """The name in :data:`~acrobot_mj.physics.models.MODELS` of the acrobot ``model`` is (a
    name, or a file of the same parameters), or None."""
    acrobot = resolve(model)
    return next((name for name, known in MODELS.items() if known == acrobot), None)


def kindred(model: ModelSpec) -> str | None:
    """The shipped acrobot whose entries' settings ``model`` takes: itself where it is one,
    else the one stepped alike (the same physics step, integrator and driven joint) nearest in
    its other parameters (the sum of ``|log(a / b)|`` over the finite ones); None where none is
    stepped alike."""
    acrobot = resolve(model)
    name = shipped_name(acrobot)
    if name is not None:
        return name

    def stepping(known: AcrobotModel) -> tuple:  # the step, integrator and driven joint
        return known.params.dt, known.integrator, known.actuated

    def distance(known: str) -> float:
        pairs = zip(astuple(MODELS[known].params), astuple(acrobot.params), strict=True)
        finite = [(a, b) for a, b in pairs if a > 0 and b > 0 and math.isfinite(a * b)]
        return sum(abs(math.log(a / b)) for a, b in finite)

    found = [known for known in MODELS if stepping(MODELS[known]) == stepping(acrobot)]
    return min(found, key=distance) if found else None


def planned_swing_up(model: ModelSpec) -> Trajectory:
    """The swing-up planned for ``model``; one line where none is."""
    name = shipped_name(model)
    if name not in PLANNED:
        raise ValueError(
            f"no planned swing-up for the model {str(model)!r}; there are: {sorted(PLANNED)}"
        )
    return shipped(PLANNED[name])
