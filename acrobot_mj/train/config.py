"""Training configuration: one typed, flat dataclass and command-line parsing of its fields.

Flat on purpose: every hyperparameter has one short name (``alpha``, ``lam``, ``frame_skip``), the
name the command line (``--alpha 0.1``) and sweeps (``alpha=0.1``) use.

Which fields apply is declared, not guessed: the algorithm's and the features' specs
(:mod:`acrobot_mj.agents.registry`) list the fields they read, the task lists its options
(:mod:`acrobot_mj.envs.tasks`), and two fields depend on another's value (``noise_until`` on
``start_noise > 0``). A field that does not apply holds
``None``; setting it raises an error naming why it has no effect. :meth:`TrainConfig.replace`
drops the values that stop applying (switching a preset's algorithm keeps nothing stale) and
gives fields that start to apply their defaults.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any

from acrobot_mj.agents.registry import AGENTS, FEATURES, agent_spec, feature_spec
from acrobot_mj.agents.sarsa_lambda import KERNELS, TRACES
from acrobot_mj.envs.env import MAX_FRAME_SKIP
from acrobot_mj.envs.tasks import TASKS, get_task

#: Learners of one lockstep group from which their algorithm's lockstep is the default (tabular
#: SARSA): in smaller groups the learners that finish an episode wait for the group's slowest,
#: and one process per seed is faster (measured: docs/learning.md).
LOCKSTEP_GROUP_FROM = 25


def _always(doc: str, default: Any) -> Any:
    return field(default=default, metadata={"doc": doc})


def _used(doc: str, default: Any, by: str) -> Any:
    """A field that applies when the ``by`` (algorithm, features or task) declares it."""
    return field(default=None, metadata={"doc": doc, "default": default, "by": by})


def _when(doc: str, default: Any, on: str, test: Callable[[Any], bool], condition: str) -> Any:
    """A field that applies when ``test`` holds for field ``on``'s value (``condition`` says it
    in words)."""
    meta = {"doc": doc, "default": default, "on": on, "test": test, "condition": condition}
    return field(default=None, metadata=meta)


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run except the seed. Defaults: the report's preset."""

    # The task and the learner.
    task: str = _always("the task (acrobot_mj.envs.tasks): height_goal", "height_goal")
    algorithm: str = _always("sarsa (one-step, tabular) or sarsa_lambda (linear, traces)", "sarsa")
    features: str = _always("grid (the report's nearest-centre table) or tiles", "grid")
    alpha: float | None = _used("step size per weight", 0.5, "algorithm")
    gamma: float | None = _used("discount factor", 1.0, "algorithm")
    epsilon: float | None = _used("exploration probability of epsilon-greedy", 0.001, "algorithm")
    lam: float | None = _used("trace decay lambda", 0.0, "algorithm")
    traces: str | None = _used("replacing or accumulating", "replacing", "algorithm")
    trace_cutoff: float | None = _used(
        "traces below this are dropped; 0 keeps all (exact)", 1e-3, "algorithm"
    )
    kernel: str | None = _used(
        "numpy (the reference) or numba (compiled, tiles only, the same numbers; the fast extra)",
        "numpy",
        "algorithm",
    )
    # The report's grid.
    angle_bins: int | None = _used("grid cells per angle (centres -pi/2..pi/2)", 5, "features")
    velocity_bins: int | None = _used("grid cells per velocity", 3, "features")
    velocity_centre_max: float | None = _used(
        "outermost velocity centre [rad/s]", math.pi / 4, "features"
    )
    # Tile coding (Sutton and Barto's acrobot).
    tilings: int | None = _used("tilings over all four variables", 12, "features")
    subset_tilings: bool | None = _used(
        "add the book's 36 tilings over subsets of the variables", True, "features"
    )
    angle_tiles: int | None = _used("tiles across the circle per angle", 6, "features")
    velocity_tiles: int | None = _used("tiles across each velocity's range", 7, "features")
    # The environment.
    frame_skip: int = _always("physics steps of 0.05 s per decision", 1)
    integrator: str = _always("euler (MuJoCo's semi-implicit) or rk4", "euler")
    max_episode_steps: int = _always("decisions before truncation", 1000)
    start_noise: float = _always("uniform start noise during training [rad, rad/s]", 0.0)
    noise_until: float | None = _when(
        "fraction of the episodes over which start_noise falls linearly to 0 (0: constant)",
        0.0,
        "start_noise",
        lambda noise: noise > 0,
        "start_noise > 0",
    )
    step_reward: float | None = _used("reward per step", -1.0, "task")
    goal_reward: float | None = _used("reward of the step that reaches the goal", 100.0, "task")
    energy_shaping: float = _always(
        "scale of potential-based shaping with the normalised energy (0: none)", 0.0
    )
    # The run.
    episodes: int = _always("training episodes (per learner)", 200)
    population: int = _always(
        "independent learners of `episodes` each; the one whose last 20 episodes scored best "
        "is kept",
        1,
    )
    max_decisions: int = _always(
        "learning decisions per run at most, split equally between a population's learners "
        "(the last episode is cut short); 0: no cap, the episodes decide",
        0,
    )
    identify_decisions: int = _always(
        "env decisions of random torques to identify the dynamics from; > 0: the learners "
        "train in the identified model (acrobot_mj.train.model_based); 0: in the env",
        0,
    )
    checkpoint_every: int = _always("episodes between checkpoints (and at the end)", 50)

    def __post_init__(self) -> None:
        for f in fields(self):
            _check_type(f, getattr(self, f.name))
        _check_names(self)
        for f in fields(self):
            _settle(self, f)
        _check_ranges(self)

    def replace(self, **overrides: Any) -> TrainConfig:
        """A copy with ``overrides`` applied (unknown names raise, naming the known ones).

        Values this config has for fields that stop applying are dropped; fields that start to
        apply take their defaults unless ``overrides`` set them."""
        unknown = sorted(set(overrides) - set(FIELD_NAMES))
        if unknown:
            raise ValueError(f"unknown config keys {unknown}; known: {sorted(FIELD_NAMES)}")
        merged = {**self.to_dict(), **overrides}
        probe = _Values(merged)
        _check_names(probe)
        for f in fields(self):
            if f.name not in overrides and _reason_unused(probe, f) is not None:
                merged[f.name] = None
        return TrainConfig(**merged)

    @property
    def lockstep(self) -> bool:
        """Whether seeds can train together on one vector env (an algorithm with a lockstep
        form for this config, one learner per run, no shaping, no decision cap)."""
        spec = agent_spec(self.algorithm)
        return (
            spec.lockstep is not None
            and (spec.lockstep_if is None or spec.lockstep_if(self))
            and self.energy_shaping == 0.0
            and self.population == 1
            and self.max_decisions == 0
            and self.identify_decisions == 0
        )

    @property
    def lockstep_by_default(self) -> bool:
        """Whether seeds train in lockstep unless told otherwise, in groups large enough
        (:meth:`lockstep_pays`): they can, and for this algorithm that is the faster way
        (tabular SARSA)."""
        return self.lockstep and agent_spec(self.algorithm).lockstep_default

    def lockstep_pays(self, group: int) -> bool:
        """Whether ``group`` learners of this config train in lockstep unless told otherwise:
        :attr:`lockstep_by_default`, and at least :data:`LOCKSTEP_GROUP_FROM` of them."""
        return self.lockstep_by_default and group >= LOCKSTEP_GROUP_FROM

    @property
    def learner_decisions(self) -> int:
        """The decision cap of each learner (0: none): ``max_decisions`` split equally."""
        return self.max_decisions // self.population

    def finished(self, record: dict[str, Any]) -> bool:
        """Whether a run record of this config spent its whole budget: every episode, or every
        learner's decision cap."""
        if record.get("episodes_done") == self.episodes * self.population:
            return True
        cap = self.learner_decisions
        return cap > 0 and record.get("steps") == cap * self.population

    @property
    def env_id(self) -> str:
        """The Gymnasium id of the config's task."""
        return get_task(self.task).env_id

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainConfig:
        """The config of a record (``to_dict``'s output, or an older record's).

        Records written before the fields were declared per algorithm hold values for fields
        that do not apply (defaults, or a ``noise_until`` without start noise); they had no
        effect then and are read as not set. Records before 0.3.0 hold ``eval_episodes`` and
        ``eval_noise``: evaluation is no longer part of a run's config (it must not be, so that
        what training sees cannot depend on it; :mod:`acrobot_mj.train.heldout`), and they
        are dropped."""
        data = {k: v for k, v in data.items() if k not in RETIRED}
        probe = _Values({**cls().to_dict(), **data})
        _check_names(probe)
        for f in fields(cls):
            if f.name in data and _reason_unused(probe, f) is not None:
                data[f.name] = None
        return cls().replace(**data)

    def start_noise_at(self, episode: int) -> float:
        """Start noise [rad, rad/s] of training episode ``episode`` (0-based)."""
        if not self.noise_until:
            return self.start_noise
        return self.start_noise * max(0.0, 1.0 - episode / (self.noise_until * self.episodes))

    def env_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for ``gymnasium.make(config.env_id, ...)``: the physics, the
        truncation and the task options that are config fields."""
        options = [name for name in get_task(self.task).options if name in FIELD_NAMES]
        return {
            "frame_skip": self.frame_skip,
            "integrator": self.integrator,
            "max_episode_steps": self.max_episode_steps,
            **{name: getattr(self, name) for name in options},
        }


FIELD_NAMES = tuple(f.name for f in fields(TrainConfig))
#: Fields of older records that no longer exist (see :meth:`TrainConfig.from_dict`).
RETIRED = ("eval_episodes", "eval_noise")


class _Values:
    """Attribute access to a dict of field values (applicability tests on unbuilt configs)."""

    def __init__(self, values: dict[str, Any]) -> None:
        self.__dict__.update(values)


def field_type(f: dataclasses.Field) -> type:
    """The type of a config field, without the ``None`` of fields that may not apply."""
    hint = typing.get_type_hints(TrainConfig)[f.name]
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return next(arg for arg in typing.get_args(hint) if arg is not type(None))
    return hint


def _check_type(f: dataclasses.Field, value: Any) -> None:
    if value is None and "default" in f.metadata:
        return
    kind = field_type(f)
    if kind is bool:
        ok = isinstance(value, bool)
    elif kind is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif kind is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        ok = ok and math.isfinite(value)
    else:
        ok = isinstance(value, str)
    if not ok:
        raise TypeError(f"config {f.name} must be a {kind.__name__}, got {value!r}")


def _check_names(config: TrainConfig) -> None:
    """The task, algorithm and features exist and fit together."""
    for name, known in (("task", TASKS), ("algorithm", AGENTS), ("features", FEATURES)):
        if getattr(config, name) not in known:
            raise ValueError(
                f"config {name} must be one of {sorted(known)}, got {getattr(config, name)!r}"
            )
    spec = agent_spec(config.algorithm)
    if config.features not in spec.features:
        raise ValueError(
            f"algorithm {spec.name} ({spec.doc}) needs features in {list(spec.features)}, "
            f"got {config.features!r}"
        )


def _users(config: Any, by: str) -> tuple[str, ...]:
    """The config fields that the config's algorithm, features or task use."""
    if by == "algorithm":
        return agent_spec(config.algorithm).uses
    if by == "features":
        return feature_spec(config.features).uses
    return get_task(config.task).options


