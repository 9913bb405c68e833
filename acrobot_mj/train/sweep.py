"""Sweeps: seeds x a grid of hyperparameters, on this machine or on a Ray cluster, resumable.

A sweep file (TOML) names a preset, overrides (top-level config keys, or an ``[overrides]``
table), ``seeds`` and a ``[grid]`` table of lists whose cartesian product is swept::

    preset = "report"
    episodes = 5
    seeds = [0, 1]
    [grid]
    alpha = [0.1, 0.5]

:func:`parse_sweep` checks every key and builds every trial's config, so a bad sweep fails before
anything runs. Every trial (grid point x seed) writes ``DIR/trials/NAME/run.json`` as soon as it
finishes; a trial counts as finished only when that record is readable, of this sweep, and says
it completed every episode; a re-run runs the others again, from their checkpoints. A failing
trial writes ``error.json`` and the others go on; Ctrl-C stops the sweep promptly (queued trials
cancelled, running ones save their checkpoints). The summary (``summary.json``, ``summary.md``,
``summary.png``) gives each grid point's greedy performance over its seeds, from rest and on the
held-out protocol, with its distinct behaviours, and names failed and unfinished seeds. One
process owns the sweep directory at a time.
"""

from __future__ import annotations

import itertools
import json
import sys
import tempfile
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import write_json, write_text
from acrobot_mj.report.plots import Series, line_plot
from acrobot_mj.train.config import TrainConfig, field_names
from acrobot_mj.train.evaluate import distinct_outcomes, evaluate_run
from acrobot_mj.train.learners import DEFAULT
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.lockstep import check_lockstep, lockstep_pays, train_lockstep
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.progress import Progress
from acrobot_mj.train.records import (
    CHECKPOINT_FILE,
    EVAL_FILE,
    RUN_FILE,
    SUMMARY_FILE,
    recent_score,
    spread,
)
from acrobot_mj.train.seeds import WorkerPool
from acrobot_mj.train.trainer import train

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

_TOP_LEVEL = ("preset", "seeds", "episodes", "grid", "overrides")
#: The presets a sweep can start from: the learners by interaction.
SWEEPABLE = {name: config for name, config in PRESETS.items() if isinstance(config, TrainConfig)}


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
        return SWEEPABLE[self.preset].replace(**self.overrides)

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
    unknown = sorted(set(data) - set(_TOP_LEVEL) - set(field_names()))
    if unknown:
        raise ValueError(
            f"{source}: unknown keys {unknown}; use {list(_TOP_LEVEL)} or config "
            f"keys {sorted(field_names())}"
        )
    preset, presets = data.get("preset", "report"), sorted(SWEEPABLE)
    if preset not in SWEEPABLE:
        raise ValueError(f"{source}: preset must be one of {presets}, got {preset!r}")
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
    top = {k: v for k, v in data.items() if k in field_names()}
    twice = sorted(set(top) & set(extra))
    if twice:
        raise ValueError(f"{source}: {twice[0]} is set at the top level and in [overrides]")
    swept = sorted(set(grid) & (set(top) | set(extra)))
    if swept:
        where = "at the top level" if swept[0] in top else "in [overrides]"
        raise ValueError(f"{source}: {swept[0]} is set {where} and swept in [grid]; keep one")
    for key, values in grid.items():
        if key not in field_names():
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


ERROR_FILE = "error.json"


def trial_dir(out: Path, trial: Trial) -> Path:
    """The run directory of ``trial`` in sweep directory ``out``."""
    return out / "trials" / trial.name


def complete(record: dict[str, Any], config: TrainConfig) -> bool:
    """Whether a run record says its run spent its whole budget (``config.finished``)."""
    return (
        record.get("interrupted") is False
        and config.finished(record)
        and isinstance(record.get("greedy_from_rest"), dict)
    )


def trial_state(out: Path, trial: Trial) -> tuple[dict[str, Any] | None, str]:
    """``(record, "")`` for a finished trial, else ``(None, why it must run)``; a record of
    another sweep's trial raises (this sweep would overwrite it)."""
    path = trial_dir(out, trial) / RUN_FILE
    if not path.exists():
        return None, "not run yet"
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        return None, f"its record {path} is unreadable ({error})"
    if not isinstance(record, dict) or not isinstance(record.get("config"), dict):
        return None, f"its record {path} is not a run record"
    try:
        config = TrainConfig.from_dict(record["config"])
    except (TypeError, ValueError) as error:
        return None, f"its record {path} holds no valid config ({error})"
    if config != trial.config or record.get("seed") != trial.seed:
        raise ValueError(
            f"{path} holds another sweep's trial (a different config or seed): "
            "give this sweep its own --out"
        )
    if not complete(record, trial.config):
        done = record.get("episodes_done")
        return None, f"its record says it stopped after {done} of {trial.config.episodes} episodes"
    return record, ""


