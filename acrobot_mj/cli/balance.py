"""``acrobot-mj balance``: a swing-up followed and balanced (``balance.json`` and a video), or
with ``--feedback`` the state-feedback run and its video; every output checked before any work,
the output folder held (its lock) while it is written."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import gymnasium as gym

from acrobot_mj.cli.controllers import CONTROLLERS, add_source, controlled
from acrobot_mj.cli.tools import (
    Commands,
    add_command,
    add_progress,
    path_text,
    positive_int,
    show_progress,
    writable_folder,
)
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.report.video import RenderSettings, check_video
from acrobot_mj.settings import add_arguments
from acrobot_mj.train.balance_preset import PlanConfig
from acrobot_mj.train.evaluate import balance_controlled, render_run
from acrobot_mj.train.lock import RunLock
from acrobot_mj.train.records import CHECKPOINT_FILE, RUN_FILE, SUMMARY_FILE, check_fresh
from acrobot_mj.train.run import RunOptions


def add_balance(commands: Commands) -> None:
    p = add_command(
        commands,
        "balance",
        balance_command,
        "swing up AND balance at upright with |tau| <= 1 N m, in MuJoCo",
        "Follow a trajectory to upright at rest (shipped for --reserve 1 and 0.8, "
        "optimised with CasADi otherwise) with TVLQR, then balance with the "
        "constrained LQR; write balance.json (every step's torque and state) and a "
        "video.",
    )
    p.add_argument(
        "--feedback",
        action="store_true",
        help="build the state-feedback controller (no clock: swings up from any start, again "
        "after a push) into a run directory for evaluate and render",
    )
    p.add_argument(
        "--adaptive",
        action="store_true",
        help="with --feedback: identify the model from the first 3 s of each episode and "
        "replan the swing-up on it (CasADi)",
    )
    p.add_argument(
        "controller",
        nargs="?",
        type=path_text,
        metavar="CONTROLLER",
        help=f"swing up and balance with this controller instead: {CONTROLLERS}; its episode "
        "from hanging, 120 s, into balance.json (each decision's torque, the balance measures) "
        "and the video",
    )
    add_arguments(p, PlanConfig, ("discrete", "reserve"))
    add_source(
        p,
        None,
        "with --feedback or a CONTROLLER: the acrobot (default: the report's), with --feedback "
        "one with a planned swing-up",
    )
    add_arguments(p, PlanConfig, ("hold",), given=True)  # --feedback takes none
    p.add_argument(
        "--out",
        type=path_text,
        help="folder for balance.json and the video (default runs/balance; "
        "with --feedback the run directory, default runs/feedback)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="with --feedback: replace the run in --out (never one that is running)",
    )
    p.add_argument("--optimise", action="store_true", help="optimise the trajectory anew")
    video = argparse.BooleanOptionalAction
    p.add_argument("--video", action=video, default=True, help="render an MP4 of the closed loop")
    p.add_argument("--width", type=positive_int, default=480, help="video width [pixels]")
    p.add_argument("--height", type=positive_int, default=480, help="video height [pixels]")
    add_progress(p)


def balance_folder(args: argparse.Namespace) -> Path:
    """``--out`` (or its default), refused before any work where it cannot be a folder."""
    return writable_folder(Path(args.out or ("runs/feedback" if args.feedback else "runs/balance")))


def balance_video(args: argparse.Namespace, out: Path) -> RenderSettings | None:
    """The video's settings (None: ``--no-video``), refused before any work where
    :func:`~acrobot_mj.report.video.record_episode` would refuse them."""
    if not args.video:
        return None
    settings = RenderSettings(args.width, args.height, strip=out / "swing_up.png")
    with gym.make(Balance.env_id, render_mode="rgb_array", **settings.env_kwargs()) as env:
        check_video(env, out / "swing_up.mp4", settings.strip)
    return settings


def feedback_command(
    args: argparse.Namespace, out: Path, video: RenderSettings | None
) -> dict[str, Any]:
    """``balance --feedback``: the state-feedback run, and a video of it from rest."""
    from acrobot_mj.train.feedback_run import FeedbackConfig
    from acrobot_mj.train.trainer import train

    config = FeedbackConfig(
        discrete=args.discrete, reserve=args.reserve, adaptive=args.adaptive, model=args.model
    )
    with RunLock(out, "balance"):  # the run and its video, with no other writer between
        if not args.force:
            try:
                check_fresh(out)
            except FileExistsError as error:
                raise FileExistsError(f"{error} with --force") from None
        record = train(config, seed=0, out_dir=out, options=RunOptions(overwrite=args.force))
        rest = record["greedy_from_rest"]
        kind = ("{-1, 0, +1}" if args.discrete else "continuous") + " torques"
        kind += ", adaptive" if args.adaptive else ""
        held = (
            f"balanced after {rest['first_balance_seconds']:g} s"
            if rest["balanced_at_end"]
            else "NOT balanced at the end"
        )
        words = (
            f"state feedback built in {record['build_seconds']:.2f} s ({kind}, funnel "
            f"of the {record['swing_up']} swing-up); from rest: {held} -> {out}"
        )
        if video is not None:
            try:
                words += f", {render_run(out, out / 'swing_up.mp4', video)['video']}"
            except KeyboardInterrupt as stop:
                raise type(stop)(
                    f"interrupted while rendering the video; the run in {out} is whole: "
                    "evaluate or render it, or build it again with --force"
                ) from None
    print(words)
    return record


def controller_command(
    args: argparse.Namespace, out: Path, video: RenderSettings | None
) -> dict[str, Any]:
    """``balance CONTROLLER``: the controller's episode from hanging, and its video."""
    flags = ("feedback", "adaptive", "optimise", "discrete", "force")
    given = [f"--{flag}" for flag in flags if getattr(args, flag)]
    given += ["--hold"] if args.hold is not None else []
    if given:
        raise ValueError(
            f"{', '.join(given)}: options of the planned swing-up; a CONTROLLER runs 120 s from "
            "hanging and replaces its own balance.json"
        )
    args.model = args.model or "report"
    learner = controlled(args, args.controller)
    with RunLock(out, "balance"):
        refuse_a_run(out)
        record = balance_controlled(learner, out, video)
    held = (
        f"balanced after {record['assessment']['first_balance_seconds']:g} s"
        if record["assessment"]["balanced_at_end"]
        else "NOT balanced at the end"
    )
    video_words = f", {record['video']}" if record["video"] else ""
    print(
        f"{args.controller} on {args.model}, from hanging: {held} -> {out / 'balance.json'}"
        + video_words
    )
    return record


