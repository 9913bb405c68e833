"""What a task is: its start, its step rule (reward, termination, success, what ``info``
reports) and how its results are scored.

A task is a :class:`Task` subclass plus one registration (:func:`acrobot_mj.envs.tasks.
register_task`). The step rule is written once, in :meth:`Task.rule`, on Python floats and
``math``: the single env calls it as it is, and the vector env runs it over its rows compiled by
numba (:meth:`Task.outcomes`); the two cannot drift apart.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from acrobot_mj.checks import check_float
from acrobot_mj.compiled import compiled

#: ``rule(q1, q2, dq1, dq2) -> (reward, terminated, success, values)`` on the angles [rad] and
#: velocities [rad/s] after a step; ``values``: a tuple of floats named by ``Task.info_keys``.
Rule = Callable[[float, float, float, float], tuple[float, bool, bool, tuple[float, ...]]]
#: The compiled form of each task's rule over rows, by the task's type and settings.
_ROWS: dict[tuple, Callable[..., None]] = {}


@dataclass(frozen=True)
class Score:
    """How a task's episodes are scored: ``quantity`` ``"length"`` (decisions) or ``"return"``
    (the field of a greedy result and, as ``episode_{quantity}s``, of a run record) and which
    way is better."""

    quantity: str
    lower_is_better: bool
    label: str  # what the number is, e.g. "decisions per episode"
    unit: str  # e.g. "decisions"
    best_word: str  # "shortest", "highest": the best of several, in words
    log_scale: bool = False  # plots of it read better on a log axis

    def __post_init__(self) -> None:
        if self.quantity not in ("length", "return"):
            raise ValueError(f"score quantity must be 'length' or 'return', got {self.quantity!r}")

    def values(self, record: dict[str, Any]) -> list[float]:
        """The per-episode scores of a run record."""
        return record[f"episode_{self.quantity}s"]

    def is_better(self, a: float, b: float) -> bool:
        """Whether score ``a`` is strictly better than ``b``."""
        return a < b if self.lower_is_better else a > b


class Task(ABC):
    """One acrobot task on the shared physics, actions and observations.

    Subclasses set the class attributes and implement :meth:`rule` and :meth:`caption`; their
    constructor takes ``links`` (l1, l2 [m], measured on the model by the env), ``start_noise``
    and the keyword :attr:`options`, each validated.
    """

    #: Short name: ``TrainConfig.task`` and the ``task`` argument of the envs.
    name: ClassVar[str]
    #: The Gymnasium id it is registered under.
    env_id: ClassVar[str]
    #: Truncation (Gymnasium's TimeLimit, and the vector env's default).
    max_episode_steps: ClassVar[int]
    score: ClassVar[Score]
    #: The mean return that counts as solved with the registered defaults (or None).
    reward_threshold: ClassVar[float | None] = None
    #: Keyword options of the constructor besides ``start_noise``.
    options: ClassVar[tuple[str, ...]] = ()
    #: The model keyframe episodes start from.
    start_keyframe: ClassVar[str] = "hanging"
    #: Names of the rule's ``values`` in ``info``, and the names success is reported under.
    info_keys: ClassVar[tuple[str, ...]] = ()
    success_keys: ClassVar[tuple[str, ...]] = ("is_success",)
    #: Caption of a successful frame in videos, and what success means in words.
    success_label: ClassVar[str] = "SUCCESS"
    success_text: ClassVar[str] = "succeeded"

    def __init__(self, links: tuple[float, float], start_noise: float = 0.0) -> None:
        self.l1, self.l2 = (check_float("link length", v, 0.0) for v in links)
        self.start_noise = check_float("start_noise", start_noise, 0.0, 1.0)

    def start_offsets(
        self, rng: np.random.Generator, noise: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """What a reset adds to the keyframe's ``qpos`` and ``qvel`` [rad, rad/s]: ``U(-noise,
        noise)`` for each angle, then each velocity (None without noise)."""
        if noise <= 0.0:
            return None
        return rng.uniform(-noise, noise, 2), rng.uniform(-noise, noise, 2)

    @abstractmethod
    def rule(self) -> Rule:
        """The step rule (see :data:`Rule`): plain arithmetic on floats and ``math``, so that
        numba compiles it; the task's numbers are read once, outside the returned function."""

    @abstractmethod
    def caption(self, info: dict[str, Any]) -> str:
        """A few words on a frame's state for video captions, e.g. ``tip +0.53 m``."""

    def assess(self, states: np.ndarray, dt: float, swing_up: int | None = None) -> dict:
        """Task-specific measures of an episode's states ``(T + 1, 4)``, ``dt`` [s] apart
        (``swing_up``: the steps a planned swing-up takes), for evaluations: none here."""
        return {}

    @staticmethod
    def summarise(assessments: list[dict[str, Any]], spread: Callable) -> dict[str, Any]:
        """What :meth:`assess` says over many episodes (``spread``: the statistics of a list)."""
        return {}

    @classmethod
    def reference(cls, frame_skip: int) -> tuple[float, str] | None:
        """A reference score and its label for plots (e.g. the best known), or None."""
        return None

    def info(self) -> Callable[[tuple, Any], dict[str, Any]]:
        """``info(values, success)``: a step's ``info``, the rule's values by
        :attr:`info_keys`, then success by :attr:`success_keys` (a dict literal where there is
        one value: the single env's hot path)."""
        keys, names = self.info_keys, self.success_keys
        if len(keys) == 1 and len(names) in (1, 2):
            key, first, last = keys[0], names[0], names[-1]
            return lambda values, success: {key: values[0], first: success, last: success}
        return lambda values, success: {**dict(zip(keys, values)), **dict.fromkeys(names, success)}

    def outcomes(self, q1: np.ndarray, q2: np.ndarray, dq1: np.ndarray, dq2: np.ndarray) -> tuple:
        """The rule over rows (arrays ``(N,)``), compiled: rewards, terminations and ``info``
        (one new array per entry, none sharing memory with another)."""
        n = len(q1)
        reward, flags = np.empty(n), np.empty((2, n), bool)
        values = np.empty((len(self.info_keys), n))
        rows = self.__dict__.get("_compiled_rows") or self._rows()
        rows(q1, q2, dq1, dq2, reward, flags, values)
        info = {key: values[j] for j, key in enumerate(self.info_keys)}
        success = flags[1]
        for key in self.success_keys[:-1]:
            info[key] = success.copy()
        info[self.success_keys[-1]] = success
        return reward, flags[0], info

    def _rows(self) -> Callable[..., None]:
        """:meth:`rule` over rows, compiled once per process for each task's settings."""
        settings = {k: v for k, v in vars(self).items() if not k.startswith("_")}
        key = (type(self), tuple(sorted(settings.items())))
        if key not in _ROWS:
            rule = self.rule()

            def rows(q1, q2, dq1, dq2, reward, flags, values):  # pragma: no cover  (compiled)
                for i in range(q1.shape[0]):
                    r, t, s, v = rule(q1[i], q2[i], dq1[i], dq2[i])
                    reward[i], flags[0, i], flags[1, i] = r, t, s
                    for j in range(values.shape[0]):
                        values[j, i] = v[j]

            _ROWS[key] = compiled(rows, cache=False, calls=(rule,))
        self._compiled_rows = _ROWS[key]
        return _ROWS[key]
