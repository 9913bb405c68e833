"""The named presets: the report, Sutton and Barto's book, the best model-free and model-based
learners, and the balance preset (identify, plan, TVLQR)."""

from __future__ import annotations

from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.plan import PlanConfig

# The report, exactly: tabular SARSA on the 5x5x3x3 grid, 0.05 s decisions, 200 episodes.
_REPORT = TrainConfig()
# Sutton and Barto's acrobot: Sarsa(lambda), 48 tilings, alpha 0.2/48, lambda 0.9, epsilon 0,
# weights 0, a decision every 0.2 s, 500 episodes, and their reward: -1 on every step, the last
# one included (with the report's +100 the zero weights stop being optimistic near the goal, and
# exploration dies there).
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
_MODEL_FREE = _BOOK.replace(
    angle_tiles=12,
    velocity_tiles=14,
    start_noise=0.05,
    energy_shaping=20.0,
    episodes=1000,
    max_decisions=48_000,
)
PRESETS: dict[str, TrainConfig | PlanConfig] = {
    "report": _REPORT,
    "book": _BOOK,
    # The best learner measured on held-out starts (the README's learning results): the
    # model-free recipe below, in a model identified from 1,000 env decisions of random torques
    # (acrobot_mj.train.model_based: the manipulator structure is known, its values are not),
    # as 10 learners of 48,000 simulated decisions each, the one whose last 20 simulated
    # training episodes were shortest kept. 1,000 env decisions in all, and the greedy run.
    # Its shaping scale is 40: up to this version the model-based path applied the recipe's 20
    # twice (the model was shaped, then each learner's env again), and that is what was
    # measured; it is now stated once. A checkpoint every 250 episodes: a learner's 490 or so
    # episodes take about a second, and a checkpoint of its 10 MB of weights 25 ms.
    "tuned": _MODEL_FREE.replace(
        identify_decisions=1000,
        population=10,
        max_decisions=480_000,
        energy_shaping=40.0,
        checkpoint_every=250,
    ),
    # Not the book: its learner on the book's budget of about 48,000 learning decisions (capped
    # exactly), trained from the evaluation's start distribution (U(-0.05, 0.05) around rest,
    # constant) with finer tiles (12 per angle, 14 per velocity, still 48 tilings) and
    # potential-based energy shaping (scale 20, which leaves the optimal policies unchanged).
    # One learner: restarts split the budget too thin. The episodes never bind (a swing-up
    # takes at least 63 decisions, so 1000 episodes need more than 48,000). Chosen on held-out
    # starts over training seeds 0-29, 100-119 and 200-219; the README reports it on other
    # seeds.
    "model_free": _MODEL_FREE,
    # Swing up AND balance, model-based: identify, plan, TVLQR (acrobot_mj.train.plan).
    "balance": PlanConfig(),
}

#: The ``tuned`` preset of 0.2.0 (10 learners of 50 episodes, start noise 0.1 falling to 0 by
#: half of each run): 65 decisions from rest, but 85 from held-out starts, with about 88,000
#: decisions. Kept for comparison and for its golden run.
TUNED_0_2 = _BOOK.replace(
    angle_tiles=12,
    velocity_tiles=14,
    start_noise=0.1,
    noise_until=0.5,
    episodes=50,
    population=10,
)
