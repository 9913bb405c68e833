"""The report's state grid and the tile coder: hand-computed cells and tiling invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from acrobot_mj.agents.features import StateGrid, TileCoder, book_tile_coder
from acrobot_mj.envs.spaces import observation_space

PI = math.pi


def test_report_grid_centres_and_size() -> None:
    grid = StateGrid()
    angles = (-PI / 2, -PI / 4, 0.0, PI / 4, PI / 2)
    assert grid.centres == (angles, angles, (-PI / 4, 0.0, PI / 4), (-PI / 4, 0.0, PI / 4))
    assert grid.num_features == 225


@pytest.mark.parametrize(
    ("obs", "cells"),
    [
        ((-PI / 2, 0.0, 0.0, 0.0), (0, 2, 1, 1)),  # hanging at rest
        ((PI / 2, 0.0, 0.0, 0.0), (4, 2, 1, 1)),  # upright
        ((-3.0, 3.0, -10.0, 20.0), (0, 4, 0, 2)),  # beyond the outer centres: outer cells
        ((PI / 8 - 1e-9, PI / 8 + 1e-9, PI / 8 - 1e-9, PI / 8 + 1e-9), (2, 3, 1, 2)),  # midpoints
    ],
)
def test_grid_nearest_centre(obs, cells) -> None:
    # Hand-computed: row-major index over (q1, q2, dq1, dq2) with 5, 5, 3, 3 cells.
    q1, q2, v1, v2 = cells
    assert StateGrid().index(obs) == ((q1 * 5 + q2) * 3 + v1) * 3 + v2
    assert StateGrid().active(obs).tolist() == [StateGrid().index(obs)]


def test_grid_bins_are_configurable() -> None:
    grid = StateGrid(angle_bins=9, velocity_bins=7, velocity_range=(-4.0, 4.0))
    assert grid.num_features == 9 * 9 * 7 * 7
    assert grid.index((PI / 2, PI / 2, 4.0, 4.0)) == grid.num_features - 1
    with pytest.raises(ValueError, match="angle_bins"):
        StateGrid(angle_bins=0)
    with pytest.raises(ValueError, match="velocity_range"):
        StateGrid(velocity_range=(1.0, -1.0))


def test_tile_indices_hand_computed() -> None:
    # One variable over [0, 4) with 4 tiles (no wrap: 5 coordinates per tiling), 2 tilings.
    # Tiling 0 has offset 0, tiling 1 offset 1/2 tile: x = 1.2 -> floor(1.2) = 1 and
    # floor(1.7) = 1 in the second block (base 5): tiles 1 and 6.
    coder = TileCoder([((0,), 2)], tiles=(4,), low=(0.0,), high=(4.0,), wrap=(False,))
    assert coder.num_features == 10 and coder.num_active == 2
    assert coder.active([1.2]).tolist() == [1, 6]
    assert coder.active([1.6]).tolist() == [1, 7]
    assert coder.active([-5.0]).tolist() == [0, 5]  # below the range: the edge tiles
    assert coder.active([9.0]).tolist() == [4, 9]


def test_wrapping_variables_are_periodic() -> None:
    coder = book_tile_coder(observation_space())
    x = np.array([0.3, -2.0, 1.0, -3.0])
    shifted = x + [2 * PI, -2 * PI, 0.0, 0.0]
    np.testing.assert_array_equal(coder.active(x), coder.active(shifted))


def test_book_coder_invariants() -> None:
    coder = book_tile_coder(observation_space())
    assert coder.num_active == 48
    counts = {}
    for variables, n in coder.groups:
        counts[len(variables)] = counts.get(len(variables), 0) + n
    assert counts == {4: 12, 3: 12, 2: 12, 1: 12}
    rng = np.random.default_rng(0)
    low, high = coder.low, coder.high
    states = rng.uniform(low, high, (500, 4))
    blocks = np.append(coder.tables[6], coder.num_features)  # each tiling's first index
    for x in states:
        tiles = coder.active(x)
        # One active tile per tiling, inside that tiling's own block of indices.
        assert tiles.shape == (48,)
        assert np.all((tiles >= blocks[:-1]) & (tiles < blocks[1:]))
        np.testing.assert_array_equal(tiles, coder.active(x.copy()))  # same input, same tiles
    # Generalisation: a tiny move keeps most tiles, a large one few.
    x = states[0]
    near = np.sum(coder.active(x) == coder.active(x + [0.01, 0.0, 0.0, 0.0]))
    far = np.sum(coder.active(x) == coder.active(x + [PI, PI, 10.0, 20.0]))
    assert near >= 40 and far <= 15


def test_tile_coder_rejects_bad_specs() -> None:
    space = observation_space()
    bounds = {"tiles": (6, 6, 7, 7), "low": space.low, "high": space.high}
    with pytest.raises(ValueError, match="variable subset"):
        TileCoder([((0, 5), 2)], **bounds)
    with pytest.raises(ValueError, match="n_tilings"):
        TileCoder([((0,), 0)], **bounds)
    with pytest.raises(ValueError, match="tiles"):
        TileCoder([((0,), 1)], **{**bounds, "tiles": (0, 6, 7, 7)})
