"""Where a scored controller comes from (:class:`Source`): an entry's name
(:data:`~acrobot_mj.olympics.entries.ENTRIES`), a trained controller run's folder (the state
feedback of ``acrobot-mj balance --feedback``, the black box of ``acrobot-mj train --preset
black_box``), ``module:attribute`` (a controller, a factory of one, or an object in
``double_pendulum``'s convention), or a Stable-Baselines3 policy file (``.zip``). Each is
built once per process and model (:func:`build`), a fresh copy each episode."""

from __future__ import annotations

import copy
import importlib
import json
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from acrobot_mj.control.controller import Controller, Held
from acrobot_mj.olympics import entries
from acrobot_mj.olympics.foreign import DoublePendulumController, TheirConvention, sb3_policy
from acrobot_mj.olympics.plants import equations, learnt
from acrobot_mj.physics.models import AcrobotModel, carried_acrobot, resolve
from acrobot_mj.train.records import RUN_FILE, read_record

#: The run kinds that are controllers (each acts on the observation, angles wrapped).
CONTROLLER_KINDS = ("state_feedback", "black_box")
#: What a Stable-Baselines3 policy was trained on by default: the continuous RL id of the
#: balance task, on the model scored.
POLICY_ENV = "acrobot_mj/AcrobotBalanceRLContinuous-v0"
_BUILT: dict[str, Controller] = {}


@dataclass(frozen=True)
class Source:
    """A controller's ``name`` as given (an entry, a run folder, ``module:attribute`` or a
    ``.zip`` policy file), an entry's ``options`` and the black-box run whose learnt model it
    is built on (``plant``; None: the acrobot's equations), and for a policy file the ``env``
    id and ``env_kwargs`` it was trained with (None: :data:`POLICY_ENV` on the model
    scored)."""

    name: str
    options: dict[str, Any] = field(default_factory=dict)
    env: str | None = None
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    plant: str | None = None

    @property
    def kind(self) -> str:
        """:func:`kind_of` its name."""
        return kind_of(self.name)

    def __post_init__(self) -> None:
        if not self.name.strip():
            raise ValueError("a controller must be named: an entry, a run folder, "
                             "module:attribute or a .zip policy file")  # fmt: skip
        if self.options and self.kind != "entry":
            raise ValueError(f"options are for an entry {list(entries.ENTRIES)}, not {self.name}")
        if (self.env is not None or self.env_kwargs) and self.kind != "policy":
            raise ValueError(f"--env and --env-kwargs are for a .zip policy, not {self.name}")
        if self.plant is not None and self.kind != "entry":
            raise ValueError(f"a learnt model is a plant for an entry, not for {self.name}")


def kind_of(name: str) -> str:
    """What ``name`` names: ``"entry"``, ``"policy"`` (a ``.zip`` file), ``"import"``
    (``module:attribute``) or ``"run"`` (anything else: a run folder, or nothing)."""
    if name in entries.ENTRIES:
        return "entry"
    if name.endswith(".zip"):
        return "policy"
    module, colon, attribute = name.partition(":")
    if colon and module and attribute and not Path(name).exists():
        return "import"
    return "run"


def trained_model(record: dict[str, Any]) -> str:
    """The model a controller run was trained on: its config's ``model`` (the black box's
    ``--model``), else the report's (the state feedback trains on the default acrobot only)."""
    config = record.get("config")
    name = config.get("model") if isinstance(config, dict) else None
    return "report" if name is None else str(name)


def trained_acrobot(record: dict[str, Any]) -> AcrobotModel:
    """The acrobot a controller run was trained on, a model file's as the run read it (its
    config's ``model_table``): not the file as it is now."""
    config = record.get("config")
    table = config.get("model_table") if isinstance(config, dict) else None
    return carried_acrobot(trained_model(record), table)


def same_acrobot(record: dict[str, Any], model: str, what: str) -> None:
    """Refuse, in one line, ``model`` where it is not the acrobot the run ``what`` was
    trained on (a model file edited since, or another acrobot)."""
    if trained_acrobot(record) != resolve(model):
        raise ValueError(
            f"{what} was trained on the model {trained_model(record)!r}, not {model!r} (a "
            "model file is compared as the run read it)"
        )


