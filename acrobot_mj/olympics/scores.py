"""The AI Olympics scores of trajectories, computed as the protocol computes them
(dfki-ric-underactuated-lab/double_pendulum: src/python/double_pendulum/analysis/
{leaderboard,benchmark,benchmark_scores}.py, leaderboard/acrobot/robustness_v2/
create_leaderboard.py) on the trajectory converted to its convention
(:func:`~acrobot_mj.olympics.protocol.to_protocol`). Every result is a plain float, bool or
dict, ready for JSON (an infinite swing-up time is ``None``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from acrobot_mj.olympics.protocol import (
    CRITERIA,
    HEIGHT,
    PERFORMANCE,
    ROBUSTNESS,
    Category,
    Criterion,
    Performance,
    to_protocol,
    wrap_top,
)


@dataclass(frozen=True)
class Recording:
    """One episode in our convention: times ``T`` (N+1,) [s], true states ``X`` (N+1, 4)
    ``(q1, q2, dq1, dq2)`` [rad, rad/s] and the elbow torques applied ``U`` (N,) [N m] (the
    shoulder's are 0); row ``i`` of ``U`` acts from ``T[i]`` to ``T[i+1]``."""

    T: np.ndarray
    X: np.ndarray
    U: np.ndarray

    def __post_init__(self) -> None:
        T, X, U = (np.asarray(a, dtype=float) for a in (self.T, self.X, self.U))
        if T.ndim != 1 or len(T) < 3:
            raise ValueError(f"T must be times (N+1,) with N >= 2, got shape {T.shape}")
        n = len(T) - 1
        if X.shape != (n + 1, 4):
            raise ValueError(f"X must be states ({n + 1}, 4) to match T, got shape {X.shape}")
        if U.shape != (n,):
            raise ValueError(f"U must be elbow torques ({n},) to match T, got shape {U.shape}")
        if not (np.isfinite(T).all() and np.isfinite(X).all() and np.isfinite(U).all()):
            raise ValueError("a trajectory must be finite (NaN or inf in T, X or U)")
        object.__setattr__(self, "T", T)
        object.__setattr__(self, "X", X)
        object.__setattr__(self, "U", U)

    def rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The first N rows ``(t_i, x_i, u_i)`` as the protocol's CSV keeps them, in its
        convention: times (N,), states (N, 4), torques (N, 2) (shoulder 0, elbow)."""
        n = len(self.U)
        torques = np.column_stack([np.zeros(n), self.U])
        return self.T[:n], to_protocol(self.X[:n]), torques


def tip_heights(states: np.ndarray, l1: float, l2: float) -> np.ndarray:
    """The tip's heights (N,) [m] above the shoulder of protocol states (N, 4), as its plant's
    forward kinematics gives them: ``-l1 cos theta1 - l2 cos(theta1 + theta2)``."""
    theta = np.asarray(states, dtype=float).T[:2]
    return -l1 * np.cos(theta[0]) - l2 * np.cos(theta[0] + theta[1])


def is_up(states: np.ndarray, l1: float, l2: float, height: float = HEIGHT) -> np.ndarray:
    """Whether the tip is above ``height (l1 + l2)`` (strictly), per protocol state (N, 4)."""
    return tip_heights(states, l1, l2) > height * (l1 + l2)


def swingup_time(times: np.ndarray, up: np.ndarray, t_final: float) -> float:
    """The protocol's swing-up time [s] (method "height", has_to_stay) over N rows: from the
    second-last row back to row 1, the earliest row of the last unbroken run of rows up; the
    last row itself is never looked at and row 0 never chosen; ``T[-1]`` where the second-last
    row is down (a failure); inf where the rows end before ``0.99 t_final``."""
    if times[-1] < 0.99 * t_final:
        return math.inf
    index = len(times) - 1
    for i in range(len(up) - 2, 0, -1):
        if up[i]:
            index = i
        else:
            break
    return float(times[index])


def performance(
    trajectory: Recording, l1: float, l2: float, protocol: Performance = PERFORMANCE
) -> dict[str, float | bool | None]:
    """The performance criteria of ``trajectory`` (arm lengths ``l1``, ``l2`` [m]), its
    success and v2 score: ``swingup_time`` [s] (None: inf), ``energy`` [J] (sum of ``|dtheta
    u|``), ``tau_cost`` [N^2 m^2 s], ``tau_smoothness`` [N m] (population std of torque
    changes, summed over the joints), ``velocity_cost`` [rad^2/s], ``success`` (swing-up time
    before the last row's time), ``score``."""
    T, X, U = trajectory.rows()
    time = swingup_time(T, is_up(X, l1, l2, protocol.height), protocol.t_final)
    delta_t = np.diff(T)
    V = X.T[2:].T
    criteria = {
        "swingup_time": time,
        "energy": float(
            np.sum(np.abs(np.diff(X.T[0]) * U.T[0][:-1]))
            + np.sum(np.abs(np.diff(X.T[1]) * U.T[1][:-1]))
        ),
        "tau_cost": float(np.einsum("ij, i, jk, ik", U[:-1], delta_t, np.eye(2), U[:-1])),
        "tau_smoothness": float(np.std(np.diff(U.T[0])) + np.std(np.diff(U.T[1]))),
        "velocity_cost": float(np.einsum("ij, i, jk, ik", V[:-1], delta_t, np.eye(2), V[:-1])),
    }
    success = bool(time < T[-1])
    score = score_v2(criteria, success, protocol.criteria)
    return {
        **criteria,
        "swingup_time": None if math.isinf(time) else time,
        "success": success,
        "score": score,
    }


def score_v2(
    criteria: Mapping[str, float | None],
    success: bool,
    normalised: Sequence[Criterion] = CRITERIA,
) -> float:
    """The v2 score: ``success (1 - (1/n) sum_c tanh(pi w_c c / norm_c))`` over the ``n``
    weighted criteria of ``normalised`` (the protocol's by default; a ``None`` criterion is
    inf)."""
    total = 0.0
    for c in normalised:
        value = criteria[c.name]
        total += np.tanh(np.pi * c.weight * (math.inf if value is None else value) / c.norm)
    weighted = sum(1 for c in normalised if c.weight != 0.0)
    return float(int(success) * (1.0 - 1.0 / weighted * total))


def final_success(
    state: np.ndarray, epsilon: tuple[float, float, float, float] = ROBUSTNESS.epsilon
) -> bool:
    """Whether a final true state (4,) in our convention ends a robustness episode well: within
    ``epsilon`` (the protocol's by default) of upright at rest, after its wrapping
    (:func:`~acrobot_mj.olympics.protocol.wrap_top`)."""
    x = wrap_top(to_protocol(np.asarray(state, dtype=float).reshape(4)))
    goal = (np.pi, 0.0, 0.0, 0.0)
    return bool(all(abs(x[k] - goal[k]) < epsilon[k] for k in range(4)))


#: Successes of a category's episodes: per sweep, per level, per episode.
Successes = Sequence[Sequence[Sequence[bool]]]


def level_fractions(category: Category, successes: Successes) -> list[list[float]]:
    """Each level's success fraction, per sweep (its shape checked against ``category``)."""
    if len(successes) != len(category.sweeps):
        raise ValueError(
            f"{category.key}: {len(category.sweeps)} sweeps expected, got {len(successes)}"
        )
    fractions = []
    for sweep, levels in zip(category.sweeps, successes, strict=True):
        if len(levels) != len(sweep.levels) or any(len(e) != category.repetitions for e in levels):
            raise ValueError(
                f"{category.key}, {sweep.parameter}: {len(sweep.levels)} levels of "
                f"{category.repetitions} episodes expected"
            )
        fractions.append([float(np.average(e)) for e in levels])
    return fractions


def category_score(category: Category, successes: Successes) -> float:
    """The category's score: the fraction of levels whose success fraction exceeds 1/2 (a
    ``majority`` category), else the fraction of successful episodes."""
    fractions = level_fractions(category, successes)
    if category.majority:
        passed = [f > 0.5 for sweep in fractions for f in sweep]
        return float(np.sum(passed) / len(passed))
    every = [bool(s) for levels in successes for episodes in levels for s in episodes]
    return float(np.sum(every) / len(every))


def overall_robustness(scores: Mapping[str, float], categories: Sequence[Category]) -> float:
    """The overall robustness score: the six category scores' mean, summed as the
    leaderboard sums them (``1/6 a + 1/6 b + ...``, in its order)."""
    missing = [c.key for c in categories if c.key not in scores]
    if missing:
        raise ValueError(f"the overall robustness needs every category: missing {missing}")
    return float(sum(1.0 / len(categories) * scores[c.key] for c in categories))


def uptime(
    trajectory: Recording, l1: float, l2: float, t_final: float, height: float = HEIGHT
) -> dict[str, float]:
    """The global policy's ``uptime`` [s]: the sum of ``T[i] - T[i-1]`` over the first N rows
    up (above ``height (l1 + l2)``; row 0 counts 0), and its ``score``: uptime over ``t_final``
    [s]."""
    T, X, _ = trajectory.rows()
    up = is_up(X, l1, l2, height)
    time = float(np.sum(np.diff(T, prepend=0.0)[up]))
    return {"uptime": time, "score": float(1.0 * time / t_final)}


def t_quantile(p: float, dof: int) -> float:
    """Student's t quantile: the x with P(T <= x) = ``p`` (0.5 <= p < 1) for ``dof`` >= 1
    degrees of freedom; the CDF integrated by Simpson's rule on a change of variable that
    maps the whole half-line onto a finite interval, solved by bisection (to about 1e-9)."""
    if not 0.5 <= p < 1.0 or dof < 1:
        raise ValueError(f"t_quantile needs 0.5 <= p < 1 and dof >= 1, got p={p}, dof={dof}")
    log_c = math.lgamma((dof + 1) / 2) - math.lgamma(dof / 2) - 0.5 * math.log(dof * math.pi)

    def above_half(x: float) -> float:  # P(0 <= T <= x), with t = x s, s in [0, 1]
        s = np.linspace(0.0, 1.0, 2001)
        density = np.exp(log_c - (dof + 1) / 2 * np.log1p((x * s) ** 2 / dof))
        weights = np.ones(s.size)
        weights[1:-1:2], weights[2:-1:2] = 4.0, 2.0
        return float(x * (s[1] - s[0]) / 3.0 * weights @ density)

    low, high = 0.0, 1.0
    while above_half(high) < p - 0.5:
        low, high = high, 2.0 * high
    for _ in range(100):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if above_half(middle) < p - 0.5 else (low, middle)
    return 0.5 * (low + high)


def mean_interval(values: Sequence[float], level: float = 0.95) -> dict[str, object]:
    """The mean of ``values`` (episodes of independent seeds) and its ``level`` confidence
    interval by Student's t (None with fewer than two values)."""
    x = np.asarray(values, dtype=float)
    mean = float(x.mean())
    if x.size < 2:
        return {"mean": mean, "interval": None, "level": level}
    half = t_quantile(0.5 + level / 2, x.size - 1) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return {"mean": mean, "interval": [mean - half, mean + half], "level": level}
