"""``acrobot-mj train | evaluate | sweep | curves``: parsers and handlers (library calls only)."""

from __future__ import annotations

import argparse
import json
from dataclasses import fields
from pathlib import Path
from typing import Any

from acrobot_mj.cli.common import Commands, add_progress, positive_int, seed, show_progress
from acrobot_mj.cli.planning import (
    add_plan_options,
    check_no_plan_options,
    evaluate_plan_command,
    train_plan_command,
)
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.report.plots import compare_curves, figure_format
from acrobot_mj.train.config import FIELD_NAMES, TrainConfig, parse_value
from acrobot_mj.train.evaluate import evaluate
from acrobot_mj.train.heldout import DEFAULT, Protocol
from acrobot_mj.train.plan_config import BALANCE_NOISE, PLANNERS, is_plan_run
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import recent_score
from acrobot_mj.train.rundir import EVAL_FILE, RUN_FILE, SUMMARY_FILE
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.sweep import run_sweep
from acrobot_mj.train.sweep_spec import load_sweep
from acrobot_mj.train.sweep_summary import summary_table
from acrobot_mj.train.trainer import train


def config_of(args: argparse.Namespace) -> TrainConfig:
    """The preset with every ``--<field>`` given on the command line applied."""
    overrides = {
        name: parse_value(name, getattr(args, name))
        for name in FIELD_NAMES
        if getattr(args, name) is not None
    }
    return PRESETS[args.preset].replace(**overrides)


def add_train(commands: Commands) -> None:
    p = commands.add_parser(
        "train",
        help="train a learner, write run.json, checkpoint and learning curve",
        description="Train the report's or the book's learner. Every config field can be "
        "overridden with --FIELD VALUE (floats may be fractions, e.g. --alpha 0.2/48).",
    )
    p.add_argument("--preset", choices=sorted([*PRESETS, *PLANNERS]), default="report")
    p.add_argument("--seed", type=seed, default=0, help="seed (the first one with --seeds)")
    p.add_argument(
        "--seeds",
        type=positive_int,
        help="train K seeds and write summary.json; tabular SARSA runs them in "
        "lockstep on one batched vector env from 25 a process, else one per process",
    )
    p.add_argument(
        "--jobs",
        type=positive_int,
        default=1,
        help="processes for --seeds (one seed at a time each, or a lockstep group each)",
    )
    p.add_argument(
        "--lockstep",
        action=argparse.BooleanOptionalAction,
        help="with --seeds or --population: train the seeds (or a run's learners) together on "
        "one vector env (Sarsa(lambda) needs --kernel numba; the same runs); default: the "
        "seeds of tabular SARSA from 25 a process, a population's learners one by one",
    )
    p.add_argument("--out", help="run directory (default runs/PRESET__ALGORITHM__seedS)")
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    p.add_argument("--force", action="store_true", help="overwrite a run already in --out")
    add_progress(p)
    p.add_argument(
        "--tensorboard",
        metavar="DIR",
        help="write each training episode's length, return and success to DIR for "
        "TensorBoard (needs the tensorboard extra)",
    )
    group = p.add_argument_group("config overrides (defaults: the preset's)")
    for f in fields(TrainConfig):
        group.add_argument(
            f"--{f.name.replace('_', '-')}", dest=f.name, metavar="VALUE", help=f.metadata["doc"]
        )
    add_plan_options(p)
    p.set_defaults(func=train_command)


def train_command(args: argparse.Namespace) -> dict[str, Any]:
    progress = show_progress(args)
    if args.preset in PLANNERS:
        return train_plan_command(args, progress)
    check_no_plan_options(args)
    config = config_of(args)
    if args.seeds is None and args.jobs != 1:
        raise ValueError("--jobs runs several seeds at once: it needs --seeds")
    if args.seeds is None and args.lockstep is not None and config.population == 1:
        raise ValueError(
            "--lockstep trains several seeds or a population's learners together: it needs "
            "--seeds or --population"
        )
    if args.seeds is not None:
        return _train_seeds(args, config, progress)
    out = Path(args.out or f"runs/{args.preset}__{config.algorithm}__seed{args.seed}")
    record = train(
        config,
        args.seed,
        out,
        resume=args.resume,
        progress=progress,
        overwrite=args.force,
        tensorboard=args.tensorboard,
        lockstep=args.lockstep,
    )
    task = get_task(config.task)
    pop = record.get("population")
    kept = f" (kept learner {pop['kept']} of {pop['learners']})" if pop else ""
    print(
        f"trained {record['episodes_done']} episodes ({record['steps']} decisions, "
        f"{record['wall_seconds']:.1f} s) -> {out}: {sum(record['episode_successes'])} "
        f"{task.success_text}; last 20 episodes{kept} median {recent_score(record):g} "
        f"{task.score.unit}; greedy from rest: {_greedy_words(record['greedy_from_rest'], task)}"
    )
    return record


