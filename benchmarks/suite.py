"""The speed benchmarks behind ``acrobot-mj bench``: rates measured side by side in one run.

Every measurement returns steps per second; :func:`run` calls them in interleaved rounds (so
load on a shared machine hits all alike), keeps the median of each, and reports ratios to the
Gymnasium baselines and to the ``mujoco.batch`` ceiling, a scaling table over the number of
sub-envs and the peak memory of 1024 lockstep learners. Targets: our env >= 8x
Acrobot-v1, report SARSA on it >= 5x SARSA on Acrobot-v1, the vector env >= 0.8 of the batch
ceiling at N = 1024 (>= 0.9 at every N >= 256 of the scaling table), lockstep SARSA >= 25x SARSA
on Acrobot-v1, the book learner's decisions >= 1.5x and the tuned preset's over 20 seeds >= 3x
Acrobot-v1's ``env.step``, the AI Olympics robustness score's episodes projected at
most 10 minutes on 2 workers, and the vector env at least as fast as Gymnasium's ``SyncVectorEnv``
over single envs at N = 1, 4, 16 and 64 (measured A B A B in short alternating runs, medians).
Apart from the rates, the AI Olympics entries' time per call of their controllers
(``benchmarks/latency.py``).
"""

from __future__ import annotations

import importlib.util
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import gymnasium as gym
import mujoco

import acrobot_mj
from acrobot_mj.agents.base import Learning
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.envs.wrappers import make_gymnasium_acrobot
from acrobot_mj.train.learners import make_env
from acrobot_mj.train.lockstep import train_lockstep
from acrobot_mj.train.presets import PRESETS

Rate = Callable[[int], float]  # round -> steps per second
#: Sizes at which the vector env is measured against Gymnasium's SyncVectorEnv.
SYNC_SIZES = (1, 4, 16, 64)
#: The bench's parts: the rates (every row in steps per second and its ratios) and the entries'
#: time per call of their controllers (``benchmarks/latency.py``).
PARTS = ("rates", "latency")


def env_steps(env: gym.Env, steps: int) -> Rate:
    def measure(k: int) -> float:
        env.reset(seed=k)
        start = time.perf_counter()
        for i in range(steps):
            _, _, terminated, truncated, _ = env.step(i % 3)
            if terminated or truncated:
                env.reset()
        return steps / (time.perf_counter() - start)

    return measure


def raw_mj_step(steps: int) -> Rate:
    env = acrobot_mj.AcrobotEnv()
    model, data = env.model, env.data

    def measure(k: int) -> float:
        mujoco.mj_resetDataKeyframe(model, data, model.key("hanging").id)
        start = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        return steps / (time.perf_counter() - start)

    return measure


