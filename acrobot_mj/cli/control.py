"""``acrobot-mj balance``: swing up and balance with the model-based controller."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from acrobot_mj.cli.common import Commands, add_progress, positive_int, show_progress


def add_balance(commands: Commands) -> None:
    p = commands.add_parser(
        "balance",
        help="swing up AND balance at upright with |tau| <= 1 N m, in MuJoCo",
        description="Follow a trajectory to upright at rest (shipped for --reserve 1 and 0.8, "
        "re-checked against the dynamics; optimised with CasADi otherwise) with TVLQR, then "
        "balance with the saturated LQR; write balance.json (every step's torque and state) "
        "and a video.",
    )
    p.add_argument("--discrete", action="store_true", help="torques {-1, 0, +1} (sigma-delta)")
    p.add_argument(
        "--reserve",
        type=float,
        default=0.8,
        metavar="U",
        help="nominal torque bound |u| <= U N m of the trajectory, in (0, 1]; the rest is the "
        "feedback's (default 0.8; 1 is the minimum-time trajectory, with none)",
    )
    p.add_argument("--hold", type=float, default=60.0, help="seconds to balance after it")
    p.add_argument("--out", default="runs/balance", help="folder for balance.json and the video")
    p.add_argument("--optimise", action="store_true", help="optimise the trajectory anew")
    p.add_argument("--video", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--width", type=positive_int, default=480)
    p.add_argument("--height", type=positive_int, default=480)
    add_progress(p)
    p.set_defaults(func=balance_command)


def balance_command(args: argparse.Namespace) -> dict[str, Any]:
    from acrobot_mj.report.balance import run_balance  # MuJoCo and maybe CasADi: on demand

    out = Path(args.out)
    record = run_balance(
        out, args.discrete, args.reserve, args.hold, args.optimise, args.video,
        (args.width, args.height), show_progress(args),
    )  # fmt: skip
    trajectory = record["trajectory"]
    kind = "{-1, 0, +1}" if args.discrete else "continuous"
    held = (
        f"balanced for {record['hold_seconds']:.1f} s (largest error "
        f"{record['max_error_during_hold']:.2g} rad)"
        if record["balanced"]
        else f"NOT balanced: held {record['hold_seconds']:.1f} s of {args.hold:g}"
    )
    print(
        f"swing-up in {record['swing_up_seconds']:.2f} s along the {trajectory['source']} "
        f"trajectory ({trajectory['steps']} steps, |u| <= {trajectory['u_max']:g} N m), "
        f"{kind} torques; {held} -> {out / 'balance.json'}"
        + (f", {record['video']}" if record["video"] else "")
    )
    return record
