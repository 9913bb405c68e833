"""A second task, as a user would add one: keep the tip high (reward = its height, every step).

One Task subclass and one registration: the env, the vector env, training, population
selection, summaries, plots and videos take it from here.
"""

from __future__ import annotations

from typing import Any

from acrobot_mj.envs.tasks import Outcome, Score, Task, register_task


class TipHeight(Task):
    """Reward: the tip's height above the pivot [m] on every step; no termination; success: the
    tip above 1.5 m at the episode's last step. Truncated at 200 actions."""

    name = "tip_height"
    env_id = "acrobot_mj_test/TipHeight-v0"
    max_episode_steps = 200
    score = Score(
        "return", lower_is_better=False, label="return per episode", unit="m", best_word="highest"
    )
    success_label = "HIGH"
    success_text = "ended high"

    def outcome(self, xp: Any) -> Outcome:
        l1, l2, sin = self.l1, self.l2, xp.sin

        def outcome(q1: Any, q2: Any, dq1: Any, dq2: Any) -> tuple[Any, Any, dict[str, Any]]:
            tip = l1 * sin(q1) + l2 * sin(q1 + q2)
            return tip, False, {"tip_height": tip, "is_success": tip > 1.5}

        return outcome

    def caption(self, info: dict[str, Any]) -> str:
        return f"tip {float(info['tip_height']):+.2f} m"


register_task(TipHeight)
