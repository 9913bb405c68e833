"""``acrobot-mj render | validate | bench | demo | params``, and what every command
shares (argument types, the progress flag, writing a command's record)."""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import gymnasium as gym

from acrobot_mj.control.policies import POLICY_NAMES, make_policy
from acrobot_mj.envs.rollout import Hooks, PolicyActor, acrobot_of, run_episode
from acrobot_mj.envs.tasks import HeightGoal
from acrobot_mj.files import check_regular, versions, write_json
from acrobot_mj.physics.models import MODELS, resolve
from acrobot_mj.physics.params import describe
from acrobot_mj.pool import BACKENDS
from acrobot_mj.train.records import History, output_into


class Commands(Protocol):
    """What ``ArgumentParser.add_subparsers()`` returns."""

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser: ...


class HelpFormatter(argparse.HelpFormatter):
    """Each option's default after its help, where it has one the help does not already say."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            action.option_strings
            and default not in (None, False, argparse.SUPPRESS)
            and "default" not in text
        ):
            shown = ",".join(map(str, default)) if isinstance(default, (tuple, list)) else default
            text += f" (default: {shown})"  # a tuple as it is typed
        return text


def add_command(
    commands: Commands, name: str, func: Callable, text: str, description: str | None = None
) -> argparse.ArgumentParser:
    """Command ``name`` (``text``: its help, and its description unless one is given) that runs
    ``func(args)``."""
    p = commands.add_parser(
        name,
        help=text,
        description=description or text[0].upper() + text[1:] + ".",
        formatter_class=HelpFormatter,
    )
    p.set_defaults(func=func)
    return p


def positive_int(text: str) -> int:
    """An argparse type: an integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def acrobot_model(text: str) -> str:
    """An argparse type: a parameter set's name or a ``.json`` or ``.toml`` file of one."""
    try:
        resolve(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text


def add_model(parser: argparse.ArgumentParser) -> None:
    """``--model NAME|FILE``: the acrobot (:data:`~acrobot_mj.physics.models.MODELS`)."""
    parser.add_argument(
        "--model",
        type=acrobot_model,
        default="report",
        metavar="NAME|FILE",
        help=f"the acrobot: one of {', '.join(MODELS)}, or a .json or .toml file of one",
    )


def seed(text: str) -> int:
    """An argparse type: an integer >= 0 (numpy's seeding takes no other)."""
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"a seed must be an integer >= 0, got {value}")
    return value


def add_backend(p: argparse.ArgumentParser, what: str) -> None:
    """``--backend``, ``--address`` and ``--num-cpus``: where ``what`` run (local processes, by
    ``--jobs``, or Ray), the same three options for every command that offers Ray."""
    p.add_argument(
        "--backend",
        choices=BACKENDS,
        default="local",
        help=f"where {what} run: local processes, or Ray (the ray extra)",
    )
    p.add_argument(
        "--address",
        type=path_text,
        help="Ray cluster address (e.g. auto or ray://host:10001); without it, a local Ray "
        "instance on 127.0.0.1",
    )
    p.add_argument("--num-cpus", type=positive_int, help="CPUs of a local Ray instance")


def add_progress(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )


def show_progress(args: argparse.Namespace) -> bool:
    return sys.stderr.isatty() if args.progress is None else args.progress


def path_text(text: str) -> str:
    """An argparse type: a path, not an empty string (which would mean the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must name a path, got ''")
    return text


def writable_folder(out: Path, flag: str = "--out") -> Path:
    """``out``, refused before any work where it cannot be a folder that is written: it or a
    folder above it is a file, or the nearest existing one cannot be written."""
    existing = next(p for p in (out, *out.absolute().parents) if p.exists())
    if not existing.is_dir():
        raise NotADirectoryError(f"{flag} {out}: {existing} exists and is not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise PermissionError(f"{flag} {out}: {existing} cannot be written")
    return out


def output_file(text: str) -> str:
    """An argparse type: a file to write, checked before any work is done (not empty, not a
    folder, a device or a pipe: renaming a record over ``/dev/null`` replaced the device)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must name a file, got ''")
    try:
        check_regular(text)
    except IsADirectoryError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text


def check_output(path: str | None, command: str) -> None:
    """Refuse at once, not after the work, an output that :func:`output_into` would refuse."""
    if path:
        with output_into(path, command):
            pass


def write_record(path: str | None, data: dict[str, Any]) -> None:
    """Write ``data`` as JSON to ``path`` (when given) and say so."""
    if path:
        with output_into(path, "write a record"):
            write_json(path, data)
        print(f"wrote {path}")


def add_validate(commands: Commands) -> None:
    p = add_command(
        commands,
        "validate",
        validate_command,
        "check the dynamics against MuJoCo; controllers, bounds, minimum time",
    )
    p.add_argument("--out", default="runs/validation", help="folder for the JSON, report, PNGs")
    p.add_argument("--quick", action="store_true", help="narrower searches, fewer samples (CI)")
    add_progress(p)


def validate_command(args: argparse.Namespace) -> dict[str, Any]:
    from acrobot_mj.report.validation import summary_rows, validate  # heavy: on demand

    report = validate(args.out, quick=args.quick, progress=show_progress(args))
    rows = summary_rows(report)
    width = max(len(what) for what, _ in rows)
    for what, value in rows:
        print(f"{what:<{width}}  {value}")
    print(
        f"wrote {Path(args.out) / 'validation.json'}, validation.md and "
        f"{len(report['figures'])} figures ({report['wall_seconds']:.0f} s)"
    )
    return report


def names(text: str) -> tuple[str, ...]:
    """An argparse type: names, comma-separated (at least one)."""
    chosen = tuple(name.strip() for name in text.split(",") if name.strip())
    if not chosen:
        raise argparse.ArgumentTypeError(f"must name at least one, got {text!r}")
    return chosen


