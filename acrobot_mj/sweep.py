"""Sweeps: seeds x a grid of hyperparameters, on this machine or on a Ray cluster, resumable.

A sweep file (TOML) names a preset, optional overrides (top-level config keys, or an
``[overrides]`` table), ``seeds``, optional ``episodes`` and a ``[grid]`` table of lists whose
cartesian product is swept::

    preset = "report"
    episodes = 5
    seeds = [0, 1]
    [grid]
    alpha = [0.1, 0.5]

Every trial (grid point x seed) writes ``DIR/trials/NAME/run.json`` as soon as it finishes; a
re-run skips trials that have one, so a crash or Ctrl-C loses nothing finished. A failing trial
writes ``error.json`` instead and the others go on. The end writes ``DIR/summary.json``,
``DIR/summary.md`` (a table of the final greedy performance per grid point: median and spread
over seeds) and ``DIR/summary.png``.
"""

from __future__ import annotations

import itertools
import json
import sys
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.config import FIELD_NAMES, PRESETS, TrainConfig
from acrobot_mj.plots import Series, line_plot

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

BACKENDS = ("local", "ray")
_TOP_LEVEL = ("preset", "seeds", "episodes", "grid", "overrides")


@dataclass(frozen=True)
class Trial:
    name: str
    point: dict[str, Any]  # the grid values of this trial
    seed: int
    config: TrainConfig


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
    extra = data.get("overrides", {})
    if not isinstance(extra, dict):
        raise ValueError(f"{source}: [overrides] must be a table of config keys")
    overrides = {k: v for k, v in data.items() if k in FIELD_NAMES}
    overrides.update(extra)
    if "episodes" in data:
        overrides["episodes"] = data["episodes"]
    grid = data.get("grid", {})
    if not isinstance(grid, dict):
        raise ValueError(f"{source}: [grid] must be a table of lists")
    for key, values in grid.items():
        if key not in FIELD_NAMES:
            raise ValueError(f"{source}: grid key {key!r} is not a config key")
        if not isinstance(values, list) or not values:
            raise ValueError(f"{source}: grid {key} must be a non-empty list")
    for key, values in grid.items():
        if len({json.dumps(v) for v in values}) != len(values) or len(set(map(str, values))) != len(
            values
        ):
            raise ValueError(f"{source}: grid {key} repeats a value: {values!r}")
    spec = SweepSpec(preset, seeds, grid, overrides)
    trials = spec.trials()  # building them checks every config
    # Tuples compare numbers by value (1 == 1.0), so equal configs collapse here.
    if len({(tuple(sorted(t.config.to_dict().items())), t.seed) for t in trials}) != len(trials):
        raise ValueError(f"{source}: two grid points give the same config (e.g. 1 and 1.0)")
    return spec


def load_sweep(path: str | Path) -> SweepSpec:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"sweep file not found: {path}")
    return parse_sweep(path.read_text(), str(path))


def _trial_dir(out: Path, trial: Trial) -> Path:
    return out / "trials" / trial.name


def _train_or_error(config: dict[str, Any], seed: int, run_dir: str | None) -> dict[str, Any]:
    """Train one trial (writing its run directory if given), or describe its error."""
    from acrobot_mj.training import train

    try:
        return train(TrainConfig.from_dict(config), seed, run_dir, overwrite=True)
    except Exception as error:  # a failing trial is recorded, the others go on
        return {
            "error": repr(error),
            "traceback": traceback.format_exc(),
            "seed": seed,
            "config": config,
        }


def _write_error(run_dir: Path, record: dict[str, Any]) -> None:
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "error.json").write_text(json.dumps(record, indent=1))


