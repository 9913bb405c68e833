"""Several seeds of one config: a run directory per seed, a summary across them and their
learning curves; seeds in lockstep (:mod:`.lockstep`) where the algorithm allows, or in a
:class:`~acrobot_mj.pool.WorkerPool`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from acrobot_mj.bars import EpisodeBar
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import versions, write_json
from acrobot_mj.pool import WorkerPool
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import distinct_outcomes, evaluate_run
from acrobot_mj.train.learners import DEFAULT, HeldOut
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.lockstep import check_lockstep, lockstep_pays, train_lockstep
from acrobot_mj.train.monitor import (
    LogFollower,
    Monitor,
    run_total,
    summary_writer,
    watching,
)
from acrobot_mj.train.records import (
    CURVE_FILE,
    EPISODE_LOG,
    RECENT,
    SUMMARY_FILE,
    check_fresh,
    plot_learning_curves,
    recent_score,
    resumable,
    seed_dir,
    spread,
)
from acrobot_mj.train.run import PLAIN, RunOptions
from acrobot_mj.train.trainer import train

#: A seed's run record and its held-out evaluation (None: not evaluated where it trained).
SeedResult = tuple[dict[str, Any], dict[str, Any] | None]


@dataclass(frozen=True)
class SeedRuns:
    """What every seed's run of a ``train --seeds`` shares (sent to worker processes)."""

    config: TrainConfig
    out: Path
    resume: bool = False
    protocol: HeldOut | None = DEFAULT
    tensorboard: str | Path | None = None

    def one(
        self, seed: int, progress: bool | Monitor = False, board: str | None = None
    ) -> SeedResult:
        """One seed's run and (``protocol``) its held-out evaluation, where it trained. Resuming,
        a seed that never reached a checkpoint starts from its first episode."""
        run_dir = seed_dir(self.out, seed)
        resume = self.resume and resumable(run_dir)
        options = RunOptions(resume, overwrite=True, progress=progress, tensorboard=board)
        record = train(self.config, seed, run_dir, options)
        return record, None if self.protocol is None else evaluate_run(run_dir, self.protocol)

    def group(self, seeds: list[int], board: str | None = None) -> list[SeedResult]:
        """One lockstep group of seeds, then each one's held-out evaluation, where it trained."""
        dirs = [seed_dir(self.out, s) for s in seeds]
        options = RunOptions(self.resume, tensorboard=board)
        records = train_lockstep(self.config, seeds, None, options, run_dirs=dirs)
        return [
            (r, None if self.protocol is None else evaluate_run(d, self.protocol))
            for r, d in zip(records, dirs, strict=True)
        ]


def train_seeds(
    config: TrainConfig,
    seeds: list[int],
    out_dir: str | Path,
    options: RunOptions = PLAIN,
    *,
    protocol: HeldOut | None = DEFAULT,
) -> dict[str, Any]:
    """Train one run per seed into ``out_dir/seed_S`` (``options.jobs`` processes), evaluate each
    on ``protocol`` (None: not), then write ``out_dir/summary.json`` and the learning curve
    across seeds. ``options.progress``: one bar over all the seeds' episodes;
    ``options.tensorboard``: each seed's scalars in ``tensorboard/seed_S``;
    ``options.lockstep``: the seeds together on one vector env (True), one run per seed
    (False), or where that pays (None)."""
    options.only(
        "several seeds", "resume", "overwrite", "progress", "tensorboard", "jobs", "lockstep"
    )
    if not seeds:
        raise ValueError("train_seeds needs at least one seed")
    if options.tensorboard is not None:
        summary_writer()  # without the extra: its one-line error now, before any training
    out = Path(out_dir)
    with RunLock(out, "train --seeds"):
        if not options.resume and not options.overwrite:
            for path in (out, *(seed_dir(out, s) for s in seeds)):
                check_fresh(path)
        finished = _train_all(config, seeds, out, options, protocol)
        records = [record for record, _ in finished]
        evaluations: list[dict[str, Any] | None] = [evaluation for _, evaluation in finished]
        if protocol is not None and None in evaluations:  # lockstep here: evaluated now
            evaluations = [evaluate_run(seed_dir(out, s), protocol) for s in seeds]
        return _summarize_into(out, config, seeds, records, evaluations)


