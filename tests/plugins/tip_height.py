"""A second task, as a user would add one: keep the tip high (reward = its height, every step).

One Task subclass and one registration: the env, the vector env, training, population
selection, summaries, plots and videos take it from here.
"""

from __future__ import annotations

import math
from typing import Any

from acrobot_mj.envs.tasks import Rule, Score, Task, register_task


class TipHeight(Task):
    """Reward: the tip's height above the pivot [m] on every step; no termination; success: the
    tip above 1.5 m at the episode's last step. Truncated at 200 actions."""

    name = "tip_height"
    env_id = "acrobot_mj_test/TipHeight-v0"
    max_episode_steps = 200
    score = Score(
        "return", lower_is_better=False, label="return per episode", unit="m", best_word="highest"
    )
    info_keys = ("tip_height",)
    success_label = "HIGH"
    success_text = "ended high"

    def rule(self) -> Rule:
        l1, l2 = self.l1, self.l2

        def rule(q1: float, q2: float, dq1: float, dq2: float) -> tuple:
            tip = l1 * math.sin(q1) + l2 * math.sin(q1 + q2)
            return tip, False, tip > 1.5, (tip,)

        return rule

    def caption(self, info: dict[str, Any]) -> str:
        return f"tip {float(info['tip_height']):+.2f} m"


register_task(TipHeight)
