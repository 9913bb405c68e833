"""Wall time of an AI Olympics entry's calls in the global policy's episode of a seed, as
``acrobot-mj olympics ENTRY --scores global --seed SEED`` runs it (the same episode and score):

    python scripts/time_entry.py tree 3

Prints the score, the calls' count, median, 99th percentile and max [ms], and the share over
the 0.002 s step.
"""

from __future__ import annotations

import sys
import time

from acrobot_mj.control.controller import Timed
from acrobot_mj.olympics import sources
from acrobot_mj.olympics.episodes import global_run
from acrobot_mj.olympics.protocol import GLOBAL
from acrobot_mj.olympics.scores import uptime
from acrobot_mj.physics.models import resolve


def main(entry: str, seed: int) -> None:
    started = time.perf_counter()
    controller = Timed(sources.build(sources.Source(entry), "ai_olympics"))
    built = time.perf_counter() - started
    targets, reset_times = GLOBAL.draw(seed)
    recording = global_run(controller, "ai_olympics", targets, reset_times)
    p = resolve("ai_olympics").params
    score = uptime(recording, p.l1, p.l2, GLOBAL.t_final, GLOBAL.height)["score"]
    calls = controller.summary(GLOBAL.dt)
    print(
        f"{entry} seed {seed}: score {score:.3f}; built in {built:.1f} s; {calls['calls']} calls, "
        f"median {calls['median_ms']:.3f} ms, p99 {calls['p99_ms']:.3f} ms, "
        f"max {calls['max_ms']:.1f} ms, over 2 ms {calls['over_step']:.4f}"
    )


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
