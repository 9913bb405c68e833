"""Where a controller's time goes in the global-policy test of a model (the scaled protocol off
``ai_olympics``): over the episodes of seeds 0-2, in how many intervals after a reset the arm
is caught (up from some moment to the next reset), how long after the reset, and how far the
arm was wound (whole turns of ``q1`` from upright and of ``q2``, unwrapped, when the reset
came: the reset's PID unwinds them):

    python scripts/global_catches.py runs/feedback
    python scripts/global_catches.py funnel --model report --seeds 0,1

Prints the catches, their median and mean time [s], and the windings, most common first.
"""

from __future__ import annotations

import argparse
import itertools
from collections import Counter

import numpy as np

from acrobot_mj.olympics.episodes import global_episode
from acrobot_mj.olympics.protocol import to_protocol
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.olympics.scores import is_up
from acrobot_mj.olympics.sources import Source
from acrobot_mj.physics.models import resolve


def caught_after(T: np.ndarray, up: np.ndarray, start: float, end: float) -> float | None:
    """The time [s] after ``start`` from which the arm stays up until ``end``, or None."""
    rows = np.flatnonzero((T >= start) & (T < end))
    down = np.flatnonzero(~up[rows])
    if len(down) == 0:
        return 0.0
    last = down[-1] + 1
    return None if last == len(rows) else float(T[rows[last]] - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("controller", help="what acrobot-mj olympics scores: an entry, a run...")
    parser.add_argument("--model", default="report")
    parser.add_argument("--seeds", default="0,1,2")
    arguments = parser.parse_args()
    policy = protocol_for(arguments.model).global_policy
    p = resolve(arguments.model).params
    catches: list[float] = []
    windings: Counter[tuple[int, int]] = Counter()
    intervals = 0
    for seed in (int(s) for s in arguments.seeds.split(",")):
        source = Source(arguments.controller)
        recording, drawn = global_episode(source, arguments.model, seed, policy)
        T, X = recording.T, recording.X
        up = is_up(np.array([to_protocol(x) for x in X]), p.l1, p.l2, policy.height)
        times = [*drawn["reset_times"], policy.t_final]
        for start, end in itertools.pairwise(times):
            x = X[np.searchsorted(T, start)]
            turns = (round((x[0] - np.pi / 2) / (2 * np.pi)), round(x[1] / (2 * np.pi)))
            windings[turns] += 1
            intervals += 1
            found = caught_after(T, up, start, end)
            if found is not None:
                catches.append(found)
    summary = "-"
    if catches:
        summary = f"median {np.median(catches):.1f} s, mean {np.mean(catches):.1f} s"
    print(f"caught in {len(catches)} of {intervals} intervals after a reset; {summary}")
    print("windings (q1 turns, q2 turns) at the resets:", windings.most_common())


if __name__ == "__main__":
    main()
