"""A sweep file (docs/guide/sweeps.md): a preset, seeds and a grid of settings in TOML, read into
a :class:`SweepSpec` of :class:`Trial` s (grid point x seed)."""

from __future__ import annotations

import itertools
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acrobot_mj.train.config import TrainConfig, field_names
from acrobot_mj.train.presets import PRESETS

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


_TOP_LEVEL = ("preset", "seeds", "episodes", "grid", "overrides")


SWEEPABLE = {name: config for name, config in PRESETS.items() if isinstance(config, TrainConfig)}


@dataclass(frozen=True)
class Trial:
    """A grid point and a seed; ``name`` (``KEY=VALUE__...__seed=S``) is its directory's."""

    name: str
    point: dict[str, Any]
    seed: int
    config: TrainConfig

    @property
    def point_name(self) -> str:
        return self.name.rsplit("__seed=", 1)[0]


@dataclass
class SweepSpec:
    preset: str
    seeds: list[int]
    grid: dict[str, list[Any]]
    overrides: dict[str, Any] = field(default_factory=dict)

    def base(self) -> TrainConfig:
        return SWEEPABLE[self.preset].replace(**self.overrides)

    def trials(self) -> list[Trial]:
        """The cartesian product of the grid (keys in file order) times the seeds."""
        trials, keys = [], list(self.grid)
        for values in itertools.product(*(self.grid[k] for k in keys)):
            point = dict(zip(keys, values, strict=True))
            config = self.base().replace(**point)
            label = "__".join(f"{k}={v}" for k, v in point.items())
            trials += [Trial(f"{label or 'base'}__seed={s}", point, s, config) for s in self.seeds]
        return trials


def parse_sweep(text: str, source: str = "sweep file") -> SweepSpec:
    """Read and check a sweep's TOML, every trial's config included; errors name the key."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{source} is not valid TOML: {error}") from error
    names = field_names()
    unknown = sorted(set(data) - set(_TOP_LEVEL) - set(names))
    if unknown:
        raise ValueError(
            f"{source}: unknown keys {unknown}; use {list(_TOP_LEVEL)} or config "
            f"keys {sorted(names)}"
        )
    preset, seeds = data.get("preset", "report"), data.get("seeds", [0])
    if preset not in SWEEPABLE:
        raise ValueError(f"{source}: preset must be one of {sorted(SWEEPABLE)}, got {preset!r}")
    distinct = isinstance(seeds, list) and seeds and len(set(seeds)) == len(seeds)
    if not (distinct and all(type(s) is int and s >= 0 for s in seeds)):
        raise ValueError(
            f"{source}: seeds must be a non-empty list of distinct integers >= 0, got {seeds!r}"
        )
    extra, grid = data.get("overrides", {}), data.get("grid", {})
    if not isinstance(extra, dict):
        raise ValueError(f"{source}: [overrides] must be a table of config keys")
    if not isinstance(grid, dict):
        raise ValueError(f"{source}: [grid] must be a table of lists")
    top = {k: v for k, v in data.items() if k in names}
    values = [("", k, v) for k, v in {**top, **extra}.items()]
    values += [("grid ", k, v) for k, vs in grid.items() if isinstance(vs, list) for v in vs]
    for where, key, value in values:
        if not isinstance(value, (bool, int, float, str)):
            raise ValueError(
                f"{source}: {where}{key} value {value!r} is not a number, string or boolean"
            )
    if set(top) & set(extra):
        raise ValueError(
            f"{source}: {sorted(set(top) & set(extra))[0]} is set at the top level "
            "and in [overrides]"
        )
    for key, values in grid.items():
        if key in top or key in extra:
            where = "at the top level" if key in top else "in [overrides]"
            raise ValueError(f"{source}: {key} is set {where} and swept in [grid]; keep one")
        if key not in names:
            raise ValueError(f"{source}: grid key {key!r} is not a config key")
        if not isinstance(values, list) or not values:
            raise ValueError(f"{source}: grid {key} must be a non-empty list")
        if min(len({json.dumps(v) for v in values}), len(set(map(str, values)))) < len(values):
            raise ValueError(f"{source}: grid {key} repeats a value: {values!r}")
    spec = SweepSpec(preset, seeds, grid, {**top, **extra})
    trials = spec.trials()  # building them checks every config
    # Tuples compare numbers by value (1 == 1.0): equal configs collapse.
    if len({(tuple(sorted(t.config.to_dict().items())), t.seed) for t in trials}) < len(trials):
        raise ValueError(f"{source}: two grid points give the same config (e.g. 1 and 1.0)")
    return spec


def load_sweep(path: str | Path) -> SweepSpec:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"sweep file not found: {path}")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(
            f"{path} is not a TOML file (not UTF-8 text: {error.reason} at byte {error.start})"
        ) from None
    return parse_sweep(text, str(path))
