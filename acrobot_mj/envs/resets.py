"""Reset options of the envs, validated: ``start_noise`` and, for the single env, ``state``."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from acrobot_mj.checks import check_float

#: Reset options of the single env: ``start_noise`` (this episode's noise) or ``state`` (an exact
#: start ``(q1, q2, dq1, dq2)`` [rad, rad/s], as evaluation records store them, for replays).
RESET_OPTIONS = ("start_noise", "state")
#: Reset options the vector env shares with the single env.
SHARED_RESET_OPTIONS = ("start_noise",)


def reset_noise(
    options: Any,
    default: float,
    also_known: tuple[str, ...] = (),
    known: tuple[str, ...] = SHARED_RESET_OPTIONS,
) -> float:
    """The start noise of a reset: ``options["start_noise"]`` if given (validated), else
    ``default``; options outside ``known`` or a non-dict raise (``also_known``: options the
    caller took out before, named in the error)."""
    if options is not None and not isinstance(options, Mapping):
        raise TypeError(f"reset options must be a dict, got {options!r}")
    if not options:
        return default
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ValueError(f"unknown reset options {unknown}; known: {[*also_known, *known]}")
    if "start_noise" in options:
        return check_float("start_noise", options["start_noise"], 0.0, 1.0)
    return default


def reset_state(options: Any) -> np.ndarray | None:
    """The exact start ``options["state"]`` of a reset, as 4 floats (None without); giving
    ``start_noise`` as well is refused (the state is the whole start)."""
    if not isinstance(options, Mapping) or options.get("state") is None:
        return None
    if "start_noise" in options:
        raise ValueError("reset options 'state' and 'start_noise' exclude each other; give one")
    try:
        state = np.array(options["state"], dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"reset option 'state' must be 4 numbers (q1, q2, dq1, dq2), got {options['state']!r}"
        ) from None
    if state.shape != (4,):
        raise ValueError(
            f"reset option 'state' must be 4 numbers (q1, q2, dq1, dq2), got shape {state.shape}"
        )
    return state
