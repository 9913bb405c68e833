"""Numba kernels of Sarsa(lambda) over tile codes: the same arithmetic as the numpy reference
(:mod:`.sarsa_lambda`, :class:`.features.TileCoder`), operation for operation, compiled.

Bit-for-bit equality with numpy is the design rule, not an accident:

- sums of weights use numpy's own pairwise summation (:func:`pairwise_sum`: eight running sums
  over blocks of eight, combined as ``((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))``, then
  the rest in order; below eight values a plain loop), which is what ``ndarray.sum`` does for
  the 48 active weights;
- elementwise updates keep numpy's order of operations (``w += (alpha delta) z``,
  ``z *= (gamma lambda)``), and tile coordinates use the same ``floor`` and floor-modulo;
- numba compiles without ``fastmath``, so IEEE rounding is kept.

The random draws (exploration, ties) stay in Python with the agent's own stream. numba is an
optional dependency (``pip install acrobot-mj[fast]``), imported only by this module.
"""

from __future__ import annotations

import math

import numpy as np

try:
    from numba import njit
except ImportError as error:  # pragma: no cover  (the fast extra is missing)
    raise ImportError("the compiled learner needs numba: pip install acrobot-mj[fast]") from error


#: numpy's pairwise block: up to this many values it sums in one unrolled pass (beyond it,
#: recursively, which :func:`pairwise_sum` does not do).
PAIRWISE_BLOCK = 128