def _train_all(
    config: TrainConfig, seeds: list[int], out: Path, options: RunOptions, protocol: HeldOut | None
) -> list[SeedResult]:
    """Every seed's run, in lockstep or apart, here or in worker processes."""
    jobs = min(options.jobs or 1, len(seeds))
    lockstep = options.lockstep
    together = lockstep_pays(config, len(seeds) // jobs) if lockstep is None else lockstep
    if together:
        check_lockstep(config)
    runs = SeedRuns(config, out, options.resume, protocol, options.tensorboard)
    if together and jobs == 1:
        only = RunOptions(
            options.resume, progress=options.progress, tensorboard=options.tensorboard
        )
        return [(record, None) for record in train_lockstep(config, seeds, out, only)]
    if jobs == 1:
        count, unit = run_total(config)
        label = f"{config.algorithm} x{len(seeds)} seeds"
        total = (count * len(seeds), unit)
        with watching(options.progress, total, label, options.tensorboard) as monitor:
            return [runs.one(s, monitor.scoped(f"seed_{s}")) for s in seeds]
    return _in_workers(runs, seeds, jobs, together, bool(options.progress))


def _in_workers(runs: SeedRuns, seeds: list[int], jobs: int, together: bool, progress: bool):
    """Every seed's run in ``jobs`` processes (one lockstep group each, or a seed at a time)."""
    board = runs.tensorboard
    function: Callable[..., Any]
    calls: list[tuple[Any, ...]]
    if together:
        function, calls = runs.group, [(seeds[j::jobs], board) for j in range(jobs)]
    else:
        boards = [None if board is None else str(seed_dir(Path(board), s)) for s in seeds]
        function, calls = runs.one, [(s, False, b) for s, b in zip(seeds, boards, strict=True)]
    count, unit = run_total(runs.config)
    label = f"{'lockstep ' if together else ''}{runs.config.algorithm} x{len(seeds)} seeds"
    bar = EpisodeBar(count * len(seeds), f"{label}, {jobs} processes", progress, unit, RECENT)
    logs = [seed_dir(runs.out, s) / EPISODE_LOG for s in seeds]
    try:
        with WorkerPool(jobs) as pool, LogFollower(logs, bar):
            try:
                finished = [future.result() for future in pool.run(function, calls)]
            except KeyboardInterrupt as stop:
                pool.stop()
                raise type(stop)(
                    "interrupted; each seed's checkpoint holds its last completed episode"
                ) from None
    finally:
        bar.close()
    if together:
        finished = [run for group in finished for run in group]
    by_seed = {record["seed"]: (record, evaluation) for record, evaluation in finished}
    return [by_seed[s] for s in seeds]


def _summarize_into(out, config, seeds, records, evaluations) -> dict[str, Any]:
    """``summary.json``: the spread across seeds of their records and held-out ``evaluations``
    (unless there are none); and the learning curve across seeds."""
    quantity = get_task(config.task).score.quantity
    greedy = [r["greedy_from_rest"] for r in records if "greedy_from_rest" in r]
    summary = {
        "config": config.to_dict(),
        "versions": versions(),
        "decisions": spread([r["steps"] for r in records]),
        "seeds": [r["seed"] for r in records],
        "successes": spread([sum(r["episode_successes"]) for r in records]),
        "runs_with_a_success": sum(any(r["episode_successes"]) for r in records),
        f"last20_median_{quantity}": spread([recent_score(r) for r in records]),
        f"greedy_from_rest_{quantity}": spread([g[quantity] for g in greedy]),
        "greedy_from_rest_successes": sum(g["success"] for g in greedy),
        "runs": [seed_dir(Path(), s).name for s in seeds],
    }
    if None not in evaluations:
        held_out = summary["held_out"] = {
            "protocol": evaluations[0]["protocol"],
            f"median_{quantity}": spread([e["summary"][quantity]["median"] for e in evaluations]),
            "successes": spread([e["summary"]["successes"] for e in evaluations]),
            "distinct_outcomes": distinct_outcomes(evaluations),
        }
        if all("minima" in e for e in evaluations):
            held_out["median_ratio"] = spread([e["minima"]["ratio"]["median"] for e in evaluations])
    write_json(out / SUMMARY_FILE, summary)
    plot_learning_curves(out / CURVE_FILE, config, records, f"{len(seeds)} seeds")
    return summary
