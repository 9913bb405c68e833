"""State features for the learners: the report's state grid and Sutton's tile coding.

Both map an observation ``(q1, q2, dq1, dq2)`` [rad, rad/s] to the indices of its active binary
features, so one linear learner serves both: the grid has one active feature (a table), tile
coding has one per tiling.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from acrobot_mj.agents.protocol import FeatureSpec
from acrobot_mj.envs.spaces import OBS_HIGH, OBS_LOW


def _centres(low: float, high: float, n: int) -> tuple[float, ...]:
    if n == 1:
        return ((low + high) / 2,)
    return tuple(low + (high - low) * i / (n - 1) for i in range(n))


@dataclass(frozen=True)
class StateGrid:
    """Nearest-centre discretisation, one cell index per state (the report's table).

    The report's grid (the default) has angle centres ``-pi/2, -pi/4, 0, pi/4, pi/2`` rad and
    velocity centres ``-pi/4, 0, pi/4`` rad/s: 5 x 5 x 3 x 3 = 225 cells. Each variable goes to
    its nearest centre, so values beyond the outer centres fall in the outer cells (the report's
    rule; it makes every speed above pi/8 rad/s look alike).
    """

    angle_bins: int = 5
    velocity_bins: int = 3
    angle_range: tuple[float, float] = (-math.pi / 2, math.pi / 2)
    velocity_range: tuple[float, float] = (-math.pi / 4, math.pi / 4)

    def __post_init__(self) -> None:
        for name in ("angle_bins", "velocity_bins"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        for name in ("angle_range", "velocity_range"):
            low, high = getattr(self, name)
            if not (math.isfinite(low) and math.isfinite(high) and low < high):
                raise ValueError(f"{name} must be (low, high) with low < high, got {(low, high)}")
        # (low, cells per unit, cells) for the angles, then for the velocities: for index().
        (low_a, high_a), (low_v, high_v) = self.angle_range, self.velocity_range
        n_a, n_v = self.angle_bins, self.velocity_bins
        consts = (
            low_a,
            (n_a - 1) / (high_a - low_a),
            n_a,
            low_v,
            (n_v - 1) / (high_v - low_v),
            n_v,
        )
        object.__setattr__(self, "_consts", consts)

    @property
    def centres(self) -> tuple[tuple[float, ...], ...]:
        """Cell centres per variable (q1, q2, dq1, dq2)."""
        a = _centres(*self.angle_range, self.angle_bins)
        v = _centres(*self.velocity_range, self.velocity_bins)
        return (a, a, v, v)

    @property
    def num_features(self) -> int:
        return self.angle_bins**2 * self.velocity_bins**2

    @property
    def num_active(self) -> int:
        return 1

    def index(self, obs: Sequence[float]) -> int:
        """Cell index of ``obs`` in ``[0, num_features)``, row-major over (q1, q2, dq1, dq2)."""
        # Unrolled over the four variables, in Python floats: the training loop's hot path.
        q1, q2, v1, v2 = obs.tolist() if isinstance(obs, np.ndarray) else obs
        low_a, per_a, n_a, low_v, per_v, n_v = self._consts
        top_a, top_v = n_a - 1, n_v - 1
        i1, i2 = round((q1 - low_a) * per_a), round((q2 - low_a) * per_a)
        i3, i4 = round((v1 - low_v) * per_v), round((v2 - low_v) * per_v)
        i1 = 0 if i1 < 0 else top_a if i1 > top_a else i1
        i2 = 0 if i2 < 0 else top_a if i2 > top_a else i2
        i3 = 0 if i3 < 0 else top_v if i3 > top_v else i3
        i4 = 0 if i4 < 0 else top_v if i4 > top_v else i4
        return ((i1 * n_a + i2) * n_v + i3) * n_v + i4

    def indices(self, obs: np.ndarray) -> np.ndarray:
        """:meth:`index` of each row of ``obs`` ``(n, 4)``, as int64 ``(n,)``: the same numbers
        (numpy's round, like Python's, rounds halves to even)."""
        low_a, per_a, n_a, low_v, per_v, n_v = self._consts
        obs = np.asarray(obs, dtype=np.float64)
        cells = np.empty(obs.shape, dtype=np.int64)
        cells[:, :2] = np.clip(np.round((obs[:, :2] - low_a) * per_a), 0, n_a - 1)
        cells[:, 2:] = np.clip(np.round((obs[:, 2:] - low_v) * per_v), 0, n_v - 1)
        return ((cells[:, 0] * n_a + cells[:, 1]) * n_v + cells[:, 2]) * n_v + cells[:, 3]

    def active(self, obs: Sequence[float]) -> np.ndarray:
        """Active feature indices, shape ``(1,)``."""
        return np.array([self.index(obs)])


class TileCoder:
    """Tile coding in the style of Sutton's tiles3, with dense indices (no hashing).

    ``groups`` lists ``(variables, n_tilings)``: each tiling covers the chosen subset of the
    variables ``(q1, q2, dq1, dq2)`` with ``tiles[j]`` tiles across ``[low_j, high_j]``. Tiling
    ``k`` of a group is displaced by ``k * (1, 3, 5, 7)[j] / n_tilings`` of a tile width along
    variable ``j`` (tiles3's asymmetric displacement), so the tilings are deterministic. Angles
    wrap around the circle (tiles3's ``tileswrap``); velocities get one extra tile so the displaced
    tilings still cover the range, and values beyond it fall in the edge tiles.

    Every state activates exactly one tile per tiling; indices are dense in
    ``[0, num_features)``, each tiling owning its own block.
    """

    def __init__(
        self,
        groups: Sequence[tuple[Sequence[int], int]],
        tiles: Sequence[int] = (6, 6, 7, 7),
        low: Sequence[float] = OBS_LOW,
        high: Sequence[float] = OBS_HIGH,
        wrap: Sequence[bool] = (True, True, False, False),
    ) -> None:
        n_vars = len(tiles)
        if not (len(low) == len(high) == len(wrap) == n_vars):
            raise ValueError("tiles, low, high and wrap must have one entry per variable")
        if any(not isinstance(t, (int, np.integer)) or t < 1 for t in tiles):
            raise ValueError(f"tiles must be integers >= 1, got {tuple(tiles)}")
        if any(not hi > lo for lo, hi in zip(low, high, strict=True)):
            raise ValueError(f"each low must be below its high, got {low} and {high}")
        if not groups:
            raise ValueError("groups must name at least one (variables, n_tilings) pair")
        self.groups = [(tuple(int(v) for v in variables), int(n)) for variables, n in groups]
        self.tiles, self.wrap = tuple(int(t) for t in tiles), tuple(bool(w) for w in wrap)
        self.low, self.high = np.asarray(low, float), np.asarray(high, float)
        # Coordinates per variable: n tiles when wrapping, n + 1 otherwise.
        extent = [t if w else t + 1 for t, w in zip(self.tiles, self.wrap, strict=True)]

        offsets, strides, sizes, bases = [], [], [], []
        base = 0
        for variables, n_tilings in self.groups:
            if (
                not variables
                or len(set(variables)) != len(variables)
                or not all(0 <= v < n_vars for v in variables)
            ):
                raise ValueError(f"bad variable subset {variables} for {n_vars} variables")
            if n_tilings < 1:
                raise ValueError(f"n_tilings must be >= 1, got {n_tilings} for {variables}")
            size = math.prod(extent[v] for v in variables)
            stride, step = np.zeros(n_vars, dtype=np.int64), 1
            for v in reversed(variables):  # row-major within the tiling
                stride[v], step = step, step * extent[v]
            for k in range(n_tilings):
                offset = np.zeros(n_vars)
                for position, v in enumerate(variables):
                    offset[v] = (k * (2 * position + 1) / n_tilings) % 1.0
                offsets.append(offset)
                strides.append(stride)
                bases.append(base)
                base += size
            sizes.append(size)
        self._offset = np.array(offsets)  # (n_tilings, n_vars), in tile widths
        self._stride = np.array(strides)  # (n_tilings, n_vars), 0 for variables not covered
        self._base = np.array(bases, dtype=np.int64)  # (n_tilings,)
        self._scale = np.array(self.tiles) / (self.high - self.low)
        self._extent = np.array(extent)
        self._wrap_mask = np.array(self.wrap)
        self.num_features = base
        self.num_active = len(bases)

    def tables(self) -> tuple[np.ndarray, ...]:
        """What :meth:`active` computes from, for compiled kernels: ``(low, scale, offset,
        extent, wrap, stride, base)`` (see :func:`acrobot_mj.agents.kernels.tile_active`)."""
        return (self.low, self._scale, self._offset, self._extent, self._wrap_mask,
                self._stride, self._base)  # fmt: skip

    def active(self, obs: Sequence[float]) -> np.ndarray:
        """Indices of the active tile of every tiling, shape ``(num_active,)``, int64."""
        scaled = (np.asarray(obs, dtype=float) - self.low) * self._scale
        coords = np.floor(scaled + self._offset).astype(np.int64)
        coords = np.where(
            self._wrap_mask, coords % self._extent, np.clip(coords, 0, self._extent - 1)
        )
        return self._base + (coords * self._stride).sum(axis=1)

    def __repr__(self) -> str:
        return (
            f"TileCoder({self.num_active} tilings, {self.num_features} features, "
            f"tiles={self.tiles}, groups={self.groups})"
        )


def book_tile_coder(
    tilings: int = 12, subset_tilings: bool = True, angle_tiles: int = 6, velocity_tiles: int = 7
) -> TileCoder:
    """Sutton and Barto's acrobot tile coding: 48 tilings in all.

    ``tilings`` (12) over all four variables with angles in ``angle_tiles`` (6) and velocities in
    ``velocity_tiles`` (7) intervals, and, with ``subset_tilings``, 3 tilings for each of the four
    sets of three variables, 2 for each of the six pairs and 3 for each single variable.
    """
    groups: list[tuple[tuple[int, ...], int]] = [((0, 1, 2, 3), tilings)]
    if subset_tilings:
        for size, n in ((3, 3), (2, 2), (1, 3)):
            groups += [(subset, n) for subset in itertools.combinations(range(4), size)]
    tiles = (angle_tiles, angle_tiles, velocity_tiles, velocity_tiles)
    return TileCoder(groups, tiles=tiles)


def _grid(config: Any) -> StateGrid:
    v = config.velocity_centre_max
    return StateGrid(config.angle_bins, config.velocity_bins, velocity_range=(-v, v))


def _tiles(config: Any) -> TileCoder:
    return book_tile_coder(
        config.tilings, config.subset_tilings, config.angle_tiles, config.velocity_tiles
    )


FEATURE_SPECS = (
    FeatureSpec(
        "grid",
        "the report's nearest-centre table",
        ("angle_bins", "velocity_bins", "velocity_centre_max"),
        _grid,
    ),
    FeatureSpec(
        "tiles",
        "Sutton and Barto's tile coding",
        ("tilings", "subset_tilings", "angle_tiles", "velocity_tiles"),
        _tiles,
    ),
)
