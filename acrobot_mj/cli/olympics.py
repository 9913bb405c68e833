"""``acrobot-mj olympics``: the AI Olympics protocol's scores of a controller."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from acrobot_mj.cli import tools
from acrobot_mj.olympics.entries import ENTRIES
from acrobot_mj.olympics.report import RECORD_FILE, read_olympics, write_olympics
from acrobot_mj.olympics.run import PARTS, OlympicsRun
from acrobot_mj.olympics.sources import POLICY_ENV, Source
from acrobot_mj.settings import declared, parse


def parts(text: str) -> tuple[str, ...]:
    """An argparse type: some of :data:`PARTS`, comma-separated."""
    chosen = tuple(p.strip() for p in text.split(",") if p.strip())
    unknown = sorted(set(chosen) - set(PARTS))
    if unknown or not chosen:
        raise argparse.ArgumentTypeError(f"must be some of {','.join(PARTS)}, got {text!r}")
    return chosen


def option(text: str) -> tuple[str, str]:
    """An argparse type: ``NAME=VALUE``."""
    name, equals, value = text.partition("=")
    if not (equals and name.strip()):
        raise argparse.ArgumentTypeError(f"must be NAME=VALUE, got {text!r}")
    return name.strip(), value.strip()


def json_object(text: str) -> dict[str, Any]:
    """An argparse type: a JSON object."""
    try:
        value = json.loads(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"must be a JSON object: {error}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object, got {text!r}")
    return value


def source_of(args: argparse.Namespace) -> Source:
    """The controller the command names, with its entry options (each parsed as the entry's
    declared type) and a policy's env."""
    options: dict[str, Any] = {}
    if args.option:
        entry = ENTRIES.get(args.controller)
        if entry is None:
            raise ValueError(f"--option is for an entry {list(ENTRIES)}, not {args.controller}")
        known = declared(entry.options)
        for name, text in args.option:
            if name not in known:
                raise ValueError(
                    f"the {entry.name} entry has no option {name!r}; it has {sorted(known)}"
                )
            options[name] = parse(entry.options, name, text)
    return Source(args.controller, options, args.env, args.env_kwargs or {})


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
        "mass, torque limit and swing-up time.",
    )
    p.add_argument(
        "controller",
        metavar="CONTROLLER",
        help=f"an entry ({', '.join(ENTRIES)}); a trained controller run's folder "
        "(balance --feedback, train --preset black_box) trained on --model; module:attribute "
        "(an acrobot_mj Controller, an object with double_pendulum's get_control_output(x, t), "
        "or a factory of one taking the model); or a Stable-Baselines3 policy file (.zip)",
    )
    p.add_argument(
        "--option",
        type=option,
        action="append",
        metavar="NAME=VALUE",
        help="an entry's option (funnel: mpc=true); repeat for more",
    )
    p.add_argument(
        "--env",
        metavar="ID",
        help=f"a .zip policy's training env (default {POLICY_ENV} on --model)",
    )
    p.add_argument(
        "--env-kwargs",
        type=json_object,
        metavar="JSON",
        help="with --env: its keyword arguments, a JSON object",
    )
    p.add_argument(
        "--model",
        type=tools.acrobot_model,
        default="ai_olympics",
        metavar="NAME|FILE",
        help="the acrobot (a planned swing-up must be shipped for it); on any model but "
        "ai_olympics the protocol is scaled to it (docs: guide/olympics-scaled)",
    )
    p.add_argument(
        "--scores", type=parts, default=PARTS, metavar="LIST", help="which scores, comma-separated"
    )
    p.add_argument("--out", type=tools.path_text, required=True, help="folder for olympics.json")
    p.add_argument("--seed", type=tools.seed, default=0, help="seed of every draw")
    p.add_argument("--jobs", type=tools.positive_int, default=1, help="processes for episodes")
    p.add_argument("--force", action="store_true", help="replace a record already in --out")
    tools.add_progress(p)


def check_out(folder: Path, force: bool) -> None:
    """Refuse at once, not after the episodes, an ``--out`` that is not a folder or that already
    holds a record (unless ``force``)."""
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"--out {folder} is a file, not a folder")
    if (folder / RECORD_FILE).exists() and not force:
        raise ValueError(f"{folder} already holds {RECORD_FILE}; --force replaces it")


def olympics_command(args: argparse.Namespace) -> dict[str, Any]:
    check_out(Path(args.out), args.force)
    run = OlympicsRun(
        source_of(args),
        args.model,
        args.scores,
        args.seed,
        args.jobs,
        tools.show_progress(args),
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
        words.append(f"global {record['global']['score']:.3f}")
    scaled = record.get("protocol") not in (None, "ai_olympics")
    return ("scaled protocol: " if scaled else "") + ", ".join(words)
