"""Sweeps: seeds x a grid of hyperparameters (a sweep file, :mod:`.sweep_spec`), on this
machine or on a Ray cluster, resumable.

Every trial (grid point x seed) writes ``DIR/trials/NAME/run.json`` as soon as it finishes; a
re-run runs only the trials that have not finished (:mod:`.sweep_trials`), continuing from their
checkpoints, so a crash or Ctrl-C loses nothing finished. A failing trial writes ``error.json``
and the others go on. Ctrl-C stops the sweep promptly: queued trials are cancelled, running ones
save their checkpoints, and the summary (:mod:`.sweep_summary`) says what is unfinished. One
process owns the sweep directory at a time (:mod:`.lock`).
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path
from typing import Any

from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.lockstep import check_lockstep, train_lockstep
from acrobot_mj.train.progress import Progress
from acrobot_mj.train.rundir import CHECKPOINT_FILE
from acrobot_mj.train.sweep_spec import SweepSpec, Trial
from acrobot_mj.train.sweep_summary import summarize_sweep
from acrobot_mj.train.sweep_trials import (
    ERROR_FILE,
    run_trial,
    run_trial_in_worker,
    train_elsewhere,
    trial_dir,
    trial_state,
    write_trial,
)
from acrobot_mj.train.workers import WorkerPool

BACKENDS = ("local", "ray")


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
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
        if trial.config.lockstep_pays(left[trial.point_name]) if lockstep is None else lockstep:
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
                record, evaluation = (
                    {
                        "error": f"{type(error).__name__}: {error}",
                        "seed": trial.seed,
                        "config": trial.config.to_dict(),
                    },
                    None,
                )
            write_trial(out, trial, record, evaluation)
            bar.advance()
    finally:
        for ref in pending:  # Ctrl-C: the queued and running tasks are given up
            ray.cancel(ref)
        if started_here:
            ray.shutdown()
