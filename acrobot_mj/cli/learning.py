"""``acrobot-mj train | sweep``: parsers and handlers."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from acrobot_mj.checks import check_memory
from acrobot_mj.cli import tools
from acrobot_mj.cli.tools import add_command, add_progress, positive_int, seed, show_progress
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.train.balance_preset import PlanConfig
from acrobot_mj.train.black_box import BlackBoxConfig
from acrobot_mj.train.config import RETIRED, TrainConfig, field_names, parse_value
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import recent_score
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.sweep import run_sweep, summary_table
from acrobot_mj.train.sweep_file import load_sweep
from acrobot_mj.train.trainer import train

#: The balance preset's options: flag, PlanConfig field, help.
PLAN_OPTIONS = (
    ("--reserve", "reserve", "nominal torque bound of the plan [N m] (default 0.8)"),
    ("--hold", "hold", "seconds of balance after the swing-up (default 60)"),
    ("--data-noise", "data_noise", "start noise of the data episodes (default 1.0)"),
    ("--horizons", "horizons", "start horizons of the search, START:STOP:STEP physics steps"),
    ("--targets", "targets", "upright poses the search tries, indices 0-5, e.g. 1,4"),
    ("--starts", "starts", "warm starts of the search: rest (default) or pumping"),
)


#: Help for each setting (a config field); every default is the preset's.
SETTING_HELP = {
    "task": "what counts as success: height_goal (the report's) or balance",
    "algorithm": "sarsa (tabular) or sarsa_lambda (linear, tile coding)",
    "features": "grid (the report's table) or tiles (tile coding)",
    "alpha": "step size; a fraction is allowed, e.g. 0.2/48",
    "epsilon": "exploration: the probability of a random action",
    "gamma": "discount factor",
    "lam": "sarsa_lambda: trace decay lambda",
    "trace_cutoff": "sarsa_lambda: traces below this are dropped",
    "traces": "sarsa_lambda: replacing or accumulating",
    "angle_bins": "grid: bins per angle",
    "velocity_bins": "grid: bins per angular velocity",
    "velocity_centre_max": "grid: half-width of the velocity bins' range [rad/s]",
    "tilings": "tiles: number of tilings",
    "subset_tilings": "tiles: add tilings over subsets of the state (true or false)",
    "angle_tiles": "tiles: tiles per angle in each tiling",
    "velocity_tiles": "tiles: tiles per velocity in each tiling",
    "frame_skip": "physics steps of 0.05 s per decision, 1 to 1000",
    "integrator": "euler (semi-implicit, the report's) or rk4",
    "max_episode_steps": "decisions before an episode is truncated",
    "start_noise": "half-width of the uniform noise on the start state, 0 to 1",
    "noise_until": "fraction of the episodes that start with noise, 0 to 1",
    "step_reward": "reward of each step (the report's: -1)",
    "goal_reward": "reward on reaching the goal (the report's: +100)",
    "energy_shaping": "weight of a potential-based energy shaping term (0: none)",
    "episodes": "training episodes",
    "population": "learners trained; the best by its last 20 episodes is kept",
    "max_decisions": "a cap on the decisions of training (0: none)",
    "identify_decisions": "decisions of data to identify a model first, then learn in it",
    "checkpoint_every": "episodes between checkpoints",
}


def _flag(name: str) -> str:
    return f"--{name.replace('_', '-')}"


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
        group.add_argument(_flag(name), dest=name, metavar="VALUE", help=SETTING_HELP[name])
    for name in RETIRED:
        group.add_argument(_flag(name), dest=name, help=argparse.SUPPRESS)
    plan = p.add_argument_group("balance preset (identify, plan, TVLQR)")
    for flag, dest, text in PLAN_OPTIONS:
        plan.add_argument(flag, dest=f"plan_{dest}", metavar="VALUE", help=text)
    plan.add_argument(
        "--discrete",
        dest="plan_discrete",
        action="store_true",
        help="{-1, 0, +1} N m torques (sigma-delta), not continuous",
    )
    box = p.add_argument_group("black_box preset (told nothing of the equations)")
    box.add_argument(
        "--decisions",
        dest="box_decisions",
        type=positive_int,
        metavar="N",
        help="decisions of random exploration (default 20000)",
    )


def config_of(args: argparse.Namespace) -> TrainConfig | PlanConfig | BlackBoxConfig:
    """The preset with the settings given on the command line."""
    for name in RETIRED:
        if getattr(args, name) is not None:
            raise ValueError(f"{_flag(name)} was removed: {RETIRED[name]}")
    given = [name for name in field_names() if getattr(args, name) is not None]
    plan = [flag for flag, dest, _ in PLAN_OPTIONS if getattr(args, f"plan_{dest}") is not None]
    plan += ["--discrete"] if args.plan_discrete else []
    preset = PRESETS[args.preset]
    if isinstance(preset, BlackBoxConfig):
        refused = [_flag(name) for name in given] + plan
        if refused:
            raise ValueError(
                f"{', '.join(refused)}: not a setting of the black_box preset (it "
                "takes --decisions)"
            )
        decisions = args.box_decisions
        return preset if decisions is None else preset.replace(decisions=decisions)
    if args.box_decisions is not None:
        raise ValueError("--decisions: only the black_box preset takes it")
    if isinstance(preset, TrainConfig):
        if plan:
            raise ValueError(f"{', '.join(plan)}: only the balance preset takes these")
        return preset.replace(**{name: parse_value(name, getattr(args, name)) for name in given})
    refused = [_flag(name) for name in given if name != "identify_decisions"]
    if refused:
        raise ValueError(
            f"{', '.join(refused)}: not a setting of the balance preset (a planner, "
            "not a tabular or tile-coded learner)"
        )
    overrides: dict[str, Any] = {"discrete": True} if args.plan_discrete else {}
    texts = {"identify_decisions": args.identify_decisions}
    texts.update((dest, getattr(args, f"plan_{dest}")) for _, dest, _ in PLAN_OPTIONS)
    for dest, text in texts.items():
        if text is not None and dest in ("horizons", "targets"):
            parts = text.split(":" if dest == "horizons" else ",")
            overrides[dest] = tuple(_number(v, int, _flag(dest)) for v in parts)
        elif text is not None and dest == "starts":
            overrides[dest] = text
        elif text is not None:
            kind = int if dest == "identify_decisions" else float
            overrides[dest] = _number(text, kind, _flag(dest))
    return preset.replace(**overrides)


def _number(text: str, kind: type, flag: str) -> Any:
    try:
        return kind(text)
    except ValueError:
        raise ValueError(f"{flag} needs {kind.__name__} values, got {text!r}") from None


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
    p.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="where trials run: local processes, or Ray (the ray extra)",
    )
    p.add_argument(
        "--address",
        type=tools.path_text,
        help="Ray cluster address (e.g. auto or ray://host:10001)",
    )
    p.add_argument("--out", type=tools.path_text, help="sweep directory (default runs/sweep__NAME)")
    p.add_argument("--jobs", type=positive_int, help="local processes (default: all cores)")
    p.add_argument("--num-cpus", type=positive_int, help="CPUs of a local Ray instance")
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
