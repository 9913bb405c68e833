"""The agents' own random numbers: a seeded numpy Generator read in blocks."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

BLOCK = 1024


class RandomStream:
    """Uniform draws in [0, 1) from ``numpy.random.default_rng(seed)``, fetched ``BLOCK`` at a
    time (one Generator call per draw costs more than an agent's whole update).

    The same seed gives the same draws; :meth:`state_dict` captures the generator and the unread
    part of the block, so a restored stream continues exactly where it stopped.
    """

    def __init__(self, seed: int | np.random.SeedSequence | None = None) -> None:
        self.generator = np.random.default_rng(seed)
        self._block: list[float] = []
        self._next = 0

    def random(self) -> float:
        """One uniform draw in [0, 1)."""
        if self._next == len(self._block):
            self._block = self.generator.random(BLOCK).tolist()
            self._next = 0
        u = self._block[self._next]
        self._next += 1
        return u

    def below(self, n: int) -> int:
        """A uniform integer in ``[0, n)``."""
        return int(self.random() * n)

    def argmax(self, values: list[float]) -> int:
        """Index of the largest value, ties broken uniformly at random."""
        best = max(values)
        if values.count(best) == 1:  # the common case, at C speed
            return values.index(best)
        ties = [i for i, v in enumerate(values) if v == best]
        return ties[self.below(len(ties))]

    def position(self) -> tuple[Any, ...]:
        """Where the stream is now, cheaply (a block is replaced, never changed): give it to
        :meth:`state_dict` later for the state as it is now."""
        return self.generator.bit_generator.state, self._block, self._next

    def state_dict(
        self, prefix: str = "", at: tuple[Any, ...] | None = None
    ) -> dict[str, np.ndarray]:
        """The stream's state (or, ``at``, the state at that :meth:`position`) as arrays, their
        names starting with ``prefix``."""
        bit_state, block, nxt = self.position() if at is None else at
        return {
            f"{prefix}bit_generator": np.array(json.dumps(bit_state)),
            f"{prefix}block": np.array(block, dtype=np.float64),
            f"{prefix}next": np.array(nxt),
        }

    def load_state_dict(self, state: dict[str, Any], prefix: str = "") -> None:
        """Restore what :meth:`state_dict` returned (with the same ``prefix``)."""
        state = {k.removeprefix(prefix): v for k, v in state.items() if k.startswith(prefix)}
        bit_state = json.loads(str(state["bit_generator"]))
        if bit_state.get("bit_generator") != type(self.generator.bit_generator).__name__:
            raise ValueError(
                f"random state is for {bit_state.get('bit_generator')!r}, not "
                f"{type(self.generator.bit_generator).__name__}"
            )
        block = np.asarray(state["block"], dtype=np.float64)
        nxt = int(state["next"])
        if block.ndim != 1 or not 0 <= nxt <= len(block):
            raise ValueError("random state has an inconsistent block position")
        self.generator.bit_generator.state = bit_state
        self._block, self._next = block.tolist(), nxt


def checked_values(state: dict[str, Any], name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``state[name]`` as float64, refused unless it has ``shape`` and only finite values."""
    values = np.asarray(state[name], dtype=np.float64)
    if values.shape != shape:
        raise ValueError(f"{name} has shape {values.shape}, this agent needs {shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{name} holds non-finite values")
    return values