def _reason_unused(config: Any, f: dataclasses.Field) -> str | None:
    """Why field ``f`` has no effect in ``config`` (None if it applies)."""
    meta = f.metadata
    if "by" in meta:
        if f.name in _users(config, meta["by"]):
            return None
        return f"{meta['by']}={getattr(config, meta['by'])!r}"
    if "test" in meta and not meta["test"](getattr(config, meta["on"])):
        return f"{meta['on']}={getattr(config, meta['on'])!r}"
    return None


def _settle(config: TrainConfig, f: dataclasses.Field) -> None:
    """Give an unset field that applies its default; refuse a set field that does not."""
    if "default" not in f.metadata:
        return
    reason = _reason_unused(config, f)
    value = getattr(config, f.name)
    if value is None and reason is None:
        object.__setattr__(config, f.name, f.metadata["default"])
    elif value is not None and reason is not None:
        when = f.metadata.get("condition")
        raise ValueError(
            f"config {f.name} has no effect with {reason}"
            + (f" (it applies when {when})" if when else "")
        )


def _check_ranges(c: TrainConfig) -> None:
    positive = (
        "angle_bins",
        "velocity_bins",
        "tilings",
        "angle_tiles",
        "velocity_tiles",
        "frame_skip",
        "max_episode_steps",
        "episodes",
        "population",
        "checkpoint_every",
    )
    for name in positive:
        value = getattr(c, name)
        if value is not None and value < 1:
            raise ValueError(f"config {name} must be >= 1, got {value}")
    if c.frame_skip > MAX_FRAME_SKIP:
        raise ValueError(
            f"config frame_skip must be in [1, {MAX_FRAME_SKIP}] (0.05 s physics steps per "
            f"decision), got {c.frame_skip}"
        )
    unit = ("noise_until", "gamma", "epsilon", "lam", "start_noise")
    for name in unit:
        value = getattr(c, name)
        if value is not None and not 0.0 <= value <= 1.0:
            raise ValueError(f"config {name} must be in [0, 1], got {value}")
    if c.alpha is not None and not 0.0 < c.alpha <= 1.0:
        raise ValueError(f"config alpha must be in (0, 1], got {c.alpha}")
    if c.trace_cutoff is not None and not 0.0 <= c.trace_cutoff < 1.0:
        raise ValueError(f"config trace_cutoff must be in [0, 1), got {c.trace_cutoff}")
    if c.kernel is not None and c.kernel not in KERNELS:
        raise ValueError(f"config kernel must be one of {KERNELS}, got {c.kernel!r}")
    if c.kernel == "numba" and c.features != "tiles":
        raise ValueError("config kernel 'numba' needs features 'tiles'")
    if c.traces is not None and c.traces not in TRACES:
        raise ValueError(f"config traces must be one of {TRACES}, got {c.traces!r}")
    if c.integrator not in ("euler", "rk4"):
        raise ValueError(f"config integrator must be one of ('euler', 'rk4'), got {c.integrator!r}")
    if c.max_decisions < 0 or 0 < c.max_decisions < c.population:
        raise ValueError(
            f"config max_decisions must be 0 (no cap) or >= population ({c.population}), got "
            f"{c.max_decisions}"
        )
    if c.identify_decisions < 0:
        raise ValueError(f"config identify_decisions must be >= 0, got {c.identify_decisions}")
    if c.energy_shaping < 0:
        raise ValueError(f"config energy_shaping must be >= 0, got {c.energy_shaping}")
    if c.velocity_centre_max is not None and not c.velocity_centre_max > 0:
        raise ValueError("config velocity_centre_max must be > 0")


def parse_value(name: str, text: str) -> Any:
    """Parse ``text`` as the type of config field ``name`` (floats may be written ``0.2/48``)."""
    if name not in FIELD_NAMES:
        raise ValueError(f"unknown config key {name!r}; known: {sorted(FIELD_NAMES)}")
    kind = field_type(next(f for f in fields(TrainConfig) if f.name == name))
    try:
        if kind is bool:
            if text.lower() not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return text.lower() in ("true", "1")
        if kind is int:
            return int(text)
        if kind is float:
            if "/" in text:
                numerator, denominator = text.split("/")
                return float(numerator) / float(denominator)
            return float(text)
    except (ValueError, ZeroDivisionError) as error:
        article = "an" if kind is int else "a"
        raise ValueError(f"config {name} needs {article} {kind.__name__}, got {text!r}") from error
    return text
