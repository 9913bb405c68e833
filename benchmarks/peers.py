"""The peers' acrobots, timed: envpool's ``Acrobot-v1`` (C++ classic control, batched) and
gymnax's ``Acrobot-v1`` under ``jax.vmap`` and ``jax.lax.scan`` (JAX on the CPU).

Runs by itself in any Python that has the peers (it imports nothing of ``acrobot_mj``, only
numpy, and each peer when it is timed), so gymnax, which pins an older Gymnasium, can live in
an environment of its own::

    python benchmarks/peers.py --json [--only envpool,gymnax] [--sizes 1,64,1024]
        [--steps 100000] [--rounds 3]

prints one JSON object: per peer its version and, per N, ``steps_per_second`` (sub-env steps
of all N per wall second) and ``sim_seconds_per_second`` (simulated seconds per wall second:
steps per second times :data:`PEER_DT`); gymnax adds ``compile_seconds`` per N; peers that
cannot run are under ``skipped`` with one line each. ``acrobot-mj bench --peer-python PATH``
runs it in a subprocess (``benchmarks/peer_compare.py``); the suite also imports it to time
peers installed beside the package.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import importlib.util
import json
import os
import statistics
import sys
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

Rate = Callable[[int], float]  # round -> sub-env steps per second
#: Simulated time per step of both peers' ``Acrobot-v1`` [s] (Gymnasium's dt of 0.2 s).
PEER_DT = 0.2
PEERS = ("envpool", "gymnax")
SIZES = (1, 64, 1024)
#: Fewest steps of all N per measurement (fewer time mostly the call and threads waking up).
MIN_STEPS = 500
#: What to install where a peer is missing (docs/guide/benchmarks.md has the whole recipe).
INSTALL = {
    "envpool": "pip install 'acrobot-mj[bench]' (or envpool) beside the package",
    "gymnax": "it needs a peer env of its own, see docs/guide/benchmarks.md",
}


def envpool_threads(n: int) -> int:
    """envpool's worker threads for ``n`` envs: one per env up to the CPUs (one for N = 1)."""
    return max(1, min(n, os.cpu_count() or 1))


def envpool_rate(n: int, steps: int) -> Rate:
    """``envpool.make_gymnasium("Acrobot-v1", num_envs=n)`` stepped synchronously (batch of
    all ``n``) ``steps`` times with random actions drawn beforehand; envpool resets finished
    envs on the next step itself."""
    import envpool

    with warnings.catch_warnings():  # its Box spaces warn about float32 bounds
        warnings.simplefilter("ignore")
        env = envpool.make_gymnasium("Acrobot-v1", num_envs=n, num_threads=envpool_threads(n))
    actions = np.random.default_rng(0).integers(0, 3, (steps, n)).astype(np.int32)

    def measure(k: int) -> float:
        env.reset()
        start = time.perf_counter()
        for a in actions:
            env.step(a)
        return n * steps / (time.perf_counter() - start)

    return measure


def gymnax_rollout(n: int, steps: int) -> tuple[Callable[[Any], Any], float]:
    """gymnax's ``Acrobot-v1``: ``n`` envs under ``jax.vmap``, ``steps`` steps in one
    ``jax.lax.scan`` with the random actions drawn inside it (gymnax's ``step`` resets finished
    envs itself), jitted and compiled ahead. Returns the compiled rollout (a PRNG key -> the
    final states and summed rewards) and its compile time [s]."""
    import gymnax
    import jax

    env, params = gymnax.make("Acrobot-v1")
    step = jax.vmap(env.step, in_axes=(0, 0, 0, None))

    def rollout(key: Any) -> Any:
        key, reset_key = jax.random.split(key)
        _, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(reset_key, n), params)

        def body(carry: Any, _: Any) -> tuple[Any, None]:
            key, state, total = carry
            key, act_key, step_key = jax.random.split(key, 3)
            actions = jax.random.randint(act_key, (n,), 0, 3)
            out = step(jax.random.split(step_key, n), state, actions, params)
            return (key, out[1], total + out[2]), None  # (obs, state, reward, ...)

        zeros = jax.numpy.zeros(n)
        (_, state, total), _ = jax.lax.scan(body, (key, state, zeros), None, length=steps)
        return state, total

    start = time.perf_counter()
    compiled = jax.jit(rollout).lower(jax.random.PRNGKey(0)).compile()
    return compiled, time.perf_counter() - start


def gymnax_rate(n: int, steps: int) -> tuple[Rate, float]:
    """Steps per second of :func:`gymnax_rollout` after one warm-up call, each timed to
    ``block_until_ready``; and the compile time [s]."""
    import jax

    compiled, compile_seconds = gymnax_rollout(n, steps)
    jax.block_until_ready(compiled(jax.random.PRNGKey(0)))  # warm-up

    def measure(k: int) -> float:
        key = jax.random.PRNGKey(k + 1)
        start = time.perf_counter()
        jax.block_until_ready(compiled(key))
        return n * steps / (time.perf_counter() - start)

    return measure, compile_seconds