def controller_record(run_dir: str) -> dict[str, Any]:
    """The ``run.json`` of the controller run ``run_dir``; refused in one line where it is none."""
    path = Path(run_dir)
    if not path.is_dir():
        raise ValueError(
            f"controller {run_dir!r} is neither an entry {list(entries.ENTRIES)}, a run folder, "
            "module:attribute nor a .zip policy file"
        )
    record = read_record(path / RUN_FILE, "trained run")
    kind = record.get("kind")
    if kind not in CONTROLLER_KINDS:
        raise ValueError(
            f"{run_dir} is a run of kind {kind!r}, not a controller run "
            f"(one of {list(CONTROLLER_KINDS)})"
        )
    return record


def check_source(source: Source, model: str) -> None:
    """Refuse, in one line and before any episode, a source that cannot be built for
    ``model``: an entry not set for it, a run trained on another acrobot, a file that is not
    there."""
    resolve(model)
    if source.kind == "entry":
        entries.ENTRIES[source.name].check(model, learnt=source.plant is not None)
        entries.ENTRIES[source.name].options.from_dict(dict(source.options))
        if source.plant is not None:
            record = controller_record(source.plant)
            if record.get("kind") != "black_box":
                raise ValueError(
                    f"{source.plant} is not a black-box run (its kind {record.get('kind')!r})"
                )
            same_acrobot(record, model, source.plant)
    elif source.kind == "policy":
        if not Path(source.name).is_file():
            raise ValueError(f"no policy file at {source.name}")
    elif source.kind == "run":
        same_acrobot(controller_record(source.name), model, source.name)


def _imported(name: str, model: str) -> Controller:
    """``module:attribute``, imported from the current folder or the path: a controller, an
    object in ``double_pendulum``'s convention, or a factory of either called with the model
    (an :class:`~acrobot_mj.physics.models.AcrobotModel`)."""
    module_name, _, attribute = name.partition(":")
    if "" not in sys.path and str(Path.cwd()) not in sys.path:
        sys.path.insert(0, str(Path.cwd()))
    try:
        found: Any = importlib.import_module(module_name)
        for part in attribute.split("."):
            found = getattr(found, part)
    except (ImportError, AttributeError) as error:
        raise ValueError(f"cannot import the controller {name}: {error}") from None
    if callable(found) and not _shaped(found):
        try:
            found = found(resolve(model))
        except TypeError as error:
            raise ValueError(f"{name} called with the model: {error}") from None
    if isinstance(found, Controller):
        return found
    if _shaped(found):
        return TheirConvention(found)
    raise ValueError(
        f"{name} is {type(found).__name__}: neither an acrobot_mj Controller, an object with "
        "get_control_output(x, t), nor a factory of one"
    )


def _shaped(found: Any) -> bool:
    """Whether ``found`` is a controller object (not a class) of either shape."""
    if isinstance(found, type):
        return False
    return isinstance(found, (Controller, DoublePendulumController))


def _run(run_dir: str, model: str) -> Controller:
    from acrobot_mj.train.controller_run import ControllerLearner
    from acrobot_mj.train.trainer import load_learner

    learner = load_learner(run_dir)
    assert isinstance(learner, ControllerLearner)  # its kind was checked
    params = resolve(model).params
    every = max(1, round(learner.trajectory.dt / params.dt))
    return Held(learner.controller(), params.max_torque, every)


def _build(source: Source, model: str) -> Controller:
    if source.kind == "entry":
        plant = equations(model) if source.plant is None else learnt(source.plant)
        return entries.ENTRIES[source.name].build(plant, source.options)
    if source.kind == "import":
        return _imported(source.name, model)
    if source.kind == "policy":
        given = dict(source.env_kwargs)
        kwargs = given if source.env is not None else {"model": model, **given}
        return sb3_policy(source.name, source.env or POLICY_ENV, kwargs, resolve(model).params)
    return _run(source.name, model)


def build(source: Source | Controller | str, model: str) -> Controller:
    """A fresh controller from ``source`` for ``model`` (built once per process and model, a
    copy each call; a controller itself: a copy of it; a name: its :class:`Source`)."""
    if isinstance(source, Controller):
        return copy.deepcopy(source)
    if isinstance(source, str):
        source = Source(source)
    key = json.dumps([asdict(source), model], sort_keys=True, default=str)
    if key not in _BUILT:
        check_source(source, model)
        _BUILT[key] = _build(source, model)
    return copy.deepcopy(_BUILT[key])