def _greedy_words(greedy: dict[str, Any], task: Any) -> str:
    """``goal in 89 decisions`` (for the height goal), with the return where it is the score."""
    label = task.success_label.lower()
    words = f"{label if greedy['success'] else 'no ' + label} in {greedy['length']} decisions"
    if task.score.quantity == "return":
        words += f", return {greedy['return']:g} {task.score.unit}"
    return words


def _train_seeds(args: argparse.Namespace, config: TrainConfig, progress: bool) -> dict:
    out = Path(args.out or f"runs/{args.preset}__{config.algorithm}__seeds{args.seeds}")
    seeds = list(range(args.seed, args.seed + args.seeds))
    summary = train_seeds(
        config,
        seeds,
        out,
        jobs=args.jobs,
        resume=args.resume,
        progress=progress,
        overwrite=args.force,
        tensorboard=args.tensorboard,
        lockstep=args.lockstep,
    )
    score = get_task(config.task).score
    g, s = summary[f"greedy_from_rest_{score.quantity}"], summary["successes"]
    print(
        f"{len(seeds)} seeds -> {out}: successes per run median {s['median']:g} "
        f"(min {s['min']:g}, max {s['max']:g}); greedy {score.unit} from rest median "
        f"{g['median']:g} (IQR {g['q25']:g}-{g['q75']:g}), "
        f"{summary['greedy_from_rest_successes']}/{len(seeds)} {get_task(config.task).success_text}"
    )
    held = summary["held_out"]
    m, n = held[f"median_{score.quantity}"], held["protocol"]["episodes"]
    words = (
        f"held out ({n} starts): per-seed median {score.unit}, median over seeds {m['median']:g} "
        f"(IQR {m['q25']:g}-{m['q75']:g})"
    )
    if "median_ratio" in held:
        words += f", {held['median_ratio']['median']:.3g} x the per-start minima"
    distinct = held["distinct_outcomes"]["held_out"]
    print(words + f"; {distinct} distinct greedy behaviours in {len(seeds)} seeds")
    return summary


def add_evaluate(commands: Commands) -> None:
    p = commands.add_parser(
        "evaluate",
        help="greedy episodes of a trained run from held-out starts -> eval.json",
        description="Greedy episodes from held-out starts (rest plus U(-S, S) on each angle and "
        "velocity, drawn with a seed no training uses), and apart from rest. eval.json holds "
        "every episode's start state and actions, so any simulator can replay it.",
    )
    p.add_argument("run_dir", help="a directory written by acrobot-mj train")
    p.add_argument("--episodes", type=positive_int, default=DEFAULT.episodes)
    p.add_argument(
        "--start-noise",
        type=float,
        metavar="S",
        help=f"start noise [rad, rad/s] (default {DEFAULT.start_noise:g}; for a balance-preset "
        f"run {BALANCE_NOISE:g})",
    )
    p.add_argument("--seed", type=seed, default=DEFAULT.seed, help="seed of the held-out starts")
    p.add_argument(
        "--minima",
        action="store_true",
        help="compute the per-start minimum-time references (a beam search, about 4 s per "
        "start) where none are stored for this protocol and env",
    )
    p.set_defaults(func=evaluate_command)


def evaluate_command(args: argparse.Namespace) -> dict[str, Any]:
    if is_plan_run(args.run_dir):
        return evaluate_plan_command(args)
    noise = DEFAULT.start_noise if args.start_noise is None else args.start_noise
    protocol = Protocol(args.episodes, noise, args.seed)
    record = evaluate(args.run_dir, protocol, minima="compute" if args.minima else "stored")
    print(evaluation_words(record) + f"; wrote {Path(args.run_dir) / EVAL_FILE}")
    return record


def evaluation_words(record: dict[str, Any]) -> str:
    """One line on an evaluation record: held-out scores, against the minima, and from rest."""
    task = get_task(record["config"]["task"])
    quantity, unit = task.score.quantity, task.score.unit
    summary, rest = record["summary"], record["rest"]
    values = summary[quantity]
    words = (
        f"{summary['episodes']} held-out starts: {summary['successes']} {task.success_text}, "
        f"{quantity} median {values['median']:g} {unit} (IQR {values['q25']:g}-{values['q75']:g})"
    )
    if "minima" in record:
        ratio = record["minima"]["ratio"]
        words += f", {ratio['median']:.3g} x the per-start minima (IQR {ratio['q25']:.3g}-"
        words += f"{ratio['q75']:.3g})"
    words += f"; from rest {rest[quantity]:g} {unit}"
    return words + ("" if rest["success"] else " (no goal)")


