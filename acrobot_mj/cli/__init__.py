"""Command line: ``acrobot-mj train | evaluate | render | validate | balance | olympics | bench |
sweep | curves | demo | params``. Each command parses its arguments and calls library functions."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Sequence
from typing import Any, NoReturn

import mujoco

from acrobot_mj.cli import balance, evaluation, learning, olympics, render, tools
from acrobot_mj.envs.acrobot import Diverged
from acrobot_mj.envs.gl import GLBackendError
from acrobot_mj.stops import clear_stop, raise_stop
from acrobot_mj.train.checkpoint import CheckpointError
from acrobot_mj.train.lock import RunDirectoryBusy
from acrobot_mj.train.records import resumable
from acrobot_mj.version import __version__

COMMANDS = (
    learning.add_train,
    evaluation.add_evaluate,
    render.add_render,
    tools.add_validate,
    balance.add_balance,
    olympics.add_olympics,
    learning.add_sweep,
    evaluation.add_curves,
    tools.add_bench,
    tools.add_demo,
    tools.add_params,
)
#: What a command reports in one line: ImportError is an optional extra not installed (the
#: message names it), ArithmeticError a learner that diverged, Diverged a simulation.
ERRORS = (
    Diverged,
    ValueError,
    TypeError,
    OSError,
    ImportError,
    ArithmeticError,
    CheckpointError,
    GLBackendError,
    RunDirectoryBusy,
)


#: What ``acrobot-mj --help`` says above the commands.
DESCRIPTION = (
    "The Acrobot on MuJoCo: train learners that swing it up, evaluate them on held-out "
    "starts, render videos, balance it upright, and check the physics."
)
EPILOG = "Each command has its own help: acrobot-mj COMMAND --help."


class Parser(argparse.ArgumentParser):
    """argparse's parser, whose errors are one line that names the command's help (a usage
    block of 30 lines hides the one that says what is wrong)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="acrobot-mj", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=__version__)
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    for add in COMMANDS:
        add(commands)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is: runs save their checkpoints and say so."""


def _stop(signum: int, frame: object) -> None:
    raise_stop(
        Terminated("terminated (SIGTERM)") if signum == signal.SIGTERM else KeyboardInterrupt()
    )


def _unraisable(report: Any) -> None:
    # A stop raised in a C callback (numba's loader) is dropped there and raised again by
    # check_stop: it is not reported twice.
    if not isinstance(report.exc_value, KeyboardInterrupt):
        sys.__unraisablehook__(report)


def quiet_mujoco() -> None:
    """No MUJOCO_LOG.TXT in the user's folder and no second line on stderr: a simulation that
    diverges is one line naming MuJoCo's warnings (:class:`~acrobot_mj.envs.acrobot.Diverged`)."""
    config = mujoco.MjLogConfig.get()
    config.logto_file = config.logto_console = False
    config.set()


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:  # no command: what there is to do
        parser.print_help()
        return 0
    clear_stop()
    quiet_mujoco()
    main_thread = threading.current_thread() is threading.main_thread()
    if main_thread:  # restored on return: main may run inside another program (the tests)
        before = [signal.signal(s, _stop) for s in (signal.SIGINT, signal.SIGTERM)]
        hook, sys.unraisablehook = sys.unraisablehook, _unraisable
    try:
        args.func(args)
    except ERRORS as error:
        if os.environ.get("ACROBOT_MJ_DEBUG"):
            raise  # the whole traceback, for bug reports
        parser.exit(2, f"acrobot-mj {args.command}: error: {error}\n")
    except KeyboardInterrupt as interrupt:
        out = getattr(args, "run_out", None)  # a run that trains by episodes, where it trains
        saved = out is not None and any(resumable(d) for d in (out, *out.glob("seed_*")))
        hint = "; continue with --resume" if saved else ""
        code = 143 if isinstance(interrupt, Terminated) else 130  # 128 + the signal's number
        parser.exit(code, f"acrobot-mj {args.command}: {str(interrupt) or 'interrupted'}{hint}\n")
    finally:
        clear_stop()
        if main_thread:
            signal.signal(signal.SIGINT, before[0])
            signal.signal(signal.SIGTERM, before[1])
            sys.unraisablehook = hook
    return 0


if __name__ == "__main__":
    sys.exit(main())
