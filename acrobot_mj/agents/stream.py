"""The agents' own random numbers: a seeded numpy Generator read in blocks, and the draws of an
epsilon-greedy policy written once (:func:`policy`), for Python and compiled learners alike."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from acrobot_mj.compiled import jitable

BLOCK = 1024


@jitable
def argmax(values, block, position) -> tuple:
    """The index of the largest of ``values``, ties broken by one draw from ``block`` at
    ``position`` (only when there is a tie): ``(index, next position)``."""
    best, first, count = values[0], 0, 1
    for i in range(1, values.shape[0]):
        if values[i] > best:
            best, first, count = values[i], i, 1
        elif values[i] == best:
            count += 1
    if count == 1:
        return first, position
    pick = int(block[position] * count)
    for i in range(first, values.shape[0]):
        if values[i] == best:
            if pick == 0:
                return i, position + 1
            pick -= 1
    return first, position + 1  # not reached


@jitable
def policy(values, epsilon, block, position) -> tuple:
    """Epsilon-greedy in ``values``: with probability ``epsilon`` (one draw, when ``epsilon >
    0``) a uniformly random action (one more draw), else :func:`argmax`."""
    if epsilon > 0.0:
        position += 1
        if block[position - 1] < epsilon:
            return int(block[position] * values.shape[0]), position + 1
    return argmax(values, block, position)


class RandomStream:
    """Uniform draws in [0, 1) from ``numpy.random.default_rng(seed)``, fetched ``BLOCK`` at a
    time (one Generator call per draw costs more than an agent's whole update). The same seed
    gives the same draws; :meth:`state_dict` captures the generator and the unread part of the
    block, so a restored stream goes on exactly where it stopped."""

    def __init__(self, seed: int | np.random.SeedSequence | None = None) -> None:
        self.generator = np.random.default_rng(seed)
        self.block, self.position = np.zeros(0), 0

    def reserve(self, count: int = 2) -> None:
        """At least ``count`` unread draws in :attr:`block` (the next block appended where
        fewer are left: the same draws in the same order), for a compiled learner to read."""
        if len(self.block) - self.position < count:
            rest = self.block[self.position :]
            self.block = np.concatenate([rest, self.generator.random(BLOCK)])
            self.position = 0

    def random(self) -> float:
        """One uniform draw in [0, 1)."""
        self.reserve(1)
        self.position += 1
        return float(self.block[self.position - 1])

    def below(self, n: int) -> int:
        """A uniform integer in ``[0, n)``."""
        return int(self.random() * n)

    def argmax(self, values: Any) -> int:
        """Index of the largest value, ties broken uniformly at random (:func:`argmax`)."""
        self.reserve(1)
        index, self.position = argmax(np.asarray(values, dtype=float), self.block, self.position)
        return index

    def position_now(self) -> tuple[Any, ...]:
        """Where the stream is now, cheaply (a block is replaced, never changed): give it to
        :meth:`state_dict` later for the state as it is now."""
        return self.generator.bit_generator.state, self.block, self.position

    def state_dict(self, prefix: str = "", at: tuple[Any, ...] | None = None) -> dict:
        """The stream's state (or, ``at``, the state at that :meth:`position_now`) as arrays,
        their names starting with ``prefix``."""
        bit_state, block, position = self.position_now() if at is None else at
        return {
            f"{prefix}bit_generator": np.array(json.dumps(bit_state)),
            f"{prefix}block": np.array(block, dtype=np.float64),
            f"{prefix}next": np.array(position),
        }

    def load_state_dict(self, state: dict[str, Any], prefix: str = "") -> None:
        """Restore what :meth:`state_dict` returned (with the same ``prefix``)."""
        state = {k.removeprefix(prefix): v for k, v in state.items() if k.startswith(prefix)}
        try:
            bit_state = json.loads(str(state["bit_generator"]))
            kind = bit_state.get("bit_generator")
        except (ValueError, AttributeError) as error:
            raise ValueError(f"random state is not a generator's state ({error})") from None
        if kind != type(self.generator.bit_generator).__name__:
            raise ValueError(f"random state is for {kind!r}, not "
                             f"{type(self.generator.bit_generator).__name__}")  # fmt: skip
        block = np.asarray(state["block"], dtype=np.float64)
        position = int(state["next"])
        if block.ndim != 1 or not 0 <= position <= len(block):
            raise ValueError("random state has an inconsistent block position")
        self.generator.bit_generator.state = bit_state
        self.block, self.position = block.copy(), position


def checked_values(state: dict[str, Any], name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``state[name]`` as float64, refused unless it has ``shape`` and only finite values."""
    values = np.asarray(state[name], dtype=np.float64)
    if values.shape != shape:
        raise ValueError(f"{name} has shape {values.shape}, this agent needs {shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{name} holds non-finite values")
    return values
