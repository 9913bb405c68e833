"""Sweeps: seeds x a grid of settings from a TOML file (docs/guide/sweeps.md), on this machine or on
a Ray cluster; resumable, each trial (grid point x seed) in ``DIR/trials/NAME``, a failing one
writing ``error.json``, and a summary (``summary.json``, ``.md``, ``.png``) at the end."""

from __future__ import annotations

import sys
import tempfile
import traceback
from collections import Counter
from pathlib import Path
from typing import Any

from acrobot_mj.bars import Steps
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import is_sealed, read_json, sealed, write_json, write_text
from acrobot_mj.pool import Ray, RayPool, WorkerPool, backend_of
from acrobot_mj.report.plots import Labels, Series, line_plot
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import distinct_outcomes, evaluate_run
from acrobot_mj.train.learners import DEFAULT
from acrobot_mj.train.lock import RunDirectoryBusy, RunLock
from acrobot_mj.train.lockstep import check_lockstep, lockstep_pays, train_lockstep
from acrobot_mj.train.records import (
    CHECKPOINT_FILE,
    EVAL_FILE,
    RUN_FILE,
    SUMMARY_FILE,
    recent_score,
    spread,
)
from acrobot_mj.train.run import PLAIN, RunOptions
from acrobot_mj.train.sweep_file import SweepSpec, Trial
from acrobot_mj.train.trainer import train

ERROR_FILE = "error.json"


def trial_dir(out: Path, trial: Trial) -> Path:
    return out / "trials" / trial.name


def complete(record: dict[str, Any], config: TrainConfig) -> bool:
    """Whether a run record says its run spent its whole budget."""
    greedy = isinstance(record.get("greedy_from_rest"), dict)
    return record.get("interrupted") is False and config.finished(record) and greedy


def trial_state(out: Path, trial: Trial) -> tuple[dict[str, Any] | None, str]:
    """``(record, "")`` for a finished trial, else ``(None, why it must run)``; raises for a
    record of another sweep's trial."""
    path = trial_dir(out, trial) / RUN_FILE
    if not path.exists():
        return None, "not run yet"
    try:
        record = read_json(path)
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
    """Train one trial (resuming from a checkpoint in ``run_dir``), or describe its error."""
    try:
        resume = run_dir is not None and (Path(run_dir) / CHECKPOINT_FILE).exists()
        options = RunOptions(resume, overwrite=True)
        return train(TrainConfig.from_dict(config), seed, run_dir, options)
    except Exception as error:  # a failing trial is recorded, the others go on
        error_record = {"error": f"{type(error).__name__}: {error}", "seed": seed}
        return error_record | {"traceback": traceback.format_exc(), "config": config}


def run_trial(config: dict[str, Any], seed: int, run_dir: str) -> dict[str, Any]:
    try:
        with RunLock(run_dir, "sweep trial"):  # held through the trial's records
            record = train_or_error(config, seed, run_dir)
            write_trial(Path(run_dir), record, None)
    except RunDirectoryBusy as busy:  # another process's: nothing written there, unfinished
        sys.stderr.write(f"sweep: trial {Path(run_dir).name} left unfinished: {busy}\n")
        return {"busy": str(busy), "seed": seed, "config": config}
    if "error" not in record:
        evaluate_run(run_dir)
    return record


def run_trial_in_worker(config: dict[str, Any], seed: int, run_dir: str) -> dict[str, Any]:
    """``run_trial`` in a worker: stopped by its driver, it returns, not kills the worker."""
    try:
        return run_trial(config, seed, run_dir)
    except KeyboardInterrupt:
        return {"interrupted": True, "seed": seed, "config": config}


def train_elsewhere(config: dict[str, Any], seed: int) -> tuple[dict[str, Any], dict | None]:
    """One trial in a temporary directory (no shared file system): its record and evaluation
    (None if it failed)."""
    with tempfile.TemporaryDirectory(prefix="acrobot-mj-trial-") as scratch:
        record = train_or_error(config, seed, scratch)
        return record, None if "error" in record else evaluate_run(scratch)


def write_trial(run: Path, record: dict[str, Any], evaluation: dict[str, Any] | None) -> None:
    if "error" in record:
        write_json(run / ERROR_FILE, record)
        return
    (run / ERROR_FILE).unlink(missing_ok=True)
    if evaluation is not None:  # from elsewhere: this process writes them
        write_json(run / RUN_FILE, record)
        moved = {k: v for k, v in evaluation.items() if k != "sha256"} | {"run": str(run)}
        write_json(run / EVAL_FILE, sealed(moved))


