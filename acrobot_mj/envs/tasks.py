"""Tasks: what the acrobot is asked to do (start, step rule, ``info``, scoring) and their registry.
The single env calls a task's :meth:`Task.rule`; the vector env runs it compiled over rows.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, TypedDict

import gymnasium
import numpy as np

from acrobot_mj.checks import check_float
from acrobot_mj.compiled import compiled
from acrobot_mj.envs.disturbances import recoveries
from acrobot_mj.physics.xp import maximum, wrap

#: ``rule(q1, q2, dq1, dq2) -> (reward, terminated, success, values)`` on the state [rad, rad/s]
#: after a step; ``values``: floats named by ``Task.info_keys``.
Rule = Callable[[float, float, float, float], tuple[float, bool, bool, tuple[float, ...]]]
#: The compiled form of each task's rule over rows, by the task's type and settings.
_ROWS: dict[tuple, Callable[..., None]] = {}


@dataclass(frozen=True)
class Score:
    """How episodes are scored: ``quantity`` ``"length"`` or ``"return"`` (a run record's
    ``episode_{quantity}s``) and which way is better."""

    quantity: str
    lower_is_better: bool
    label: str  # e.g. "decisions per episode"
    unit: str  # e.g. "decisions"
    best_word: str  # the best of several, in words: "shortest", "highest"
    log_scale: bool = False  # plots read better on a log axis

    def __post_init__(self) -> None:
        if self.quantity not in ("length", "return"):
            raise ValueError(f"score quantity must be 'length' or 'return', got {self.quantity!r}")

    def values(self, record: dict[str, Any]) -> list[float]:
        """The per-episode scores of a run record."""
        return record[f"episode_{self.quantity}s"]

    def is_better(self, a: float, b: float) -> bool:
        """Whether score ``a`` is strictly better than ``b``."""
        return a < b if self.lower_is_better else a > b


class TaskOptions(TypedDict, total=False):
    """The built-in tasks' keyword options, which the envs pass on to their task (each task
    refuses those it does not take): typed, so that a type checker catches a misspelt keyword.
    A task of one's own with other options works at run time; a type checker then wants a
    ``# type: ignore[call-arg]`` where they are passed."""

    start_noise: float  # every task
    step_reward: float  # HeightGoal
    goal_reward: float  # HeightGoal
    goal_height: float  # HeightGoal
    tolerance: float  # Balance


