"""What the benchmarks share: interleaved timing rounds and a ratio table."""

from __future__ import annotations

import statistics
from collections.abc import Callable


def interleaved(runs: dict[str, Callable[[int], float]], rounds: int) -> dict[str, list[float]]:
    """Call every run once per round, in turn (so load on a shared machine hits all alike);
    each returns a rate. Round ``k`` passes ``k`` (a seed)."""
    rates: dict[str, list[float]] = {name: [] for name in runs}
    for k in range(rounds):
        for name, run in runs.items():
            rates[name].append(run(k))
    return rates


def print_ratios(rates: dict[str, list[float]], baseline: str, unit: str = "steps/s") -> None:
    """Median rate, time per step and ratio to ``baseline`` for each entry."""
    base = statistics.median(rates[baseline])
    width = max(len(name) for name in rates) + 2
    print(f"{'':<{width}} {unit:>10} {'us/step':>8} {'ratio':>6}")
    for name, values in rates.items():
        rate = statistics.median(values)
        print(f"{name:<{width}} {rate:10.0f} {1e6 / rate:8.2f} {rate / base:6.2f}")
