"""The analytic backend's rows of ``acrobot-mj bench``: the vector env on the compiled lumped
model against the same env on ``mujoco.batch``, side by side in one run, and the bare kernel.

At each N (1, 64, 1024, 4096) and ``frame_skip = 4`` (decisions of 0.2 s, as Gymnasium's and
gymnax's Acrobot-v1), in interleaved rounds, medians:

- ``analytic_env`` and ``mujoco_env``: ``env.step`` of random actions through autoresets, in
  sub-env steps (decisions) per second;
- ``kernel_scan`` (one thread) and ``kernel_scan_threads`` (numba's threads): many decisions of
  N acrobots in one compiled call of :func:`scan` (physics only: no task, resets, checks or
  Python), the ceiling of the analytic env;
- each also in simulated seconds per wall second (decisions/s x 0.2 s).

``profile`` splits the analytic env's step at N = 1024 into the physics (the kernel call) and
the rest (actions, observation, the task's outcome, flags and info), in microseconds
(medians of single calls; the physics stepped once more between the env's steps, so the states
stay the env's kind). :func:`one_step_gap` measures the rounding gap of one physics step
between the backends.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import mujoco
import numpy as np

from acrobot_mj.compiled import available_threads, compiled, prange, set_threads
from acrobot_mj.envs.batch import lumped_parameters
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.physics.integrators import UNLIMITED, step

SIZES = (1, 64, 1024, 4096)
FRAME_SKIP = 4


def _env_rate(env: AcrobotVectorEnv, steps: int) -> float:
    """Sub-env steps per second of ``env.step`` under random actions (autoresets included)."""
    actions = np.random.default_rng(0).integers(0, 3, (steps, env.num_envs))
    env.reset(seed=0)
    start = time.perf_counter()
    for a in actions:
        env.step(a)
    return env.num_envs * steps / (time.perf_counter() - start)


def scan(state, taus, constants, substeps):
    """``T`` decisions of every row ``i`` of ``state`` (``(N, 4)``, in place) with torques
    ``taus[i]`` (``(N, T)``, each row's contiguous) and ``constants = (a, b, c, d, e, dt, |dq1|,
    |dq2|)``: :func:`~acrobot_mj.physics.integrators.step` alone (semi-implicit Euler, the
    velocity limits after each physics step), no task, no resets. Compiled, its rows run on
    numba's threads with ``parallel=True``."""
    theta = (constants[0], constants[1], constants[2], constants[3], constants[4])
    dt, max_vel = constants[5], (constants[6], constants[7])
    for i in prange(state.shape[0]):
        q1, q2, dq1, dq2 = state[i, 0], state[i, 1], state[i, 2], state[i, 3]
        for t in range(taus.shape[1]):
            q1, q2, dq1, dq2 = step(q1, q2, dq1, dq2, taus[i, t], theta, dt, max_vel, substeps, 0)
        state[i, 0], state[i, 1], state[i, 2], state[i, 3] = q1, q2, dq1, dq2


def _scan_rate(n: int, decisions: int, threads: bool) -> float:
    """Decisions per second of the bare kernel :func:`scan`: ``decisions`` of ``n`` acrobots in
    one call, on one thread or (``threads``) on all of numba's."""
    # Not cached on disk: numba cannot load a cached function of a module loaded from its path.
    kernel = compiled(scan, parallel=threads, cache=False)
    if threads:
        set_threads(available_threads())
    constants = AcrobotVectorEnv(num_envs=n, backend="analytic").physics.constants
    state = np.tile([-np.pi / 2, 0.0, 0.0, 0.0], (n, 1))
    taus = np.random.default_rng(0).integers(-1, 2, (n, decisions)).astype(np.float64)
    kernel(state[:1].copy(), taus[:1, :1].copy(), constants, FRAME_SKIP)  # compiled first
    start = time.perf_counter()
    kernel(state, taus, constants, FRAME_SKIP)
    return n * decisions / (time.perf_counter() - start)


def profile(n: int = 1024, steps: int = 200) -> dict[str, float]:
    """Microseconds per ``step`` of the analytic env at ``n`` sub-envs and per call of its
    physics alone, alternately, each the median of ``steps`` calls (robust to the moments a
    loaded machine takes a thread away)."""
    env = AcrobotVectorEnv(num_envs=n, frame_skip=FRAME_SKIP, backend="analytic")
    actions = np.random.default_rng(0).integers(0, 3, (steps, n))
    physics, clock = env.physics, time.perf_counter
    env.reset(seed=0)
    whole, kernel = [], []
    for a in actions:
        start = clock()
        env.step(a)
        middle = clock()
        physics.step(FRAME_SKIP)
        whole.append(middle - start)
        kernel.append(clock() - middle)
    total, alone = statistics.median(whole), statistics.median(kernel)
    return {
        "step_us": total * 1e6,
        "physics_us": alone * 1e6,
        "rest_us": (total - alone) * 1e6,
        "physics_fraction": alone / total,
    }