def _run_trial(config: dict[str, Any], seed: int, run_dir: str) -> dict[str, Any]:
    """One trial in this process or a local worker process: its files, or error.json."""
    record = _train_or_error(config, seed, run_dir)
    if "error" in record:
        _write_error(Path(run_dir), record)
    else:
        (Path(run_dir) / "error.json").unlink(missing_ok=True)
    return record


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
    backend: str = "local",
    address: str | None = None,
    jobs: int | None = None,
    ray_num_cpus: int | None = None,
) -> dict[str, Any]:
    """Run the trials that have no ``run.json`` yet, then summarise all of them."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    trials = spec.trials()
    todo = []
    for t in trials:
        run = _trial_dir(out, t) / "run.json"
        if not run.exists():
            todo.append(t)
            continue
        record = json.loads(run.read_text())
        if record.get("config") != t.config.to_dict() or record.get("seed") != t.seed:
            raise ValueError(
                f"{run} holds another sweep's trial (a different config or seed): "
                "give this sweep its own --out"
            )
    if backend == "local":
        _run_local(todo, out, jobs)
    else:
        _run_ray(todo, out, address, ray_num_cpus)
    return summarize_sweep(spec, out)


def _run_local(todo: list[Trial], out: Path, jobs: int | None) -> None:
    from acrobot_mj.training import train_lockstep

    # Tabular SARSA: one lockstep run per grid point (its seeds together on one vector env).
    by_point: dict[str, list[Trial]] = {}
    for trial in todo:
        if trial.config.lockstep:
            by_point.setdefault(trial.name.rsplit("__seed=", 1)[0], []).append(trial)
    for group in by_point.values():
        try:
            records = train_lockstep(group[0].config, [t.seed for t in group])
        except Exception:
            for t in group:
                _run_trial(t.config.to_dict(), t.seed, str(_trial_dir(out, t)))
            continue
        for t, record in zip(group, records, strict=True):
            _write_run(out, t, record)
    rest = [t for t in todo if not t.config.lockstep]
    if jobs == 1:  # in this process, one after the other
        for t in rest:
            _run_trial(t.config.to_dict(), t.seed, str(_trial_dir(out, t)))
        return
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [
            pool.submit(_run_trial, t.config.to_dict(), t.seed, str(_trial_dir(out, t)))
            for t in rest
        ]
        for future in as_completed(futures):
            future.result()


def _write_run(out: Path, trial: Trial, record: dict[str, Any]) -> None:
    run = _trial_dir(out, trial)
    run.mkdir(parents=True, exist_ok=True)
    (run / "run.json").write_text(json.dumps(record, indent=1))
    (run / "error.json").unlink(missing_ok=True)  # an earlier failure of this trial


def _run_ray(todo: list[Trial], out: Path, address: str | None, num_cpus: int | None) -> None:
    try:
        import ray
    except ImportError as error:
        raise ImportError("the ray backend needs Ray: pip install acrobot-mj[ray]") from error
    started_here = not ray.is_initialized()
    if started_here:
        kwargs = {"address": address} if address else {"num_cpus": num_cpus}
        ray.init(include_dashboard=False, log_to_driver=False, **kwargs)
    try:
        # Tasks return their records and this process writes them as each finishes: the
        # workers need no file system shared with the driver.
        task = ray.remote(_train_or_error)
        trial_of = {task.remote(t.config.to_dict(), t.seed, None): t for t in todo}
        pending = list(trial_of)
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            trial = trial_of[done[0]]
            try:
                record = ray.get(done[0])
            except Exception as error:  # the worker itself died (crash, out of memory)
                record = {
                    "error": repr(error),
                    "seed": trial.seed,
                    "config": trial.config.to_dict(),
                }
            if "error" in record:
                _write_error(_trial_dir(out, trial), record)
            else:
                _write_run(out, trial, record)
    finally:
        if started_here:
            ray.shutdown()


def summarize_sweep(spec: SweepSpec, out: str | Path) -> dict[str, Any]:
    """Final greedy performance per grid point (median and spread over seeds)."""
    from acrobot_mj.training import last20_length

    out = Path(out)
    points: dict[str, dict[str, Any]] = {}
    for trial in spec.trials():
        key = trial.name.rsplit("__seed=", 1)[0]
        entry = points.setdefault(
            key,
            {
                "point": trial.point,
                "runs": 0,
                "failed": [],
                "greedy": [],
                "successes": [],
                "last20": [],
            },
        )
        run = _trial_dir(out, trial)
        if (run / "run.json").exists():
            record = json.loads((run / "run.json").read_text())
            entry["runs"] += 1
            greedy = record.get("greedy_from_rest", {})
            entry["greedy"].append(greedy.get("length", float("nan")))
            entry["successes"].append(bool(greedy.get("success", False)))
            entry["last20"].append(last20_length(record))
        elif (run / "error.json").exists():
            entry["failed"].append(trial.seed)
    rows = []
    for key, entry in points.items():
        g = np.asarray(entry["greedy"], dtype=float)
        q25, q50, q75 = np.percentile(g, [25, 50, 75]) if g.size else (np.nan,) * 3
        rows.append(
            {
                "name": key,
                "point": entry["point"],
                "runs": entry["runs"],
                "failed_seeds": entry["failed"],
                "greedy_median": float(q50),
                "greedy_q25": float(q25),
                "greedy_q75": float(q75),
                "greedy_success_fraction": float(np.mean(entry["successes"]))
                if entry["successes"]
                else 0.0,
                "last20_median": float(np.median(entry["last20"]))
                if entry["last20"]
                else float("nan"),
            }
        )
    summary = {
        "preset": spec.preset,
        "seeds": spec.seeds,
        "grid": spec.grid,
        "overrides": spec.overrides,
        "trials": len(spec.trials()),
        "points": rows,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    (out / "summary.md").write_text(summary_table(summary))
    finished = [r for r in rows if r["runs"]]
    if finished:
        x = np.arange(len(finished))
        line_plot(
            out / "summary.png",
            [
                Series(
                    "greedy decisions from rest: median, 25-75 % band over seeds",
                    x,
                    [r["greedy_median"] for r in finished],
                    [r["greedy_q25"] for r in finished],
                    [r["greedy_q75"] for r in finished],
                )
            ],
            f"Sweep of the {spec.preset} preset over {list(spec.grid)}",
            "grid point (rows of summary.md, in order)",
            "decisions from rest",
        )
    return summary


def summary_table(summary: dict[str, Any]) -> str:
    lines = [
        "| grid point | runs | failed | greedy from rest: median (IQR) | reach the goal | "
        "last 20 episodes, median |",
        "|---|---|---|---|---|---|",
    ]
    for r in summary["points"]:
        lines.append(
            f"| {r['name']} | {r['runs']} | {len(r['failed_seeds'])} | "
            f"{r['greedy_median']:g} ({r['greedy_q25']:g}-{r['greedy_q75']:g}) | "
            f"{r['greedy_success_fraction']:.0%} | {r['last20_median']:g} |"
        )
    return "\n".join(lines) + "\n"
