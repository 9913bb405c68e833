"""Linear Sarsa(lambda) over binary features (Sutton and Barto, 2nd ed., section 12.7), with
sparse traces (those below ``trace_cutoff`` dropped). A decision is one compiled call
(:func:`decide`, after the tile coding in the same call) whose sums and updates follow numpy's
order of operations."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.agents.base import DivergenceError, RandomStream, checked_values, policy
from acrobot_mj.agents.features import TileCoder, tile_active
from acrobot_mj.agents.sarsa import discount, exploration, step_size
from acrobot_mj.checks import check_memory
from acrobot_mj.compiled import compiled, jitable, without_dispatch
from acrobot_mj.settings import Settings, setting

TRACES = ("replacing", "accumulating")
#: numpy's pairwise block: up to this many values it sums in one unrolled pass.
PAIRWISE_BLOCK = 128


@dataclass(frozen=True)
class SarsaLambdaConfig(Settings):
    """Sarsa(lambda)'s hyperparameters (the book's); a ``trace_cutoff`` of 0 keeps every trace."""

    alpha: float = step_size(0.2 / 48)
    gamma: float = discount(1.0)
    epsilon: float = exploration(0.0)
    lam: float = setting(0.9, "sarsa_lambda: trace decay lambda", low=0.0, high=1.0)
    traces: str = setting("replacing", "sarsa_lambda: replacing or accumulating", choices=TRACES)
    trace_cutoff: float = setting(
        1e-3, "sarsa_lambda: traces below this are dropped", low=0.0, high=1.0, high_open=True
    )


@jitable
def pairwise_sum(values, n) -> float:
    """The sum of ``values[:n]`` in numpy's pairwise order (n up to 128)."""
    if n < 8:
        total = 0.0
        for i in range(n):
            total += values[i]
        return total
    r = values[:8].copy()
    i = 8
    while i + 8 <= n:
        for k in range(8):
            r[k] += values[i + k]
        i += 8
    total = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        total += values[i]
        i += 1
    return total


@jitable
def action_values(w, active, num_features, gathered, out) -> None:
    """Q(s, a) of every action into ``out``: the pairwise sum of ``a``'s active weights."""
    for a in range(out.shape[0]):
        for i in range(active.size):
            gathered[i] = w[a * num_features + active[i]]
        out[a] = pairwise_sum(gathered, active.size)


@jitable
def decide(w, a, active, following, outcome, traces, count, settings, stream, scratch) -> tuple:
    """One decision after ``a`` at the ``active`` features; ``following``: the next state's.
    ``traces = (pairs, values, place, undo pairs, undo values)``: the live traces, each weight's
    place among them (-1: none) and the log of newly traced weights' old values (off where
    empty). Returns ``(a', traces, logged, position, delta)``, ``a'`` -1 once the episode is
    over, -2 if ``delta`` is not finite (nothing updated)."""
    reward, terminated, truncated = outcome
    pairs, values, place, undo_pairs, undo_values = traces
    n, logged = count
    alpha, gamma, factor, cutoff, epsilon, num_features, replacing = settings
    gathered, q = scratch
    block, position = stream
    for i in range(active.size):  # delta = r - Q(s, a)
        gathered[i] = w[a * num_features + active[i]]
    delta = reward - pairwise_sum(gathered, active.size)
    for i in range(active.size):  # mark (s, a): known traces first, then new ones
        at = place[a * num_features + active[i]]
        if at >= 0:
            values[at] = 1.0 if replacing else values[at] + 1.0
    for i in range(active.size):
        pair = a * num_features + active[i]
        if place[pair] < 0:
            if undo_pairs.size > 0:
                undo_pairs[logged], undo_values[logged] = pair, w[pair]
                logged += 1
            place[pair], pairs[n], values[n] = n, pair, 1.0
            n += 1
    a2 = -1
    if not terminated:
        action_values(w, following, num_features, gathered, q)
        a2, position = policy(q, epsilon, block, position)
        delta = delta + gamma * q[a2]
    if not -math.inf < delta < math.inf:
        return -2, n, logged, position, delta
    step, kept = alpha * delta, 0
    for i in range(n):  # w += alpha delta z, then z *= gamma lambda
        pair = pairs[i]
        w[pair] += step * values[i]
        if terminated or truncated:
            continue
        value = values[i] * factor
        if cutoff <= 0.0 or value >= cutoff:
            pairs[kept], values[kept], place[pair] = pair, value, kept
            kept += 1
        else:
            place[pair] = -1
    if terminated or truncated:
        return -1, n, logged, position, delta
    return a2, kept, logged, position, delta