def one_step_gap(states: int = 20_000, seed: int = 1) -> float:
    """Largest absolute gap [rad, rad/s] between one ``mj_step`` and one analytic physics step
    (no velocity limits) from random states (angles in [-pi, pi), velocities up to the limits)
    and torques in [-1, 1] N m: the rounding that the acrobot's chaos then amplifies."""
    model = AcrobotVectorEnv().model
    data = mujoco.MjData(model)
    theta, dt = lumped_parameters(model), model.opt.timestep
    rng, worst = np.random.default_rng(seed), 0.0
    for _ in range(states):
        speeds = rng.uniform(-1, 1, 2) * (MAX_VEL1, MAX_VEL2)
        x = np.concatenate([rng.uniform(-np.pi, np.pi, 2), speeds])
        tau = float(rng.uniform(-1, 1))
        data.qpos[:], data.qvel[:], data.ctrl[:] = x[:2], x[2:], tau
        mujoco.mj_step(model, data)
        new = step(*x.tolist(), tau, theta, dt, UNLIMITED)
        worst = max(worst, float(np.max(np.abs(np.concatenate([data.qpos, data.qvel]) - new))))
    return worst


def analytic_rows(quick: bool = False, rounds: int | None = None) -> dict[str, Any]:
    """The analytic and MuJoCo vector envs and the bare kernel at each of :data:`SIZES`, in
    decisions/s and simulated seconds per wall second (medians of interleaved rounds)."""
    rounds = rounds or (1 if quick else 3)
    budget = 20_000 if quick else 100_000  # sub-env steps per measurement
    decision = FRAME_SKIP * 0.05
    sizes: dict[int, dict[str, float]] = {}
    for n in SIZES:
        steps = max(10, budget // n)
        envs = {
            b: AcrobotVectorEnv(num_envs=n, frame_skip=FRAME_SKIP, backend=b)
            for b in ("analytic", "mujoco")
        }
        _env_rate(envs["analytic"], 2)  # compiled (or loaded from numba's cache) first
        samples: dict[str, list[float]] = {
            "analytic_env": [],
            "mujoco_env": [],
            "kernel_scan": [],
            "kernel_scan_threads": [],
        }
        decisions = max(10, 10 * budget // n)
        for _ in range(rounds):
            samples["analytic_env"].append(_env_rate(envs["analytic"], steps))
            samples["mujoco_env"].append(_env_rate(envs["mujoco"], steps))
            samples["kernel_scan"].append(_scan_rate(n, decisions, threads=False))
            samples["kernel_scan_threads"].append(_scan_rate(n, decisions, threads=True))
        row = {name: statistics.median(values) for name, values in samples.items()}
        for name in list(row):
            row[f"{name}_sim_s_per_s"] = row[name] * decision
        row["analytic_vs_mujoco"] = row["analytic_env"] / row["mujoco_env"]
        row["analytic_env_vs_kernel"] = row["analytic_env"] / row["kernel_scan"]
        row["analytic_nthread"] = envs["analytic"].nthread
        sizes[n] = row
    return {
        "frame_skip": FRAME_SKIP,
        "decision_s": decision,
        "sizes": sizes,
        "profile_N1024": profile(1024, 50 if quick else 200),
    }


def report_lines(rows: dict[str, Any]) -> list[str]:
    """The rows as text."""
    lines = [
        "",
        f"analytic backend (frame_skip {rows['frame_skip']}, decisions of "
        f"{rows['decision_s']:g} s): decisions/s, simulated s per wall s",
    ]
    head = f"{'N':>6} {'analytic env':>13} {'MuJoCo env':>11} {'scan 1 thread':>14} "
    lines.append(head + f"{'scan threads':>13} {'sim s/s analytic':>17} {'MuJoCo':>7} {'an/MJ':>6}")
    for n, r in rows["sizes"].items():
        lines.append(
            f"{n:>6} {r['analytic_env']:13.0f} {r['mujoco_env']:11.0f} {r['kernel_scan']:14.0f} "
            f"{r['kernel_scan_threads']:13.0f} {r['analytic_env_sim_s_per_s']:17.0f} "
            f"{r['mujoco_env_sim_s_per_s']:7.0f} {r['analytic_vs_mujoco']:6.1f}"
        )
    p = rows["profile_N1024"]
    lines.append(
        f"analytic env step at N=1024: {p['step_us']:.0f} us, of which physics "
        f"{p['physics_us']:.0f} us ({100 * p['physics_fraction']:.0f} %), the rest "
        f"{p['rest_us']:.0f} us"
    )
    return lines


if __name__ == "__main__":
    import sys

    print("\n".join(report_lines(analytic_rows(quick="--quick" in sys.argv))))
