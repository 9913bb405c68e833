"""What a task is: its start distribution, its reward, termination and success, what ``info``
reports, and how its results are scored.

A task is a :class:`Task` subclass (one file in this package) plus one registration
(:func:`acrobot_mj.envs.tasks.register_task`). :class:`~acrobot_mj.envs.env.AcrobotEnv`,
:class:`~acrobot_mj.envs.vector.AcrobotVectorEnv`, training summaries, population selection,
sweeps, plots and video captions all ask the task; none of them knows the height goal.

The per-step rule is written once, in :meth:`Task.outcome`, over a small math namespace ``xp``:
:data:`SCALAR` (Python floats, the single env's hot path) or :data:`ARRAY` (numpy, one row per
sub-env of the vector env; ``constant_of(xp)(x)`` gives a task's number in the namespace's fast
form). The same formula serves both, so the two envs cannot drift apart.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from acrobot_mj.checks import check_float

#: ``outcome(q1, q2, dq1, dq2) -> (reward, terminated, info)`` on unwrapped angles [rad] and
#: velocities [rad/s] after a step; floats with :data:`SCALAR`, arrays with :data:`ARRAY`.
Outcome = Callable[[Any, Any, Any, Any], tuple[Any, Any, dict[str, Any]]]


def _where(condition: bool, if_true: Any, if_false: Any) -> Any:
    return if_true if condition else if_false


def _same(value: float) -> float:
    return value


class ScalarMath:
    """numpy's names for the math a task's outcome uses, on Python floats (several times faster
    than numpy's on one number)."""

    sin = staticmethod(math.sin)
    cos = staticmethod(math.cos)
    exp = staticmethod(math.exp)
    sqrt = staticmethod(math.sqrt)
    abs = staticmethod(abs)
    maximum = staticmethod(max)
    minimum = staticmethod(min)
    where = staticmethod(_where)
    constant = staticmethod(_same)


class ArrayMath:
    """numpy, on arrays of one row per sub-env, and ``constant(x)``: a task's number as a
    0-d array, which numpy 2 broadcasts faster than a Python float or a one-element array
    (measured at 256 rows: a product 0.6 us, against 1.0 and 1.3 us; the same numbers: every
    operation is still elementwise IEEE arithmetic)."""

    def __getattr__(self, name: str) -> Any:
        return getattr(np, name)

    @staticmethod
    def constant(value: float) -> np.ndarray:
        return np.array(value)


def constant_of(xp: Any) -> Callable[[float], Any]:
    """``xp.constant``, or (a namespace without it, such as the numpy module) the identity."""
    return getattr(xp, "constant", _same)


SCALAR = ScalarMath()
ARRAY = ArrayMath()


@dataclass(frozen=True)
class Score:
    """How a task's episodes are scored: a per-episode quantity and which way is better.

    ``quantity`` is ``"length"`` (decisions) or ``"return"``: the field of a greedy result and,
    as ``episode_{quantity}s``, the per-episode list of a run record.
    """

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

    Subclasses set the class attributes and implement :meth:`outcome` and :meth:`caption`;
    their constructor takes ``links`` (l1, l2 [m], measured on the model by the env),
    ``start_noise`` and the keyword options listed in :attr:`options`, each validated.
    """

    #: Short name: ``TrainConfig.task`` and the ``task`` argument of the envs.
    name: ClassVar[str]
    #: The Gymnasium id it is registered under.
    env_id: ClassVar[str]
    #: Truncation (Gymnasium's TimeLimit, and the vector env's default).
    max_episode_steps: ClassVar[int]
    #: How its results are scored.
    score: ClassVar[Score]
    #: The registered spec's ``reward_threshold``: the mean return that counts as solved with
    #: the registered defaults, or None where the task names none.
    reward_threshold: ClassVar[float | None] = None
    #: Keyword options of the constructor besides ``start_noise`` (also the config fields that
    #: apply to this task).
    options: ClassVar[tuple[str, ...]] = ()
    #: The model keyframe episodes start from.
    start_keyframe: ClassVar[str] = "hanging"
    #: Caption of a successful frame in videos, and what success means in words.
    success_label: ClassVar[str] = "SUCCESS"
    success_text: ClassVar[str] = "succeeded"

    def __init__(self, links: tuple[float, float], start_noise: float = 0.0) -> None:
        self.l1, self.l2 = (check_float("link length", v, 0.0) for v in links)
        self.start_noise = check_float("start_noise", start_noise, 0.0, 1.0)

    def start_offsets(
        self, rng: np.random.Generator, noise: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """What is added to the keyframe's ``qpos`` and ``qvel`` [rad, rad/s] at a reset:
        ``U(-noise, noise)`` for each angle, then each velocity (None without noise)."""
        if noise <= 0.0:
            return None
        return rng.uniform(-noise, noise, 2), rng.uniform(-noise, noise, 2)

    @abstractmethod
    def outcome(self, xp: Any) -> Outcome:
        """The step rule over the math namespace ``xp`` (:data:`SCALAR` or :data:`ARRAY`).

        ``info`` must hold ``is_success``; the envs add nothing else to it.
        """

    def compiled_outcome(self) -> Outcome | None:
        """The rule of ``outcome(ARRAY)`` compiled (numba), the same numbers bit for bit, for
        large batches; None (the default) where the task has none. Built-in tasks have one
        (:mod:`~acrobot_mj.envs.tasks.compiled`); a new task needs none.

        Its rule returns new arrays of one entry per row, none shared with another (``terminated``
        an array too, and ``info["is_success"]`` apart from ``terminated``), which the vector
        env hands on as they are."""
        return None

    def rows_outcome(self, compiled: bool) -> tuple[Outcome, bool]:
        """The step rule over arrays of one row per sub-env, and whether it is the compiled one:
        :meth:`compiled_outcome` where ``compiled`` and the task has one (and numba loads), else
        ``outcome(ARRAY)``.

        A compiled rule is used only where it was written beside the ``outcome`` it copies: a
        subclass (or an instance) that overrides ``outcome`` without a ``compiled_outcome`` of
        its own gets its own rule, not its parent's compiled one."""
        own = "outcome" not in vars(self) and callable(self.compiled_outcome)
        if compiled and own and _defined_in(type(self), "compiled_outcome", "outcome"):
            try:
                fast = self.compiled_outcome()
            except (ImportError, RuntimeError):  # a numba that does not load
                fast = None
            if fast is not None:
                return fast, True
        return self.outcome(ARRAY), False

    @abstractmethod
    def caption(self, info: dict[str, Any]) -> str:
        """A few words on a frame's state for video captions, e.g. ``tip +0.53 m``."""

    @classmethod
    def reference(cls, frame_skip: int) -> tuple[float, str] | None:
        """A reference score and its label for plots (e.g. the best known), or None."""
        return None


def _defined_in(cls: type, name: str, below: str) -> bool:
    """Whether ``cls`` takes ``name`` from the class that defines ``below``, or from a subclass
    of it (an override of ``below`` further down leaves ``name`` behind)."""
    owner = next(k for k in cls.__mro__ if name in k.__dict__)
    return issubclass(owner, next(k for k in cls.__mro__ if below in k.__dict__))
