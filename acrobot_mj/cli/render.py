"""``acrobot-mj render``: an MP4 (or a live window) of a run's greedy episode from rest, of a
controller's, or of a fixed policy's."""

from __future__ import annotations

import argparse
from typing import Any

from acrobot_mj.cli import tools
from acrobot_mj.cli.controllers import add_source, controlled
from acrobot_mj.cli.tools import (
    add_command,
    add_progress,
    output_file,
    positive_int,
    seed,
    show_progress,
)
from acrobot_mj.control.policies import POLICY_NAMES
from acrobot_mj.olympics.sources import kind_of
from acrobot_mj.report.video import RenderSettings, render_policy, watch_policy
from acrobot_mj.train.evaluate import render_controlled, render_run, watch_learner, watch_run
from acrobot_mj.train.records import output_into


def add_render(commands: tools.Commands) -> None:
    p = add_command(
        commands,
        "render",
        render_command,
        "MP4 of a trained run's greedy policy, or of a fixed policy",
        "Render an episode from rest to MP4 at real time (EGL or OSMesa, headless).",
    )
    p.add_argument(
        "run_dir",
        nargs="?",
        metavar="RUN|CONTROLLER",
        help="a directory written by acrobot-mj train (or balance --feedback); or a controller "
        "(as olympics takes it) on --model",
    )
    p.add_argument("--policy", choices=POLICY_NAMES, help="a fixed policy instead of a run")
    p.add_argument("--out", type=output_file, help="the .mp4 file (a .json record goes beside it)")
    p.add_argument(
        "--live",
        action="store_true",
        help="show the episode in MuJoCo's viewer window at real time instead (needs a display)",
    )
    p.add_argument("--steps", type=positive_int, help="most steps (default: the whole episode)")
    p.add_argument("--seed", type=seed, default=0, help="seed of the env, ties and --policy random")
    p.add_argument(
        "--frame-skip",
        type=positive_int,
        help="with --policy only (default: 1; a run renders at its own)",
    )
    p.add_argument("--width", type=positive_int, default=480, help="video width [pixels]")
    p.add_argument("--height", type=positive_int, default=480, help="video height [pixels]")
    p.add_argument("--camera", default="side", help="a camera of the model: side or wide")
    p.add_argument(
        "--strip", metavar="PNG", type=output_file, help="also write a strip of 6 frames"
    )
    p.add_argument(
        "--captions",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="time, torque and tip height on each frame",
    )
    add_source(p, None, "a controller's acrobot (a run renders on its own)")
    add_progress(p)


def render_command(args: argparse.Namespace) -> dict[str, Any]:
    if (args.run_dir is None) == (args.policy is None):
        raise ValueError("give either a run directory or --policy, not both or neither")
    if args.run_dir is not None and args.frame_skip is not None:
        raise ValueError("--frame-skip is for --policy: a run renders at its own frame skip")
    controller = None
    if args.run_dir is not None and kind_of(args.run_dir) != "run":
        controller = controlled(args, args.run_dir)
    elif args.model is not None or args.option or args.env:
        raise ValueError("a run renders on its own acrobot: give no --model, --option or --env")
    frame_skip = args.frame_skip or 1
    settings = RenderSettings(
        args.width,
        args.height,
        args.camera,
        args.captions,
        args.strip,
        args.steps,
        args.seed,
        show_progress(args),
    )
    if args.live:
        if args.out is not None or args.strip is not None:
            raise ValueError(
                "--live shows the episode in a window and writes nothing: give no --out or --strip"
            )
        if controller is not None:
            record = watch_learner(controller, settings)
        elif args.run_dir is not None:
            record = watch_run(args.run_dir, settings)
        else:
            record = watch_policy(args.policy, settings, frame_skip)
        print(
            f"showed {record['length']} actions; the goal was "
            + ("reached" if record["success"] else "not reached")
        )
        return record
    if args.out is None:
        raise ValueError("give --out FILE.mp4 for the video, or --live to watch in a window")
    with output_into(args.out, "render"):
        if controller is not None:
            record = render_controlled(controller, args.out, settings)
        elif args.run_dir is not None:
            record = render_run(args.run_dir, args.out, settings)
        else:
            record = render_policy(args.policy, args.out, settings, frame_skip)
    outcome = "reaches the goal" if record["success"] else "does not reach the goal"
    if "balanced" in record:  # the balance task
        outcome = "stays balanced" if record["balanced"] else "does not stay balanced"
    print(
        f"wrote {args.out}: {record['frames']} frames at {record['fps']:g} fps; the policy "
        f"{outcome} in {record['length']} actions"
    )
    return record
