"""acrobot-mj: the Acrobot swing-up on MuJoCo.

``import acrobot_mj`` registers the Gymnasium environment ``acrobot_mj/Acrobot-v0``
(:class:`acrobot_mj.env.AcrobotEnv`, truncated at 1000 actions).
"""

from __future__ import annotations

# First, before anything imports mujoco: pick a headless OpenGL backend (render.py).
from acrobot_mj.render import configure_gl

configure_gl()

import gymnasium  # noqa: E402

from acrobot_mj.params import AcrobotParams  # noqa: E402

__version__ = "0.1.0"
ENV_ID = "acrobot_mj/Acrobot-v0"
MAX_EPISODE_STEPS = 1000

__all__ = ["ENV_ID", "MAX_EPISODE_STEPS", "AcrobotEnv", "AcrobotParams", "__version__"]

if ENV_ID not in gymnasium.registry:
    gymnasium.register(
        id=ENV_ID,
        entry_point="acrobot_mj.env:AcrobotEnv",
        vector_entry_point="acrobot_mj.vector:AcrobotVectorEnv",
        max_episode_steps=MAX_EPISODE_STEPS,
    )


def __getattr__(name: str):
    # AcrobotEnv on first use, so `import acrobot_mj` stays light for the analytic model.
    if name == "AcrobotEnv":
        from acrobot_mj.env import AcrobotEnv

        return AcrobotEnv
    raise AttributeError(f"module 'acrobot_mj' has no attribute {name!r}")