class Task(ABC):
    """One acrobot task on the shared physics. Subclasses set the class attributes and implement
    :meth:`rule` and :meth:`caption`; the constructor takes ``links`` (l1, l2 [m]),
    ``start_noise`` and the keyword :attr:`options`."""

    name: ClassVar[str]  # TrainConfig.task and the envs' task argument
    env_id: ClassVar[str]  # the Gymnasium id
    max_episode_steps: ClassVar[int]  # truncation
    score: ClassVar[Score]
    #: The mean return that counts as solved with the registered defaults (or None), and with
    #: those of the RL-ready variants (``VARIANTS``).
    reward_threshold: ClassVar[float | None] = None
    rl_reward_threshold: ClassVar[float | None] = None
    #: Constructor keywords besides ``start_noise``.
    options: ClassVar[tuple[str, ...]] = ()
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
        """What a reset adds to the keyframe's ``qpos`` and ``qvel``: ``U(-noise, noise)`` for
        each angle, then each velocity (None without noise)."""
        if noise <= 0.0:
            return None
        return rng.uniform(-noise, noise, 2), rng.uniform(-noise, noise, 2)

    @abstractmethod
    def rule(self) -> Rule:
        """The step rule: plain float arithmetic and ``math`` (numba compiles it), with the
        task's numbers read outside the returned function."""

    @abstractmethod
    def caption(self, info: dict[str, Any]) -> str:
        """A few words on a frame's state for video captions, e.g. ``tip +0.53 m``."""

    def assess(
        self, states: np.ndarray, dt: float, swing_up: int | None = None, pushes: Sequence[int] = ()
    ) -> dict:
        """Task-specific measures of an episode's states ``(T + 1, 4)``, ``dt`` [s] apart
        (``pushes``: the decisions before which a push landed)."""
        return {}

    @staticmethod
    def summarise(assessments: list[dict[str, Any]], spread: Callable) -> dict[str, Any]:
        """What :meth:`assess` says over many episodes (``spread``: statistics of a list)."""
        return {}

    @classmethod
    def reference(cls, frame_skip: int) -> tuple[float, str] | None:
        """A reference score and its label for plots, or None."""
        return None

    def info(self) -> Callable[[tuple, Any], dict[str, Any]]:
        """``info(values, success)``: a step's ``info`` (a dict literal where there is one value:
        the single env's hot path)."""
        keys, names = self.info_keys, self.success_keys
        if len(keys) == 1 and len(names) in (1, 2):
            key, first, last = keys[0], names[0], names[-1]
            return lambda values, success: {key: values[0], first: success, last: success}
        return lambda values, success: {
            **dict(zip(keys, values, strict=False)),
            **dict.fromkeys(names, success),
        }

    def outcomes(self, q1: np.ndarray, q2: np.ndarray, dq1: np.ndarray, dq2: np.ndarray) -> tuple:
        """The rule over rows ``(N,)``, compiled: rewards, terminations and ``info`` (each entry
        a new array)."""
        keys, names = self.info_keys, self.success_keys
        n = len(q1)
        block, flags = np.empty((1 + len(keys), n)), np.empty((2, n), bool)  # rows: reward, values
        rows = self.__dict__.get("_compiled_rows") or self._rows()
        rows(q1, q2, dq1, dq2, block, flags)
        if len(keys) == 1 and len(names) == 1:  # the common case, written out: the hot path
            return block[0], flags[0], {keys[0]: block[1], names[0]: flags[1]}
        info = dict(zip(keys, block[1:], strict=True))
        info |= {name: flags[1].copy() for name in names[:-1]} | {names[-1]: flags[1]}
        return block[0], flags[0], info

    def _rows(self) -> Callable[..., None]:
        """:meth:`rule` over rows, compiled once per process for each task's settings."""
        settings = {k: v for k, v in vars(self).items() if not k.startswith("_")}
        key = (type(self), tuple(sorted(settings.items())))
        if key not in _ROWS:
            rule = self.rule()

            def rows(q1, q2, dq1, dq2, block, flags):  # kernel (numba, compiled)
                for i in range(q1.shape[0]):
                    r, t, s, v = rule(q1[i], q2[i], dq1[i], dq2[i])
                    block[0, i], flags[0, i], flags[1, i] = r, t, s
                    for j in range(block.shape[0] - 1):
                        block[j + 1, i] = v[j]

            _ROWS[key] = compiled(rows, cache=False, calls=(rule,))
        self._compiled_rows = _ROWS[key]
        return _ROWS[key]


class HeightGoal(Task):
    """Swing the tip above ``goal_height`` over the bar (default ``l1``: one link length, 1 m on
    the report's acrobot), the report's task: ``step_reward``
    (-1) per step, ``goal_reward`` (+100) on the step whose end reaches it, which terminates.
    Starts hanging at rest, plus ``U(-start_noise, start_noise)`` on each angle and velocity.
    Truncated at 1000 actions; ``info``: ``tip_height`` [m] and ``is_success``."""

    name = "height_goal"
    env_id = "acrobot_mj/Acrobot-v0"
    max_episode_steps = 1000
    # Acrobot-v1's -100 (the goal within 20 s): the goal at step 401 of 0.05 s returns -300,
    # at decision 101 of 0.2 s (the RL variants) 0.
    reward_threshold = -300.0
    rl_reward_threshold = 0.0
    score = Score(
        "length",
        lower_is_better=True,
        label="decisions per episode",
        unit="decisions",
        best_word="shortest",
        log_scale=True,
    )
    options = ("step_reward", "goal_reward", "goal_height")
    info_keys = ("tip_height",)
    success_label = "GOAL"
    success_text = "reached the goal"
    #: Best-known minimum decisions from rest to the goal (``acrobot-mj validate``'s search).
    MIN_DECISIONS = {1: 249, 4: 63}

    def __init__(
        self,
        links: tuple[float, float],
        start_noise: float = 0.0,
        step_reward: float = -1.0,
        goal_reward: float = 100.0,
        goal_height: float | None = None,
    ) -> None:
        super().__init__(links, start_noise)
        self.step_reward = check_float("step_reward", step_reward)
        self.goal_reward = check_float("goal_reward", goal_reward)
        reach = self.l1 + self.l2
        height = self.l1 if goal_height is None else goal_height
        self.goal_height = check_float("goal_height", height, -reach, reach)
        if abs(self.goal_height) == reach:
            raise ValueError(
                f"goal_height must be strictly inside (-{reach:g}, {reach:g}) m: "
                f"at {self.goal_height:g} m the goal is never or always reached"
            )

    def rule(self) -> Rule:
        l1, l2, height = self.l1, self.l2, self.goal_height
        goal_reward, step_reward = self.goal_reward, self.step_reward

        def rule(q1: float, q2: float, dq1: float, dq2: float) -> tuple:
            tip = l1 * math.sin(q1) + l2 * math.sin(q1 + q2)
            reached = tip > height
            return (goal_reward if reached else step_reward), reached, reached, (tip,)

        return rule

    def caption(self, info: dict[str, Any]) -> str:
        return f"tip {float(info['tip_height']):+.2f} m"

    @classmethod
    def reference(cls, frame_skip: int) -> tuple[float, str] | None:
        best = cls.MIN_DECISIONS.get(frame_skip)
        return (best, f"best known minimum ({best})") if best else None


