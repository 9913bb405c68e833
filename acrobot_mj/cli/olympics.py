"""``acrobot-mj olympics``: the AI Olympics protocol's scores of a controller."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import Any

from acrobot_mj.cli import tools
from acrobot_mj.cli.controllers import CONTROLLERS, add_source, source_of
from acrobot_mj.olympics.protocol import GLOBAL_VERSIONS, ICRA2025_DRAWS, GlobalPolicy
from acrobot_mj.olympics.report import RECORD_FILE, read_olympics, write_olympics
from acrobot_mj.olympics.run import PARTS, OlympicsRun
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.pool import backend_of


def parts(text: str) -> tuple[str, ...]:
    """An argparse type: some of :data:`PARTS`, comma-separated."""
    chosen = tuple(p.strip() for p in text.split(",") if p.strip())
    unknown = sorted(set(chosen) - set(PARTS))
    if unknown or not chosen:
        raise argparse.ArgumentTypeError(f"must be some of {','.join(PARTS)}, got {text!r}")
    return chosen


def global_test(text: str) -> tuple[str, str]:
    """An argparse type: a version of the global test, with ``:ENTRY`` a leaderboard entry's
    draw to replay (:data:`~acrobot_mj.olympics.protocol.ICRA2025_DRAWS`)."""
    version, _, replay = text.partition(":")
    try:
        GlobalPolicy(version=version, replay=replay)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return version, replay


def add_olympics(commands: tools.Commands) -> None:
    p = tools.add_command(
        commands,
        "olympics",
        olympics_command,
        "the AI Olympics protocol's scores of a controller -> olympics.json and figures",
        "The AI Olympics protocol (RealAIGym's double_pendulum leaderboards: performance, "
        "robustness, global policy) run on this project's MuJoCo model of the acrobot, with the "
        "protocol's definitions, levels and criteria; not official leaderboard entries. On "
        "another acrobot than ai_olympics, its constants are scaled to that acrobot's length, "
        "mass, torque limit and swing-up time. Episodes run in this process, on --jobs "
        "processes, or as Ray tasks (--backend ray: on --address, or a local Ray instance of "
        "--num-cpus); the record is the same to the byte.",
    )
    p.add_argument(
        "controller",
        type=tools.path_text,
        metavar="CONTROLLER",
        help=f"{CONTROLLERS}; or a trained controller run's folder (balance --feedback, train "
        "--preset black_box) trained on --model",
    )
    add_source(
        p,
        "ai_olympics",
        "the acrobot (a planned swing-up must be shipped for it); on any model but ai_olympics "
        "the protocol is scaled to it (docs: guide/olympics-scaled)",
    )
    p.add_argument(
        "--scores",
        type=parts,
        default=PARTS,
        metavar="LIST",
        help="which scores, comma-separated",
    )
    p.add_argument("--out", type=tools.path_text, required=True, help="folder for olympics.json")
    p.add_argument("--seed", type=tools.seed, default=0, help="seed of every draw")
    _add_global(p)
    p.add_argument(
        "--jobs", type=tools.positive_int, help="local processes for episodes (default: 1)"
    )
    tools.add_backend(p, "episodes")
    p.add_argument("--force", action="store_true", help="replace a record already in --out")
    tools.add_progress(p)


def _add_global(p: argparse.ArgumentParser) -> None:
    """The global test's options: its seeds, its draws' version and its bound."""
    p.add_argument(
        "--seeds",
        type=tools.positive_int,
        default=1,
        metavar="K",
        help="the global score over K seeds from --seed (one episode each): their mean, its 95 "
        "%% interval and every seed's uptime",
    )
    p.add_argument(
        "--global-test",
        type=global_test,
        default=("current", ""),
        metavar="VERSION[:ENTRY]",
        help=f"the global test's draws: {' or '.join(GLOBAL_VERSIONS)} (the ICRA 2025 "
        "leaderboard's, April 2025); icra2025:ENTRY replays that entry's draw ("
        f"{', '.join(ICRA2025_DRAWS)}) (default: current)",
    )
    p.add_argument(
        "--bound",
        action="store_true",
        help="each global episode's bound beside its score: the uptime after the fastest "
        "returns to up the trajectory optimiser finds (ai_olympics only; the control extra; about "
        "a minute a seed)",
    )


def check_out(folder: Path, force: bool) -> None:
    """Refuse at once, not after the episodes, an ``--out`` that cannot be a folder (it or one
    above it a file) or that already holds a record (unless ``force``)."""
    tools.writable_folder(folder)
    if (folder / RECORD_FILE).exists() and not force:
        raise ValueError(f"{folder} already holds {RECORD_FILE}; --force replaces it")


def olympics_command(args: argparse.Namespace) -> dict[str, Any]:
    jobs = backend_of(args.backend, args.jobs, args.address, args.num_cpus)
    check_out(Path(args.out), args.force)
    source, model = source_of(args, args.controller)
    version, replay = args.global_test
    if replay and args.seeds > 1:
        raise ValueError(f"--global-test {version}:{replay} is one draw: give no --seeds")
    rules = protocol_for(model)
    drawn = replace(rules.global_policy, version=version, replay=replay)
    run = OlympicsRun(
        source,
        model,
        args.scores,
        args.seed,
        1 if jobs is None else jobs,
        tools.show_progress(args),
        replace(rules, global_policy=drawn),
        global_seeds=args.seeds,
        bound=args.bound,
    )
    path = write_olympics(Path(args.out), run.run())
    record = read_olympics(path)
    print(f"{summary(record)}; wrote {path}")
    return record


def summary(record: dict[str, Any]) -> str:
    """One line: each score asked for."""
    words = []
    if record.get("performance"):
        words.append(f"performance {record['performance']['score']:.3f}")
    if record.get("robustness"):
        overall = record["robustness"].get("overall")
        categories = ", ".join(
            f"{c['key']} {c['score']:.3f}" for c in record["robustness"]["categories"]
        )
        words.append(
            f"robustness {overall:.3f} ({categories})" if overall is not None else categories
        )
    if record.get("global"):
        run = record["global"]
        spread = ""
        if run.get("interval"):
            low, high = run["interval"]
            spread = f" (mean of {len(run['seeds'])} seeds, 95 % interval {low:.3f}-{high:.3f})"
        words.append(f"global {run['score']:.3f}{spread}")
        if "bound" in run:
            words.append(f"{run['of_bound']:.3f} of the bound {run['bound']['score']:.3f}")
    scaled = record.get("protocol") not in (None, "ai_olympics")
    return ("scaled protocol: " if scaled else "") + ", ".join(words)
