"""A learner's bookkeeping as each of its training episodes ends, the same for one learner
(:mod:`.learners`) and for learners in lockstep (:mod:`.lockstep`): its history, episode log and
checkpoint, its monitor; a return that is not finite stops it as diverged."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import gymnasium as gym

from acrobot_mj.agents import DivergenceError
from acrobot_mj.train.checkpoint import Checkpoints
from acrobot_mj.train.monitor import Monitor
from acrobot_mj.train.records import History

#: Called after every training episode with its index and the history so far.
OnEpisode = Callable[[int, History], None]


class Books:
    """One learner's ``history`` so far, ``checkpoints`` (holding ``state()``, its arrays) and
    ``monitor``; ``on_episode(index, history)`` after each episode."""

    def __init__(
        self,
        checkpoints: Checkpoints,
        state: Callable[[], Any],
        monitor: Monitor,
        history: History,
        *,
        on_episode: OnEpisode | None = None,
    ) -> None:
        self.checkpoints, self.state, self.monitor = checkpoints, state, monitor
        self.history, self.on_episode = history, on_episode

    def start(self) -> None:
        """Begin at the history (a resumed run's, or none): the log keeps exactly its episodes."""
        self.checkpoints.start(self.history)
        self.checkpoints.snapshot(self.state, self.history)
        self.monitor.restored(self.history)

    def end(self, length: int, total: float, success: bool) -> None:
        """One episode ended: ``length`` decisions, return ``total``, ``success``. Its history
        entry and log line, the state after it kept, a checkpoint where one is due; a
        :class:`~acrobot_mj.agents.base.DivergenceError` (nothing recorded) if ``total`` is not
        finite."""
        episode = len(self.history)
        if not math.isfinite(total):
            raise DivergenceError(f"the episode's return is {total}", rewards=True)
        self.history.add(length, total, success)
        self.checkpoints.snapshot(self.state, self.history)
        self.monitor.episode(episode, length, total, success)
        if (episode + 1) % self.checkpoints.config.checkpoint_every == 0:
            self.checkpoints.save()
        if self.on_episode is not None:
            self.on_episode(episode, self.history)

    def diverged(self, error: DivergenceError) -> DivergenceError:
        """The error the learner stops with when it diverges in its next episode: where, the
        likely cause, and what its checkpoint keeps."""
        config, seed, path = self.checkpoints.config, self.checkpoints.seed, self.checkpoints.path
        if error.rewards:
            cause = (
                f"the rewards (step_reward {config.step_reward}, goal_reward "
                f"{config.goal_reward}) overflow a float"
            )
        else:
            n = config.encoding.build(gym.spaces.Box(-1.0, 1.0, (4,))).num_active
            cause = (
                f"the step size: alpha={config.alpha:g} is per weight, and {n} features are "
                f"active in each state (Sutton and Barto use 0.2/{n} with tile coding)"
            )
        kept = len(self.history)
        return DivergenceError(
            f"{config.algorithm} diverged in episode {kept + 1} of seed {seed} ({error}); the "
            f"likely cause is {cause}; "
            + (f"{path} keeps the state after episode {kept}" if path else "not saved")
        )