@njit(cache=True)
def pairwise_sum(values: np.ndarray, n: int) -> float:
    """The sum of ``values[:n]`` in numpy's pairwise order (n up to 128: one block)."""
    if n < 8:
        total = 0.0
        for i in range(n):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[0], values[1], values[2], values[3]
    r4, r5, r6, r7 = values[4], values[5], values[6], values[7]
    i = 8
    while i + 8 <= n:
        r0 += values[i]
        r1 += values[i + 1]
        r2 += values[i + 2]
        r3 += values[i + 3]
        r4 += values[i + 4]
        r5 += values[i + 5]
        r6 += values[i + 6]
        r7 += values[i + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        total += values[i]
        i += 1
    return total


@njit(cache=True)
def tile_active(obs, low, scale, offset, extent, wrap, stride, base, out) -> None:
    """:meth:`TileCoder.active` into ``out``: one tile per tiling."""
    n_tilings, n_vars = offset.shape
    for k in range(n_tilings):
        index = base[k]
        for j in range(n_vars):
            c = math.floor((obs[j] - low[j]) * scale[j] + offset[k, j])  # an int in numba
            if wrap[j]:
                c %= extent[j]
            elif c < 0:
                c = 0
            elif c > extent[j] - 1:
                c = extent[j] - 1
            index += c * stride[k, j]
        out[k] = index


@njit(cache=True)
def q_values(w, active, num_features, n_actions, gathered, out) -> None:
    """Q(s, a) for every action: the pairwise sum of the active weights of each action."""
    n = active.size
    for a in range(n_actions):
        for i in range(n):
            gathered[i] = w[a * num_features + active[i]]
        out[a] = pairwise_sum(gathered, n)


@njit(cache=True)
def mark(w, a, active, num_features, pairs, values, position, count, replacing, gathered,
         undo):  # fmt: skip
    """The TD error's first part ``-Q(s, a)`` (returned), then the traces of (s, a) set to 1
    (replacing) or raised by 1 (accumulating), new ones appended; returns ``(-Q, count)``.
    ``undo = (pairs, values, used)``: each new trace's pair and its weight before any change
    are appended there (``used[0]`` entries; see :func:`rewind`), unless its arrays are
    empty. Only traced weights change, so the log holds every weight the episode changed."""
    n = active.size
    undo_pairs, undo_values, used = undo
    logging = undo_pairs.size > 0
    for i in range(n):
        gathered[i] = w[a * num_features + active[i]]
    q = pairwise_sum(gathered, n)
    for i in range(n):
        pair = a * num_features + active[i]
        at = position[pair]
        if at >= 0:
            values[at] = 1.0 if replacing else values[at] + 1.0
    for i in range(n):  # new traces after the known ones, in order (numpy's concatenate)
        pair = a * num_features + active[i]
        if position[pair] < 0:
            if logging:
                undo_pairs[used[0]] = pair
                undo_values[used[0]] = w[pair]
                used[0] += 1
            position[pair] = count
            pairs[count] = pair
            values[count] = 1.0
            count += 1
    return q, count


def undo_log(room: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An empty :func:`mark` log with room for ``room`` entries (0: no log is kept)."""
    return np.zeros(room, dtype=np.int64), np.zeros(room), np.zeros(1, dtype=np.int64)


@njit(cache=True)
def rewind(w, undo_pairs, undo_values, used) -> None:
    """Undo :func:`mark`'s log on ``w`` (latest entry first, so a weight traced twice gets the
    value its first entry saw): the weights as they were when the log was started."""
    for u in range(used - 1, -1, -1):
        w[undo_pairs[u]] = undo_values[u]


@njit(cache=True)
def update(w, pairs, values, count, step) -> None:
    """``w[traced] += step z`` with ``step = alpha delta``."""
    for i in range(count):
        w[pairs[i]] += step * values[i]


@njit(cache=True)
def decay(pairs, values, position, count, factor, cutoff) -> int:
    """``z *= factor`` (gamma lambda), then the traces below ``cutoff`` dropped, order kept;
    returns the new count."""
    for i in range(count):
        values[i] *= factor
    if cutoff <= 0.0:
        return count
    kept = 0
    for i in range(count):
        if values[i] >= cutoff:
            pairs[kept] = pairs[i]
            values[kept] = values[i]
            position[pairs[kept]] = kept
            kept += 1
        else:
            position[pairs[i]] = -1
    return kept


@njit(cache=True)
def update_decay(w, pairs, values, position, count, step, factor, cutoff) -> int:
    """:func:`update` then :func:`decay` in one pass over the traces (each weight and trace
    gets the same operations in the same order: the same numbers, half the memory traffic)."""
    kept = 0
    for i in range(count):
        pair = pairs[i]
        w[pair] += step * values[i]
        value = values[i] * factor
        if cutoff <= 0.0 or value >= cutoff:
            pairs[kept] = pair
            values[kept] = value
            position[pair] = kept
            kept += 1
        else:
            position[pair] = -1
    return kept


@njit(cache=True)
def clear(pairs, position, count) -> None:
    """Drop every trace (the start of an episode)."""
    for i in range(count):
        position[pairs[i]] = -1


@njit(cache=True)
def greedy_step(w, a, active, nxt, obs, tiles, sizes, traces, count, reward, rates, gathered, q,
                undo):  # fmt: skip
    """A whole non-terminal decision when the policy needs no random draw (``epsilon = 0`` and
    one best action): mark (s, a), the TD error, the next state's tiles and values, a' = argmax,
    the update and the decay, in that order (the numpy learner's). Returns ``(a', count)``;
    ``a' = -1`` when the policy must draw (a tie, or a value that is not a number): then only
    the marking, the tiles and the values are done, and ``q`` and the returned ``-Q(s, a)``
    (``count`` holds it, see below) let Python finish. ``sizes = (num_features, n_actions,
    replacing, truncated)``, ``rates = (alpha, gamma, decay factor, cutoff)``,
    ``traces = (pairs, values, position)``, ``undo`` :func:`mark`'s log; the TD error's
    first part comes back in ``gathered[0]``."""
    num_features, n_actions, replacing, truncated = sizes
    pairs, values, position = traces
    q_sa, count = mark(w, a, active, num_features, pairs, values, position, count, replacing,
                       gathered, undo)  # fmt: skip
    delta = reward - q_sa
    low, scale, offset, extent, wrap, stride, base = tiles
    tile_active(obs, low, scale, offset, extent, wrap, stride, base, nxt)
    q_values(w, nxt, num_features, n_actions, gathered, q)
    gathered[0] = delta
    best, ties = q[0], 1
    for i in range(1, n_actions):
        if q[i] > best:
            best, ties = q[i], 1
        elif q[i] == best:
            ties += 1
    if ties != 1 or best != best:
        return -1, count
    a2 = 0
    while q[a2] != best:
        a2 += 1
    delta = delta + rates[1] * q[a2]
    if not -math.inf < delta < math.inf:
        return -1, count  # Python raises the divergence, with the same value
    if truncated:
        update(w, pairs, values, count, rates[0] * delta)
        return a2, count
    return a2, update_decay(w, pairs, values, position, count, rates[0] * delta, rates[2],
                            rates[3])  # fmt: skip


@njit(cache=True)
def lockstep_greedy(ids, w, a, active, nxt, obs, tiles, sizes, traces, count, rewards, truncated,
                    rates, gathered, q, out, undo) -> None:  # fmt: skip
    """:func:`greedy_step` for learners ``ids[j]`` of a lockstep group, in one call: row ``i`` of
    each 2-D array (``w``, ``active``, ``nxt``, and ``traces = (pairs, values, position)``) is
    learner ``i``'s, row ``j`` of ``obs``, ``gathered``, ``q`` and entry ``j`` of ``rewards``,
    ``truncated`` and ``out`` the step's. ``out[j]``: a', or -1 when Python must finish (then
    ``gathered[j, 0]`` and ``q[j]`` hold what it needs). A learner that goes on moves to
    (s', a'). One thread: ``--jobs`` processes are the parallelism (numba's threads, on
    OpenMP, would also make later forks of the process abort). ``undo``: an empty
    :func:`mark` log (the group's checkpoints copy the weights)."""
    num_features, n_actions, replacing = sizes
    pairs, values, position = traces
    for j in range(ids.size):
        i = ids[j]
        a2, c = greedy_step(
            w[i], a[i], active[i], nxt[i], obs[j], tiles,
            (num_features, n_actions, replacing, truncated[j]),
            (pairs[i], values[i], position[i]), count[i], rewards[j], rates, gathered[j], q[j],
            undo,
        )  # fmt: skip
        count[i] = c
        out[j] = a2
        if a2 >= 0 and not truncated[j]:
            for t in range(active.shape[1]):
                active[i, t] = nxt[i, t]
            a[i] = a2
