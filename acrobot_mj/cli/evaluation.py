"""``acrobot-mj evaluate | curves``: parsers and handlers."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from acrobot_mj.cli import tools
from acrobot_mj.cli.controllers import CONTROLLERS, add_source, controlled
from acrobot_mj.cli.tools import add_command, seed
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.olympics.sources import kind_of
from acrobot_mj.report.plots import compare_curves, figure_format
from acrobot_mj.settings import add_arguments, declared, help_text
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import evaluate, evaluate_controlled
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.records import EVAL_FILE, RUN_FILE, SUMMARY_FILE, output_into, read_record


def add_evaluate(commands: tools.Commands) -> None:
    p = add_command(
        commands,
        "evaluate",
        evaluate_command,
        "greedy episodes of a trained run from held-out starts -> eval.json",
        "Greedy episodes from held-out starts (rest plus U(-S, S) on each angle and "
        "velocity, drawn with a seed no training uses), and apart from rest. "
        "eval.json holds every episode's start state and actions, to replay "
        "anywhere.",
    )
    p.add_argument(
        "run_dir",
        metavar="RUN|CONTROLLER",
        help=f"a directory written by acrobot-mj train (or balance --feedback); or {CONTROLLERS}, "
        "evaluated on --model into --out",
    )
    add_source(p, None, "a controller's acrobot (a run evaluates on its own)")
    p.add_argument("--out", type=tools.path_text, help="a controller's folder for eval.json")
    add_arguments(p, HeldOut, ("episodes", "start_noise"), given=True)
    p.add_argument("--seed", type=seed, help=help_text(HeldOut, "seed"))
    names = ("starts_from", "seconds", "push_every", "push_size", "perturb")
    add_arguments(p, HeldOut, names, given=True)
    sensor_motor = ("velocity_noise", "delay", "torque_noise", "torque_response")
    add_arguments(p, HeldOut, sensor_motor, given=True)
    p.add_argument(
        "--minima",
        action="store_true",
        help="compute per-start minimum-time "
        "references (beam search, ~4 s a start) where none are stored",
    )


def evaluate_command(args: argparse.Namespace) -> dict[str, Any]:
    starts = args.starts_from
    if args.start_noise is not None:  # noise starts, whatever the run's own protocol starts
        if starts == "uniform":
            raise ValueError("--start-noise is for --starts noise, not uniform")
        starts = "noise"
    given = {name: getattr(args, name) for name in declared(HeldOut)} | {"starts_from": starts}
    protocol = {k: v for k, v in given.items() if v is not None}
    if kind_of(args.run_dir) != "run":
        if args.out is None or args.minima:
            raise ValueError(
                f"{args.run_dir} is a controller: give --out for its eval.json (and no --minima)"
            )
        record = evaluate_controlled(controlled(args, args.run_dir), args.out, protocol)
        print(f"{evaluation_words(record)}; wrote {Path(args.out) / EVAL_FILE}")
        return record
    if args.model is not None or args.out is not None or args.option or args.env:
        raise ValueError(
            f"{args.run_dir} is a run: it evaluates on its own acrobot into its own folder "
            "(give no --model, --out, --option or --env)"
        )
    record = evaluate(args.run_dir, protocol, minima="compute" if args.minima else "stored")
    path = Path(args.run_dir) / EVAL_FILE
    wrote = f"wrote {path}" if os.access(args.run_dir, os.W_OK) else f"{args.run_dir} is read-only"
    print(f"{evaluation_words(record)}; {wrote}")
    return record


def balance_words(record: dict[str, Any]) -> str:
    """One line on a balance-task evaluation: catches, falls, recoveries from pushes."""
    summary, rest, protocol = record["summary"], record["rest"], record["protocol"]
    noise = protocol["start_noise"]
    starts = "uniform" if protocol.get("starts_from") == "uniform" else f"U(-{noise:g}, {noise:g})"
    caught, pushes = summary["first_balance_seconds"], summary["pushes"]
    when = (
        ""
        if caught["median"] is None
        else (f" (median {caught['median']:.4g} s, at most {caught['max']:.4g} s)")
    )
    words = (
        f"{summary['episodes']} held-out starts ({starts}): "
        f"{summary['episodes'] - summary['never_balanced']} caught their balance{when}, "
        f"{summary['balanced']} ended balanced, {summary['falls']} falls"
    )
    if pushes["total"]:
        words += (
            f"; {pushes['recovered']} of {pushes['total']} pushes recovered from; "
            f"{pushes['without_fall']} of the {pushes['while_balanced']} pushed while "
            "balanced held without a fall"
        )
    held = "balanced" if rest["balanced"] else f"held {rest['hold_seconds']:g} s"
    return f"{words}; from rest: {held}"


def evaluation_words(record: dict[str, Any]) -> str:
    """One line on an evaluation record: held-out scores, against the minima, and from rest."""
    summary, rest = record["summary"], record["rest"]
    if "balanced" in summary:  # the balance task's measures
        return balance_words(record)
    task = get_task(record["config"]["task"])
    quantity, unit = task.score.quantity, task.score.unit
    values = summary[quantity]
    words = (
        f"{summary['episodes']} held-out starts: {summary['successes']} {task.success_text}, "
        f"{quantity} median {values['median']:g} {unit} (IQR {values['q25']:g}-"
        f"{values['q75']:g})"
    )
    if "minima" in record:
        ratio = record["minima"]["ratio"]
        words += (
            f", {ratio['median']:.3g} x the per-start minima (IQR {ratio['q25']:.3g}-"
            f"{ratio['q75']:.3g})"
        )
    elif "no_minima" in record:
        words += f" ({record['no_minima']})"
    words += f"; from rest {rest[quantity]:g} {unit}"
    return words + ("" if rest["success"] else " (no goal)")


def add_curves(commands: tools.Commands) -> None:
    p = add_command(commands, "curves", curves_command, "learning curves of runs, one figure")
    p.add_argument(
        "run_dirs",
        nargs="+",
        help="directories written by train: of --seeds (their median and band) or "
        "one run's (a population's learner_K among them)",
    )
    p.add_argument(
        "--out",
        required=True,
        type=tools.output_file,
        help="the figure: .png, .svg or .pdf (by its suffix)",
    )
    p.add_argument("--title", default="Learning curves", help="the figure's title")
    p.add_argument("--minimum", action="store_true", help="draw the task's best known minimum")


def _curve_records(folder: Path) -> tuple[TrainConfig, list[dict[str, Any]]]:
    """The config and run records of a ``--seeds`` directory (its runs) or of one run."""
    summary_file, run_file = folder / SUMMARY_FILE, folder / RUN_FILE
    if summary_file.is_file():
        summary = read_record(summary_file)
        if not isinstance(summary.get("runs"), list) or not summary["runs"]:
            raise ValueError(f"{summary_file} lists no runs: nothing to draw")
        runs = [read_record(folder / str(run) / RUN_FILE) for run in summary["runs"]]
        return _config(summary_file, summary), runs
    if run_file.is_file():
        record = read_record(run_file)
        return _config(run_file, record), [record]
    raise FileNotFoundError(
        f"{folder} holds neither {SUMMARY_FILE} nor {RUN_FILE}: give "
        "directories written by acrobot-mj train"
    )


def _config(path: Path, record: dict[str, Any]) -> TrainConfig:
    try:
        return TrainConfig.from_dict(record["config"])
    except (KeyError, ValueError, TypeError) as error:
        raise ValueError(f"{path} holds no readable config: {error}") from None


def curves_command(args: argparse.Namespace) -> None:
    figure_format(args.out)  # a bad suffix is refused before any run is read
    groups: dict[str, list[list[float]]] = {}
    for folder in args.run_dirs:  # at least one (argparse)
        config, records = _curve_records(Path(folder))
        score = get_task(config.task).score
        try:
            groups[Path(folder).name] = [score.values(record) for record in records]
        except KeyError as error:
            raise ValueError(f"{folder}: a run record lacks {error}: not a training run") from None
    task = get_task(config.task)
    reference = task.reference(config.frame_skip) if args.minimum else None
    with output_into(args.out, "curves"):
        compare_curves(
            args.out,
            groups,
            args.title,
            [reference] if reference else [],
            task.score.label,
            task.score.log_scale,
        )
    print(f"wrote {args.out}")
