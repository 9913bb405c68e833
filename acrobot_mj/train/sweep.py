"""Sweeps: seeds x a grid of hyperparameters (a sweep file, :mod:`.sweep_spec`), on this
machine or on a Ray cluster, resumable.

Every trial (grid point x seed) writes ``DIR/trials/NAME/run.json`` as soon as it finishes; a
re-run skips trials that have one, so a crash or Ctrl-C loses nothing finished. A failing trial
writes ``error.json`` instead and the others go on. The end writes ``DIR/summary.json``,
``DIR/summary.md`` (a table of the final greedy performance per grid point: median and spread
over seeds, scored by the task) and ``DIR/summary.png``.
"""

from __future__ import annotations

import json
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import write_json
from acrobot_mj.report.plots import Series, line_plot
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.lockstep import train_lockstep
from acrobot_mj.train.records import recent_score
from acrobot_mj.train.rundir import RUN_FILE, SUMMARY_FILE
from acrobot_mj.train.stats import spread
from acrobot_mj.train.sweep_spec import SweepSpec, Trial
from acrobot_mj.train.trainer import train

BACKENDS = ("local", "ray")


def _trial_dir(out: Path, trial: Trial) -> Path:
    return out / "trials" / trial.name


def _train_or_error(config: dict[str, Any], seed: int, run_dir: str | None) -> dict[str, Any]:
    """Train one trial (writing its run directory if given), or describe its error."""
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
    write_json(run_dir / "error.json", record)


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
        run = _trial_dir(out, t) / RUN_FILE
        if not run.exists():
            todo.append(t)
            continue
        record = json.loads(run.read_text())
        if _config_of(record) != t.config or record.get("seed") != t.seed:
            raise ValueError(
                f"{run} holds another sweep's trial (a different config or seed): "
                "give this sweep its own --out"
            )
    if backend == "local":
        _run_local(todo, out, jobs)
    else:
        _run_ray(todo, out, address, ray_num_cpus)
    return summarize_sweep(spec, out)


def _config_of(record: dict[str, Any]) -> TrainConfig | None:
    """The config of a trial's record (None if it holds none that is valid)."""
    try:
        return TrainConfig.from_dict(record["config"])
    except (KeyError, TypeError, ValueError):
        return None


def _run_local(todo: list[Trial], out: Path, jobs: int | None) -> None:
    # Tabular SARSA: one lockstep run per grid point (its seeds together on one vector env).
    by_point: dict[str, list[Trial]] = {}
    for trial in todo:
        if trial.config.lockstep:
            by_point.setdefault(trial.point_name, []).append(trial)
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
    write_json(run / RUN_FILE, record)
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
    out = Path(out)
    quantity = get_task(spec.base().task).score.quantity
    points: dict[str, dict[str, Any]] = {}
    for trial in spec.trials():
        entry = points.setdefault(
            trial.point_name,
            {"point": trial.point, "runs": 0, "failed": [], "greedy": [], "successes": []}
            | {"recent": []},
        )
        run = _trial_dir(out, trial)
        if (run / RUN_FILE).exists():
            record = json.loads((run / RUN_FILE).read_text())
            entry["runs"] += 1
            greedy = record.get("greedy_from_rest", {})
            entry["greedy"].append(greedy.get(quantity, float("nan")))
            entry["successes"].append(bool(greedy.get("success", False)))
            entry["recent"].append(recent_score(record))
        elif (run / "error.json").exists():
            entry["failed"].append(trial.seed)
    rows = [_point_row(key, entry) for key, entry in points.items()]
    summary = {
        "preset": spec.preset,
        "seeds": spec.seeds,
        "grid": spec.grid,
        "overrides": spec.overrides,
        "trials": len(spec.trials()),
        "points": rows,
    }
    write_json(out / SUMMARY_FILE, summary)
    (out / "summary.md").write_text(summary_table(summary))
    _plot_summary(out / "summary.png", spec, [r for r in rows if r["runs"]])
    return summary


def _point_row(key: str, entry: dict[str, Any]) -> dict[str, Any]:
    """One grid point's line of the summary."""
    greedy, recent = spread(entry["greedy"]), spread(entry["recent"])
    successes = entry["successes"]
    return {
        "name": key,
        "point": entry["point"],
        "runs": entry["runs"],
        "failed_seeds": entry["failed"],
        "greedy_median": greedy["median"],
        "greedy_q25": greedy["q25"],
        "greedy_q75": greedy["q75"],
        "greedy_success_fraction": sum(successes) / len(successes) if successes else 0.0,
        "last20_median": recent["median"],
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
