"""The task registry: every task, by name, each registered with Gymnasium.

Built in: :class:`~acrobot_mj.envs.tasks.height_goal.HeightGoal` (``height_goal``,
``acrobot_mj/Acrobot-v0``) and :class:`~acrobot_mj.envs.tasks.balance.Balance` (``balance``,
``acrobot_mj/AcrobotBalance-v0``). A new task is one file with a
:class:`~acrobot_mj.envs.tasks.base.Task` subclass plus one :func:`register_task` call (here for
a built-in one, anywhere for your own).
"""

from __future__ import annotations

import gymnasium

from acrobot_mj.envs.tasks.balance import Balance
from acrobot_mj.envs.tasks.base import Rule, Score, Task
from acrobot_mj.envs.tasks.height_goal import HeightGoal

__all__ = ["TASKS", "Balance", "HeightGoal", "Rule", "Score", "Task", "get_task", "register_task"]

TASKS: dict[str, type[Task]] = {}
_REQUIRED = ("name", "env_id", "max_episode_steps", "score")


def register_task(task: type[Task]) -> type[Task]:
    """Add ``task`` to :data:`TASKS` and register its Gymnasium id (``gymnasium.make`` with its
    TimeLimit, and ``gymnasium.make_vec``). Returns the class, so it can decorate it."""
    if not (isinstance(task, type) and issubclass(task, Task)):
        raise TypeError(f"a task must be a subclass of acrobot_mj.envs.tasks.Task, got {task!r}")
    missing = [attribute for attribute in _REQUIRED if not hasattr(task, attribute)]
    if missing:
        raise TypeError(f"task {task.__name__} lacks the class attributes {missing}")
    known = TASKS.get(task.name)
    if known is not None and known is not task:
        raise ValueError(f"a task named {task.name!r} is already registered ({known.__name__})")
    TASKS[task.name] = task
    if task.env_id not in gymnasium.registry:
        gymnasium.register(
            id=task.env_id,
            entry_point="acrobot_mj.envs.acrobot:AcrobotEnv",
            vector_entry_point="acrobot_mj.envs.vector:AcrobotVectorEnv",
            max_episode_steps=task.max_episode_steps,
            reward_threshold=task.reward_threshold,
            kwargs={"task": task.name},
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