def train_or_error(config: dict[str, Any], seed: int, run_dir: str | None) -> dict[str, Any]:
    """Train one trial (into its run directory if given, resuming from a checkpoint there), or
    describe its error. Ctrl-C (or the driver's stop) propagates: the run saved what it had."""
    try:
        resume = run_dir is not None and (Path(run_dir) / CHECKPOINT_FILE).exists()
        return train(TrainConfig.from_dict(config), seed, run_dir, resume=resume, overwrite=True)
    except Exception as error:  # a failing trial is recorded, the others go on
        return {
            "error": f"{type(error).__name__}: {error}",
            "traceback": traceback.format_exc(),
            "seed": seed,
            "config": config,
        }


def run_trial(config: dict[str, Any], seed: int, run_dir: str) -> dict[str, Any]:
    """One trial in this process: its files and its held-out evaluation, or ``error.json``."""
    record = train_or_error(config, seed, run_dir)
    if "error" in record:
        write_json(Path(run_dir) / ERROR_FILE, record)
    else:
        (Path(run_dir) / ERROR_FILE).unlink(missing_ok=True)
        evaluate_run(run_dir)
    return record


def train_elsewhere(config: dict[str, Any], seed: int) -> tuple[dict[str, Any], dict | None]:
    """One trial in a temporary directory of this (remote) process: its record and its
    held-out evaluation (None if it failed), for a driver without a shared file system."""
    with tempfile.TemporaryDirectory(prefix="acrobot-mj-trial-") as scratch:
        record = train_or_error(config, seed, scratch)
        return record, None if "error" in record else evaluate_run(scratch)


def trial_evaluation(out: Path, trial: Trial) -> dict[str, Any] | None:
    """A finished trial's held-out evaluation on the default protocol: its ``eval.json`` if
    that is of this trial and protocol, else evaluated now from its checkpoint (None without
    one)."""
    run_dir = trial_dir(out, trial)
    path = run_dir / EVAL_FILE
    if path.exists():
        saved = json.loads(path.read_text())
        if (
            saved.get("protocol") == DEFAULT.to_dict()
            and saved.get("run_seed") == trial.seed
            and saved.get("config") == trial.config.to_dict()
        ):
            return saved
    if not (run_dir / CHECKPOINT_FILE).exists():
        return None
    return evaluate_run(run_dir)


def run_trial_in_worker(config: dict[str, Any], seed: int, run_dir: str) -> dict[str, Any]:
    """:func:`run_trial` in a worker process: stopped by its driver, it returns (its run saved
    its checkpoint) instead of taking the worker down."""
    try:
        return run_trial(config, seed, run_dir)
    except KeyboardInterrupt:
        return {"interrupted": True, "seed": seed, "config": config}


def write_trial(
    out: Path, trial: Trial, record: dict[str, Any], evaluation: dict[str, Any] | None = None
) -> None:
    """A trial's record (or its error) and its held-out evaluation, written by the driver."""
    run = trial_dir(out, trial)
    if "error" in record:
        write_json(run / ERROR_FILE, record)
        return
    write_json(run / RUN_FILE, record)
    (run / ERROR_FILE).unlink(missing_ok=True)  # an earlier failure of this trial
    if evaluation is not None:
        write_json(run / EVAL_FILE, {**evaluation, "run": str(run)})


def summarize_sweep(spec: SweepSpec, out: str | Path) -> dict[str, Any]:
    """Final greedy performance per grid point (median and spread over seeds), from rest and
    on the held-out starts of the default protocol."""
    out = Path(out)
    quantity = get_task(spec.base().task).score.quantity
    points: dict[str, dict[str, Any]] = {}
    for trial in spec.trials():
        entry = points.setdefault(
            trial.point_name,
            {"point": trial.point, "runs": 0, "failed": [], "unfinished": [], "greedy": []}
            | {"successes": [], "recent": [], "evaluations": []},
        )
        record, _ = trial_state(out, trial)
        if record is not None:  # finished: it says so, with every episode
            entry["runs"] += 1
            greedy = record["greedy_from_rest"]
            entry["greedy"].append(greedy[quantity])
            entry["successes"].append(bool(greedy["success"]))
            entry["recent"].append(recent_score(record))
            evaluation = trial_evaluation(out, trial)
            if evaluation is not None:
                entry["evaluations"].append(evaluation)
        elif (trial_dir(out, trial) / "error.json").exists():
            entry["failed"].append(trial.seed)
        else:
            entry["unfinished"].append(trial.seed)
    rows = [_point_row(key, entry, quantity) for key, entry in points.items()]
    summary = {
        "protocol": DEFAULT.to_dict(),
        "preset": spec.preset,
        "seeds": spec.seeds,
        "grid": spec.grid,
        "overrides": spec.overrides,
        "trials": len(spec.trials()),
        "points": rows,
    }
    summary["unfinished"] = sum(len(r["unfinished_seeds"]) for r in rows)
    write_json(out / SUMMARY_FILE, summary)
    write_text(out / "summary.md", summary_table(summary))
    _plot_summary(out / "summary.png", spec, [r for r in rows if r["runs"]])
    return summary