def trial_evaluation(out: Path, trial: Trial) -> dict[str, Any] | None:
    """A finished trial's default held-out evaluation: its ``eval.json`` if that is of this
    trial and protocol, else evaluated now (None without a checkpoint)."""
    run_dir = trial_dir(out, trial)
    path = run_dir / EVAL_FILE
    if path.exists():
        try:
            saved = read_json(path)
        except (OSError, ValueError):
            saved = None
        mine = {
            "protocol": DEFAULT.to_dict(),
            "run_seed": trial.seed,
            "config": trial.config.to_dict(),
        }
        if not is_sealed(saved):  # its checksum fails: unreadable, cut short or edited
            sys.stderr.write(
                f"sweep: evaluating {trial.name} again: {path} is not as it was "
                "written (unreadable, edited, or older than checksums)\n"
            )
        elif all(saved.get(k) == v for k, v in mine.items()):
            return saved
    return evaluate_run(run_dir) if (run_dir / CHECKPOINT_FILE).exists() else None


def summarize_sweep(spec: SweepSpec, out: str | Path) -> dict[str, Any]:
    """Each grid point's greedy score over its seeds, from rest and held out: ``summary.json``,
    ``.md`` and ``.png``."""
    out, score = Path(out), get_task(spec.base().task).score
    points: dict[str, dict[str, Any]] = {}
    for trial in spec.trials():
        entry = points.setdefault(
            trial.point_name,
            {"point": trial.point, "runs": 0}
            | {
                key: [] for key in ("failed", "unfinished", "greedy", "successes", "recent", "held")
            },
        )
        record, _ = trial_state(out, trial)
        if record is not None:
            entry["runs"] += 1
            entry["greedy"].append(record["greedy_from_rest"][score.quantity])
            entry["successes"].append(bool(record["greedy_from_rest"]["success"]))
            entry["recent"].append(recent_score(record))
            evaluation = trial_evaluation(out, trial)
            entry["held"] += [] if evaluation is None else [evaluation]
        else:
            failed = (trial_dir(out, trial) / ERROR_FILE).exists()
            entry["failed" if failed else "unfinished"].append(trial.seed)
    rows = [_point_row(key, entry, score.quantity) for key, entry in points.items()]
    unfinished = sum(len(r["unfinished_seeds"]) for r in rows)
    summary = {
        "protocol": DEFAULT.to_dict(),
        "preset": spec.preset,
        "seeds": spec.seeds,
        "grid": spec.grid,
        "overrides": spec.overrides,
        "trials": len(spec.trials()),
        "points": rows,
        "unfinished": unfinished,
    }
    write_json(out / SUMMARY_FILE, summary)
    write_text(out / "summary.md", summary_table(summary))
    finished = [r for r in rows if r["runs"]]
    if finished:
        band = ([r[f"greedy_{k}"] for r in finished] for k in ("median", "q25", "q75"))
        series = Series(
            f"greedy {score.unit} from rest: median, 25-75 % band over seeds",
            list(range(len(finished))),
            *band,
        )
        line_plot(
            out / "summary.png",
            [series],
            Labels(
                f"Sweep of the {spec.preset} preset over {list(spec.grid)}",
                "grid point (rows of summary.md, in order)",
                f"{score.unit} from rest",
            ),
        )
    return summary


def _point_row(key: str, entry: dict[str, Any], quantity: str) -> dict[str, Any]:
    greedy, successes = spread(entry["greedy"]), entry["successes"]
    held = spread([e["summary"][quantity]["median"] for e in entry["held"]])
    return {
        "name": key,
        "point": entry["point"],
        "runs": entry["runs"],
        "failed_seeds": entry["failed"],
        "unfinished_seeds": entry["unfinished"],
        **{f"greedy_{k}": greedy[k] for k in ("median", "q25", "q75")},
        "greedy_success_fraction": sum(successes) / len(successes) if successes else None,
        "last20_median": spread(entry["recent"])["median"],
        **{f"held_out_{k}": held[k] for k in ("median", "q25", "q75")},
        "held_out_runs": len(entry["held"]),
        "distinct_outcomes": distinct_outcomes(entry["held"]),
    }