def add_bench(commands: Commands) -> None:
    p = add_command(
        commands,
        "bench",
        bench_command,
        "steps per second against Gymnasium's Acrobot-v1 and MuJoCo's ceiling, and the AI "
        "Olympics entries' time per call",
    )
    p.add_argument("--quick", action="store_true", help="smaller sizes and one round (CI)")
    p.add_argument(
        "--only",
        type=names,
        metavar="PARTS",
        help="the parts to run, comma-separated: rates (every steps-per-second row), latency "
        "(each AI Olympics entry's time per call in one global-test episode, on one core); "
        "default: both",
    )
    p.add_argument(
        "--entries",
        type=names,
        metavar="LIST",
        help="the entries whose latency is timed, comma-separated, each with its options as "
        "NAME:OPTION=VALUE (tree:candidates=32) (default: tree,funnel)",
    )
    p.add_argument(
        "--json", metavar="FILE", type=output_file, help="also write the results as JSON"
    )
    p.add_argument(
        "--peer-python",
        metavar="PATH",
        help="a Python with gymnax and jax (docs/guide/benchmarks.md) for the "
        "peers' rows; default $ACROBOT_MJ_PEER_PYTHON, else those rows are "
        "skipped",
    )


def bench_command(args: argparse.Namespace) -> dict[str, Any]:
    suite_path = Path(__file__).resolve().parents[2] / "benchmarks" / "suite.py"
    if not suite_path.is_file():
        raise FileNotFoundError(
            f"acrobot-mj bench runs the benchmarks of a source checkout; "
            f"{suite_path} is not there (clone the repository)"
        )
    check_output(args.json, "bench")
    spec = importlib.util.spec_from_file_location("acrobot_mj_benchmarks", suite_path)
    if spec is None or spec.loader is None:  # a .py file always has both
        raise ImportError(f"cannot load {suite_path}")
    suite = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(suite)
    peer_python = args.peer_python or os.environ.get("ACROBOT_MJ_PEER_PYTHON") or None
    parts = suite.PARTS if args.only is None else args.only
    result = suite.run(quick=args.quick, peer_python=peer_python, parts=parts, entries=args.entries)
    print(suite.report(result))
    write_record(args.json, result)
    return result


def add_demo(commands: Commands) -> None:
    p = add_command(commands, "demo", demo, "roll out a fixed policy from rest, print the states")
    p.add_argument(
        "--policy",
        choices=POLICY_NAMES,
        default="pump",
        help="pump: tau = -sign(dq1); zero: no torque; random: uniform (seeded)",
    )
    p.add_argument("--steps", type=positive_int, default=1000, help="most actions to take")
    p.add_argument("--seed", type=seed, default=0, help="seed of the env and the random policy")
    p.add_argument("--frame-skip", type=positive_int, default=1, help="physics steps per action")
    p.add_argument(
        "--integrator",
        choices=("euler", "rk4"),
        default="euler",
        help="semi-implicit Euler (the report's) or RK4",
    )
    p.add_argument("--every", type=positive_int, default=20, help="print every N-th state")
    add_model(p)
    p.add_argument(
        "--json", metavar="FILE", type=output_file, help="also write the run record as JSON"
    )


def demo(args: argparse.Namespace) -> dict[str, Any]:
    """Roll out a fixed policy from rest and print the state as it goes."""
    check_output(args.json, "demo")
    goal = resolve(args.model).params.l1  # the height goal: one link length above the pivot
    env = gym.make(
        HeightGoal.env_id,
        frame_skip=args.frame_skip,
        integrator=args.integrator,
        model=args.model,
        goal_height=goal,
    )
    states, tips = [], []

    def keep(obs: Any, info: dict[str, Any]) -> None:
        states.append(obs.tolist())
        tips.append(info["tip_height"])

    episode = run_episode(
        env,
        PolicyActor(make_policy(args.policy, args.seed)),
        args.seed,
        max_steps=args.steps,
        hooks=Hooks(keep, lambda action, obs, *rest: keep(obs, rest[-1])),
    )
    dt = acrobot_of(env).dt
    print(
        f"policy {args.policy}, frame_skip {args.frame_skip} ({dt:g} s per action), "
        f"integrator {args.integrator}"
    )
    print(f"{'step':>5} {'t [s]':>7} {'q1':>8} {'q2':>8} {'dq1':>8} {'dq2':>8} {'tip [m]':>8}")
    for k, (state, tip) in enumerate(zip(states, tips, strict=True)):
        if k % args.every == 0 or k == episode.length:
            print(f"{k:5d} {k * dt:7.2f} " + " ".join(f"{v:8.3f}" for v in state) + f" {tip:8.3f}")
    outcome = "reached the goal" if episode.success else "did not reach the goal"
    print(
        f"{outcome} after {episode.length} actions ({episode.length * dt:.2f} s), "
        f"return {episode.episode_return:g}"
    )
    history = History()
    history.add_episode(episode)
    config = {k: v for k, v in vars(args).items() if k not in ("func", "json")}
    results = {k: getattr(episode, k) for k in ("length", "episode_return", "success", "truncated")}
    record = {
        "command": "demo",
        "config": config,
        "seed": args.seed,
        "versions": versions(),
        **history.to_dict(),
        "episodes": [{**results, "states": states, "tip_heights": tips}],
    }
    write_record(args.json, record)
    return record


def add_params(commands: Commands) -> None:
    p = add_command(
        commands,
        "params",
        lambda args: print(describe(resolve(args.model).params)),
        "print the physical parameters, units and sources",
    )
    add_model(p)
