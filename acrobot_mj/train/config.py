"""Training configuration: a frozen dataclass holding the algorithm's and the features' typed
configs. Every setting has one flat name (``alpha``, ``lam``, ``frame_skip``), used by the command
line, sweeps, records and :meth:`TrainConfig.replace`; a setting that does not apply reads as
None, and setting it is refused, saying why."""

from __future__ import annotations

import dataclasses
import inspect
import math
import typing
from dataclasses import dataclass, fields
from typing import Any

import gymnasium as gym

from acrobot_mj.agents import AGENTS, FEATURES, agent_spec
from acrobot_mj.envs.acrobot import MAX_FRAME_SKIP
from acrobot_mj.envs.tasks import TASKS, get_task

#: Settings of the task that are config fields (where the task takes them).
TASK_OPTIONS = ("step_reward", "goal_reward")
#: Fields of older records that no longer exist, and what replaced them.
RETIRED = {
    "eval_episodes": "evaluation is not configuration: acrobot-mj evaluate --episodes",
    "eval_noise": "evaluation is not configuration: acrobot-mj evaluate --start-noise",
    "kernel": "Sarsa(lambda) always runs compiled (numba, the same numbers as numpy's)",
}


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run except the seed; the defaults are the report's.
    ``agent`` and ``encoding``: the algorithm's and the features' configs (None: defaults)."""

    task: str = "height_goal"
    algorithm: str = "sarsa"
    features: str = "grid"
    agent: Any = None
    encoding: Any = None
    frame_skip: int = 1
    integrator: str = "euler"
    max_episode_steps: int = 1000
    start_noise: float = 0.0
    noise_until: float | None = None
    step_reward: float | None = None
    goal_reward: float | None = None
    energy_shaping: float = 0.0
    episodes: int = 200
    population: int = 1
    max_decisions: int = 0
    identify_decisions: int = 0
    checkpoint_every: int = 50

    def __post_init__(self) -> None:
        for name, kind in _TOP_TYPES.items():
            _check_type(name, kind, getattr(self, name))
        _check_names(self.task, self.algorithm, self.features)
        for name, kind in _part_kinds(self.algorithm, self.features).items():
            value = getattr(self, name)
            if value is None:
                object.__setattr__(self, name, kind())
            elif not isinstance(value, kind):
                raise TypeError(f"config {name} must be a {kind.__name__}, got {value!r}")
        options = get_task(self.task).options
        for name in TASK_OPTIONS:
            value = getattr(self, name)
            if name in options and value is None:
                default = inspect.signature(get_task(self.task).__init__).parameters[name].default
                object.__setattr__(self, name, default)
            elif name not in options and value is not None:
                raise ValueError(f"config {name} has no effect with task={self.task!r}")
        if self.start_noise > 0 and self.noise_until is None:
            object.__setattr__(self, "noise_until", 0.0)
        elif self.start_noise == 0 and self.noise_until is not None:
            raise ValueError(
                f"config noise_until has no effect with start_noise="
                f"{self.start_noise!r} (it applies when start_noise > 0)"
            )
        _check_ranges(self)

    def __getattr__(self, name: str) -> Any:
        """A setting of the agent's or the features' config; None for one that does not apply."""
        if name.startswith("_") or name not in field_names():
            raise AttributeError(f"TrainConfig has no setting {name!r}")
        for part in (self.__dict__.get("agent"), self.__dict__.get("encoding")):
            if part is not None and name in _names(type(part)):
                return getattr(part, name)
        return None

    def replace(self, **changes: Any) -> TrainConfig:
        """A copy with ``changes``; a new algorithm or features keeps the settings both have."""
        for name in set(changes) & set(RETIRED):
            raise ValueError(f"config {name} was removed: {RETIRED[name]}")
        unknown = sorted(set(changes) - set(field_names()))
        if unknown:
            raise ValueError(f"unknown config keys {unknown}; known: {sorted(field_names())}")
        top = {k: v for k, v in changes.items() if k in _TOP_TYPES}
        named = ("task", "algorithm", "features")
        task, algorithm, features = (top.get(k, getattr(self, k)) for k in named)
        _check_names(task, algorithm, features)
        kinds = _part_kinds(algorithm, features)
        parts = {}
        for name, kind in kinds.items():
            values = {**dataclasses.asdict(getattr(self, name)), **changes}
            parts[name] = kind(**{k: v for k, v in values.items() if k in _names(kind)})
        bad = set(changes) - set(_TOP_TYPES) - _names(kinds["agent"]) - _names(kinds["encoding"])
        for name in bad:
            owner = "algorithm" if name in _all_names(AGENTS) else "features"
            value = top.get(owner, getattr(self, owner))
            raise ValueError(f"config {name} has no effect with {owner}={value!r}")
        options = get_task(task).options
        carried = {k: None for k in TASK_OPTIONS if k not in options and k not in top}
        if "start_noise" in top and top["start_noise"] == 0 and "noise_until" not in top:
            carried["noise_until"] = None
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return TrainConfig(**{**values, **carried, **top, **parts})

    def to_dict(self) -> dict[str, Any]:
        """Every setting by its flat name (None where it does not apply): ``run.json``'s."""
        return {name: getattr(self, name) for name in field_names()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainConfig:
        """The config of a record (an older one's settings that do not apply are ignored)."""
        if not isinstance(data, dict):
            raise ValueError(f"a run's config must be a JSON object of settings, got {data!r:.40}")
        data = {k: v for k, v in data.items() if k not in RETIRED and v is not None}
        algorithm, features = data.get("algorithm", "sarsa"), data.get("features", "grid")
        task = data.get("task", "height_goal")
        _check_names(task, algorithm, features)
        kinds = _part_kinds(algorithm, features)
        applies = set(_TOP_TYPES) | _names(kinds["agent"]) | _names(kinds["encoding"])
        applies -= {k for k in TASK_OPTIONS if k not in get_task(task).options}
        if not data.get("start_noise"):
            applies.discard("noise_until")
        return cls().replace(**{k: v for k, v in data.items() if k in applies})

    @property
    def env_id(self) -> str:
        return get_task(self.task).env_id

    def env_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for ``gymnasium.make(config.env_id, ...)``."""
        options = {k: getattr(self, k) for k in TASK_OPTIONS if getattr(self, k) is not None}
        return {
            "frame_skip": self.frame_skip,
            "integrator": self.integrator,
            "max_episode_steps": self.max_episode_steps,
            **options,
        }

    def start_noise_at(self, episode: int) -> float:
        """Start noise [rad, rad/s] of training episode ``episode`` (0-based)."""
        if not self.noise_until:
            return self.start_noise
        return self.start_noise * max(0.0, 1.0 - episode / (self.noise_until * self.episodes))

    @property
    def learner_decisions(self) -> int:
        """The decision cap of each learner (0: none): ``max_decisions`` split equally."""
        return self.max_decisions // self.population

    def finished(self, record: dict[str, Any]) -> bool:
        """Whether a run record of this config spent every episode, or every decision allowed."""
        if record.get("episodes_done") == self.episodes * self.population:
            return True
        cap = self.learner_decisions
        return cap > 0 and record.get("steps") == cap * self.population

    def make_agent(self, seed: Any, space: gym.Space, n_actions: int = 3) -> Any:
        """The learner of this config over observations in ``space``, its stream from ``seed``."""
        spec = agent_spec(self.algorithm)
        return spec.build(self.encoding.build(space), self.agent, seed, n_actions)


#: The run's own settings and their types (the agent's and the features' are in their configs).
_TOP_TYPES = {
    k: v for k, v in typing.get_type_hints(TrainConfig).items() if k not in ("agent", "encoding")
}


def _names(kind: type) -> set[str]:
    return {f.name for f in fields(kind)}


def _all_names(table: dict[str, Any]) -> set[str]:
    return {n for v in table.values() for n in _names(v.config if hasattr(v, "config") else v)}


def _part_kinds(algorithm: str, features: str) -> dict[str, type]:
    return {"agent": agent_spec(algorithm).config, "encoding": FEATURES[features]}


def field_names() -> tuple[str, ...]:
    """Every setting's flat name: the run's, every algorithm's and every kind of features'."""
    top = list(_TOP_TYPES)
    parts = [name for table in (AGENTS, FEATURES) for name in sorted(_all_names(table))]
    return (*top[:3], *dict.fromkeys(n for n in parts if n not in top[:3]), *top[3:])


def _check_names(task: str, algorithm: str, features: str) -> None:
    for name, value, known in (
        ("task", task, TASKS),
        ("algorithm", algorithm, AGENTS),
        ("features", features, FEATURES),
    ):
        if value not in known:
            raise ValueError(f"config {name} must be one of {sorted(known)}, got {value!r}")
    spec = agent_spec(algorithm)
    if features not in spec.features:
        raise ValueError(
            f"algorithm {spec.name} ({spec.doc}) needs features in "
            f"{list(spec.features)}, got {features!r}"
        )


def field_type(name: str) -> type:
    """The type of setting ``name`` (without the None of settings that may not apply)."""
    for kind in (TrainConfig, *(s.config for s in AGENTS.values()), *FEATURES.values()):
        hints = typing.get_type_hints(kind)
        if name in hints and name not in ("agent", "encoding"):
            args = [a for a in typing.get_args(hints[name]) if a is not type(None)]
            return args[0] if args else hints[name]
    raise ValueError(f"unknown config key {name!r}; known: {sorted(field_names())}")


def _check_type(name: str, kind: Any, value: Any) -> None:
    if value is None and type(None) in typing.get_args(kind):
        return
    kind = field_type(name)
    ok = isinstance(value, kind) and not (kind is not bool and isinstance(value, bool))
    if kind is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        ok = ok and math.isfinite(value)
    if not ok:
        raise TypeError(f"config {name} must be a {kind.__name__}, got {value!r}")


def _check_ranges(c: TrainConfig) -> None:
    for name in ("max_episode_steps", "episodes", "population", "checkpoint_every"):
        if getattr(c, name) < 1:
            raise ValueError(f"config {name} must be >= 1, got {getattr(c, name)}")
    if not 1 <= c.frame_skip <= MAX_FRAME_SKIP:
        raise ValueError(
            f"config frame_skip must be in [1, {MAX_FRAME_SKIP}] (0.05 s physics "
            f"steps per decision), got {c.frame_skip}"
        )
    for name in ("noise_until", "start_noise"):
        value = getattr(c, name)
        if value is not None and not 0.0 <= value <= 1.0:
            raise ValueError(f"config {name} must be in [0, 1], got {value}")
    if c.integrator not in ("euler", "rk4"):
        raise ValueError(f"config integrator must be one of ('euler', 'rk4'), got {c.integrator!r}")
    if c.max_decisions < 0 or 0 < c.max_decisions < c.population:
        raise ValueError(
            f"config max_decisions must be 0 (no cap) or >= population "
            f"({c.population}), got {c.max_decisions}"
        )
    for name in ("identify_decisions", "energy_shaping"):
        if getattr(c, name) < 0:
            raise ValueError(f"config {name} must be >= 0, got {getattr(c, name)}")


def parse_value(name: str, text: str) -> Any:
    """``text`` as setting ``name``'s type (floats may be written ``0.2/48``)."""
    kind = field_type(name)
    try:
        if kind is bool:
            if text.lower() not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return text.lower() in ("true", "1")
        if kind is int:
            return int(text)
        if kind is float:
            numerator, _, denominator = text.partition("/")
            return float(numerator) / float(denominator or 1.0)
    except (ValueError, ZeroDivisionError) as error:
        article = "an" if kind is int else "a"
        raise ValueError(f"config {name} needs {article} {kind.__name__}, got {text!r}") from error
    return text
