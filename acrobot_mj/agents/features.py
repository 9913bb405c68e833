"""State features: the report's grid and Sutton's tile coding, both mapping an observation to
the indices of its active binary features (the grid one, tile coding one per tiling)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from acrobot_mj.checks import check_memory
from acrobot_mj.compiled import compiled, jitable
from acrobot_mj.settings import Settings, setting


@jitable
def grid_cell(q1, q2, v1, v2, consts) -> int:
    """The grid cell of one state, each variable to its nearest centre (halves to even),
    row-major; ``consts = (low angle, cells per rad, angle cells, low velocity, cells per rad/s,
    velocity cells)``."""
    low_a, per_a, n_a, low_v, per_v, n_v = consts
    top_a, top_v = int(n_a) - 1, int(n_v) - 1
    i1, i2 = round((q1 - low_a) * per_a), round((q2 - low_a) * per_a)
    i3, i4 = round((v1 - low_v) * per_v), round((v2 - low_v) * per_v)
    i1 = 0 if i1 < 0 else top_a if i1 > top_a else i1
    i2 = 0 if i2 < 0 else top_a if i2 > top_a else i2
    i3 = 0 if i3 < 0 else top_v if i3 > top_v else i3
    i4 = 0 if i4 < 0 else top_v if i4 > top_v else i4
    return ((i1 * (top_a + 1) + i2) * (top_v + 1) + i3) * (top_v + 1) + i4


@jitable
def grid_rows(obs, consts, out) -> None:
    """:func:`grid_cell` of every row of ``obs`` ``(N, 4)`` into ``out``."""
    for i in range(obs.shape[0]):
        out[i] = grid_cell(obs[i, 0], obs[i, 1], obs[i, 2], obs[i, 3], consts)


@dataclass(frozen=True)
class StateGrid:
    """Nearest-centre discretisation (the report's table): by default angle centres ``-pi/2 ..
    pi/2`` rad and velocity centres ``-pi/4, 0, pi/4`` rad/s, 225 cells; values beyond the outer
    centres fall in the outer cells."""

    angle_bins: int = 5
    velocity_bins: int = 3
    angle_range: tuple[float, float] = (-math.pi / 2, math.pi / 2)
    velocity_range: tuple[float, float] = (-math.pi / 4, math.pi / 4)
    if TYPE_CHECKING:  # set by __post_init__; a field to type checkers only (no init, asdict)
        constants: tuple[float, ...] = field(init=False)

    def __post_init__(self) -> None:
        for name in ("angle_bins", "velocity_bins"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        for name in ("angle_range", "velocity_range"):
            low, high = getattr(self, name)
            if not (math.isfinite(low) and math.isfinite(high) and low < high):
                raise ValueError(f"{name} must be (low, high) with low < high, got {(low, high)}")
        (low_a, high_a), (low_v, high_v) = self.angle_range, self.velocity_range
        n_a, n_v = self.angle_bins, self.velocity_bins
        consts = (
            low_a,
            (n_a - 1) / (high_a - low_a),
            float(n_a),
            low_v,
            (n_v - 1) / (high_v - low_v),
            float(n_v),
        )
        object.__setattr__(self, "constants", consts)  # grid_cell's

    @property
    def centres(self) -> tuple[tuple[float, ...], ...]:
        """Cell centres per variable (q1, q2, dq1, dq2)."""

        def centres(low: float, high: float, n: int) -> tuple[float, ...]:
            if n == 1:
                return ((low + high) / 2,)
            return tuple(low + (high - low) * i / (n - 1) for i in range(n))

        a = centres(*self.angle_range, self.angle_bins)
        v = centres(*self.velocity_range, self.velocity_bins)
        return (a, a, v, v)

    @property
    def num_features(self) -> int:
        return self.angle_bins**2 * self.velocity_bins**2

    @property
    def num_active(self) -> int:
        return 1

    def index(self, obs: Sequence[float]) -> int:
        """Cell index of ``obs`` in ``[0, num_features)``."""
        q1, q2, v1, v2 = obs.tolist() if isinstance(obs, np.ndarray) else obs
        return grid_cell(q1, q2, v1, v2, self.constants)

    def indices(self, obs: np.ndarray) -> np.ndarray:
        """:meth:`index` of each row of ``obs`` ``(n, 4)``, int64 ``(n,)``."""
        out = np.empty(len(obs), dtype=np.int64)
        compiled(grid_rows)(np.asarray(obs, dtype=np.float64), self.constants, out)
        return out

    def active(self, obs: Sequence[float]) -> np.ndarray:
        return np.array([self.index(obs)])


@jitable
def tile_active(obs, low, scale, offset, extent, wrap, stride, base, out) -> None:
    """The active tile of every tiling into ``out``."""
    n_tilings, n_vars = offset.shape
    for k in range(n_tilings):
        index = base[k]
        for j in range(n_vars):
            c = math.floor((obs[j] - low[j]) * scale[j] + offset[k, j])
            if wrap[j]:
                c %= extent[j]
            elif c < 0:
                c = 0
            elif c > extent[j] - 1:
                c = extent[j] - 1
            index += c * stride[k, j]
        out[k] = index


class TileCoder:
    """Tile coding after Sutton's tiles3, dense: ``groups`` of ``(variables, n_tilings)``, tiling
    ``k`` displaced by ``k * (1, 3, 5, 7)[j] / n_tilings`` of a tile; ``wrap`` variables wrap,
    the others get one extra tile."""

    def __init__(
        self,
        groups: Sequence[tuple[Sequence[int], int]],
        tiles: Sequence[int],
        low: Sequence[float],
        high: Sequence[float],
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
        extent = [t if w else t + 1 for t, w in zip(self.tiles, self.wrap, strict=True)]
        for variables, n_tilings in self.groups:
            distinct = len(set(variables)) == len(variables) > 0
            if not distinct or not all(0 <= v < n_vars for v in variables):
                raise ValueError(f"bad variable subset {variables} for {n_vars} variables")
            if n_tilings < 1:
                raise ValueError(f"n_tilings must be >= 1, got {n_tilings} for {variables}")
        tilings = sum(n for _, n in self.groups)
        features = sum(n * math.prod(extent[v] for v in vs) for vs, n in self.groups)
        # Under 1 kB a tiling while it is built, and a learner needs a weight per feature.
        check_memory(
            f"tile coding of {tilings:,} tilings and {features:,} features",
            1e3 * tilings + 8.0 * features,
        )
        offsets, strides, bases, base = [], [], [], 0
        for variables, n_tilings in self.groups:
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
                base += step
        self.num_features, self.num_active = base, len(bases)
        self.tables = (
            self.low,
            np.array(self.tiles) / (self.high - self.low),
            np.array(offsets),
            np.array(extent),
            np.array(self.wrap),
            np.array(strides),
            np.array(bases, dtype=np.int64),
        )

    def active(self, obs: Sequence[float]) -> np.ndarray:
        """The active tile of every tiling, int64 ``(num_active,)``."""
        out = np.empty(self.num_active, dtype=np.int64)
        compiled(tile_active)(np.asarray(obs, dtype=np.float64), *self.tables, out)
        return out

    def __repr__(self) -> str:
        return (
            f"TileCoder({self.num_active} tilings, {self.num_features} features, "
            f"tiles={self.tiles}, groups={self.groups})"
        )


def book_tile_coder(
    space: Any,
    tilings: int = 12,
    subset_tilings: bool = True,
    angle_tiles: int = 6,
    velocity_tiles: int = 7,
) -> TileCoder:
    """Sutton and Barto's acrobot tile coding over ``space``'s bounds: ``tilings`` over all four
    variables and, with ``subset_tilings``, 3 per three variables, 2 per pair, 3 per variable."""
    groups: list[tuple[tuple[int, ...], int]] = [((0, 1, 2, 3), tilings)]
    if subset_tilings:
        for size, n in ((3, 3), (2, 2), (1, 3)):
            groups += [(subset, n) for subset in itertools.combinations(range(4), size)]
    tiles = (angle_tiles, angle_tiles, velocity_tiles, velocity_tiles)
    return TileCoder(groups, tiles, space.low, space.high)


@dataclass(frozen=True)
class GridConfig(Settings):
    """The report's grid: cells per angle and per velocity, the outermost velocity centre
    [rad/s]."""

    angle_bins: int = setting(5, "grid: bins per angle", low=1)
    velocity_bins: int = setting(3, "grid: bins per angular velocity", low=1)
    velocity_centre_max: float = setting(
        math.pi / 4, "grid: half-width of the velocity bins' range", "rad/s", low=0.0, low_open=True
    )

    def build(self, space: Any) -> StateGrid:
        v = self.velocity_centre_max
        return StateGrid(self.angle_bins, self.velocity_bins, velocity_range=(-v, v))


@dataclass(frozen=True)
class TilesConfig(Settings):
    """Sutton and Barto's tile coding (:func:`book_tile_coder`)."""

    tilings: int = setting(12, "tiles: number of tilings", low=1)
    subset_tilings: bool = setting(
        True, "tiles: add tilings over subsets of the state (true or false)"
    )
    angle_tiles: int = setting(6, "tiles: tiles per angle in each tiling", low=1)
    velocity_tiles: int = setting(7, "tiles: tiles per velocity in each tiling", low=1)

    def build(self, space: Any) -> TileCoder:
        return book_tile_coder(space, **asdict(self))


#: The kinds of features, by name, with their typed configs.
FEATURES: dict[str, type] = {"grid": GridConfig, "tiles": TilesConfig}
