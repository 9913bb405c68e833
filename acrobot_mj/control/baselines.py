"""Fixed baseline policies, for demos and smoke tests: simple reference behaviours that need no
training (the learners are in :mod:`acrobot_mj.agents`). Each maps an observation
``(q1, q2, dq1, dq2)`` to a ``Discrete(3)`` action (0: -1 N m, 1: 0, 2: +1 N m)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

POLICY_NAMES = ("pump", "zero", "random")


def zero_policy(obs: np.ndarray) -> int:
    """No torque: the acrobot stays hanging at rest."""
    return 1


def pump_policy(obs: np.ndarray) -> int:
    """Bang-bang energy pumping, ``tau = -sign(dq1)`` [N m].

    A demo heuristic found by trying the four sign laws on ``dq1`` and ``dq2``: from rest it
    reaches the goal in 300 steps at frame_skip 1 and 96 decisions at frame_skip 4.
    """
    return 0 if obs[2] > 0 else 2


def random_policy(seed: int | None = None) -> Callable[[np.ndarray], int]:
    """Uniformly random actions from its own generator (seeded)."""
    rng = np.random.default_rng(seed)
    return lambda obs: int(rng.integers(3))


def make_policy(name: str, seed: int | None = None) -> Callable[[np.ndarray], int]:
    """The policy called ``name``: one of :data:`POLICY_NAMES`."""
    if name == "zero":
        return zero_policy
    if name == "pump":
        return pump_policy
    if name == "random":
        return random_policy(seed)
    raise ValueError(f"unknown policy {name!r}; choose one of {POLICY_NAMES}")
