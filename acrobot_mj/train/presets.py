"""The named training presets: the report, Sutton and Barto's book, and a tuned variant."""

from __future__ import annotations

from acrobot_mj.train.config import TrainConfig

# The report, exactly: tabular SARSA on the 5x5x3x3 grid, 0.05 s decisions, 200 episodes.
_REPORT = TrainConfig()
# Sutton and Barto's acrobot: Sarsa(lambda), 48 tilings, alpha 0.2/48, lambda 0.9, epsilon 0,
# weights 0, a decision every 0.2 s, 500 episodes, and their reward: -1 on every step, the last
# one included (with the report's +100 the zero weights stop being optimistic near the goal, and
# exploration dies there).
_BOOK = TrainConfig(
    algorithm="sarsa_lambda",
    features="tiles",
    alpha=0.2 / 48,
    epsilon=0.0,
    lam=0.9,
    frame_skip=4,
    episodes=500,
    goal_reward=-1.0,
)
PRESETS: dict[str, TrainConfig] = {
    "report": _REPORT,
    "book": _BOOK,
    # Not the book: its learner with finer tiles (12 per angle, 14 per velocity, still 48
    # tilings), start noise U(-0.1, 0.1) falling to 0 by half of each learner's run, and the
    # book's 500 episodes spent as 10 independent learners of 50, keeping the one whose last 20
    # training episodes were shortest (acrobot_mj.train.population). See the README's results.
    "tuned": _BOOK.replace(
        angle_tiles=12,
        velocity_tiles=14,
        start_noise=0.1,
        noise_until=0.5,
        episodes=50,
        population=10,
    ),
}