def _point_row(key: str, entry: dict[str, Any], quantity: str) -> dict[str, Any]:
    """One grid point's line of the summary."""
    greedy, recent = spread(entry["greedy"]), spread(entry["recent"])
    successes, evaluations = entry["successes"], entry["evaluations"]
    held = spread([e["summary"][quantity]["median"] for e in evaluations])
    return {
        "name": key,
        "point": entry["point"],
        "runs": entry["runs"],
        "failed_seeds": entry["failed"],
        "unfinished_seeds": entry["unfinished"],
        "greedy_median": greedy["median"],
        "greedy_q25": greedy["q25"],
        "greedy_q75": greedy["q75"],
        "greedy_success_fraction": sum(successes) / len(successes) if successes else None,
        "last20_median": recent["median"],
        "held_out_median": held["median"],
        "held_out_q25": held["q25"],
        "held_out_q75": held["q75"],
        "held_out_runs": len(evaluations),
        "distinct_outcomes": distinct_outcomes(evaluations),
    }


def _plot_summary(path: Path, spec: SweepSpec, finished: list[dict[str, Any]]) -> None:
    """The greedy score per grid point with its 25-75 % band over seeds."""
    if not finished:
        return
    score = get_task(spec.base().task).score
    line_plot(
        path,
        [
            Series(
                f"greedy {score.unit} from rest: median, 25-75 % band over seeds",
                list(range(len(finished))),
                [r["greedy_median"] for r in finished],
                [r["greedy_q25"] for r in finished],
                [r["greedy_q75"] for r in finished],
            )
        ],
        f"Sweep of the {spec.preset} preset over {list(spec.grid)}",
        "grid point (rows of summary.md, in order)",
        f"{score.unit} from rest",
    )


