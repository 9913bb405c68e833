"""Summary statistics across runs, the one place summaries and sweeps compute them."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Training episodes whose scores a run's recent performance is judged by.
RECENT = 20


def spread(values: Sequence[float]) -> dict[str, float | None]:
    """Mean, standard deviation, median, quartiles and range of ``values`` (None, JSON's null,
    for each if there are none)."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return dict.fromkeys(("mean", "std", "median", "q25", "q75", "min", "max"))
    q25, q50, q75 = np.percentile(v, [25, 50, 75])
    return {
        "mean": float(v.mean()),
        "std": float(v.std()),
        "median": float(q50),
        "q25": float(q25),
        "q75": float(q75),
        "min": float(v.min()),
        "max": float(v.max()),
    }


def recent_median(values: Sequence[float]) -> float:
    """Median of the last :data:`RECENT` values (of a run's per-episode scores)."""
    return float(np.median(values[-RECENT:]))
