"""Command line: ``acrobot-mj train | evaluate | render | validate | bench | sweep | ...``."""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

import gymnasium as gym

import acrobot_mj
from acrobot_mj.checkpoint import CheckpointError
from acrobot_mj.config import FIELD_NAMES, PRESETS, TrainConfig, parse_value
from acrobot_mj.params import describe
from acrobot_mj.policies import POLICY_NAMES, make_policy, run_episode
from acrobot_mj.render import GLBackendError
from acrobot_mj.training import evaluate, last20_length, train, train_seeds, versions


def _write_json(path: str | None, data: dict[str, Any]) -> None:
    """Write ``data`` to ``path`` (when given) and say so."""
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(data, indent=1))
        print(f"wrote {path}")


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def _config(args: argparse.Namespace) -> TrainConfig:
    """The preset with every ``--<field>`` given on the command line applied."""
    overrides = {
        name: parse_value(name, getattr(args, name))
        for name in FIELD_NAMES
        if getattr(args, name) is not None
    }
    return PRESETS[args.preset].replace(**overrides)


def train_command(args: argparse.Namespace) -> dict[str, Any]:
    config = _config(args)
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    if args.seeds is None and args.jobs != 1:
        raise ValueError("--jobs runs several seeds at once: it needs --seeds")
    if args.seeds is not None:
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
        )
        g, s = summary["greedy_from_rest_length"], summary["successes"]
        print(
            f"{len(seeds)} seeds -> {out}: successes per run median {s['median']:g} "
            f"(min {s['min']:g}, max {s['max']:g}); greedy decisions from rest median "
            f"{g['median']:g} (IQR {g['q25']:g}-{g['q75']:g}), "
            f"{summary['greedy_from_rest_successes']}/{len(seeds)} reach the goal"
        )
        return summary
    out = Path(args.out or f"runs/{args.preset}__{config.algorithm}__seed{args.seed}")
    record = train(
        config, args.seed, out, resume=args.resume, progress=progress, overwrite=args.force
    )
    greedy = record["greedy_from_rest"]
    outcome = "goal" if greedy["success"] else "no goal"
    pop = record.get("population")
    kept = f" (kept learner {pop['kept']} of {pop['learners']})" if pop else ""
    print(
        f"trained {record['episodes_done']} episodes ({record['steps']} decisions, "
        f"{record['wall_seconds']:.1f} s) -> {out}: {sum(record['episode_successes'])} reached "
        f"the goal; last 20 episodes{kept} median {last20_length(record):g} decisions; greedy "
        f"from rest: {outcome} in {greedy['length']} decisions"
    )
    return record


def evaluate_command(args: argparse.Namespace) -> dict[str, Any]:
    record = evaluate(args.run_dir, args.episodes, seed=args.seed)
    lengths, successes = record["episode_lengths"], record["episode_successes"]
    print(
        f"{len(lengths)} greedy episodes of {args.run_dir}: {sum(successes)} reached the goal; "
        f"from rest {lengths[0]} decisions"
        + ("" if successes[0] else " (no goal)")
        + f"; wrote {Path(args.run_dir) / 'eval.json'}"
    )
    return record


def demo(args: argparse.Namespace) -> dict[str, Any]:
    """Roll out a fixed policy from rest and print the state as it goes."""
    env = gym.make(acrobot_mj.ENV_ID, frame_skip=args.frame_skip, integrator=args.integrator)
    policy = make_policy(args.policy, args.seed)
    episode = run_episode(env, policy, seed=args.seed, max_steps=args.steps)
    dt = env.unwrapped.dt
    print(
        f"policy {args.policy}, frame_skip {args.frame_skip} ({dt:g} s per action), "
        f"integrator {args.integrator}"
    )
    print(f"{'step':>5} {'t [s]':>7} {'q1':>8} {'q2':>8} {'dq1':>8} {'dq2':>8} {'tip [m]':>8}")
    last = episode.length
    for k, (state, tip) in enumerate(zip(episode.states, episode.tip_heights, strict=True)):
        if k % args.every == 0 or k == last:
            print(f"{k:5d} {k * dt:7.2f} " + " ".join(f"{v:8.3f}" for v in state) + f" {tip:8.3f}")
    outcome = "reached the goal" if episode.success else "did not reach the goal"
    print(
        f"{outcome} after {episode.length} actions ({episode.length * dt:.2f} s), "
        f"return {episode.episode_return:g}"
    )
    record = {
        "command": "demo",
        "config": {k: v for k, v in vars(args).items() if k not in ("func", "json")},
        "seed": args.seed,
        "versions": versions(),
        "episode_lengths": [episode.length],
        "episode_returns": [episode.episode_return],
        "episode_successes": [episode.success],
        "episodes": [episode.to_dict()],
    }
    _write_json(args.json, record)
    return record