def summary_table(summary: dict[str, Any]) -> str:
    """The summary as a Markdown table ("-" where no trial of a grid point finished)."""
    lines = [
        "| grid point | runs | failed | unfinished | held-out median per seed: median (IQR) | "
        "distinct behaviours | greedy from rest: median (IQR) | greedy success | "
        "last 20 episodes, median |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["points"]:
        cells = ["-"] * 5
        if r["runs"]:
            held = f"{r['held_out_median']:g} ({r['held_out_q25']:g}-{r['held_out_q75']:g})"
            cells = [
                "-" if r["held_out_median"] is None else held,
                r["distinct_outcomes"]["held_out"],
                f"{r['greedy_median']:g} ({r['greedy_q25']:g}-{r['greedy_q75']:g})",
                f"{r['greedy_success_fraction']:.0%}",
                f"{r['last20_median']:g}",
            ]
        counts = [r["runs"], len(r["failed_seeds"]), len(r["unfinished_seeds"])]
        lines.append("| " + " | ".join(map(str, [r["name"], *counts, *cells])) + " |")
    return "\n".join(lines) + "\n"


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
    options: RunOptions = PLAIN,
    *,
    backend: str = "local",
    address: str | None = None,
    ray_num_cpus: int | None = None,
) -> dict[str, Any]:
    """Run the unfinished trials, then summarise all. ``options``: a ``progress`` bar over the
    trials; ``lockstep``: each grid point's seeds together on one vector env in this process
    (True: every point, refused where one cannot), one trial per process (False), or where that
    pays (None); ``jobs``: local processes. Ray: ``address``, or a local instance of
    ``ray_num_cpus``."""
    options.only("a sweep", "progress", "jobs", "lockstep")
    lockstep = options.lockstep
    where = backend_of(backend, options.jobs, address, ray_num_cpus)
    if lockstep and isinstance(where, Ray):
        raise ValueError("lockstep sweeps run on the local backend (Ray runs one task a trial)")
    if isinstance(where, Ray):
        where.check()
    for trial in spec.trials() if lockstep else ():
        try:
            check_lockstep(trial.config)
        except ValueError as error:
            raise ValueError(f"grid point {trial.point_name}: {error}") from None
    out, stop = Path(out), None
    with RunLock(out, "sweep"):
        todo = []
        for trial in spec.trials():
            record, why = trial_state(out, trial)
            todo += [trial] if record is None else []
            if record is None and why != "not run yet":
                sys.stderr.write(f"sweep: running {trial.name} again: {why}\n")
        try:
            with Steps(
                len(todo), f"sweep {out.name}", bool(options.progress), unit="trials"
            ) as bar:
                if isinstance(where, Ray):
                    _run_ray(todo, out, where, bar)
                else:
                    _run_local(todo, out, where, bar, lockstep)
        except KeyboardInterrupt as interrupt:
            stop = interrupt
        summary = summarize_sweep(spec, out)
    if stop:
        raise type(stop)(
            f"sweep interrupted: {summary['unfinished']} of {summary['trials']} "
            "trials unfinished (running ones saved their checkpoints); run it "
            "again to continue"
        )
    return summary


def _run_local(todo: list[Trial], out: Path, jobs: int | None, bar: Steps, lockstep) -> None:
    """One lockstep run per grid point whose seeds go together (those with checkpoints apart
    from the others), then every other trial in a process of its own."""
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
            options = RunOptions(resume=saved)
            train_lockstep(group[0].config, [t.seed for t in group], None, options, run_dirs=dirs)
        except Exception:  # one trial at a time, each failure recorded
            for t in group:
                run_trial(t.config.to_dict(), t.seed, str(trial_dir(out, t)))
                bar.done()
            continue
        for path in dirs:  # train_lockstep wrote each run.json; an earlier failure is over
            (path / ERROR_FILE).unlink(missing_ok=True)
        bar.done(count=len(group))
    calls = [
        (t.config.to_dict(), t.seed, str(trial_dir(out, t))) for t in todo if id(t) not in together
    ]
    if jobs == 1:  # in this process, one after the other
        for call in calls:
            run_trial(*call)
            bar.done()
        return
    with WorkerPool(jobs) as pool:
        for future in pool.run(run_trial_in_worker, calls):
            future.result()
            bar.done()


def _run_ray(todo: list[Trial], out: Path, cluster: Ray, bar: Steps) -> None:
    """Each trial a Ray task; this process writes its record and evaluation."""
    calls = [(t.config.to_dict(), t.seed) for t in todo]
    with RayPool(cluster) as pool:
        for index, ok, value in pool.finished(train_elsewhere, calls):
            trial = todo[index]
            if ok:
                record, evaluation = value
            else:  # the worker itself died (crash, out of memory)
                error = f"{type(value).__name__}: {value}"
                record = {"error": error, "seed": trial.seed, "config": trial.config.to_dict()}
                evaluation = None
            write_trial(trial_dir(out, trial), record, evaluation)
            bar.done()
