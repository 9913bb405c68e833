"""Sweep files: a preset, overrides, seeds and a grid of hyperparameters, as TOML.

A sweep file names a preset, optional overrides (top-level config keys, or an ``[overrides]``
table), ``seeds``, optional ``episodes`` and a ``[grid]`` table of lists whose cartesian product
is swept::

    preset = "report"
    episodes = 5
    seeds = [0, 1]
    [grid]
    alpha = [0.1, 0.5]

:func:`parse_sweep` checks every key and builds every trial's config, so a bad sweep fails before
anything runs; :mod:`.sweep` runs it.
"""

from __future__ import annotations

import itertools
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acrobot_mj.train.config import FIELD_NAMES, TrainConfig
from acrobot_mj.train.presets import PRESETS

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

_TOP_LEVEL = ("preset", "seeds", "episodes", "grid", "overrides")


@dataclass(frozen=True)
class Trial:
    """One run of a sweep: a grid point and a seed."""

    name: str  # "KEY=VALUE__...__seed=S", its directory's name
    point: dict[str, Any]  # the grid values of this trial
    seed: int
    config: TrainConfig

    @property
    def point_name(self) -> str:
        """The name of the trial's grid point (its name without the seed)."""
        return self.name.rsplit("__seed=", 1)[0]


@dataclass
class SweepSpec:
    preset: str
    seeds: list[int]
    grid: dict[str, list[Any]]
    overrides: dict[str, Any] = field(default_factory=dict)

    def base(self) -> TrainConfig:
        return PRESETS[self.preset].replace(**self.overrides)

    def trials(self) -> list[Trial]:
        """The cartesian product of the grid (keys in file order) times the seeds."""
        keys = list(self.grid)
        trials = []
        for values in itertools.product(*(self.grid[k] for k in keys)):
            point = dict(zip(keys, values, strict=True))
            config = self.base().replace(**point)
            label = "__".join(f"{k}={v}" for k, v in point.items()) or "base"
            trials += [Trial(f"{label}__seed={s}", point, s, config) for s in self.seeds]
        return trials


def parse_sweep(text: str, source: str = "sweep file") -> SweepSpec:
    """Read and check a sweep's TOML; errors name the offending key."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{source} is not valid TOML: {error}") from error
    unknown = sorted(set(data) - set(_TOP_LEVEL) - set(FIELD_NAMES))
    if unknown:
        raise ValueError(
            f"{source}: unknown keys {unknown}; use {list(_TOP_LEVEL)} or config "
            f"keys {sorted(FIELD_NAMES)}"
        )
    preset = data.get("preset", "report")
    if preset not in PRESETS:
        raise ValueError(f"{source}: preset must be one of {sorted(PRESETS)}, got {preset!r}")
    seeds = data.get("seeds", [0])
    if not (
        isinstance(seeds, list)
        and seeds
        and len(set(seeds)) == len(seeds)
        and all(type(s) is int and s >= 0 for s in seeds)
    ):
        raise ValueError(
            f"{source}: seeds must be a non-empty list of distinct integers >= 0, got {seeds!r}"
        )
    overrides, grid = _overrides_and_grid(data, source)
    spec = SweepSpec(preset, seeds, grid, overrides)
    trials = spec.trials()  # building them checks every config
    # Tuples compare numbers by value (1 == 1.0), so equal configs collapse here.
    if len({(tuple(sorted(t.config.to_dict().items())), t.seed) for t in trials}) != len(trials):
        raise ValueError(f"{source}: two grid points give the same config (e.g. 1 and 1.0)")
    return spec


def _overrides_and_grid(data: dict[str, Any], source: str) -> tuple[dict, dict[str, list]]:
    """The fixed overrides (top-level config keys and ``[overrides]``) and the grid, checked:
    a key given twice would have one value win silently, so it is refused, naming both places."""
    extra = data.get("overrides", {})
    if not isinstance(extra, dict):
        raise ValueError(f"{source}: [overrides] must be a table of config keys")
    grid = data.get("grid", {})
    if not isinstance(grid, dict):
        raise ValueError(f"{source}: [grid] must be a table of lists")
    top = {k: v for k, v in data.items() if k in FIELD_NAMES}
    twice = sorted(set(top) & set(extra))
    if twice:
        raise ValueError(f"{source}: {twice[0]} is set at the top level and in [overrides]")
    swept = sorted(set(grid) & (set(top) | set(extra)))
    if swept:
        where = "at the top level" if swept[0] in top else "in [overrides]"
        raise ValueError(f"{source}: {swept[0]} is set {where} and swept in [grid]; keep one")
    for key, values in grid.items():
        if key not in FIELD_NAMES:
            raise ValueError(f"{source}: grid key {key!r} is not a config key")
        if not isinstance(values, list) or not values:
            raise ValueError(f"{source}: grid {key} must be a non-empty list")
        if len({json.dumps(v) for v in values}) != len(values) or len(set(map(str, values))) != len(
            values
        ):
            raise ValueError(f"{source}: grid {key} repeats a value: {values!r}")
    return {**top, **extra}, grid


def load_sweep(path: str | Path) -> SweepSpec:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"sweep file not found: {path}")
    return parse_sweep(path.read_text(), str(path))
