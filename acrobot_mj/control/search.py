"""The minimum-time swing-up: a beam search over torque sequences on the analytic model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import HANGING, tip_height
from acrobot_mj.physics.params import REPORT
from acrobot_mj.physics.xp import wrap_angle


@dataclass
class SearchResult:
    decisions: int | None  # None if the goal was not reached within max_decisions
    actions: list[int]  # Discrete(3) actions: 0 = -1 N m, 1 = 0, 2 = +1 N m
    expanded: int  # states expanded


@dataclass(frozen=True)
class Beam:
    """What a search keeps at each depth: one state per ``cell`` [rad, rad, rad/s, rad/s] of
    the state space, the ``width`` most energetic of them."""

    width: int = 20_000
    cell: tuple[float, ...] = (0.05, 0.05, 0.1, 0.2)


def min_time_search(
    frame_skip: int = 4,
    *,
    beam: Beam = Beam(),
    method: str = "semi_implicit_euler",
    max_decisions: int = 1000,
    goal_height: float = 1.0,
    start: np.ndarray | None = None,
) -> SearchResult:
    """Fewest decisions of {-1, 0, +1} N m to get the tip above ``goal_height`` [m] (an upper
    bound): breadth-first over the :class:`Beam` of each depth."""
    width, cell = beam.width, beam.cell
    torques = np.array([-1.0, 0.0, 1.0])
    states = (HANGING if start is None else np.asarray(start, dtype=np.float64))[None].copy()
    if states.shape != (1, 4) or not np.all(np.isfinite(states)):
        raise ValueError(f"start must be a finite state (q1, q2, dq1, dq2), got {start!r}")
    parents: list[np.ndarray] = []  # per depth: the kept states' parents and actions
    choices: list[np.ndarray] = []
    expanded = 0
    for depth in range(1, max_decisions + 1):
        n = len(states)
        expanded += 3 * n
        children = integrators.step_states(
            np.repeat(states, 3, axis=0), np.tile(torques, n), REPORT, frame_skip, method
        )
        parent, choice = np.repeat(np.arange(n), 3), np.tile(np.arange(3), n)
        reached = np.flatnonzero(tip_height(children) > goal_height)
        if reached.size:
            actions = [int(choice[reached[0]])]
            index = parent[reached[0]]
            for level in range(depth - 2, -1, -1):
                actions.append(int(choices[level][index]))
                index = parents[level][index]
            return SearchResult(depth, actions[::-1], expanded)
        key = np.concatenate([wrap_angle(children[:, :2]), children[:, 2:]], axis=1)
        _, first = np.unique(
            np.floor(key / np.asarray(cell)).astype(np.int64), axis=0, return_index=True
        )
        if first.size > width:
            # A stable sort: argpartition's order (which the beam's merging depends on) varies
            # between numpy versions.
            energy = dynamics.total_energy(children[first, :2], children[first, 2:])
            first = first[np.argsort(-energy, kind="stable")[:width]]
        states = children[first]
        parents.append(parent[first])
        choices.append(choice[first])
    return SearchResult(None, [], expanded)
