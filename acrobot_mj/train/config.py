"""Training configuration: a frozen dataclass holding the algorithm's and the features' typed
configs. Every setting has one flat name (``alpha``, ``lam``, ``frame_skip``), used by the command
line, sweeps, records and :meth:`TrainConfig.replace`; a setting that does not apply reads as
None, and setting it is refused, saying why."""

from __future__ import annotations

import dataclasses
import inspect
import math
from dataclasses import dataclass, fields
from typing import Any, ClassVar

import gymnasium as gym

from acrobot_mj.agents import AGENTS, FEATURES, agent_spec
from acrobot_mj.envs.acrobot import MAX_FRAME_SKIP
from acrobot_mj.envs.tasks import TASKS, get_task
from acrobot_mj.physics.models import (
    MODELS,
    AcrobotModel,
    carried_acrobot,
    carry_model,
    table_setting,
)
from acrobot_mj.settings import SettingError, Settings, declared, followers, parse, setting

#: The longest episode [decisions] and the most episodes a run takes: about a minute of steps
#: each, and days of training (larger sizes could not finish).
MAX_EPISODE_STEPS, MAX_EPISODES = 1_000_000, 10_000_000
#: Settings of the task that are config fields (where the task takes them).
TASK_OPTIONS = ("step_reward", "goal_reward")
#: Fields that records of 0.1 to 0.3 hold and that are no longer settings (evaluation's, now
#: ``acrobot-mj evaluate``'s options; the kernel, now always numba's): reading such a record
#: drops them, so that old run directories load.
RETIRED = ("eval_episodes", "eval_noise", "kernel")