def summary_table(summary: dict[str, Any]) -> str:
    """The summary as a Markdown table ("-" where no trial of a grid point finished)."""
    lines = [
        "| grid point | runs | failed | unfinished | held-out median per seed: median (IQR) | "
        "distinct behaviours | greedy from rest: median (IQR) | greedy success | "
        "last 20 episodes, median |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["points"]:
        if r["runs"]:
            held = (
                "-"
                if r["held_out_median"] is None
                else f"{r['held_out_median']:g} ({r['held_out_q25']:g}-{r['held_out_q75']:g})"
            )
            distinct = r["distinct_outcomes"]["held_out"]
            greedy = f"{r['greedy_median']:g} ({r['greedy_q25']:g}-{r['greedy_q75']:g})"
            success, recent = f"{r['greedy_success_fraction']:.0%}", f"{r['last20_median']:g}"
        else:
            held = distinct = greedy = success = recent = "-"
        lines.append(
            f"| {r['name']} | {r['runs']} | {len(r['failed_seeds'])} | "
            f"{len(r['unfinished_seeds'])} | {held} | {distinct} | {greedy} | {success} | "
            f"{recent} |"
        )
    return "\n".join(lines) + "\n"


BACKENDS = ("local", "ray")


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
    *,
    backend: str = "local",
    address: str | None = None,
    jobs: int | None = None,
    ray_num_cpus: int | None = None,
    progress: bool = False,
    lockstep: bool | None = None,
) -> dict[str, Any]:
    """Run the trials that have not finished, then summarise all of them (``progress``: a bar
    over the trials on stderr). ``lockstep``: each grid point's seeds left to train together on
    one vector env, in this process (True: every point, refused where a point has no lockstep
    form and with Ray; the same records), one trial per process (False), or the algorithm's
    faster way (None: tabular SARSA's points with at least 25 seeds left)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if lockstep:
        _check_lockstep(spec, backend)
    out = Path(out)
    with RunLock(out, "sweep"):
        todo = []
        for trial in spec.trials():
            record, why = trial_state(out, trial)
            if record is None:
                todo.append(trial)
                if why != "not run yet":
                    sys.stderr.write(f"sweep: running {trial.name} again: {why}\n")
        stop: KeyboardInterrupt | None = None
        bar = Progress(len(todo), f"sweep {out.name}", progress, unit="trials")
        try:
            if backend == "local":
                _run_local(todo, out, jobs, bar, lockstep)
            else:
                _run_ray(todo, out, address, ray_num_cpus, bar)
        except KeyboardInterrupt as interrupt:
            stop = interrupt
        finally:
            bar.close()
        summary = summarize_sweep(spec, out)
    if stop:
        raise type(stop)(
            f"sweep interrupted: {summary['unfinished']} of {summary['trials']} trials "
            "unfinished (running ones saved their checkpoints); run it again to continue"
        )
    return summary


def _check_lockstep(spec: SweepSpec, backend: str) -> None:
    """Refuse a lockstep sweep on Ray, or with a grid point that has no lockstep form."""
    if backend != "local":
        raise ValueError("lockstep sweeps run on the local backend (Ray runs one task a trial)")
    for trial in spec.trials():
        try:
            check_lockstep(trial.config)
        except ValueError as error:
            raise ValueError(f"grid point {trial.point_name}: {error}") from None


def _run_local(
    todo: list[Trial], out: Path, jobs: int | None, bar: Progress, lockstep: bool | None
) -> None:
    # One lockstep run per grid point whose seeds go together (lockstep, or by default tabular
    # SARSA's with enough seeds left to train), those with checkpoints resumed together, the
    # others started together.
    left = Counter(t.point_name for t in todo)
    groups: dict[tuple[str, bool], list[Trial]] = {}
    for trial in todo:
        if lockstep_pays(trial.config, left[trial.point_name]) if lockstep is None else lockstep:
            saved = (trial_dir(out, trial) / CHECKPOINT_FILE).exists()
            groups.setdefault((trial.point_name, saved), []).append(trial)
    together = {id(t) for group in groups.values() for t in group}
    for (_, saved), group in groups.items():
        dirs = [trial_dir(out, t) for t in group]
        try:
            train_lockstep(group[0].config, [t.seed for t in group], run_dirs=dirs, resume=saved)
        except Exception:  # one trial at a time, each failure recorded
            for t in group:
                run_trial(t.config.to_dict(), t.seed, str(trial_dir(out, t)))
                bar.advance()
            continue
        for t in group:  # train_lockstep wrote each run.json; an earlier failure is over
            (trial_dir(out, t) / ERROR_FILE).unlink(missing_ok=True)
        bar.advance(len(group))
    rest = [t for t in todo if id(t) not in together]
    calls = [(t.config.to_dict(), t.seed, str(trial_dir(out, t))) for t in rest]
    if jobs == 1:  # in this process, one after the other
        for call in calls:
            run_trial(*call)
            bar.advance()
        return
    with WorkerPool(jobs) as pool:
        for future in pool.run(run_trial_in_worker, calls):
            future.result()
            bar.advance()


def _run_ray(
    todo: list[Trial], out: Path, address: str | None, num_cpus: int | None, bar: Progress
) -> None:
    try:
        import ray
    except ImportError as error:
        raise ImportError("the ray backend needs Ray: pip install acrobot-mj[ray]") from error
    started_here = not ray.is_initialized()
    if started_here:
        kwargs = {"address": address} if address else {"num_cpus": num_cpus}
        ray.init(include_dashboard=False, log_to_driver=False, **kwargs)
    # Tasks return their records and held-out evaluations, and this process writes them as
    # each finishes: the workers need no file system shared with the driver (and keep no
    # checkpoints).
    task = ray.remote(train_elsewhere)
    trial_of = {task.remote(t.config.to_dict(), t.seed): t for t in todo}
    pending = list(trial_of)
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            trial = trial_of[done[0]]
            try:
                record, evaluation = ray.get(done[0])
            except Exception as error:  # the worker itself died (crash, out of memory)
                error_record = {"error": f"{type(error).__name__}: {error}", "seed": trial.seed,
                                "config": trial.config.to_dict()}  # fmt: skip
                record, evaluation = error_record, None
            write_trial(out, trial, record, evaluation)
            bar.advance()
    finally:
        for ref in pending:  # Ctrl-C: the queued and running tasks are given up
            ray.cancel(ref)
        if started_here:
            ray.shutdown()