def refuse_a_run(out: Path) -> None:
    """Refuse ``out`` where it holds a run: balance writes a folder of its own."""
    if taken := [n for n in (RUN_FILE, CHECKPOINT_FILE, SUMMARY_FILE) if (out / n).exists()]:
        raise FileExistsError(
            f"{out} holds a run ({', '.join(taken)}): balance writes its own folder; "
            "choose another --out"
        )


def balance_command(args: argparse.Namespace) -> dict[str, Any]:
    from acrobot_mj.report.balance_run import BalanceRun, run_balance

    if args.controller is not None:
        out = balance_folder(args)
        return controller_command(args, out, balance_video(args, out))
    if args.option or args.env or args.env_kwargs:
        raise ValueError("--option, --env and --env-kwargs are for a CONTROLLER")
    if args.feedback and (args.optimise or args.hold is not None):
        raise ValueError(
            "--feedback follows a shipped swing-up for as long as an episode lasts "
            "(evaluate --seconds): give no --optimise or --hold"
        )
    if args.adaptive and not args.feedback:
        raise ValueError("--adaptive is an option of --feedback")
    if args.model is not None and not args.feedback:
        raise ValueError(
            "--model is an option of --feedback or a CONTROLLER: balance follows the report's plans"
        )
    if args.force and not args.feedback:
        raise ValueError("--force is for --feedback: balance replaces its own balance.json")
    out = balance_folder(args)
    video = balance_video(args, out)
    if args.feedback:
        return feedback_command(args, out, video)
    hold = PlanConfig.hold if args.hold is None else args.hold
    settings = BalanceRun(
        args.discrete, args.reserve, hold, args.optimise, args.video, (args.width, args.height)
    )
    with RunLock(out, "balance"):
        refuse_a_run(out)
        record = run_balance(out, settings, show_progress(args))
    trajectory = record["trajectory"]
    kind = "{-1, 0, +1}" if args.discrete else "continuous"
    held = (
        f"balanced for {record['hold_seconds']:.1f} s (largest error "
        f"{record['max_error_during_hold']:.2g} rad)"
        if record["balanced"]
        else f"NOT balanced: held {record['hold_seconds']:.1f} s of {hold:g}"
    )
    print(
        f"swing-up in {record['swing_up_seconds']:.2f} s along the {trajectory['source']} "
        f"trajectory ({trajectory['steps']} steps, |u| <= {trajectory['u_max']:g} N m), "
        f"{kind} torques; {held} -> {out / 'balance.json'}"
        + (f", {record['video']}" if record["video"] else "")
    )
    return record