class Balance(Task):
    """Swing up from hanging and stay balanced upright, ``(q1, q2) = (pi/2, 0)``.

    Rewards ``(1 + sin q1) (1 + cos q2) / 4`` per step (1 upright, no flat region, no velocity
    term); no termination, truncated at 2000 actions. ``info``: ``upright_error`` (the larger
    wrapped angle error [rad]) and ``is_balanced`` (below ``tolerance`` rad), also
    ``is_success``. Ten +1 N m steps from rest reach ``(q1, q2) = (-1.647489786, 0.204950005)``,
    reward ``0.00145437`` and error ``|q1 - pi/2 + 2 pi| = 3.064899`` rad by hand:

    >>> import gymnasium as gym
    >>> import acrobot_mj
    >>> env = gym.make("acrobot_mj/AcrobotBalance-v0")
    >>> obs, info = env.reset(seed=0)
    >>> info
    {'upright_error': 3.141592653589793, 'is_balanced': False, 'is_success': False}
    >>> for _ in range(10):
    ...     obs, reward, terminated, truncated, info = env.step(2)
    >>> round(reward, 8), round(info["upright_error"], 6), info["is_balanced"], terminated
    (0.00145437, 3.064899, False, False)
    """

    name = "balance"
    env_id = "acrobot_mj/AcrobotBalance-v0"
    max_episode_steps = 2000
    # The report's objective: 60 s (1200 steps of 0.05 s; 300 of the RL variants' 0.2 s) balanced.
    reward_threshold = 1200.0
    rl_reward_threshold = 300.0
    score = Score(
        "return", lower_is_better=False, label="return per episode", unit="", best_word="highest"
    )
    options = ("tolerance",)
    info_keys = ("upright_error",)
    success_keys = ("is_balanced", "is_success")
    success_label = "BALANCED"
    success_text = "ended balanced"

    def __init__(
        self, links: tuple[float, float], start_noise: float = 0.0, tolerance: float = 0.05
    ) -> None:
        super().__init__(links, start_noise)
        self.tolerance = check_float("tolerance", tolerance, 0.0, math.pi)
        if self.tolerance in (0.0, math.pi):
            raise ValueError(f"tolerance must be inside (0, pi) rad, got {self.tolerance:g}")

    def rule(self) -> Rule:
        tolerance, up = self.tolerance, math.pi / 2

        def rule(q1: float, q2: float, dq1: float, dq2: float) -> tuple:
            reward = (1.0 + math.sin(q1)) * (1.0 + math.cos(q2)) / 4.0
            error = maximum(abs(wrap(q1 - up)), abs(wrap(q2)))
            return reward, False, error < tolerance, (error,)

        return rule

    def assess(
        self, states: np.ndarray, dt: float, swing_up: int | None = None, pushes: Sequence[int] = ()
    ) -> dict:
        """How long ``states`` stayed balanced after ``swing_up`` steps (default: where the last
        balanced stretch begins): times [s], errors [rad], and whether it held to the end; and
        when it first caught its balance, its falls and its recoveries from ``pushes``
        (:func:`~acrobot_mj.envs.disturbances.recoveries`)."""
        _, _, info = self.outcomes(*np.ascontiguousarray(states, dtype=np.float64).T)
        error, balanced = info["upright_error"], info["is_balanced"]
        if swing_up is None:
            out = np.flatnonzero(~balanced)
            swing_up = min(int(out[-1]) + 1 if out.size else 0, len(states) - 1)
        after = error[swing_up:]
        out = np.flatnonzero(~balanced[swing_up:])
        inside = after if out.size == 0 else after[: out[0]]
        return {
            "swing_up_seconds": swing_up * dt,
            "arrival_error": float(after[0]),
            "hold_seconds": max(len(inside) - 1, 0) * dt,
            "balanced": out.size == 0,
            "max_error_during_hold": float(inside.max()) if inside.size else None,
            "final_error": float(error[-1]),
            **recoveries(error, self.tolerance, dt, list(pushes)),
        }

    @staticmethod
    def summarise(assessments: list[dict[str, Any]], spread: Callable) -> dict[str, Any]:
        """Episodes that ended balanced, the ``spread`` of hold times [s], and the largest error
        while balanced [rad]."""
        balanced = [a for a in assessments if a["balanced"]]
        caught = [a["first_balance_seconds"] for a in assessments]
        after = [push for a in assessments for push in a["after_pushes"]]
        recovered = [push["recovered_seconds"] for push in after]
        return {
            "balanced": len(balanced),
            "hold_seconds": spread([a["hold_seconds"] for a in assessments]),
            "largest_error_while_balanced": max(
                (a["max_error_during_hold"] or 0.0 for a in balanced), default=None
            ),
            "first_balance_seconds": spread([t for t in caught if t is not None]),
            "never_balanced": caught.count(None),
            "balanced_at_end": sum(a["balanced_at_end"] for a in assessments),
            "falls": sum(a["falls"] for a in assessments),
            "pushes": {
                "total": len(after),
                "while_balanced": sum(push["fell"] is not None for push in after),
                "without_fall": sum(push["fell"] is False for push in after),
                "recovered": sum(t is not None for t in recovered),
                "recovered_seconds": spread([t for t in recovered if t is not None]),
            },
        }

    def caption(self, info: dict[str, Any]) -> str:
        return f"error {float(info['upright_error']):.3f} rad"