def render_command(args: argparse.Namespace) -> dict[str, Any]:
    from acrobot_mj.video import render_policy, render_run

    if (args.run_dir is None) == (args.policy is None):
        raise ValueError("give either a run directory or --policy, not both or neither")
    common = {
        "seed": args.seed,
        "width": args.width,
        "height": args.height,
        "camera": args.camera,
        "strip": args.strip,
        "captions": args.captions,
    }
    if args.run_dir is not None:
        record = render_run(args.run_dir, args.out, max_steps=args.steps, **common)
    else:
        record = render_policy(
            args.policy, args.out, steps=args.steps, frame_skip=args.frame_skip, **common
        )
    outcome = "reaches the goal" if record["success"] else "does not reach the goal"
    print(
        f"wrote {args.out}: {record['frames']} frames at {record['fps']:g} fps; the policy "
        f"{outcome} in {record['length']} actions"
    )
    return record


def validate_command(args: argparse.Namespace) -> dict[str, Any]:
    from acrobot_mj.validation import summary_rows, validate

    report = validate(args.out, quick=args.quick)
    rows = summary_rows(report)
    width = max(len(what) for what, _ in rows)
    for what, value in rows:
        print(f"{what:<{width}}  {value}")
    print(
        f"wrote {Path(args.out) / 'validation.json'}, validation.md and "
        f"{len(report['figures'])} figures ({report['wall_seconds']:.0f} s)"
    )
    return report


def bench_command(args: argparse.Namespace) -> dict[str, Any]:
    import importlib.util

    suite_path = Path(acrobot_mj.__file__).resolve().parent.parent / "benchmarks" / "suite.py"
    if not suite_path.is_file():
        raise FileNotFoundError(
            f"acrobot-mj bench runs the benchmarks of a source checkout; "
            f"{suite_path} is not there (clone the repository)"
        )
    spec = importlib.util.spec_from_file_location("acrobot_mj_benchmarks", suite_path)
    suite = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(suite)
    result = suite.run(quick=args.quick)
    print(suite.report(result))
    _write_json(args.json, result)
    return result


def sweep_command(args: argparse.Namespace) -> dict[str, Any]:
    from acrobot_mj.sweep import load_sweep, run_sweep, summary_table

    spec = load_sweep(args.sweep_file)
    out = Path(args.out or f"runs/sweep__{Path(args.sweep_file).stem}")
    summary = run_sweep(
        spec,
        out,
        backend=args.backend,
        address=args.address,
        jobs=args.jobs,
        ray_num_cpus=args.num_cpus,
    )
    print(summary_table(summary), end="")
    print(
        f"{summary['trials']} trials -> {out}/trials; wrote summary.json, summary.md, summary.png"
    )
    return summary


def curves_command(args: argparse.Namespace) -> None:
    from acrobot_mj.plots import compare_curves

    groups = {}
    for folder in args.run_dirs:
        summary_file = Path(folder) / "summary.json"
        if not summary_file.is_file():
            raise FileNotFoundError(
                f"{summary_file} not found: give directories written by acrobot-mj train --seeds"
            )
        summary = json.loads(summary_file.read_text())
        groups[Path(folder).name] = [
            json.loads((Path(folder) / run / "run.json").read_text())["episode_lengths"]
            for run in summary["runs"]
        ]
    reference = [(63, "best known minimum (63)")] if args.minimum else []
    compare_curves(args.out, groups, args.title, reference)
    print(f"wrote {args.out}")


