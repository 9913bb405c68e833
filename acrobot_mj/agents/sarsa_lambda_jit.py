"""Sarsa(lambda) over tile codes with its per-decision work compiled (:mod:`.kernels`).

:class:`CompiledSarsaLambda` is :class:`~.sarsa_lambda.SarsaLambda` with the tile coding, the
action values, the trace marking, the weight update and the trace decay in numba kernels, and
the same random stream, weights and checkpoints: the same seed gives the same actions, episode
lengths and weights, bit for bit (``tests/test_compiled.py`` checks full runs). One numba
call per decision when the policy needs no random draw (:func:`.kernels.greedy_step`), instead
of about fifteen numpy calls on tiny arrays; otherwise the policy draws in Python between two
kernel calls.

A checkpoint's state (:meth:`CompiledSarsaLambda.checkpoint_state`) is rebuilt when it is
written, from the current weights and a log of the weights the episode in progress changed,
instead of a copy of every weight after every episode (10 MB for the tuned tiles).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from acrobot_mj.agents import kernels, sarsa_lambda
from acrobot_mj.agents.features import TileCoder
from acrobot_mj.agents.protocol import DivergenceError
from acrobot_mj.agents.sarsa_lambda import SarsaLambda


class CompiledSarsaLambda(SarsaLambda):
    """:class:`SarsaLambda` on a :class:`TileCoder`, compiled (same arguments)."""

    def __init__(self, features: TileCoder, *args: Any, **kwargs: Any) -> None:
        if not isinstance(features, TileCoder):
            raise ValueError("the compiled Sarsa(lambda) needs tile-coding features")
        super().__init__(features, *args, **kwargs)
        if features.num_active > kernels.PAIRWISE_BLOCK:
            raise ValueError(
                f"the compiled Sarsa(lambda) sums at most {kernels.PAIRWISE_BLOCK} active "
                f"features (numpy's order), got {features.num_active}"
            )
        if self.clear_others:
            raise ValueError("the compiled Sarsa(lambda) does not clear other actions' traces")
        self._tiles = features.tables()
        # Room for the live traces, grown as needed (with lambda 0.9 and the cutoff 1e-3 a trace
        # lives 66 steps: about 3,200 of 48 tilings), not one per weight.
        room = min(self._w.size, 64 * features.num_active)
        self._pairs = np.zeros(room, dtype=np.int64)
        self._values = np.zeros(room)
        self._count = 0
        self._active = np.zeros(features.num_active, dtype=np.int64)
        self._next = np.zeros(features.num_active, dtype=np.int64)
        self._gathered = np.zeros(features.num_active)
        self._q_out = np.zeros(self.n_actions)
        self._factor = self.gamma * self.lam
        self._traces = (self._pairs, self._values, self._position)
        self._rates = (self.alpha, self.gamma, self._factor, self.trace_cutoff)
        # The weights this episode changed (kernels.mark's log, kept once a checkpoint's state
        # has been asked for: an empty one is not written), and what the rest of the state was
        # when it began: begin_episode calls so far, the stream's state.
        self._room = room
        self._undo = kernels.undo_log(0)
        self._begun = 0
        self._stream_at_start = self.stream.position()

    @property
    def traces(self) -> np.ndarray:
        z = np.zeros(self._w.size)
        z[self._pairs[: self._count]] = self._values[: self._count]
        return z.reshape(self.n_actions, self.num_features)

    def _active_q(self, obs: Any, out: np.ndarray) -> list[float]:
        kernels.tile_active(np.asarray(obs, dtype=float), *self._tiles, out)
        kernels.q_values(self._w, out, self.num_features, self.n_actions, self._gathered,
                         self._q_out)  # fmt: skip
        return self._q_out.tolist()

    def begin_episode(self, obs: Any) -> int:
        self._clear_traces()
        self._stream_at_start = self.stream.position()
        self._undo[2][0] = 0
        self._begun += 1
        self._a = self._policy(self._active_q(obs, self._active))
        return self._a

    def learn(self, reward: float, obs: Any, terminated: bool, truncated: bool) -> int | None:
        if self._a < 0:
            raise RuntimeError("learn() needs an episode in progress: call begin_episode()")
        if self._count + self._next.size > self._pairs.size:
            self._grow()
        if self._undo[0].size and self._undo[2][0] + self._next.size > self._undo[0].size:
            self._grow_undo()
        if not terminated and self.epsilon == 0.0:  # one compiled call, unless the policy draws
            a2, self._count = kernels.greedy_step(
                self._w, self._a, self._active, self._next, np.asarray(obs, dtype=float),
                self._tiles, (self.num_features, self.n_actions, self.replacing, bool(truncated)),
                self._traces, self._count, float(reward), self._rates, self._gathered,
                self._q_out, self._undo,
            )  # fmt: skip
            if a2 >= 0:
                return self._advance(a2, truncated)
            # A tie (or a value that is not a number): Python finishes the decision.
            return self._finish(float(self._gathered[0]), self._q_out.tolist(), truncated)
        q, self._count = kernels.mark(
            self._w, self._a, self._active, self.num_features, self._pairs, self._values,
            self._position, self._count, self.replacing, self._gathered, self._undo,
        )  # fmt: skip
        if terminated:
            self._apply(reward - q)
            self._a = -1
            return None
        return self._finish(reward - q, self._active_q(obs, self._next), truncated)

    def _finish(self, delta: float, q_next: list[float], truncated: bool) -> int | None:
        """The rest of a decision after the marking: a' from the policy, the update with the
        bootstrapped TD error, the decay."""
        a2 = self._policy(q_next)
        self._apply(delta + self.gamma * q_next[a2])
        if not truncated:
            self._count = kernels.decay(self._pairs, self._values, self._position, self._count,
                                        self._factor, self.trace_cutoff)  # fmt: skip
        return self._advance(a2, truncated)

    def _advance(self, a2: int, truncated: bool) -> int | None:
        """Move to (s', a'), or end the episode at truncation."""
        if truncated:
            self._a = -1
            return None
        self._active, self._next = self._next, self._active
        self._a = a2
        return a2

    def _apply(self, delta: float) -> None:
        if not -np.inf < delta < np.inf:  # NaN and infinities fail too
            raise DivergenceError(f"the TD error is {delta} (alpha {self.alpha:g})")
        kernels.update(self._w, self._pairs, self._values, self._count, self.alpha * delta)

    def _grow(self) -> None:
        """Twice the room for traces (at most one per weight), the live ones kept."""
        room = min(self._w.size, max(2 * self._pairs.size, self._count + self._next.size))
        pairs, values = np.zeros(room, dtype=np.int64), np.zeros(room)
        pairs[: self._count], values[: self._count] = (
            self._pairs[: self._count],
            self._values[: self._count],
        )
        self._pairs, self._values = pairs, values
        self._traces = (self._pairs, self._values, self._position)

    def _grow_undo(self) -> None:
        """Twice the room for the episode's log of changed weights, its entries kept."""
        pairs, values, used = self._undo
        grown = kernels.undo_log(2 * pairs.size + self._next.size)
        n = int(used[0])
        grown[0][:n], grown[1][:n], grown[2][0] = pairs[:n], values[:n], n
        self._undo = grown

    def _clear_traces(self) -> None:
        kernels.clear(self._pairs, self._position, self._count)
        self._count = 0

    # -- checkpoints -----------------------------------------------------------------------

    def checkpoint_state(self) -> Callable[[], dict[str, np.ndarray]]:
        """See :class:`~acrobot_mj.agents.protocol.Rewinding`: the state now, rebuilt when
        the returned function is called (the weights rewound through the log of the episode
        begun since, if one was)."""
        if self._a >= 0:
            raise RuntimeError("checkpoint_state() is for between episodes: one is in progress")
        begun = self._begun
        if not self._undo[0].size:  # the first time: keep the log from the next episode on
            self._undo = kernels.undo_log(self._room)

        def state() -> dict[str, np.ndarray]:
            now = self.state_dict()
            if self._begun == begun:
                return now
            if self._begun != begun + 1:
                raise RuntimeError(
                    "the state after an episode was asked for after the next two had begun"
                )
            pairs, values, used = self._undo
            kernels.rewind(now["w"].reshape(-1), pairs, values, int(used[0]))
            return {**now, **self.stream.state_dict("stream.", at=self._stream_at_start)}

        return state

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        super().load_state_dict(state)
        self._begun += 2  # a state asked for before the load is gone: say so if called
        self._undo[2][0] = 0
        self._stream_at_start = self.stream.position()


def build(features: TileCoder, config: Any, seed: Any, n_actions: int) -> CompiledSarsaLambda:
    """The compiled learner of ``config`` (``kernel = "numba"``)."""
    return sarsa_lambda.build(features, config, seed, n_actions, CompiledSarsaLambda)
