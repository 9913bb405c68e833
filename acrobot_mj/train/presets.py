"""The named presets: the report, Sutton and Barto's book, the best model-free and model-based
learners, the balance preset (identify, plan, TVLQR) and the black-box learner."""

from __future__ import annotations

from acrobot_mj.train.balance_preset import PlanConfig
from acrobot_mj.train.black_box import BlackBoxConfig
from acrobot_mj.train.config import TrainConfig

# The report: tabular SARSA on the 5x5x3x3 grid, 0.05 s decisions, 200 episodes.
_REPORT_CONFIG = TrainConfig()
# Sutton and Barto's acrobot: Sarsa(lambda), 48 tilings, alpha 0.2/48, lambda 0.9, epsilon 0,
# a decision every 0.2 s, 500 episodes, and -1 on every step, the last included (the report's
# +100 leaves the zero weights not optimistic near the goal, and exploration dies there).
_BOOK = TrainConfig().replace(
    algorithm="sarsa_lambda",
    features="tiles",
    alpha=0.2 / 48,
    epsilon=0.0,
    lam=0.9,
    frame_skip=4,
    episodes=500,
    goal_reward=-1.0,
)
# The book's learner on its budget of about 48,000 decisions (capped), from the evaluation's start
# distribution, with finer tiles and potential-based energy shaping (which leaves the optimal
# policies unchanged); chosen on held-out starts over other training seeds.
_MODEL_FREE = _BOOK.replace(
    angle_tiles=12,
    velocity_tiles=14,
    start_noise=0.05,
    energy_shaping=20.0,
    episodes=1000,
    max_decisions=48_000,
)
# The best learner on held-out starts: the model-free recipe in a model identified from 1,000 env
# decisions, 10 learners of 48,000 simulated decisions, the best in the model kept. Shaping 40:
# what was measured (the model-based path once applied the recipe's 20 twice).
_TUNED = _MODEL_FREE.replace(
    identify_decisions=1000,
    population=10,
    max_decisions=480_000,
    energy_shaping=40.0,
    checkpoint_every=250,
)
PRESETS: dict[str, TrainConfig | PlanConfig | BlackBoxConfig] = {
    "report": _REPORT_CONFIG,
    "book": _BOOK,
    "tuned": _TUNED,
    "model_free": _MODEL_FREE,
    "balance": PlanConfig(),
    # Told nothing of the equations: random exploration, a generic learnt model, a planned funnel.
    "black_box": BlackBoxConfig(),
}

#: The ``tuned`` preset of 0.2.0 (10 learners of 50 episodes, start noise 0.1 falling to 0 by
#: half of each run), kept for comparison and for its golden run.
TUNED_0_2 = _BOOK.replace(
    angle_tiles=12, velocity_tiles=14, start_noise=0.1, noise_until=0.5, episodes=50, population=10
)