#: The registered tasks by name (:func:`register_task` adds one).
TASKS: dict[str, type[Task]] = {}
#: RL-ready variants registered beside each task's id (``acrobot_mj/AcrobotRL-v0`` beside
#: ``acrobot_mj/Acrobot-v0``): Gymnasium's ``Acrobot-v1`` defaults (0.2 s decisions, float32
#: cos/sin observations, a start of rest plus ``U(-0.1, 0.1)`` drawn from the seed, 500
#: decisions), with discrete or continuous torques. Name suffix -> keyword arguments.
RL = {"frame_skip": 4, "start_noise": 0.1, "observation": "cos_sin"}
VARIANTS = {"RL": RL, "RLContinuous": {**RL, "continuous": True}}
RL_MAX_EPISODE_STEPS = 500


def register_task(task: type[Task]) -> type[Task]:
    """Add ``task`` to :data:`TASKS` and register its Gymnasium id (``make`` and ``make_vec``);
    returns the class, so it can decorate it."""
    if not (isinstance(task, type) and issubclass(task, Task)):
        raise TypeError(f"a task must be a subclass of acrobot_mj.envs.tasks.Task, got {task!r}")
    missing = [a for a in ("name", "env_id", "max_episode_steps", "score") if not hasattr(task, a)]
    if missing:
        raise TypeError(f"task {task.__name__} lacks the class attributes {missing}")
    known = TASKS.setdefault(task.name, task)
    if known is not task:
        raise ValueError(f"a task named {task.name!r} is already registered ({known.__name__})")
    base, version = task.env_id.rsplit("-", 1)
    ids: dict[str, tuple[dict[str, Any], int, float | None]] = {
        task.env_id: ({}, task.max_episode_steps, task.reward_threshold)
    }
    for suffix, kwargs in VARIANTS.items():
        ids[f"{base}{suffix}-{version}"] = (kwargs, RL_MAX_EPISODE_STEPS, task.rl_reward_threshold)
    for env_id, (kwargs, steps, threshold) in ids.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(
                id=env_id,
                entry_point="acrobot_mj.envs.acrobot:AcrobotEnv",
                vector_entry_point="acrobot_mj.envs.vector:AcrobotVectorEnv",
                max_episode_steps=steps,
                reward_threshold=threshold,
                kwargs={"task": task.name, **kwargs},
            )
    return task


def get_task(name: str) -> type[Task]:
    """The task class called ``name``; the error lists the known ones."""
    try:
        return TASKS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {name!r}; known: {sorted(TASKS)}") from None


register_task(HeightGoal)
register_task(Balance)