def missing(peer: str) -> str | None:
    """Why ``peer`` cannot run in this Python (None when it can)."""
    needs = {"envpool": ("envpool",), "gymnax": ("gymnax", "jax")}[peer]
    absent = [name for name in needs if importlib.util.find_spec(name) is None]
    if not absent:
        return None
    return f"{peer}: {' and '.join(absent)} not installed in {sys.executable} ({INSTALL[peer]})"


def build(peer: str, sizes: tuple[int, ...], steps: int) -> tuple[dict[int, Rate], dict]:
    """Rates of ``peer`` per N (about ``steps`` sub-env steps per measurement, at least
    :data:`MIN_STEPS` steps of all N) and what to report beside them (its version; gymnax's
    compile times [s] and jax's version)."""
    extra: dict[str, Any] = {"version": importlib.metadata.version(peer)}
    rates: dict[int, Rate] = {}
    compile_seconds = {}
    for n in sizes:
        work = max(MIN_STEPS, steps // n)
        if peer == "envpool":
            rates[n] = envpool_rate(n, work)
        else:
            rates[n], compile_seconds[str(n)] = gymnax_rate(n, work)
    if peer == "gymnax":
        import jax

        extra.update(jax=jax.__version__, compile_seconds=compile_seconds)
    return rates, extra


def build_all(
    peers: tuple[str, ...], sizes: tuple[int, ...], steps: int
) -> tuple[dict[str, tuple[dict[int, Rate], dict]], dict[str, str]]:
    """:func:`build` for each of ``peers`` that can run here; one line for each that cannot."""
    skipped = {peer: why for peer in peers if (why := missing(peer))}
    built = {}
    for peer in peers:
        if peer in skipped:
            continue
        try:
            built[peer] = build(peer, sizes, steps)
        except Exception as error:  # a peer that fails to build is skipped, said in one line
            skipped[peer] = f"{peer}: failed to start ({type(error).__name__}: {error})"
    return built, {peer: " ".join(why.split()) for peer, why in skipped.items()}


def row(samples: list[float], dt: float) -> dict[str, float]:
    """The median of ``samples`` [steps/s] and the simulated seconds per wall second it makes
    at ``dt`` [s] per step."""
    rate = statistics.median(samples)
    return {"steps_per_second": rate, "sim_seconds_per_second": rate * dt}


def measure_peers(
    peers: tuple[str, ...], sizes: tuple[int, ...], steps: int, rounds: int
) -> dict[str, Any]:
    """Every runnable peer at every N, in interleaved rounds (medians); see the module
    docstring for the result's shape."""
    built, skipped = build_all(peers, sizes, steps)
    samples: dict[tuple[str, int], list[float]] = {
        (peer, n): [] for peer, (rates, _) in built.items() for n in rates
    }
    for k in range(rounds):
        for peer, n in samples:
            samples[(peer, n)].append(built[peer][0][n](k))
    result: dict[str, Any] = {"dt": PEER_DT, "python": sys.executable, "peers": {}}
    for peer, (_, extra) in built.items():
        rows = {str(n): row(samples[(peer, n)], PEER_DT) for n in sizes}
        result["peers"][peer] = {**extra, "rows": rows}
    result["skipped"] = skipped
    return result


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description="Time envpool's and gymnax's Acrobot-v1.")
    p.add_argument("--json", action="store_true", help="print one JSON object (else a table)")
    p.add_argument("--only", default=",".join(PEERS), help="comma-separated peers to time")
    p.add_argument("--sizes", default=",".join(map(str, SIZES)), help="comma-separated N")
    p.add_argument("--steps", type=int, default=100_000, help="sub-env steps per measurement")
    p.add_argument("--rounds", type=int, default=3, help="interleaved rounds (medians)")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    peers = tuple(p for p in args.only.split(",") if p)
    unknown = [p for p in peers if p not in PEERS]
    if unknown:
        raise SystemExit(f"unknown peers {unknown}: choose from {list(PEERS)}")
    sizes = tuple(int(n) for n in args.sizes.split(","))
    result = measure_peers(peers, sizes, args.steps, args.rounds)
    if args.json:
        print(json.dumps(result))
        return 0
    for peer, entry in result["peers"].items():
        for n, row in entry["rows"].items():
            print(
                f"{peer} Acrobot-v1, N={n}: {row['steps_per_second']:.0f} steps/s, "
                f"{row['sim_seconds_per_second']:.0f} simulated s/s"
            )
    for why in result["skipped"].values():
        print(f"skipped {why}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
