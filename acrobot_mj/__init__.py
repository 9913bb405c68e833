"""acrobot-mj: the Acrobot swing-up on MuJoCo. Importing it registers every task's Gymnasium
environment (``acrobot_mj/Acrobot-v0``: the height goal, truncated at 1000 actions)."""

from __future__ import annotations

from typing import TYPE_CHECKING

# First, before anything imports mujoco: pick a headless OpenGL backend.
from acrobot_mj.envs.gl import configure_gl

configure_gl()

from acrobot_mj.envs.tasks import TASKS, HeightGoal  # noqa: E402  registers the tasks
from acrobot_mj.physics.params import AcrobotParams  # noqa: E402
from acrobot_mj.version import __version__  # noqa: E402

if TYPE_CHECKING:  # the class itself for type checkers; at run time __getattr__ imports it
    from acrobot_mj.envs.acrobot import AcrobotEnv

ENV_ID = HeightGoal.env_id
MAX_EPISODE_STEPS = HeightGoal.max_episode_steps

__all__ = ["ENV_ID", "MAX_EPISODE_STEPS", "TASKS", "AcrobotEnv", "AcrobotParams", "__version__"]


def __getattr__(name: str) -> type[AcrobotEnv]:
    # AcrobotEnv on first use, so `import acrobot_mj` stays light for the analytic model.
    if name == "AcrobotEnv":
        from acrobot_mj.envs.acrobot import AcrobotEnv

        return AcrobotEnv
    raise AttributeError(f"module 'acrobot_mj' has no attribute {name!r}")
