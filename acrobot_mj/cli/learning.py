"""``acrobot-mj train | sweep``: parsers and handlers."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from acrobot_mj.checks import check_memory
from acrobot_mj.cli import tools
from acrobot_mj.cli.tools import add_command, add_progress, positive_int, seed, show_progress
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.settings import add_arguments, cli_names, parse
from acrobot_mj.train.balance_preset import PlanConfig
from acrobot_mj.train.black_box import BlackBoxConfig
from acrobot_mj.train.config import TrainConfig, field_names, owner, parse_value
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import recent_score
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.sweep import run_sweep, summary_table
from acrobot_mj.train.sweep_file import load_sweep
from acrobot_mj.train.trainer import train

#: The settings of the presets other than TrainConfig's, in the order of their help.
PRESET_KINDS = (PlanConfig, BlackBoxConfig)


def _flag(name: str) -> str:
    return f"--{name.replace('_', '-')}"


def _takes(kind: type) -> tuple[str, ...]:
    """The settings a preset of config class ``kind`` takes on the command line."""
    return field_names() if kind is TrainConfig else cli_names(kind)


def add_train(commands: tools.Commands) -> None:
    p = add_command(
        commands,
        "train",
        train_command,
        "train a learner, write run.json, checkpoint and learning curve",
        "Train a preset's learner. Every setting can be overridden with --FIELD VALUE "
        "(floats may be fractions, e.g. --alpha 0.2/48).",
    )
    p.add_argument(
        "--preset", choices=sorted(PRESETS), default="report", help="the settings to start from"
    )
    p.add_argument("--seed", type=seed, default=0, help="seed (the first one with --seeds)")
    p.add_argument("--seeds", type=positive_int, help="train K seeds, write summary.json")
    p.add_argument("--jobs", type=positive_int, default=1, help="processes for --seeds")
    p.add_argument(
        "--lockstep",
        action=argparse.BooleanOptionalAction,
        help="with --seeds: train them together on one vector env (tabular SARSA, "
        "the same runs); default: from 25 seeds a process",
    )
    p.add_argument(
        "--out", type=tools.path_text, help="run directory (default runs/PRESET__ALGORITHM__seedS)"
    )
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    p.add_argument("--force", action="store_true", help="overwrite a run already in --out")
    add_progress(p)
    p.add_argument(
        "--tensorboard",
        metavar="DIR",
        type=tools.path_text,
        help="episode scalars to DIR for TensorBoard",
    )
    group = p.add_argument_group("settings (defaults: the preset's)")
    for name in field_names():
        add_arguments(group, owner(name), [name], typed=False, defaults=False)
    titles = (
        "balance preset (identify, plan, TVLQR)",
        "black_box preset (told nothing of the equations)",
    )
    added = set(field_names())
    for kind, title in zip(PRESET_KINDS, titles, strict=True):
        # A setting two presets share (--horizons) has one flag, its help the first one's.
        names = [n for n in cli_names(kind) if n not in added]
        added.update(names)
        add_arguments(p.add_argument_group(title), kind, names, typed=False)


def config_of(args: argparse.Namespace) -> TrainConfig | PlanConfig | BlackBoxConfig:
    """The preset with the settings given on the command line."""
    preset = PRESETS[args.preset]
    kind = type(preset)
    names = dict.fromkeys([*field_names(), *(n for k in PRESET_KINDS for n in cli_names(k))])
    given = {n: getattr(args, n) for n in names if getattr(args, n) not in (None, False)}
    if refused := [n for n in given if n not in _takes(kind)]:
        raise ValueError(_refusal(args.preset, refused))
    if kind is TrainConfig:
        return preset.replace(**{n: parse_value(n, text) for n, text in given.items()})
    values = {n: v if isinstance(v, bool) else parse(kind, n, v) for n, v in given.items()}
    return preset.replace(**values)


def _refusal(preset: str, refused: list[str]) -> str:
    """Why ``preset`` takes none of the settings ``refused``: the one preset that takes them
    all, or the settings it takes."""
    flags = ", ".join(_flag(n) for n in refused)
    owners = {name for name, p in PRESETS.items() if all(n in _takes(type(p)) for n in refused)}
    if len(owners) == 1:
        them = "it" if len(refused) == 1 else "these"
        return f"{flags}: only the {owners.pop()} preset takes {them}"
    takes = ", ".join(_flag(n) for n in _takes(type(PRESETS[preset])))
    return f"{flags}: not a setting of the {preset} preset (it takes {takes})"


def train_command(args: argparse.Namespace) -> dict[str, Any]:
    config, progress = config_of(args), show_progress(args)
    if isinstance(config, (PlanConfig, BlackBoxConfig)):
        if args.seeds is not None or args.resume or args.jobs != 1:
            raise ValueError(
                f"the {args.preset} preset trains one seed per command (no --seeds, "
                "--jobs or --resume: a run takes minutes and has nothing to "
                "resume)"
            )
        out = Path(args.out or f"runs/{args.preset}__seed{args.seed}")
        record = train(config, args.seed, out, RunOptions(overwrite=args.force, progress=progress))
        describe = plan_words if isinstance(config, PlanConfig) else black_box_words
        print(f"trained -> {out}: " + describe(record))
        return record
    if args.seeds is None and args.jobs != 1:
        raise ValueError("--jobs runs several seeds at once: it needs --seeds")
    if args.seeds is None and args.lockstep is not None:
        raise ValueError(
            "--lockstep trains several seeds together: it needs --seeds (a "
            "population's learners train one by one: faster here)"
        )
    if args.seeds is not None:
        return _train_seeds(args, config, progress)
    out = args.run_out = Path(
        args.out or f"runs/{args.preset}__{config.algorithm}__seed{args.seed}"
    )
    options = RunOptions(
        resume=args.resume, overwrite=args.force, progress=progress, tensorboard=args.tensorboard
    )
    record = train(config, args.seed, out, options)
    task = get_task(config.task)
    pop = record.get("population")
    kept = f" (kept learner {pop['kept']} of {pop['learners']})" if pop else ""
    greedy, label = record["greedy_from_rest"], task.success_label.lower()
    words = f"{label if greedy['success'] else 'no ' + label} in {greedy['length']} decisions"
    if task.score.quantity == "return":
        words += f", return {greedy['return']:g} {task.score.unit}"
    print(
        f"trained {record['episodes_done']} episodes ({record['steps']} decisions, "
        f"{record['wall_seconds']:.1f} s) -> {out}: {sum(record['episode_successes'])} "
        f"{task.success_text}; last 20 episodes{kept} median {recent_score(record):g} "
        f"{task.score.unit}; greedy from rest: {words}"
    )
    return record


def _train_seeds(args: argparse.Namespace, config: TrainConfig, progress: bool) -> dict:
    out = args.run_out = Path(
        args.out or f"runs/{args.preset}__{config.algorithm}__seeds{args.seeds}"
    )
    # Each seed's records (its history of every episode, its summary) stay in memory.
    check_memory(f"--seeds {args.seeds}", args.seeds * (2**16 + 100 * config.episodes))
    seeds = list(range(args.seed, args.seed + args.seeds))
    options = RunOptions(
        resume=args.resume,
        overwrite=args.force,
        progress=progress,
        tensorboard=args.tensorboard,
        jobs=args.jobs,
        lockstep=args.lockstep,
    )
    summary = train_seeds(config, seeds, out, options)
    task = get_task(config.task)
    score, s = task.score, summary["successes"]
    g = summary[f"greedy_from_rest_{score.quantity}"]
    print(
        f"{len(seeds)} seeds -> {out}: successes per run median {s['median']:g} "
        f"(min {s['min']:g}, max {s['max']:g}); greedy {score.unit} from rest median "
        f"{g['median']:g} (IQR {g['q25']:g}-{g['q75']:g}), "
        f"{summary['greedy_from_rest_successes']}/{len(seeds)} {task.success_text}"
    )
    held = summary["held_out"]
    m, n = held[f"median_{score.quantity}"], held["protocol"]["episodes"]
    words = (
        f"held out ({n} starts): per-seed median {score.unit}, median over seeds "
        f"{m['median']:g} (IQR {m['q25']:g}-{m['q75']:g})"
    )
    if "median_ratio" in held:
        words += f", {held['median_ratio']['median']:.3g} x the per-start minima"
    distinct = held["distinct_outcomes"]["held_out"]
    print(words + f"; {distinct} distinct greedy behaviours in {len(seeds)} seeds")
    return summary


def plan_words(record: dict[str, Any]) -> str:
    """One line on a balance run: the model, the plan, the result from rest."""
    model, plan, rest = record["model"], record["plan"], record["greedy_from_rest"]
    return (
        f"model from {model['data_decisions']} random-torque decisions (RMS error "
        f"{model['rms']:.2g}); plan {plan['seconds']:g} s to upright; {rest_words(rest)}, "
        f"largest error {rest['max_error_during_hold'] or 0:.2g} rad; "
        f"{record['wall_seconds']:.0f} s"
    )


def rest_words(rest: dict[str, Any]) -> str:
    """``from rest: balanced after T s`` (or how long it held) for a balance-task assessment."""
    held = "balanced" if rest["balanced"] else f"held {rest['hold_seconds']:g} s"
    return f"from rest: {held} after {rest['swing_up_seconds']:g} s"


def black_box_words(record: dict[str, Any]) -> str:
    """One line on a black-box run: its data, its model, the plan, the result from rest."""
    data, model = record["data"], record["model"]
    return (
        f"{model['terms']}-term model from {data['decisions']} random decisions (held-out RMS "
        f"error {max(model['held_out_errors']['rms']):.2g}); plan "
        f"{record['swing_up']['seconds']:g} s to upright; {rest_words(record['greedy_from_rest'])}"
        f"; {record['wall_seconds']:.0f} s"
    )


def add_sweep(commands: tools.Commands) -> None:
    p = add_command(
        commands,
        "sweep",
        sweep_command,
        "seeds x a grid of hyperparameters from a TOML file, resumable",
        "Run every trial (grid point x seed) of SWEEP_FILE without a run.json, then "
        "summarise. Local: lockstep for tabular SARSA, processes otherwise. Ray: one "
        "task per trial on ray.init(address=...) (a local Ray without "
        "--address).",
    )
    p.add_argument("sweep_file", help="the sweep's TOML file")
    tools.add_backend(p, "trials")
    p.add_argument("--out", type=tools.path_text, help="sweep directory (default runs/sweep__NAME)")
    p.add_argument("--jobs", type=positive_int, help="local processes (default: all cores)")
    p.add_argument(
        "--lockstep",
        action=argparse.BooleanOptionalAction,
        help="local: each grid point's seeds together on one vector env (tabular "
        "SARSA, the same records); default: points with 25+ seeds left",
    )
    add_progress(p)


def sweep_command(args: argparse.Namespace) -> dict[str, Any]:
    spec = load_sweep(args.sweep_file)
    out = Path(args.out or f"runs/sweep__{Path(args.sweep_file).stem}")
    options = RunOptions(progress=show_progress(args), jobs=args.jobs, lockstep=args.lockstep)
    summary = run_sweep(
        spec, out, options, backend=args.backend, address=args.address, ray_num_cpus=args.num_cpus
    )
    print(summary_table(summary), end="")
    print(
        f"{summary['trials']} trials -> {out}/trials; wrote summary.json, summary.md, summary.png"
    )
    return summary
