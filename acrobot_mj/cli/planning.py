"""``acrobot-mj train --preset balance`` and the evaluation of its runs: the model-based balance
learner's options and one-line reports (library calls only: :mod:`acrobot_mj.train.plan`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from acrobot_mj.train.config import FIELD_NAMES
from acrobot_mj.train.plan_config import BALANCE_NOISE

#: The balance preset's command-line options: flag, PlanConfig field, help.
OPTIONS = (
    ("--reserve", "reserve", "nominal torque bound of the plan [N m] (default 0.8)"),
    ("--hold", "hold", "seconds of balance after the swing-up (default 60)"),
    ("--data-noise", "data_noise", "start noise of the data episodes (default 1.0)"),
    ("--horizons", "horizons", "start horizons of the search, START:STOP:STEP physics steps"),
    ("--targets", "targets", "upright poses the search tries, indices 0-5, e.g. 1,4 (all)"),
)


def add_plan_options(p: argparse.ArgumentParser) -> None:
    group = p.add_argument_group(
        "balance preset (model-based: identify, plan, TVLQR; acrobot_mj.train.plan)"
    )
    for flag, dest, text in OPTIONS:
        group.add_argument(flag, dest=f"plan_{dest}", metavar="VALUE", help=text)
    group.add_argument(
        "--discrete", dest="plan_discrete", action="store_true",
        help="{-1, 0, +1} N m torques (sigma-delta) instead of continuous ones",
    )  # fmt: skip


def plan_config_of(args: argparse.Namespace) -> Any:
    """The balance preset with the options given; options of the other presets are refused."""
    from acrobot_mj.train.plan_config import PLANNERS

    given = [name for name in FIELD_NAMES if getattr(args, name) is not None]
    refused = [name for name in given if name != "identify_decisions"]
    if refused:
        flags = ", ".join(f"--{name.replace('_', '-')}" for name in refused)
        raise ValueError(f"{flags}: not a setting of the balance preset (a planner, not a "
                         "tabular or tile-coded learner)")  # fmt: skip
    overrides: dict[str, Any] = {}
    if args.identify_decisions is not None:
        overrides["identify_decisions"] = _number(
            args.identify_decisions, int, "--identify-decisions"
        )
    for flag, dest, _ in OPTIONS:
        text = getattr(args, f"plan_{dest}")
        if text is None:
            continue
        if dest in ("horizons", "targets"):
            parts = text.split(":" if dest == "horizons" else ",")
            overrides[dest] = tuple(_number(v, int, flag) for v in parts)
        else:
            overrides[dest] = _number(text, float, flag)
    if args.plan_discrete:
        overrides["discrete"] = True
    return PLANNERS[args.preset].replace(**overrides)


def check_no_plan_options(args: argparse.Namespace) -> None:
    """Refuse the balance preset's options with another preset."""
    given = [flag for flag, dest, _ in OPTIONS if getattr(args, f"plan_{dest}") is not None]
    given += ["--discrete"] if args.plan_discrete else []
    if given:
        raise ValueError(f"{', '.join(given)}: only the balance preset takes these")


def _number(text: str, kind: type, flag: str) -> Any:
    try:
        return kind(text)
    except ValueError:
        raise ValueError(f"{flag} needs {kind.__name__} values, got {text!r}") from None


def train_plan_command(args: argparse.Namespace, progress: bool) -> dict[str, Any]:
    from acrobot_mj.train.plan import train_plan

    if args.seeds is not None or args.resume or args.jobs != 1:
        raise ValueError("the balance preset trains one seed per command (no --seeds, --jobs "
                         "or --resume: a run takes minutes and has nothing to resume)")  # fmt: skip
    config = plan_config_of(args)
    out = Path(args.out or f"runs/balance__seed{args.seed}")
    record = train_plan(config, args.seed, out, progress=progress, overwrite=args.force)
    print(f"trained -> {out}: " + plan_words(record))
    return record


def plan_words(record: dict[str, Any]) -> str:
    """One line on a balance run: the model, the plan, the result from rest."""
    model, plan, rest = record["model"], record["plan"], record["greedy_from_rest"]
    held = "balanced" if rest["balanced"] else f"held {rest['hold_seconds']:g} s"
    return (
        f"model from {model['data_decisions']} random-torque decisions (RMS error "
        f"{model['rms']:.2g}); plan {plan['seconds']:g} s to upright; from rest: {held} after "
        f"{rest['swing_up_seconds']:g} s, largest error {rest['max_error_during_hold'] or 0:.2g} "
        f"rad; {record['wall_seconds']:.0f} s"
    )


def plan_evaluation_words(record: dict[str, Any]) -> str:
    """One line on a balance run's held-out evaluation."""
    summary, rest = record["summary"], record["rest"]
    hold = summary["hold_seconds"]
    return (
        f"{summary['episodes']} held-out starts (U(-{record['protocol']['start_noise']:g}, "
        f"{record['protocol']['start_noise']:g})): {summary['balanced']} ended balanced, hold "
        f"median {hold['median']:g} s (min {hold['min']:g} s); from rest: "
        + ("balanced" if rest["balanced"] else f"held {rest['hold_seconds']:g} s")
    )


def evaluate_plan_command(args: argparse.Namespace) -> dict[str, Any]:
    from acrobot_mj.train.heldout import Protocol
    from acrobot_mj.train.plan_eval import evaluate_plan

    if args.minima:
        raise ValueError("--minima compares swing-up lengths on the height goal; a balance "
                         "run has none")  # fmt: skip
    noise = BALANCE_NOISE if args.start_noise is None else args.start_noise
    record = evaluate_plan(args.run_dir, Protocol(args.episodes, noise, args.seed))
    print(plan_evaluation_words(record) + f"; wrote {Path(args.run_dir) / 'eval.json'}")
    return record