@jitable
def decide_tiles(
    obs, tables, w, a, active, following, outcome, traces, count, settings, stream, scratch
) -> tuple:
    """:func:`decide`, the next state's tiles first coded from ``obs`` into ``following``."""
    if not outcome[1]:  # terminated: no next state
        low, scale, offset, extent, wrap, stride, base = tables
        tile_active(obs, low, scale, offset, extent, wrap, stride, base, following)
    return decide(w, a, active, following, outcome, traces, count, settings, stream, scratch)


@jitable
def clear(pairs, place, n) -> None:
    for i in range(n):
        place[pairs[i]] = -1


@jitable
def rewind(w, undo_pairs, undo_values, logged) -> None:
    """Undo the log on ``w``, latest entry first."""
    for u in range(logged - 1, -1, -1):
        w[undo_pairs[u]] = undo_values[u]


class SarsaLambda:
    """Sarsa(lambda) over ``features`` (``active(obs)``, ``num_features``, ``num_active``)."""

    def __init__(
        self,
        features: Any,
        n_actions: int = 3,
        *,
        alpha: float = 0.2 / 48,
        gamma: float = 1.0,
        lam: float = 0.9,
        epsilon: float = 0.0,
        traces: str = "replacing",
        trace_cutoff: float = 1e-3,
        seed: int | np.random.SeedSequence | None = None,
    ) -> None:
        self.config = SarsaLambdaConfig(alpha, gamma, epsilon, lam, traces, trace_cutoff)
        if features.num_active > PAIRWISE_BLOCK:
            raise ValueError(
                f"Sarsa(lambda) sums at most {PAIRWISE_BLOCK} active features "
                f"(numpy's order), got {features.num_active}"
            )
        self.features, self.n_actions = features, n_actions
        self.num_features = features.num_features
        weights = float(n_actions) * self.num_features  # three arrays of their size: the
        check_memory(f"Sarsa(lambda) with {weights:,.0f} weights", 24.0 * weights)  # index, a copy
        self.stream = RandomStream(seed)
        self._w = np.zeros(n_actions * self.num_features)  # w[a, i] at a * num_features + i
        room = min(self._w.size, 64 * features.num_active)
        self._pairs, self._values = np.zeros(room, dtype=np.int64), np.zeros(room)
        self._place = np.full(self._w.size, -1, dtype=np.int64)
        undo = (np.zeros(0, dtype=np.int64), np.zeros(0))  # no log until asked for
        self._undo: tuple[np.ndarray, ...] = undo
        # the kernel's arrays
        self._traces: tuple[np.ndarray, ...] = (self._pairs, self._values, self._place, *self._undo)
        self._count = self._logged = 0
        self._a, self._active = -1, np.zeros(features.num_active, dtype=np.int64)
        self._next = np.zeros(features.num_active, dtype=np.int64)  # the tiles' two buffers
        self._tiles = isinstance(features, TileCoder)
        self._scratch = (np.zeros(features.num_active), np.zeros(n_actions))
        c = self.config
        self._settings = (
            c.alpha,
            c.gamma,
            c.gamma * c.lam,
            c.trace_cutoff,
            c.epsilon,
            self.num_features,
            c.traces == "replacing",
        )
        self._decide = compiled(decide)
        self._decide_tiles = self._first_tiles_call  # then without numba's dispatch
        self._begun, self._stream_at_start = 0, self.stream.position_now()

    @property
    def alpha(self) -> float:
        return self.config.alpha

    @property
    def w(self) -> np.ndarray:
        """The weights ``(n_actions, num_features)``, a view."""
        return self._w.reshape(self.n_actions, self.num_features)

    @property
    def traces(self) -> np.ndarray:
        """The eligibility traces, dense ``(n_actions, num_features)``."""
        z = np.zeros(self._w.size)
        z[self._pairs[: self._count]] = self._values[: self._count]
        return z.reshape(self.n_actions, self.num_features)

    def q_values(self, obs: Any) -> np.ndarray:
        return self._values_at(self.features.active(obs))

    def _values_at(self, active: np.ndarray) -> np.ndarray:
        q = np.zeros(self.n_actions)
        compiled(action_values)(self._w, active, self.num_features, self._scratch[0], q)
        return q

    def begin_episode(self, obs: Any) -> int:
        compiled(clear)(self._pairs, self._place, self._count)
        self._count = self._logged = 0
        self._begun += 1
        self._stream_at_start = self.stream.position_now()
        self._active = self.features.active(obs)
        stream = self.stream
        stream.reserve(2)
        self._a, stream.position = compiled(policy)(
            self._values_at(self._active), self.config.epsilon, stream.block, stream.position
        )
        return self._a

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        """One step from ``(r, s')``; a' (None once the episode is over)."""
        if self._a < 0:
            raise RuntimeError("learn() needs an episode in progress: call begin_episode()")
        k, undo = self.features.num_active, self._undo[0].size
        if self._count + k > self._pairs.size or (undo and self._logged + k > undo):
            self._make_room()
        stream = self.stream
        if stream.block.size - stream.position < 2:
            stream.reserve(2)
        traces = self._traces
        outcome = (float(reward), bool(terminated), bool(truncated))
        if self._tiles:  # the next tiles coded in the same compiled call
            following = self._active if terminated else self._next
            a2, self._count, self._logged, stream.position, delta = self._decide_tiles(
                np.ascontiguousarray(obs, dtype=np.float64),
                self.features.tables,
                self._w,
                self._a,
                self._active,
                following,
                outcome,
                traces,
                (self._count, self._logged),
                self._settings,
                (stream.block, stream.position),
                self._scratch,
            )
            self._next = self._active
        else:
            following = self._active if terminated else self.features.active(obs)
            a2, self._count, self._logged, stream.position, delta = self._decide(
                self._w,
                self._a,
                self._active,
                following,
                outcome,
                traces,
                (self._count, self._logged),
                self._settings,
                (stream.block, stream.position),
                self._scratch,
            )
        if a2 == -2:
            self._a = -1
            raise DivergenceError(f"the TD error is {delta} (alpha {self.config.alpha:g})")
        self._a, self._active = a2, following
        return None if a2 < 0 else a2

    def _first_tiles_call(self, *args: Any) -> tuple:
        kernel = compiled(decide_tiles)
        result = kernel(*args)
        self._decide_tiles = without_dispatch(kernel, args)  # every call's types are these
        return result

    def _make_room(self) -> None:
        need = self._count + self.features.num_active
        if need > len(self._pairs):
            room = min(self._w.size, max(2 * len(self._pairs), need))
            for name in ("_pairs", "_values"):
                old = getattr(self, name)
                setattr(self, name, np.concatenate([old, np.zeros(room - len(old), old.dtype)]))
        if self._undo[0].size and self._logged + self.features.num_active > self._undo[0].size:
            size = 2 * self._undo[0].size + self.features.num_active
            self._undo = tuple(
                np.concatenate([u, np.zeros(size - len(u), u.dtype)]) for u in self._undo
            )
        self._traces = (self._pairs, self._values, self._place, *self._undo)

    def greedy_action(self, obs: Any, stream: RandomStream) -> int:
        """argmax_a Q(s, a), ties broken by ``stream``."""
        return stream.argmax(self.q_values(obs))

    def state_dict(self) -> dict[str, np.ndarray]:
        """Weights and random stream (no traces between episodes)."""
        return {"w": self.w.copy(), **self.stream.state_dict(prefix="stream.")}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        w = checked_values(state, "w", (self.n_actions, self.num_features))
        self.stream.load_state_dict(state, prefix="stream.")
        self._w = w.ravel().copy()
        compiled(clear)(self._pairs, self._place, self._count)
        self._count, self._logged = 0, 0
        self._begun += 2  # a state asked for before the load is gone
        self._stream_at_start = self.stream.position_now()

    def checkpoint_state(self) -> Callable[[], dict[str, np.ndarray]]:
        """Between episodes: a function giving the state as it is now until the episode after
        the next begins (then RuntimeError), rebuilt from the weights and the undo log."""
        if self._a >= 0:
            raise RuntimeError("checkpoint_state() is for between episodes: one is in progress")
        begun = self._begun
        if not self._undo[0].size:  # start the log
            room = min(self._w.size, 64 * self.features.num_active)
            self._undo = (np.zeros(room, dtype=np.int64), np.zeros(room))
            self._traces = (self._pairs, self._values, self._place, *self._undo)

        def state() -> dict[str, np.ndarray]:
            now = self.state_dict()
            if self._begun == begun:
                return now
            if self._begun != begun + 1:
                raise RuntimeError(
                    "the state after an episode was asked for after the next two had begun"
                )
            compiled(rewind)(now["w"].reshape(-1), *self._undo, self._logged)
            return {**now, **self.stream.state_dict("stream.", at=self._stream_at_start)}

        return state