def add_sweep(commands: Commands) -> None:
    p = commands.add_parser(
        "sweep",
        help="seeds x a grid of hyperparameters from a TOML file, resumable",
        description="Run every trial (grid point x seed) of SWEEP_FILE that has no run.json yet, "
        "then summarise. Local: lockstep for tabular SARSA, processes otherwise. Ray: one task "
        "per trial on ray.init(address=...) (a local instance without --address).",
    )
    p.add_argument("sweep_file", help="the sweep's TOML file")
    p.add_argument("--backend", choices=("local", "ray"), default="local")
    p.add_argument("--address", help="Ray cluster address (e.g. auto or ray://host:10001)")
    p.add_argument("--out", help="sweep directory (default runs/sweep__NAME)")
    p.add_argument("--jobs", type=positive_int, help="local processes (default: all cores)")
    p.add_argument("--num-cpus", type=positive_int, help="CPUs of a local Ray instance")
    p.add_argument(
        "--lockstep",
        action=argparse.BooleanOptionalAction,
        help="local: each grid point's seeds together on one vector env, in this process "
        "(Sarsa(lambda) needs kernel numba; the same records); default: tabular SARSA's points "
        "with 25 seeds left or more",
    )
    add_progress(p)
    p.set_defaults(func=sweep_command)


def sweep_command(args: argparse.Namespace) -> dict[str, Any]:
    spec = load_sweep(args.sweep_file)
    out = Path(args.out or f"runs/sweep__{Path(args.sweep_file).stem}")
    summary = run_sweep(
        spec,
        out,
        backend=args.backend,
        address=args.address,
        jobs=args.jobs,
        ray_num_cpus=args.num_cpus,
        progress=show_progress(args),
        lockstep=args.lockstep,
    )
    print(summary_table(summary), end="")
    print(
        f"{summary['trials']} trials -> {out}/trials; wrote summary.json, summary.md, summary.png"
    )
    return summary


def add_curves(commands: Commands) -> None:
    p = commands.add_parser("curves", help="learning curves of several runs, one figure")
    p.add_argument(
        "run_dirs",
        nargs="+",
        help="directories written by train: of --seeds (their median and band) or one run's "
        "(a population's learner_K among them)",
    )
    p.add_argument(
        "--out", required=True, help="the figure file: .png, .svg or .pdf (by its suffix)"
    )
    p.add_argument("--title", default="Learning curves")
    p.add_argument(
        "--minimum",
        action="store_true",
        help="draw the task's reference (the best known minimum: 63 decisions at frame_skip 4)",
    )
    p.set_defaults(func=curves_command)


def _curve_records(folder: Path) -> tuple[TrainConfig, list[dict[str, Any]]]:
    """The config and run records of a ``--seeds`` directory (its runs) or of one run."""
    summary_file, run_file = folder / SUMMARY_FILE, folder / RUN_FILE
    if summary_file.is_file():
        summary = json.loads(summary_file.read_text())
        if not summary.get("runs"):
            raise ValueError(f"{summary_file} lists no runs: nothing to draw")
        runs = [json.loads((folder / run / RUN_FILE).read_text()) for run in summary["runs"]]
        return TrainConfig.from_dict(summary["config"]), runs
    if run_file.is_file():
        record = json.loads(run_file.read_text())
        return TrainConfig.from_dict(record["config"]), [record]
    raise FileNotFoundError(
        f"{folder} holds neither {SUMMARY_FILE} nor {RUN_FILE}: give directories written by "
        "acrobot-mj train"
    )


def curves_command(args: argparse.Namespace) -> None:
    figure_format(args.out)  # a bad suffix is refused before any run is read
    groups, config = {}, None
    for folder in args.run_dirs:
        config, records = _curve_records(Path(folder))
        score = get_task(config.task).score
        groups[Path(folder).name] = [score.values(record) for record in records]
    task = get_task(config.task)
    reference = task.reference(config.frame_skip) if args.minimum else None
    compare_curves(
        args.out,
        groups,
        args.title,
        [reference] if reference else [],
        task.score.label,
        task.score.log_scale,
    )
    print(f"wrote {args.out}")