def params_command(args: argparse.Namespace) -> None:
    """Print the physical parameters with units and sources."""
    print(describe())


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="acrobot-mj", description=__doc__)
    parser.add_argument("--version", action="version", version=acrobot_mj.__version__)
    commands = parser.add_subparsers(dest="command", required=True)

    p = commands.add_parser(
        "train",
        help="train a learner, write run.json, checkpoint and learning curve",
        description="Train the report's or the book's learner. Every config field can be "
        "overridden with --FIELD VALUE (floats may be fractions, e.g. --alpha 0.2/48).",
    )
    p.add_argument("--preset", choices=sorted(PRESETS), default="report")
    p.add_argument("--seed", type=int, default=0, help="seed (the first one with --seeds)")
    p.add_argument(
        "--seeds",
        type=_positive_int,
        help="train K seeds and write summary.json; tabular SARSA runs them in "
        "lockstep on one batched vector env, Sarsa(lambda) one per process",
    )
    p.add_argument(
        "--jobs", type=_positive_int, default=1, help="processes for --seeds with Sarsa(lambda)"
    )
    p.add_argument("--out", help="run directory (default runs/PRESET__ALGORITHM__seedS)")
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    p.add_argument("--force", action="store_true", help="overwrite a run already in --out")
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )
    group = p.add_argument_group("config overrides (defaults: the preset's)")
    for f in fields(TrainConfig):
        group.add_argument(
            f"--{f.name.replace('_', '-')}", dest=f.name, metavar="VALUE", help=f.metadata["doc"]
        )
    p.set_defaults(func=train_command)

    p = commands.add_parser("evaluate", help="greedy episodes of a trained run -> eval.json")
    p.add_argument("run_dir", help="a directory written by acrobot-mj train")
    p.add_argument("--episodes", type=_positive_int, help="default: the run's eval_episodes")
    p.add_argument("--seed", type=int, default=0, help="seed of start noise and tie-breaking")
    p.set_defaults(func=evaluate_command)

    p = commands.add_parser(
        "render",
        help="MP4 of a trained run's greedy policy, or of a fixed policy",
        description="Render an episode from rest to MP4 at real time (EGL or OSMesa, headless).",
    )
    p.add_argument("run_dir", nargs="?", help="a directory written by acrobot-mj train")
    p.add_argument("--policy", choices=POLICY_NAMES, help="a fixed policy instead of a run")
    p.add_argument("--out", required=True, help="the .mp4 file (a .json record goes beside it)")
    p.add_argument("--steps", type=_positive_int, help="most steps (default: the whole episode)")
    p.add_argument("--seed", type=int, default=0, help="seed of the env, ties and --policy random")
    p.add_argument("--frame-skip", type=_positive_int, default=1, help="with --policy only")
    p.add_argument("--width", type=_positive_int, default=480)
    p.add_argument("--height", type=_positive_int, default=480)
    p.add_argument("--camera", default="side", help="a camera of the model: side or wide")
    p.add_argument("--strip", metavar="PNG", help="also write a strip of 6 frames")
    p.add_argument(
        "--captions",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="time, torque and tip height on each frame",
    )
    p.set_defaults(func=render_command)

    p = commands.add_parser(
        "validate", help="check the dynamics against MuJoCo; controllers, bounds, minimum time"
    )
    p.add_argument("--out", default="runs/validation", help="folder for the JSON, report, PNGs")
    p.add_argument("--quick", action="store_true", help="narrower searches, fewer samples (CI)")
    p.set_defaults(func=validate_command)

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
    p.add_argument("--jobs", type=_positive_int, help="local processes (default: all cores)")
    p.add_argument("--num-cpus", type=_positive_int, help="CPUs of a local Ray instance")
    p.set_defaults(func=sweep_command)

    p = commands.add_parser("curves", help="learning curves of several --seeds runs, one PNG")
    p.add_argument("run_dirs", nargs="+", help="directories written by train --seeds")
    p.add_argument("--out", required=True, help="the PNG file")
    p.add_argument("--title", default="Learning curves")
    p.add_argument(
        "--minimum", action="store_true", help="draw the minimum of 63 decisions (frame_skip 4)"
    )
    p.set_defaults(func=curves_command)

    p = commands.add_parser(
        "bench", help="steps per second against Gymnasium's Acrobot-v1 and MuJoCo's ceiling"
    )
    p.add_argument("--quick", action="store_true", help="smaller sizes and one round (CI)")
    p.add_argument("--json", metavar="FILE", help="also write the results as JSON")
    p.set_defaults(func=bench_command)

    p = commands.add_parser("demo", help="roll out a fixed policy from rest, print the states")
    p.add_argument(
        "--policy",
        choices=POLICY_NAMES,
        default="pump",
        help="pump: tau = -sign(dq1); zero: no torque; random: uniform (seeded)",
    )
    p.add_argument("--steps", type=_positive_int, default=1000, help="most actions to take")
    p.add_argument("--seed", type=int, default=0, help="seed of the env and the random policy")
    p.add_argument("--frame-skip", type=_positive_int, default=1, help="physics steps per action")
    p.add_argument("--integrator", choices=("euler", "rk4"), default="euler")
    p.add_argument("--every", type=_positive_int, default=20, help="print every N-th state")
    p.add_argument("--json", metavar="FILE", help="also write the run record as JSON")
    p.set_defaults(func=demo)

    p = commands.add_parser("params", help="print the physical parameters, units and sources")
    p.set_defaults(func=params_command)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        args.func(args)
    except (ValueError, TypeError, OSError, CheckpointError, GLBackendError) as error:
        if os.environ.get("ACROBOT_MJ_DEBUG"):
            raise  # the whole traceback, for bug reports
        parser.exit(2, f"acrobot-mj {args.command}: error: {error}\n")
    except KeyboardInterrupt as interrupt:
        hint = "; continue with --resume" if args.command == "train" else ""
        parser.exit(130, f"acrobot-mj {args.command}: {str(interrupt) or 'interrupted'}{hint}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
