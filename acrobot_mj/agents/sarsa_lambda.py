"""Linear Sarsa(lambda) over binary features (Sutton and Barto, 2nd ed., section 12.7).

    Q(s, a) = sum of w[a, i] over the active features i of s
    per step, with delta = r - Q(s, a):
        z[a, i] = 1 (replacing) or z[a, i] += 1 (accumulating) for the active features of s
        if s' is terminal:  w += alpha delta z; the episode ends
        choose a' epsilon-greedy in Q(s', .);  delta += gamma Q(s', a')
        w += alpha delta z;  z *= gamma lambda

With the report's grid (one active feature) and lambda = 0 this is exactly tabular SARSA (the
same random draws too, for any epsilon).

Traces are kept sparse: only the (action, feature) pairs touched in the episode so far, and
those decayed below ``trace_cutoff`` are dropped (Sutton's own acrobot and mountain-car code drops
traces below 0.01). ``trace_cutoff = 0`` keeps every trace: exact.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from acrobot_mj.agents.features import StateGrid, TileCoder
from acrobot_mj.agents.protocol import AgentSpec, DivergenceError
from acrobot_mj.agents.random_stream import RandomStream, checked_values

TRACES = ("replacing", "accumulating")
#: The implementations: this module's numpy code (the reference) or numba kernels
#: (:mod:`.sarsa_lambda_jit`, tile codes only; the same numbers).
KERNELS = ("numpy", "numba")
_MIN, _MAX = -math.inf, math.inf


class SarsaLambda:
    """Sarsa(lambda) with linear function approximation over binary features.

    features: a StateGrid or TileCoder; alpha: step size per weight (the book's 0.2/48 for 48
    tilings); gamma: discount; lam: trace decay lambda; epsilon: exploration; traces:
    "replacing" or "accumulating"; trace_cutoff: traces below it are dropped; seed: the agent's
    own random stream.
    """

    def __init__(
        self,
        features: StateGrid | TileCoder,
        n_actions: int = 3,
        alpha: float = 0.2 / 48,
        gamma: float = 1.0,
        lam: float = 0.9,
        epsilon: float = 0.0,
        traces: str = "replacing",
        trace_cutoff: float = 1e-3,
        clear_others: bool = False,
        seed: int | np.random.SeedSequence | None = None,
    ) -> None:
        if not 0.0 < alpha <= 1.0:
            raise ValueError(f"alpha must be in (0, 1], got {alpha}")
        for name, value in (("gamma", gamma), ("lam", lam), ("epsilon", epsilon)):
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if traces not in TRACES:
            raise ValueError(f"traces must be one of {TRACES}, got {traces!r}")
        if not 0.0 <= trace_cutoff < 1.0:
            raise ValueError(f"trace_cutoff must be in [0, 1), got {trace_cutoff}")
        self.features, self.n_actions = features, n_actions
        self.alpha, self.gamma, self.lam, self.epsilon = alpha, gamma, lam, epsilon
        self.replacing, self.trace_cutoff = traces == "replacing", trace_cutoff
        self.clear_others = clear_others
        self.stream = RandomStream(seed)
        self.num_features = features.num_features
        self._w = np.zeros(n_actions * self.num_features)  # w[a, i] at a * num_features + i
        # Sparse traces: pair indices, values, and each pair's position (-1: no trace).
        self._trace_pairs = np.zeros(0, dtype=np.int64)
        self._trace_values = np.zeros(0)
        self._position = np.full(self._w.size, -1, dtype=np.int64)
        self._active = np.zeros(0, dtype=np.int64)
        self._a = -1
        self._offsets = np.arange(n_actions)[:, None] * self.num_features

    @property
    def w(self) -> np.ndarray:
        """The weights, shape ``(n_actions, num_features)`` (a view)."""
        return self._w.reshape(self.n_actions, self.num_features)

    @property
    def traces(self) -> np.ndarray:
        """The eligibility traces, dense, shape ``(n_actions, num_features)`` (a copy)."""
        z = np.zeros(self._w.size)
        z[self._trace_pairs] = self._trace_values
        return z.reshape(self.n_actions, self.num_features)

    def q_values(self, obs: Any) -> list[float]:
        """Q(s, a) for every action of the state ``obs``."""
        return self._q(self.features.active(obs))

    def _q(self, active: np.ndarray) -> list[float]:
        return self._w[self._offsets + active].sum(axis=1).tolist()

    def _policy(self, q: list[float]) -> int:
        stream = self.stream
        if self.epsilon > 0.0 and stream.random() < self.epsilon:
            return stream.below(self.n_actions)
        return stream.argmax(q)

    def begin_episode(self, obs: Any) -> int:
        self._clear_traces()
        self._active = self.features.active(obs)
        self._a = self._policy(self._q(self._active))
        return self._a

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        """One Sarsa(lambda) step from ``(r, s')``; return a' (``None`` once it is over)."""
        if self._a < 0:
            raise RuntimeError("learn() needs an episode in progress: call begin_episode()")
        pairs = self._a * self.num_features + self._active
        # TD error, first part: r - Q(s, a) with the current weights.
        delta = reward - self._w[pairs].sum()
        if self.clear_others:
            self._clear(self._offsets + self._active, keep=self._a)
        self._mark(pairs)
        if terminated:
            if not _MIN < delta < _MAX:  # NaN and infinities fail too
                raise DivergenceError(f"the TD error is {delta} (alpha {self.alpha:g})")
            self._w[self._trace_pairs] += self.alpha * delta * self._trace_values
            self._a = -1
            return None
        active = self.features.active(obs)
        q = self._q(active)
        a2 = self._policy(q)
        # Bootstrap from Q(s', a'), update every traced weight, then decay the traces.
        delta += self.gamma * q[a2]
        if not _MIN < delta < _MAX:  # a non-finite first part carries through the sum
            raise DivergenceError(f"the TD error is {delta} (alpha {self.alpha:g})")
        self._w[self._trace_pairs] += self.alpha * delta * self._trace_values
        if truncated:
            self._a = -1
            return None
        self._decay()
        self._active, self._a = active, a2
        return a2

    def greedy_action(self, obs: Any, stream: RandomStream) -> int:
        """argmax_a Q(s, a), ties broken by ``stream`` (so evaluation leaves ours untouched)."""
        return stream.argmax(self.q_values(obs))

    # -- traces ----------------------------------------------------------------------------

    def _clear_traces(self) -> None:
        self._position[self._trace_pairs] = -1
        self._trace_pairs = np.zeros(0, dtype=np.int64)
        self._trace_values = np.zeros(0)

    def _clear(self, all_pairs: np.ndarray, keep: int) -> None:
        """Zero the traces of the active features under every action but ``keep``."""
        others = np.delete(all_pairs, keep, axis=0).ravel()
        position = self._position[others]
        self._trace_values[position[position >= 0]] = 0.0

    def _mark(self, pairs: np.ndarray) -> None:
        """Set (replacing) or add one to (accumulating) the traces of ``pairs``."""
        position = self._position[pairs]
        known = position >= 0
        if self.replacing:
            self._trace_values[position[known]] = 1.0
        else:
            self._trace_values[position[known]] += 1.0
        if not known.all():
            new = pairs[~known]
            n = self._trace_pairs.size
            self._position[new] = np.arange(n, n + new.size)
            self._trace_pairs = np.concatenate([self._trace_pairs, new])
            self._trace_values = np.concatenate([self._trace_values, np.ones(new.size)])

    def _decay(self) -> None:
        """z *= gamma lambda, then drop the traces below the cutoff."""
        self._trace_values *= self.gamma * self.lam
        if self.trace_cutoff > 0.0:
            keep = self._trace_values >= self.trace_cutoff
            if not keep.all():
                self._position[self._trace_pairs[~keep]] = -1
                self._trace_pairs = self._trace_pairs[keep]
                self._trace_values = self._trace_values[keep]
                self._position[self._trace_pairs] = np.arange(self._trace_pairs.size)

    # -- checkpoints -----------------------------------------------------------------------

    def state_dict(self) -> dict[str, np.ndarray]:
        """Weights and random stream (traces are empty between episodes)."""
        return {"w": self.w.copy(), **self.stream.state_dict(prefix="stream.")}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        w = checked_values(state, "w", (self.n_actions, self.num_features))
        self.stream.load_state_dict(state, prefix="stream.")
        self._w = w.ravel().copy()
        self._clear_traces()


def build(
    features: StateGrid | TileCoder, c: Any, seed: Any, n_actions: int, kind: type | None = None
) -> SarsaLambda:
    """The learner of config ``c`` (``kind``: this class, or a compiled subclass)."""
    return (kind or SarsaLambda)(
        features,
        n_actions,
        c.alpha,
        c.gamma,
        c.lam,
        c.epsilon,
        c.traces,
        c.trace_cutoff,
        seed=seed,
    )


SPEC = AgentSpec(
    name="sarsa_lambda",
    doc="linear Sarsa(lambda) with eligibility traces (Sutton and Barto), in lockstep with "
    "kernel numba",
    uses=("alpha", "gamma", "epsilon", "lam", "traces", "trace_cutoff", "kernel"),
    features=("grid", "tiles"),
    build=build,
)
