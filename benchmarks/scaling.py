"""The vector env over the number of sub-envs, beside what ``mujoco.batch`` alone can do: the
bench's scaling table.

Per N, three rates measured A B C in turn each round (medians): the vector env under random
actions (autoresets included); the ceiling, bare ``Batch.step`` calls back to back on all cores
(the simulations at rest, nothing read or written between calls); and the floor of any env over
the batch, ``Batch.step`` with the least input and output an env needs (the controls written
from random actions, the observation rows read: two numpy calls between steps). The floor
against the ceiling is what that least work costs (measured: within the ceiling's own
run-to-run noise); the vector env against the floor is the env's own work (the velocity limits,
the observation's checks, the task's outcome, the flags).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np
from gymnasium.vector import VectorEnv
from mujoco.batch import Batch

import acrobot_mj
from acrobot_mj.envs.spaces import TORQUES
from acrobot_mj.envs.vector import AcrobotVectorEnv

Rate = Callable[[int], float]  # round -> steps per second
#: Rounds of the full bench's table: a measurement is short (about 0.1 s at N >= 256), and the
#: ceiling moves by 10 to 20 % between measurements on a loaded 2-core machine, so 15 A B C turns
#: (about 6 s a size) give medians that three turns do not.
ROUNDS = 15


def batch_ceiling(n: int, steps: int) -> Rate:
    """Bare ``Batch.step`` on all cores: what the vector env can at best reach."""
    batch = Batch(acrobot_mj.AcrobotEnv().model, n, nthread=0)

    def measure(k: int) -> float:
        batch.reset(keyframe=0)
        start = time.perf_counter()
        for _ in range(steps):
            batch.step()
        return n * steps / (time.perf_counter() - start)

    return measure


def io_floor(n: int, steps: int) -> Rate:
    """``Batch.step`` on all cores with the controls written before each step (torques of
    random actions) and the observation rows ``(q1, q2, dq1, dq2)`` copied out after it."""
    batch = Batch(acrobot_mj.AcrobotEnv().model, n, nthread=0)
    qpos, ctrl = batch.bind("qpos"), batch.bind("ctrl")[:, 0]
    rows = np.lib.stride_tricks.as_strided(qpos, (n, 4), qpos.strides, writeable=False)
    torques = np.array(TORQUES)[np.random.default_rng(0).integers(0, 3, (steps, n))]

    def measure(k: int) -> float:
        batch.reset(keyframe=0)
        start = time.perf_counter()
        for tau in torques:
            ctrl[:] = tau
            batch.step()
            rows.copy()
        return n * steps / (time.perf_counter() - start)

    return measure


def vector_steps(env: VectorEnv, steps: int) -> Rate:
    """Steps of all sub-envs per second under random actions (autoresets included)."""
    actions = np.random.default_rng(0).integers(0, 3, (steps, env.num_envs))

    def measure(k: int) -> float:
        env.reset(seed=k)
        start = time.perf_counter()
        for a in actions:
            env.step(a)
        return env.num_envs * steps / (time.perf_counter() - start)

    return measure


def vector_env(n: int, steps: int) -> Rate:
    """The vector env's sub-env steps per second under random actions."""
    return vector_steps(AcrobotVectorEnv(num_envs=n), steps)


def scaling_table(sizes: list[int], steps: int, rounds: int) -> dict[int, dict[str, float]]:
    """Per N in ``sizes``: the vector env's, the ceiling's and the floor's rates (sub-env steps
    per second, about ``steps`` of them per measurement), medians of ``rounds`` A B C turns."""
    table = {}
    for size in sizes:
        work = max(20, steps // size)
        rates = {
            "vector_env": vector_env(size, work),
            "batch_ceiling": batch_ceiling(size, work),
            "batch_io_floor": io_floor(size, work),
        }
        samples: dict[str, list[float]] = {name: [] for name in rates}
        for k in range(rounds):
            for name, measure in rates.items():
                samples[name].append(measure(k))
        table[size] = {name: statistics.median(values) for name, values in samples.items()}
    return table


def scaling_lines(table: dict) -> list[str]:
    """The scaling table as text: rates, and the vector env as a fraction of the ceiling and of
    the floor."""
    lines = [
        f"{'N':>6} {'vector env steps/s':>20} {'batch ceiling':>15} {'fraction':>9} "
        f"{'batch + I/O':>13} {'fraction':>9}"
    ]
    for size, row in table.items():
        ours, ceiling = row["vector_env"], row["batch_ceiling"]
        floor = row.get("batch_io_floor")  # absent from results of earlier versions
        tail = "" if floor is None else f" {floor:13.0f} {ours / floor:9.2f}"
        lines.append(f"{size:>6} {ours:20.0f} {ceiling:15.0f} {ours / ceiling:9.2f}{tail}")
    return lines
