"""Wall time of an AI Olympics entry's calls in the global policy's episode of a seed, as
``acrobot-mj olympics ENTRY --scores global --seed SEED`` runs it (the same episode and score):

    python scripts/time_entry.py tree 3

Prints the score, the calls' count, median and max [s], and the share over the 0.002 s step.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from acrobot_mj.control.controller import Controller
from acrobot_mj.olympics import sources
from acrobot_mj.olympics.protocol import GLOBAL
from acrobot_mj.olympics.run import global_run
from acrobot_mj.olympics.scores import uptime
from acrobot_mj.physics.models import resolve


class Timed(Controller):
    """A controller whose calls' wall times [s] are kept."""

    def __init__(self, controller: Controller) -> None:
        self.controller, self.seconds = controller, list[float]()

    def reset(self, seed: int | None = None) -> None:
        self.controller.reset(seed)

    def act(self, x: np.ndarray, t: float) -> float:
        started = time.perf_counter()
        torque = self.controller.act(x, t)
        self.seconds.append(time.perf_counter() - started)
        return float(torque)


def main(entry: str, seed: int) -> None:
    started = time.perf_counter()
    controller = Timed(sources.build(sources.Source(entry), "ai_olympics"))
    built = time.perf_counter() - started
    targets, reset_times = GLOBAL.draw(seed)
    recording = global_run(controller, "ai_olympics", targets, reset_times)
    p = resolve("ai_olympics").params
    score = uptime(recording, p.l1, p.l2, GLOBAL.t_final, GLOBAL.height)["score"]
    s = np.array(controller.seconds)
    print(
        f"{entry} seed {seed}: score {score:.3f}; built in {built:.1f} s; {len(s)} calls, "
        f"median {np.median(s) * 1e3:.3f} ms, max {s.max() * 1e3:.1f} ms, "
        f"over 2 ms {np.mean(s > GLOBAL.dt):.4f}"
    )


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