@dataclass(frozen=True)
class TrainConfig(Settings):
    """Everything that defines a training run except the seed; the defaults are the report's.
    ``agent`` and ``encoding``: the algorithm's and the features' configs (None: defaults).
    A :class:`~acrobot_mj.settings.Settings` whose :meth:`replace`, :meth:`to_dict` and
    :meth:`from_dict` also take the agent's and the features' settings by their flat names."""

    what: ClassVar[str] = "config"

    task: str = setting(
        "height_goal", "what counts as success: height_goal (the report's) or balance"
    )
    algorithm: str = setting("sarsa", "sarsa (tabular) or sarsa_lambda (linear, tile coding)")
    features: str = setting("grid", "grid (the report's table) or tiles (tile coding)")
    agent: Any = None
    encoding: Any = None
    frame_skip: int = setting(
        1, "length of a decision", "0.05 s physics steps per decision", low=1, high=MAX_FRAME_SKIP
    )
    integrator: str | None = setting(
        None,
        "euler or rk4 (default: the model's)",
        choices=("euler", "rk4"),
        follows="model",
    )
    model: str | None = setting(
        None,
        "a parameter set's name or a .json/.toml file (default: the report's)",
        metavar="NAME|FILE",
    )
    model_table: dict | None = table_setting()
    max_episode_steps: int = setting(
        1000, "decisions before an episode is truncated", low=1, high=MAX_EPISODE_STEPS
    )
    start_noise: float = setting(
        0.0, "half-width of the uniform noise on the start state", "rad, rad/s", low=0.0, high=1.0
    )
    noise_until: float | None = setting(
        None, "fraction of the episodes that start with noise", low=0.0, high=1.0
    )
    step_reward: float | None = setting(None, "reward of each step (the report's: -1)")
    goal_reward: float | None = setting(None, "reward on reaching the goal (the report's: +100)")
    energy_shaping: float = setting(
        0.0, "weight of a potential-based energy shaping term (0: none)", low=0.0
    )
    episodes: int = setting(200, "training episodes", low=1, high=MAX_EPISODES)
    population: int = setting(
        1, "learners trained; the best by its last 20 episodes is kept", low=1, high=10_000
    )
    max_decisions: int = setting(
        0,
        "a cap on the decisions of training (0: none; else at least population)",
        high=MAX_EPISODE_STEPS * MAX_EPISODES,
    )
    identify_decisions: int = setting(
        0, "decisions of data to identify a model first, then learn in it", low=0, high=10**9
    )
    checkpoint_every: int = setting(50, "episodes between checkpoints", low=1, high=MAX_EPISODES)

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_names(self.task, self.algorithm, self.features)
        carry_model(self)
        acrobot = self.acrobot
        if self.integrator is None:
            object.__setattr__(self, "integrator", acrobot.integrator)
        _check_model(self, acrobot)
        for name, kind in _part_kinds(self.algorithm, self.features).items():
            value = getattr(self, name)
            if value is None:
                object.__setattr__(self, name, kind())
            elif not isinstance(value, kind):
                raise SettingError(f"config {name} must be a {kind.__name__}, got {value!r}")
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
        if self.max_decisions < 0 or 0 < self.max_decisions < self.population:
            raise ValueError(
                f"config max_decisions must be 0 (no cap) or >= population "
                f"({self.population}), got {self.max_decisions}"
            )

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
        unknown = sorted(set(changes) - set(field_names()))
        if unknown:
            raise ValueError(f"unknown config keys {unknown}; known: {sorted(field_names())}")
        top = {k: v for k, v in changes.items() if k in _OWN}
        named = ("task", "algorithm", "features")
        task, algorithm, features = (top.get(k, getattr(self, k)) for k in named)
        _check_names(task, algorithm, features)
        kinds = _part_kinds(algorithm, features)
        parts = {}
        for name, kind in kinds.items():
            values = {**dataclasses.asdict(getattr(self, name)), **changes}
            parts[name] = kind(**{k: v for k, v in values.items() if k in _names(kind)})
        bad = set(changes) - set(_OWN) - _names(kinds["agent"]) - _names(kinds["encoding"])
        for name in bad:
            owner = "algorithm" if name in _all_names(AGENTS) else "features"
            value = top.get(owner, getattr(self, owner))
            raise ValueError(f"config {name} has no effect with {owner}={value!r}")
        options = get_task(task).options
        carried = {k: None for k in TASK_OPTIONS if k not in options and k not in top}
        carried |= followers(TrainConfig, top)  # the new model's integrator and parameters
        if "start_noise" in top and top["start_noise"] == 0 and "noise_until" not in top:
            carried["noise_until"] = None
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return TrainConfig(**{**values, **carried, **top, **parts})

    def to_dict(self) -> dict[str, Any]:
        """Every setting by its flat name (None where it does not apply): ``run.json``'s."""
        return {name: getattr(self, name) for name in field_names()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainConfig:
        """The config of a record (an older one's settings that do not apply, or that 0.1 to 0.3
        held, are ignored; an unknown one is refused)."""
        if not isinstance(data, dict):
            raise ValueError(f"a run's config must be a JSON object of settings, got {data!r:.40}")
        data = {k: v for k, v in data.items() if k not in RETIRED and v is not None}
        if unknown := sorted(set(data) - set(field_names())):
            raise ValueError(f"unknown config keys {unknown}; known: {sorted(field_names())}")
        algorithm, features = data.get("algorithm", "sarsa"), data.get("features", "grid")
        task = data.get("task", "height_goal")
        _check_names(task, algorithm, features)
        kinds = _part_kinds(algorithm, features)
        applies = set(_OWN) | _names(kinds["agent"]) | _names(kinds["encoding"])
        applies -= {k for k in TASK_OPTIONS if k not in get_task(task).options}
        if not data.get("start_noise"):
            applies.discard("noise_until")
        return cls().replace(**{k: v for k, v in data.items() if k in applies})

    @property
    def env_id(self) -> str:
        return get_task(self.task).env_id

    @property
    def acrobot(self) -> AcrobotModel:
        """The acrobot ``model`` names (:func:`~acrobot_mj.physics.models.resolve`; None: the
        report's), a file's as the run read it (``model_table``)."""
        try:
            return carried_acrobot(self.model, self.model_table)
        except (TypeError, ValueError) as error:
            raise SettingError(f"config model: {error}") from None

    def env_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for ``gymnasium.make(config.env_id, ...)`` (no ``model`` for the
        report's acrobot: the packaged MJCF)."""
        options = {k: getattr(self, k) for k in TASK_OPTIONS if getattr(self, k) is not None}
        model = self.model if self.model_table is None else self.acrobot  # a file's, as read
        return {
            "frame_skip": self.frame_skip,
            "integrator": self.integrator,
            "max_episode_steps": self.max_episode_steps,
            **({} if model is None else {"model": model}),
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


#: The run's own settings (the agent's and the features' are in their configs).
_OWN = tuple(declared(TrainConfig))


def _names(kind: type) -> set[str]:
    return {f.name for f in fields(kind)}


def _all_names(table: dict[str, Any]) -> set[str]:
    return {n for v in table.values() for n in _names(v.config if hasattr(v, "config") else v)}


def _part_kinds(algorithm: str, features: str) -> dict[str, type]:
    return {"agent": agent_spec(algorithm).config, "encoding": FEATURES[features]}


def field_names() -> tuple[str, ...]:
    """Every setting's flat name: the run's, every algorithm's and every kind of features'."""
    top = list(_OWN)
    parts = [name for table in (AGENTS, FEATURES) for name in sorted(_all_names(table))]
    return (*top[:3], *dict.fromkeys(n for n in parts if n not in top[:3]), *top[3:])


def _check_model(config: TrainConfig, acrobot: AcrobotModel) -> None:
    """Refuse, in one line, what ``config``'s learner cannot do on ``acrobot``."""
    unbounded = [n for n in ("max_vel1", "max_vel2") if getattr(acrobot.params, n) == math.inf]
    if config.features == "tiles" and unbounded:
        raise SettingError(
            f"config features tiles spans the velocity limits, and model {config.model!r} has "
            f"none ({' = '.join(unbounded)} = inf): use features grid, or a model with limits"
        )
    if config.identify_decisions > 0 and acrobot != MODELS["report"]:
        raise SettingError(
            "config identify_decisions identifies the report's acrobot (its velocity limits, "
            f"Euler steps, the elbow driven), not model {config.model!r}"
        )


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


def owner(name: str) -> type:
    """The config class that declares setting ``name``: the run's, an algorithm's or features'."""
    if name in _OWN:
        return TrainConfig
    for kind in (*(s.config for s in AGENTS.values()), *FEATURES.values()):
        if name in _names(kind):
            return kind
    raise ValueError(f"unknown config key {name!r}; known: {sorted(field_names())}")


def parse_value(name: str, text: str) -> Any:
    """``text`` as setting ``name``'s type (floats may be written ``0.2/48``)."""
    return parse(owner(name), name, text)
