"""What an entry is built on (:class:`Plant`): a shipped acrobot's equations
(:func:`equations`), or the learnt model of a black-box run, told nothing of the equations
(:func:`learnt`). Either gives the swing-up the tracker follows, the funnel's levels, the
step the tracker and the state estimator predict with, and the decision it acts at."""

from __future__ import annotations

import contextlib
import hashlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acrobot_mj.control.controller import Controller, Held
from acrobot_mj.control.estimator import Estimated, Observer
from acrobot_mj.control.lqr import Jacobians
from acrobot_mj.control.planned import LEVELS, shipped_name
from acrobot_mj.control.tracker import FunnelSettings
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.files import read_json, write_json
from acrobot_mj.identify.library import LibraryModel
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.models import resolve
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.train.records import MODEL_FILE


@dataclass(frozen=True)
class Plant:
    """The shipped acrobot ``name`` whose entries' settings an entry takes (the acrobot itself
    or its kin, :func:`~acrobot_mj.control.planned.kindred`), the ``swing_up`` its tracker
    follows, the funnel's ``levels``, for a learnt model its ``linear`` Jacobians and ``step``
    (each of one decision) and the physics steps a decision spans (``every``), and the
    ``model`` it is built for where that is not ``name`` (an acrobot read from a file)."""

    name: str
    swing_up: Trajectory
    levels: FunnelSettings
    linear: Jacobians | None = None
    step: Callable[[np.ndarray, float], np.ndarray] | None = None
    every: int = 1
    model: str = ""

    @property
    def learnt(self) -> bool:
        """Whether the plant is a learnt model (no equations: no energy to pump)."""
        return self.linear is not None

    def estimated(self, tracker: Controller) -> Controller:
        """``tracker`` on the estimate of an observer of the plant's step, deciding every
        ``every`` physics steps."""
        p = self.swing_up.params
        observer = Observer(p, self.swing_up.method, step=self.step)
        if self.every == 1:
            return Estimated(tracker, observer)
        return Held(Estimated(tracker, observer), p.max_torque, self.every)


def levels(name: str) -> FunnelSettings:
    """The funnel's levels on the shipped acrobot ``name``: those chosen for it
    (:data:`~acrobot_mj.control.planned.LEVELS`), else FunnelSettings', chosen on the report's
    acrobot, with the saturated LQR (the option ``mpc`` takes the constrained one)."""
    return LEVELS.get(name, FunnelSettings(horizon=0))


def equations(model: str) -> Plant:
    """The plant of ``model``'s equations (a name or a file): its swing-up, shipped or planned
    on first use (:func:`~acrobot_mj.olympics.swing_ups.swing_up_for`), with the settings of
    its kin; refused in one line where it has none."""
    from acrobot_mj.olympics.swing_ups import check_plannable, swing_up_for

    name = check_plannable(model)
    own = "" if shipped_name(model) is not None else str(model)
    return Plant(name, swing_up_for(model), levels(name), model=own)


def learnt(run_dir: str | Path) -> Plant:
    """The learnt model of the black-box run ``run_dir``, on the acrobot it was trained on: the
    swing-up planned on it for the protocol's performance criteria
    (:func:`~acrobot_mj.olympics.swing_ups.learnt_swing_up`; CasADi, the ``control`` extra;
    minutes, so kept in the run's folder, :data:`PLAN_FILE`), its Jacobians and step, and the
    levels chosen for that acrobot scaled to the decision's rate (the LQR's costs sum over the
    steps, so they shrink with the rate)."""
    from acrobot_mj.olympics.swing_ups import SECONDS, learnt_swing_up
    from acrobot_mj.train.black_box import BlackBoxLearner

    learner = BlackBoxLearner.load(Path(run_dir))
    assert learner.model is not None and learner.trajectory is not None  # loaded: both built
    model = learner.config.model or "report"
    name = shipped_name(model)
    if name != "ai_olympics":
        raise ValueError(
            f"{run_dir} learnt {model!r}: a learnt model's swing-up is planned in "
            f"{SECONDS:g} s, for ai_olympics (6 N m on its light arm) alone"
        )
    physics = resolve(model).params.dt
    limits = learner.trajectory.params
    every = round(limits.dt / physics)
    swing_up = kept_plan(Path(run_dir), learner.model, limits)
    if swing_up is None:
        swing_up = learnt_swing_up(learner.model, limits, physics)
        keep_plan(Path(run_dir), swing_up)
    chosen = levels(name)
    ratio = every * physics / resolve(name).params.dt  # the decision over the levels' step
    scaled = chosen.replace(
        upright=chosen.upright / ratio, track=chosen.track / ratio, entry=chosen.entry / ratio
    )
    return Plant(name, swing_up, scaled, learner.model.jacobians, learner.model.step, every)


#: Where a black-box run keeps the swing-up planned on its model for the protocol, once.
PLAN_FILE = "performance_plan.json"
PLAN_FORMAT = "acrobot_mj.learnt_plan"


def _fingerprint(run_dir: Path) -> str:
    return hashlib.sha256((run_dir / MODEL_FILE).read_bytes()).hexdigest()


def kept_plan(run_dir: Path, model: LibraryModel, limits: AcrobotParams) -> Trajectory | None:
    """The plan kept in ``run_dir`` (:data:`PLAN_FILE`) for its learnt ``model``, rolled out on
    it; None where there is none, or one of another model."""
    try:
        data = read_json(run_dir / PLAN_FILE)
        if data.get("format") != PLAN_FORMAT or data.get("model") != _fingerprint(run_dir):
            return None
        torques = np.asarray(data["torques"], dtype=float)
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    states = [HANGING.copy()]
    for torque in torques:
        states.append(np.asarray(model.step(states[-1], float(torque)), dtype=float))
    return Trajectory(np.array(states), torques, limits.dt, "learned", limits.max_torque, limits)


def keep_plan(run_dir: Path, plan: Trajectory) -> None:
    """Keep ``plan``'s torques in ``run_dir`` (atomically), with the fingerprint of the model
    it was made on; a folder that cannot be written keeps nothing."""
    record = {
        "format": PLAN_FORMAT,
        "model": _fingerprint(run_dir),
        "torques": plan.torques.tolist(),
    }
    with contextlib.suppress(OSError):
        write_json(run_dir / PLAN_FILE, record)
