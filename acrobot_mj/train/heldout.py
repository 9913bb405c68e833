"""The evaluation protocol: held-out start states that no training or selection sees.

A learner trains from its config's starts (rest, or rest plus ``start_noise``, drawn through
:func:`acrobot_mj.train.episodes.episode_seed`) and a population keeps a learner by its training
episodes (:mod:`acrobot_mj.train.population`). Evaluation draws its starts from another branch of
NumPy's seed tree: ``SeedSequence(seed, spawn_key=(HELDOUT_BRANCH,))``. Every draw of training
comes from a ``SeedSequence`` without a spawn key, so no training seed, whatever its value, gives
the evaluation's stream (disjoint by construction, not by choosing seeds far apart), and no
evaluation setting can change what training does.

The protocol's default is 100 starts of ``U(-0.05, 0.05)`` on each angle and velocity around the
task's rest state, with seed 0; the rest start itself is reported apart.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acrobot_mj.checks import check_float, check_int

#: The spawn key of every evaluation draw (training draws have none).
HELDOUT_BRANCH = 0xE7A1


@dataclass(frozen=True)
class Protocol:
    """Held-out evaluation: ``episodes`` starts of ``U(-start_noise, start_noise)`` [rad, rad/s]
    on each of (q1, q2, dq1, dq2) around rest, drawn with ``seed``."""

    episodes: int = 100
    start_noise: float = 0.05
    seed: int = 0

    def __post_init__(self) -> None:
        check_int("episodes", self.episodes, 1)
        check_float("start_noise", self.start_noise, 0.0, 1.0)
        check_int("seed", self.seed, 0)

    def starts(self, rest: np.ndarray) -> np.ndarray:
        """The held-out start states, shape ``(episodes, 4)``: ``rest`` plus the draws."""
        rest = np.asarray(rest, dtype=np.float64)
        if rest.shape != (4,):
            raise ValueError(f"rest must be a state (q1, q2, dq1, dq2), got shape {rest.shape}")
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(HELDOUT_BRANCH,)))
        return rest + rng.uniform(-self.start_noise, self.start_noise, size=(self.episodes, 4))

    def to_dict(self) -> dict[str, float | int]:
        return {"episodes": self.episodes, "start_noise": self.start_noise, "seed": self.seed}


#: The protocol the README's learning results use.
DEFAULT = Protocol()