def vector_vs_sync(sizes: tuple[int, ...], env_steps: int, repeats: int) -> dict[int, dict]:
    """Per N: the vector env's and ``SyncVectorEnv``'s rates over the same single envs
    (``gymnasium.make_vec``, default and ``"sync"``), measured alternately A B A B ``repeats``
    times in short runs of about ``env_steps`` sub-env steps (load hits both alike), medians."""
    table, vector_steps = {}, sibling("scaling").vector_steps
    for n in sizes:
        steps = max(50, env_steps // n)
        ours = vector_steps(gym.make_vec(acrobot_mj.ENV_ID, num_envs=n), steps)
        sync = vector_steps(
            gym.make_vec(acrobot_mj.ENV_ID, num_envs=n, vectorization_mode="sync"), steps
        )
        a, b = [], []
        for k in range(repeats):
            a.append(ours(k))
            b.append(sync(k))
        rate, base = statistics.median(a), statistics.median(b)
        table[n] = {"vector_env": rate, "sync_vector_env": base, "ratio": rate / base}
    return table


def learning(env: gym.Env, config: Any, episodes: int) -> Rate:
    """Decisions per second of ``config``'s learner learning ``episodes`` episodes on ``env``
    (a fresh learner each round)."""

    def measure(k: int) -> float:
        agent = config.make_agent(k, env.observation_space)
        steps, start = 0, time.perf_counter()
        for episode in range(episodes):
            steps += run_episode(env, Learning(agent), episode).length
        return steps / (time.perf_counter() - start)

    return measure


def sarsa(env: gym.Env, episodes: int) -> Rate:
    """The report's SARSA learning on ``env``."""
    return learning(env, PRESETS["report"], episodes)


def learner(config: Any, episodes: int) -> Rate:
    """Training decisions per second of ``config``'s learner on its env (the whole loop: the
    env, the features, the updates and the bookkeeping of an episode)."""
    return learning(make_env(config), config, episodes)


def compile_seconds() -> dict[str, float]:
    """Seconds for a fresh process to build the book learner (compiled) and run one episode:
    with an empty numba cache (compiling) and again with the cache it wrote (loading)."""
    code = (
        "import time; t = time.perf_counter()\n"
        "from acrobot_mj.agents.base import Learning\n"
        "from acrobot_mj.envs.rollout import run_episode\n"
        "from acrobot_mj.train.learners import make_env\n"
        "from acrobot_mj.train.presets import PRESETS\n"
        "c = PRESETS['book']; env = make_env(c)\n"
        "run_episode(env, Learning(c.make_agent(0, env.observation_space)), 0)\n"
        "print(time.perf_counter() - t)"
    )
    times = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("cold", "cached"):
            out = subprocess.run(
                [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
            )
            times[label] = float(out.stdout.strip().splitlines()[-1])
    return times


def lockstep_sarsa(learners: int, episodes: int) -> Rate:
    """Training only (``wall_seconds`` of the records leaves out the final greedy runs)."""
    config = PRESETS["report"].replace(episodes=episodes)

    def measure(k: int) -> float:
        records = train_lockstep(
            config, list(range(k * learners, (k + 1) * learners)), greedy=False
        )
        return sum(r["steps"] for r in records) / sum(r["wall_seconds"] for r in records)

    return measure


def lockstep_peak_memory(learners: int = 1024) -> float:
    """Peak memory [MB] that numpy and Python allocate to train ``learners`` report learners
    for one short episode (Q tables, random blocks, the batch's state)."""
    tracemalloc.start()
    train_lockstep(
        PRESETS["report"].replace(episodes=1, max_episode_steps=20),
        list(range(learners)),
        greedy=False,
    )
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 1e6


def sibling(name: str) -> ModuleType:
    """``benchmarks/<name>.py`` as a module (this file is loaded from its path, not a package)."""
    path = Path(__file__).with_name(f"{name}.py")
    spec = importlib.util.spec_from_file_location(f"acrobot_mj_bench_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def olympics_episode(seconds: float) -> Rate:
    """Steps per second of one AI Olympics robustness episode of ``funnel`` (controller,
    estimator, sensor and motor wrappers, MuJoCo), velocity noise 0.2 rad/s: what bounds
    ``acrobot-mj olympics``'s robustness score."""
    from acrobot_mj.olympics.episodes import Conditions, episode

    conditions = Conditions(sensor={"sigma": (0.0, 0.0, 0.2, 0.2)})
    episode("funnel", "ai_olympics", 0.1, conditions, 0)  # built once, before any round

    def measure(k: int) -> float:
        start = time.perf_counter()
        recording = episode("funnel", "ai_olympics", seconds, conditions, k)
        return len(recording.U) / (time.perf_counter() - start)

    return measure


def robustness_episodes() -> int:
    """The robustness score's episodes on ``ai_olympics`` (722)."""
    from acrobot_mj.olympics.protocol import ROBUSTNESS
    from acrobot_mj.physics.models import resolve

    return ROBUSTNESS.episodes(resolve("ai_olympics"))


def robustness_minutes(rate: float, workers: int = 2) -> float:
    """Minutes for the protocol's robustness episodes of 5,000 steps at ``rate`` steps per
    second on each of ``workers`` processes (the target: at most 10 on 2 cores)."""
    return robustness_episodes() * 5000 / rate / workers / 60.0


def run(
    quick: bool = False,
    rounds: int | None = None,
    peer_python: str | None = None,
    parts: tuple[str, ...] = PARTS,
    entries: tuple[str, ...] | None = None,
) -> dict[str, Any]:
    """Measure the ``parts`` of :data:`PARTS` asked for: ``rates`` (:func:`rates_part`) and
    ``latency``, the time per call of each of ``entries``' controllers (None: the default
    entries; ``benchmarks/latency.py``)."""
    unknown = sorted(set(parts) - set(PARTS))
    if unknown or not parts:
        raise ValueError(f"the bench's parts are some of {','.join(PARTS)}, got {','.join(parts)}")
    if entries is not None and "latency" not in parts:
        raise ValueError("entries are timed by the latency part, which was not asked for")
    latency = sibling("latency")
    chosen = latency.checked(latency.DEFAULT_ENTRIES if entries is None else entries)
    result = rates_part(quick, rounds, peer_python) if "rates" in parts else {"machine": machine()}
    if "latency" in parts:
        result["latency"] = latency.latency_rows(chosen, quick)
    return result


def machine() -> dict[str, Any]:
    """The machine and the versions the bench measured on."""
    return {
        "cpus": os.cpu_count(),
        "processor": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "mujoco": mujoco.__version__,
        "gymnasium": gym.__version__,
    }


def rates_part(
    quick: bool = False, rounds: int | None = None, peer_python: str | None = None
) -> dict[str, Any]:
    """Measure every rate; returns the medians, ratios, scaling table and memory, and the
    peers (envpool, gymnax: ``benchmarks/peer_compare.py``; ``peer_python`` runs those that
    need their own environment)."""
    rounds = rounds or (1 if quick else 3)
    steps = 20_000 if quick else 100_000
    n = 256 if quick else 1024
    episodes = 3 if quick else 20
    scale = sibling("scaling")
    rates_of: dict[str, Rate] = {
        "gymnasium Acrobot-v1 env.step": env_steps(gym.make("Acrobot-v1"), steps),
        "acrobot_mj env via gymnasium.make": env_steps(make_env(PRESETS["report"]), steps),
        "raw mj_step loop": raw_mj_step(steps),
        f"mujoco.batch ceiling, N={n}": scale.batch_ceiling(n, steps // n * 5),
        f"vector env, N={n}": scale.vector_env(n, steps // n * 5),
        "SARSA on Gymnasium Acrobot-v1": sarsa(
            make_gymnasium_acrobot(max_episode_steps=1000), episodes
        ),
        "SARSA on acrobot_mj": sarsa(make_env(PRESETS["report"]), episodes),
        f"lockstep SARSA, K={n}": lockstep_sarsa(n, 1 if quick else 2),
        # train --preset book as a user runs it (no flags)
        "book learner (decisions)": learner(PRESETS["book"], 5 if quick else 40),
        "olympics robustness episode (steps)": olympics_episode(2.0 if quick else 10.0),
    }
    learner(PRESETS["book"], 1)(0)  # compiled (or loaded from numba's cache) before any round
    learner_rows, learner_ratios = sibling("learners").learner_rows(quick)  # the tuned learner
    rates_of.update(learner_rows)
    samples: dict[str, list[float]] = {name: [] for name in rates_of}
    for k in range(rounds):
        for name, measure in rates_of.items():
            samples[name].append(measure(k))
    rates = {name: statistics.median(values) for name, values in samples.items()}
    env_base = rates["gymnasium Acrobot-v1 env.step"]
    sarsa_base = rates["SARSA on Gymnasium Acrobot-v1"]
    ceiling = rates[f"mujoco.batch ceiling, N={n}"]
    ratios = {
        "env_vs_gymnasium": rates["acrobot_mj env via gymnasium.make"] / env_base,
        "sarsa_vs_gymnasium_sarsa": rates["SARSA on acrobot_mj"] / sarsa_base,
        "vector_env_vs_batch_ceiling": rates[f"vector env, N={n}"] / ceiling,
        "lockstep_sarsa_vs_gymnasium_sarsa": rates[f"lockstep SARSA, K={n}"] / sarsa_base,
    }
    ratios["book_vs_gymnasium_env_step"] = rates["book learner (decisions)"] / env_base
    for name, key in learner_ratios.items():  # the tuned learner's decisions / env.step
        ratios[key] = rates[name] / env_base
    baseline = rates_of["gymnasium Acrobot-v1 env.step"]
    seeds_row = sibling("learners").tuned_seeds_row(quick, baseline)
    ratios["tuned_seeds_vs_gymnasium_env_step"] = seeds_row["ratio"]
    versus_sync = vector_vs_sync(SYNC_SIZES, 4_000 if quick else 10_000, 5 if quick else 15)
    for size, row in versus_sync.items():
        ratios[f"vector_env_vs_sync_vector_env_N{size}"] = row["ratio"]
    sizes = [1, 64, 1024] if quick else [1, 4, 16, 64, 256, 1024, 4096]
    scaling_rounds = rounds if quick else max(rounds, scale.ROUNDS)
    scaling = scale.scaling_table(sizes, steps, scaling_rounds)
    for size in (size for size in sizes if size >= 256):  # the target: >= 0.9 of the batch
        row = scaling[size]
        ratios[f"vector_env_vs_batch_N{size}"] = row["vector_env"] / row["batch_ceiling"]
        ratios[f"vector_env_vs_batch_io_floor_N{size}"] = row["vector_env"] / row["batch_io_floor"]
    result = {
        "machine": machine(),
        "quick": quick,
        "rounds": rounds,
        "scaling_rounds": scaling_rounds,
        "rates_steps_per_second": rates,
        "ratios": ratios,
        "targets": {
            "env_vs_gymnasium": 8.0,
            "sarsa_vs_gymnasium_sarsa": 5.0,
            "vector_env_vs_batch_ceiling": 0.8,
            "lockstep_sarsa_vs_gymnasium_sarsa": 25.0,
            **{f"vector_env_vs_sync_vector_env_N{size}": 1.0 for size in SYNC_SIZES},
            "book_vs_gymnasium_env_step": 1.5,
            "tuned_seeds_vs_gymnasium_env_step": 3.0,
            **{f"vector_env_vs_batch_N{size}": 0.9 for size in sizes if size >= 256},
        },
        "tuned_seeds": seeds_row,
        "compiled_learner": compile_seconds(),
        "robustness_minutes_2_workers": robustness_minutes(
            rates["olympics robustness episode (steps)"]
        ),
        "vector_env_vs_sync_steps_per_second": versus_sync,
        "scaling_steps_per_second": scaling,
        "lockstep_peak_memory_mb_1024_learners": lockstep_peak_memory(1024),
        **sibling("peer_compare").sections(rates, quick, rounds, peer_python, scale.vector_env),
        "analytic_backend": sibling("analytic").analytic_rows(quick),
    }
    versus_gymnax(result)
    return result


def versus_gymnax(result: dict[str, Any]) -> None:
    """The analytic backend over gymnax's vmap+scan at N = 1024 in simulated seconds per wall
    second, a ratio with its target, when both were measured in this run."""
    analytic, peers = result["analytic_backend"], result.get("peers", {}).get("peers", {})
    gymnax = peers.get("gymnax", {}).get("rows", {}).get("1024")  # peers' rows: by str(N)
    if gymnax is None or 1024 not in analytic["sizes"]:
        return
    ours = analytic["sizes"][1024]["analytic_env_sim_s_per_s"]
    result["ratios"]["analytic_vs_gymnax_sim_seconds_N1024"] = (
        ours / gymnax["sim_seconds_per_second"]
    )
    result["targets"]["analytic_vs_gymnax_sim_seconds_N1024"] = 1.0


def report(result: dict[str, Any]) -> str:
    """The benchmark's tables as text: the parts measured."""
    lines = rates_lines(result) if "rates_steps_per_second" in result else []
    if "latency" in result:
        apart = [""] if lines else []
        lines += [*apart, *sibling("latency").latency_lines(result["latency"])]
    return "\n".join(lines)


def rates_lines(result: dict[str, Any]) -> list[str]:
    """The rates' tables as lines."""
    rates = result["rates_steps_per_second"]
    env_base = rates["gymnasium Acrobot-v1 env.step"]
    sarsa_base = rates["SARSA on Gymnasium Acrobot-v1"]
    ceiling = next(v for k, v in rates.items() if k.startswith("mujoco.batch"))
    lines = [f"{'measurement':<36} {'steps/s':>11} {'/ Acrobot-v1':>13} {'/ ceiling':>10}"]
    for name, rate in rates.items():
        base = sarsa_base if "SARSA" in name else env_base  # learners: per env step
        lines.append(f"{name:<36} {rate:11.0f} {rate / base:13.2f} {rate / ceiling:10.2f}")
    lines.append("")
    compiled = result["compiled_learner"]
    lines.append(
        f"book learner (compiled): build and first episode {compiled['cold']:.1f} s in "
        f"a fresh process, {compiled['cached']:.1f} s from numba's cache"
    )
    lines.append(sibling("learners").tuned_seeds_line(result["tuned_seeds"]))
    minutes = result["robustness_minutes_2_workers"]
    verdict = "meets" if minutes <= 10.0 else "MISSES"
    lines.append(
        f"olympics robustness ({robustness_episodes():,} episodes) projected on 2 workers: "
        f"{minutes:.1f} min "
        f"(target <= 10: {verdict}; absolute, so it moves with the machine's load)"
    )
    lines.append("")
    for key, value in result["ratios"].items():
        target = result["targets"].get(key)
        if target is None:  # measured beside the others, with no target
            lines.append(f"{key:<36} {value:6.2f}")
            continue
        verdict = "meets" if value >= target else "MISSES"
        lines.append(f"{key:<36} {value:6.2f}  (target >= {target:g}: {verdict})")
    lines.append("")
    lines += sibling("scaling").scaling_lines(result["scaling_steps_per_second"])
    lines.append("")
    lines.append(f"{'N':>6} {'vector env steps/s':>20} {'SyncVectorEnv':>15} {'ratio':>9}")
    for size, row in result["vector_env_vs_sync_steps_per_second"].items():
        lines.append(
            f"{size:>6} {row['vector_env']:20.0f} {row['sync_vector_env']:15.0f} "
            f"{row['ratio']:9.2f}"
        )
    lines.append(
        f"\npeak memory of 1024 lockstep learners: "
        f"{result['lockstep_peak_memory_mb_1024_learners']:.1f} MB"
    )
    if "peers" in result:  # and the env rows in simulated seconds per wall second
        lines += ["", *sibling("peer_compare").section_lines(result)]
    lines += sibling("analytic").report_lines(result["analytic_backend"])
    return lines
